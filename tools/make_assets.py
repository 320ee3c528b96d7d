"""Generate the small example models in ``assets/models/`` (no downloads; deterministic).

    python tools/make_assets.py [--out assets/models]

Writes
- ``studio_sample.glb``: glTF 2.0 built with trimesh, then post-processed: a UV sphere with base
  colour, metallic-roughness, normal, occlusion and emissive textures (64x64 PNGs, embedded); a
  pedestal without UVs and without normals (crease-angle normals at load time); one cube mesh used
  by two nodes (instancing); a camera; two ``KHR_lights_punctual`` lights (a spot in candela and a
  directional light in lux). Factors are written exactly (trimesh rounds colours to 8 bits).
- ``crate.obj`` + ``crate.mtl`` + ``crate_wood.png``: three materials (textured Blinn-Phong wood
  via ``map_Kd``, a glossy metal band, an emissive knob with ``Ke``), no normals in the file.
- ``blob.ply``: a bumpy sphere with per-vertex colours (binary PLY).
- ``bracket.stl``: an L-shaped bracket modelled z-up (CAD convention), for up-axis detection.
"""
from __future__ import annotations

import argparse
import math
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))

import trimesh  # noqa: E402
from PIL import Image  # noqa: E402

from pyrt.io.assets import pack_glb, read_gltf  # noqa: E402


def uv_sphere(radius=1.0, n_u=32, n_v=16):
    """UV sphere with a seam: vertices (n_v+1)(n_u+1), pyrt/trimesh UVs (v up), pole triangles not degenerate."""
    i, j = np.mgrid[0:n_v + 1, 0:n_u + 1]
    theta = math.pi * i / n_v              # 0 at +y
    phi = 2 * math.pi * j / n_u
    v = np.stack([radius * np.sin(theta) * np.sin(phi), radius * np.cos(theta), radius * np.sin(theta) * np.cos(phi)],
                 axis=-1).reshape(-1, 3)
    uv = np.stack([j / n_u, 1.0 - i / n_v], axis=-1).reshape(-1, 2).astype(np.float64)
    idx = np.arange((n_v + 1) * (n_u + 1)).reshape(n_v + 1, n_u + 1)
    a, b, c, d = idx[:-1, :-1], idx[1:, :-1], idx[1:, 1:], idx[:-1, 1:]
    f1 = np.stack([a, b, c], axis=-1)[:-1]         # (b, c on the bottom pole in the last row: degenerate)
    f2 = np.stack([a, c, d], axis=-1)[1:]          # (a, d on the top pole in the first row: degenerate)
    faces = np.concatenate([f1.reshape(-1, 3), f2.reshape(-1, 3)])
    return v, faces, uv


def _png(arr):
    return Image.fromarray(np.ascontiguousarray(arr))


def sphere_textures(n=64):
    """Base colour (sRGB checker), metallic-roughness (G rough, B metal), normal (bumps), occlusion, emissive."""
    y, x = np.mgrid[0:n, 0:n] / n
    check = ((np.floor(x * 8) + np.floor(y * 4)) % 2).astype(bool)
    base = np.where(check[..., None], [220, 80, 40], [240, 230, 210]).astype(np.uint8)
    mr = np.zeros((n, n, 3), np.uint8)
    mr[..., 1] = np.round(255 * (0.15 + 0.7 * x)).astype(np.uint8)          # roughness ramps along u
    mr[..., 2] = np.where(y < 0.5, 255, 0).astype(np.uint8)                # top half metal
    bump = np.sin(2 * math.pi * 8 * x) * 0.35
    nrm = np.stack([-bump, np.zeros_like(bump), np.ones_like(bump)], axis=-1)
    nrm /= np.linalg.norm(nrm, axis=-1, keepdims=True)
    normal = np.round((0.5 * nrm + 0.5) * 255).astype(np.uint8)
    occ = np.full((n, n, 3), 255, np.uint8)
    occ[..., 0] = np.round(255 * (0.6 + 0.4 * np.abs(np.sin(math.pi * 4 * y)))).astype(np.uint8)
    emi = np.zeros((n, n, 3), np.uint8)
    band = np.abs(y - 0.5) < 0.03
    emi[band] = (255, 180, 60)
    return base, mr, normal, occ, emi


def make_glb(path):
    from trimesh.visual.material import PBRMaterial

    base, mr, normal, occ, emi = sphere_textures()
    v, f, uv = uv_sphere(0.5, 32, 16)
    sphere = trimesh.Trimesh(v + [0, 0.9, 0], f, process=False)
    sphere.visual = trimesh.visual.TextureVisuals(uv=uv, material=PBRMaterial(
        name="painted", baseColorTexture=_png(base), metallicRoughnessTexture=_png(mr), normalTexture=_png(normal),
        occlusionTexture=_png(occ), emissiveTexture=_png(emi)))
    pedestal = trimesh.creation.cylinder(radius=0.45, height=0.4, sections=24)
    pedestal.apply_transform(trimesh.transformations.rotation_matrix(-math.pi / 2, [1, 0, 0]))
    pedestal.apply_translation([0, 0.2, 0])
    pedestal.visual = trimesh.visual.TextureVisuals(material=PBRMaterial(name="stone"))
    cube = trimesh.creation.box(extents=(0.25, 0.25, 0.25))
    cube.visual = trimesh.visual.TextureVisuals(material=PBRMaterial(name="gold"))
    scene = trimesh.Scene()
    scene.add_geometry(sphere, node_name="sphere", geom_name="sphere")
    scene.add_geometry(pedestal, node_name="pedestal", geom_name="pedestal")
    scene.add_geometry(cube, node_name="cube_left", geom_name="cube",
                       transform=trimesh.transformations.translation_matrix([-0.75, 0.125, 0.1]))
    data = scene.export(file_type="glb")
    tmp = path + ".tmp"
    with open(tmp, "wb") as fh:
        fh.write(data)
    header, buffers = read_gltf(tmp)
    os.remove(tmp)
    # exact factors (trimesh stores colours as 8-bit)
    for m in header["materials"]:
        pbr = m.setdefault("pbrMetallicRoughness", {})
        if m["name"] == "painted":
            pbr.update(baseColorFactor=[1.0, 0.95, 0.9, 1.0], metallicFactor=1.0, roughnessFactor=1.0)
            m["emissiveFactor"] = [2.0, 2.0, 2.0]
            m["normalTexture"]["scale"] = 1.0
            m["occlusionTexture"]["strength"] = 1.0
        elif m["name"] == "stone":
            pbr.clear()
            pbr.update(baseColorFactor=[0.18, 0.18, 0.2, 1.0], metallicFactor=0.0, roughnessFactor=0.65)
            m.pop("emissiveFactor", None)
        elif m["name"] == "gold":
            pbr.clear()
            pbr.update(baseColorFactor=[1.0, 0.766, 0.336, 1.0], metallicFactor=1.0, roughnessFactor=0.3)
            m.pop("emissiveFactor", None)
    nodes = header["nodes"]
    meshes = {n.get("name"): n["mesh"] for n in nodes if "mesh" in n}
    # the pedestal has no normals and no UVs in the file
    for p in header["meshes"][meshes["pedestal"]]["primitives"]:
        p["attributes"].pop("NORMAL", None)
        p["attributes"].pop("TEXCOORD_0", None)
    # a second node instancing the cube mesh, a camera, two lights
    nodes.append({"name": "cube_right", "mesh": meshes["cube_left"], "translation": [0.75, 0.125, 0.1],
                  "rotation": [0.0, math.sin(math.pi / 8), 0.0, math.cos(math.pi / 8)]})
    header["cameras"] = [{"type": "perspective", "name": "front",
                          "perspective": {"yfov": math.radians(40.0), "aspectRatio": 4 / 3, "znear": 0.05}}]
    nodes.append({"name": "camera", "camera": 0, "translation": [0.0, 1.0, 3.2]})
    header.setdefault("extensions", {})["KHR_lights_punctual"] = {"lights": [
        {"type": "spot", "name": "key_spot", "color": [1.0, 0.95, 0.9], "intensity": 2500.0,
         "spot": {"innerConeAngle": 0.3, "outerConeAngle": 0.6}},
        {"type": "directional", "name": "sky", "color": [0.8, 0.9, 1.0], "intensity": 400.0},
    ]}
    q = trimesh.transformations.quaternion_from_matrix(
        trimesh.transformations.rotation_matrix(math.radians(-50), [1, 0, 0]))  # w, x, y, z; -Z tilted down
    nodes.append({"name": "spot", "translation": [0.0, 3.0, 2.0], "rotation": [q[1], q[2], q[3], q[0]],
                  "extensions": {"KHR_lights_punctual": {"light": 0}}})
    nodes.append({"name": "sky", "rotation": [q[1], q[2], q[3], q[0]],
                  "extensions": {"KHR_lights_punctual": {"light": 1}}})
    header["scenes"][header.get("scene", 0)]["nodes"] = list(range(len(nodes)))
    for n in nodes:
        n.pop("children", None)
    header["extensionsUsed"] = sorted(set(header.get("extensionsUsed", [])) | {"KHR_lights_punctual"})
    header["buffers"][0]["byteLength"] = len(buffers[0])
    with open(path, "wb") as fh:
        fh.write(pack_glb(header, buffers[0]))


MTL = """# generated by tools/make_assets.py
newmtl wood
Kd 0.9 0.9 0.9
Ks 0.05 0.05 0.05
Ns 20
map_Kd crate_wood.png

newmtl metal_band
Kd 0.25 0.25 0.27
Ks 0.6 0.6 0.6
Ns 200

newmtl glow
Kd 0.1 0.1 0.1
Ks 0.0 0.0 0.0
Ke 3.0 2.0 0.6
"""


def _box_faces_uv(center, extents):
    """An unwelded box: 24 vertices with per-face UVs (0..1), 12 triangles, outward winding."""
    m = trimesh.creation.box(extents=extents)
    tri = m.vertices[m.faces]                       # (12, 3, 3)
    n = m.face_normals
    verts, uvs, faces = [], [], []
    for k in range(12):
        ax = int(np.argmax(np.abs(n[k])))
        a, b = [i for i in range(3) if i != ax]
        for p in tri[k]:
            verts.append(p + center)
            uvs.append([(p[a] / extents[a]) + 0.5, (p[b] / extents[b]) + 0.5])
        faces.append([3 * k, 3 * k + 1, 3 * k + 2])
    return np.array(verts), np.array(uvs), np.array(faces)


def make_obj(folder):
    n = 64
    y, x = np.mgrid[0:n, 0:n] / n
    grain = 0.5 + 0.5 * np.sin(2 * math.pi * (6 * x + 0.6 * np.sin(2 * math.pi * 3 * y)))
    wood = np.stack([150 + 70 * grain, 95 + 50 * grain, 45 + 25 * grain], axis=-1).astype(np.uint8)
    Image.fromarray(wood).save(os.path.join(folder, "crate_wood.png"), optimize=True)
    with open(os.path.join(folder, "crate.mtl"), "w") as fh:
        fh.write(MTL)
    parts = []
    v, uv, f = _box_faces_uv(np.array([0, 0.4, 0]), np.array([0.8, 0.8, 0.8]))
    parts.append(("wood", v, uv, f))
    v, uv, f = _box_faces_uv(np.array([0, 0.4, 0]), np.array([0.84, 0.12, 0.84]))
    parts.append(("metal_band", v, uv, f))
    s = trimesh.creation.icosphere(subdivisions=2, radius=0.1)
    parts.append(("glow", s.vertices + [0, 0.86, 0], None, s.faces))
    lines = ["# generated by tools/make_assets.py", "mtllib crate.mtl"]
    vo = to = 0
    for mat, v, uv, f in parts:
        lines.append(f"o {mat}")
        lines += [f"v {a:.6f} {b:.6f} {c:.6f}" for a, b, c in v]
        if uv is not None:
            lines += [f"vt {a:.6f} {b:.6f}" for a, b in uv]
        lines.append(f"usemtl {mat}")
        for tri in f:
            if uv is not None:
                lines.append("f " + " ".join(f"{vo + i + 1}/{to + i + 1}" for i in tri))
            else:
                lines.append("f " + " ".join(f"{vo + i + 1}" for i in tri))
        vo += len(v)
        to += 0 if uv is None else len(uv)
    with open(os.path.join(folder, "crate.obj"), "w") as fh:
        fh.write("\n".join(lines) + "\n")


def make_ply(path):
    s = trimesh.creation.icosphere(subdivisions=3, radius=0.5)
    p = s.vertices
    bump = 1.0 + 0.12 * np.sin(5 * p[:, 0] / 0.5) * np.sin(4 * p[:, 1] / 0.5 + 1.0) * np.cos(3 * p[:, 2] / 0.5)
    v = p * bump[:, None] + [0, 0.55, 0]
    h = (v[:, 1] - v[:, 1].min()) / np.ptp(v[:, 1])
    col = np.stack([0.2 + 0.75 * h, 0.35 + 0.4 * np.sin(math.pi * h), 0.9 - 0.7 * h], axis=1)
    rgba = np.concatenate([np.round(255 * col), np.full((len(v), 1), 255)], axis=1).astype(np.uint8)
    m = trimesh.Trimesh(v, s.faces, vertex_colors=rgba, process=False)
    with open(path, "wb") as fh:
        fh.write(m.export(file_type="ply", encoding="binary", include_attributes=False))


def make_stl(path):
    plate = trimesh.creation.box(extents=(1.2, 0.8, 0.1))
    plate.apply_translation([0, 0, 0.05])
    wall = trimesh.creation.box(extents=(0.1, 0.8, 0.7))
    wall.apply_translation([-0.55, 0, 0.45])
    rib = trimesh.creation.box(extents=(0.4, 0.06, 0.3))
    rib.apply_translation([-0.3, 0, 0.25])
    m = trimesh.util.concatenate([plate, wall, rib])
    with open(path, "wb") as fh:
        fh.write(m.export(file_type="stl"))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=os.path.join(os.path.dirname(HERE), "assets", "models"))
    args = ap.parse_args(argv)
    os.makedirs(args.out, exist_ok=True)
    make_glb(os.path.join(args.out, "studio_sample.glb"))
    make_obj(args.out)
    make_ply(os.path.join(args.out, "blob.ply"))
    make_stl(os.path.join(args.out, "bracket.stl"))
    for f in sorted(os.listdir(args.out)):
        print(f"{os.path.join(args.out, f)}  {os.path.getsize(os.path.join(args.out, f))} bytes")
    return 0


if __name__ == "__main__":
    sys.exit(main())
