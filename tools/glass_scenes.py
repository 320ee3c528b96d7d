"""Generated glTF models that reproduce what went wrong on thick textured glass (issue 33), and their pictures.

Four models, each a :func:`pyrt.io.assets.gltf_write.embedded_gltf` header (write it with ``json.dump``):

- :func:`hurricane_glass` — a thick, curved glass shell (a hurricane candle holder: an open cylinder with a
  solid base, outer and inner walls joined at the rim), coarsely tessellated around its axis with smooth vertex
  normals (the shading normal differs from the triangles' by up to half a segment's angle), ``KHR_materials_
  transmission`` + ``_volume`` with a strongly absorbing medium (the Khronos model's attenuation, scaled to the
  model's size). With ``decal=True`` its base colour is a texture holding a coloured band (a decal printed on the
  glass: ``baseColorTexture`` tints the transmission) on the outer wall only.
- :func:`polished_metal` — a smooth-shaded chrome cylinder (metallic 1, roughness 0.05): what a viewer shows as
  silver under image-based light.
- :func:`decal_layer` — the clear thick glass with a decal as its own alpha-blended layer just outside it (two meshes,
  :func:`merge_gltf`).

``python tools/glass_scenes.py OUT_DIR`` writes the models; with ``--picture PNG`` it also renders the rough thick glass
(roughness 0.15), the decal glass and the metal with the previewer's defaults (``--spp``, as ``--seeds`` renders of
``spp / seeds``) and an unbiased reference (``--ref-spp``: glossy and dielectric depth 40, no throughput cutoff, one
glass lobe per hit from bounce 2), prints the mean linear RGB over the model's pixels of both with the default's
standard error (from the seeds), and writes a sheet: default | reference | 4 x |default - reference| per model, all
with the reference's automatic exposure (docs/glass_convergence.png: ``python tools/glass_scenes.py /tmp/glass
--picture docs/glass_convergence.png``).
"""
from __future__ import annotations

import argparse
import json
import math
import os

import numpy as np

from pyrt.io.assets.gltf_write import embedded_gltf

#: the Khronos model's volume: attenuationColor, attenuationDistance (0.001 in a 0.19-wide model)
ATTENUATION_COLOR = (0.8, 0.95, 1.0)


def _ring(radius, y, n, normal_y=0.0, normal_r=1.0):
    """``n`` vertices of a ring (positions, normals) at height ``y``; the normal is (normal_r radial, normal_y)."""
    a = 2.0 * np.pi * np.arange(n) / n
    c, s = np.cos(a), np.sin(a)
    pos = np.stack([radius * c, np.full(n, y), radius * s], axis=1)
    nrm = np.stack([normal_r * c, np.full(n, normal_y), normal_r * s], axis=1)
    nrm /= np.linalg.norm(nrm, axis=1, keepdims=True)
    return pos, nrm


def _strip(i0, i1, n, outward):
    """Quads between ring ``i0`` (lower) and ring ``i1`` (upper) of ``n`` vertices each, as triangles wound so that
    their counter-clockwise normal points outward (``outward`` True: away from the axis)."""
    k = np.arange(n)
    k1 = (k + 1) % n
    a, b, c, d = i0 + k, i0 + k1, i1 + k1, i1 + k
    t = np.concatenate([np.stack([a, d, c], 1), np.stack([a, c, b], 1)])
    return t if outward else t[:, ::-1]


def _disk(center_idx, ring_idx, n, up):
    """A fan from ``center_idx`` to ring ``ring_idx``: normal +y when ``up``, else -y."""
    k = np.arange(n)
    t = np.stack([np.full(n, center_idx), ring_idx + (k + 1) % n, ring_idx + k], axis=1)
    return t if up else t[:, ::-1]


def hurricane_mesh(*, segments=24, rings=6, radius=0.09, height=0.3, wall=0.01, base=0.03, bulge=0.25):
    """The glass shell of :func:`hurricane_glass`: ``(positions, normals, uvs, faces)``.

    A solid of revolution around +y: outer radius ``radius (1 + bulge sin(pi y / height))`` (a curved wall), the
    inner one ``wall`` less, from ``y = 0`` to ``height``; the inside's floor at ``y = base``. Walls are smooth
    (vertex normals of the exact surface of revolution), the rim and the two floors flat. ``uv`` = (angle / 2 pi,
    y / height) on the walls (the inner wall's u offset by 2: outside the decal's texture, see ``decal``).
    """
    pos, nrm, uv, faces = [], [], [], []
    count = 0

    def add(p, n, u):
        nonlocal count
        pos.append(p)
        nrm.append(n)
        uv.append(u)
        count += p.shape[0]
        return count - p.shape[0]

    def profile(y):
        r = radius * (1.0 + bulge * math.sin(math.pi * y / height))
        dr = radius * bulge * math.pi / height * math.cos(math.pi * y / height)
        return r, dr

    ang_u = np.arange(segments) / segments
    ys_out = np.linspace(0.0, height, rings + 1)
    ys_in = np.linspace(base, height, rings + 1)
    outer = []
    for y in ys_out:
        r, dr = profile(y)
        p, n = _ring(r, y, segments, normal_y=-dr, normal_r=1.0)
        outer.append(add(p, n, np.stack([ang_u, np.full(segments, y / height)], 1)))
    inner = []
    for y in ys_in:
        r, dr = profile(y)
        p, n = _ring(r - wall, y, segments, normal_y=dr, normal_r=-1.0)
        inner.append(add(p, n, np.stack([ang_u + 2.0, np.full(segments, y / height)], 1)))
    for j in range(rings):
        faces.append(_strip(outer[j], outer[j + 1], segments, True))
        faces.append(_strip(inner[j], inner[j + 1], segments, False))
    # rim (flat, +y): outer top ring to inner top ring
    r_top, _ = profile(height)
    po, no = _ring(r_top, height, segments, normal_y=1.0, normal_r=0.0)
    pi_, ni = _ring(r_top - wall, height, segments, normal_y=1.0, normal_r=0.0)
    o_rim = add(po, no, np.zeros((segments, 2)) + 3.0)
    i_rim = add(pi_, ni, np.zeros((segments, 2)) + 3.0)
    faces.append(_strip(i_rim, o_rim, segments, True))
    # floors: the inner floor faces +y (into the cavity), the bottom faces -y
    r_base, _ = profile(base)
    pf, nf = _ring(r_base - wall, base, segments, normal_y=1.0, normal_r=0.0)
    f_ring = add(pf, nf, np.zeros((segments, 2)) + 3.0)
    f_c = add(np.array([[0.0, base, 0.0]]), np.array([[0.0, 1.0, 0.0]]), np.array([[3.0, 3.0]]))
    faces.append(_disk(f_c, f_ring, segments, up=True))
    r0, _ = profile(0.0)
    pb, nb = _ring(r0, 0.0, segments, normal_y=-1.0, normal_r=0.0)
    b_ring = add(pb, nb, np.zeros((segments, 2)) + 3.0)
    b_c = add(np.array([[0.0, 0.0, 0.0]]), np.array([[0.0, -1.0, 0.0]]), np.array([[3.0, 3.0]]))
    faces.append(_disk(b_c, b_ring, segments, up=False))
    pos, nrm, faces = np.concatenate(pos), np.concatenate(nrm), np.concatenate(faces)
    faces = _orient(pos, nrm, faces)
    return pos.astype(np.float32), nrm.astype(np.float32), np.concatenate(uv).astype(np.float32), faces.astype(np.uint32)


def _orient(pos, nrm, faces):
    """``faces`` with each triangle wound so that its counter-clockwise normal agrees with its vertex normals."""
    t = pos[faces]
    ng = np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0])
    flip = np.einsum("ij,ij->i", ng, nrm[faces].sum(axis=1)) < 0
    out = faces.copy()
    out[flip] = faces[flip][:, ::-1]
    return out


def _decal_texture(size=64):
    """(size, size, 3) uint8: white, with a coloured band (the decal) over ``0.1 < u < 0.6``, ``0.35 < v < 0.65``
    (glTF's v runs down the image; the band is symmetric, so it does not matter), one texel of white border."""
    img = np.full((size, size, 3), 255, dtype=np.uint8)
    u = (np.arange(size) + 0.5) / size
    band_u = (u > 0.1) & (u < 0.6)
    band_v = (u > 0.35) & (u < 0.65)
    img[np.ix_(band_v, band_u)] = (230, 60, 30)
    return img


def hurricane_glass(*, decal=False, segments=24, attenuation_distance=0.02):
    """The glTF header of the thick glass shell (:func:`hurricane_mesh`), transmission 1, roughness 0, a volume of
    ``attenuationColor`` :data:`ATTENUATION_COLOR` over ``attenuation_distance``; ``decal``: the base colour is
    :func:`_decal_texture` (on the outer wall: the other faces' UVs lie outside the texture, clamped to white)."""
    p, n, uv, f = hurricane_mesh(segments=segments)
    mat = {"pbrMetallicRoughness": {"metallicFactor": 0.0, "roughnessFactor": 0.0},
           "extensions": {"KHR_materials_transmission": {"transmissionFactor": 1.0},
                          "KHR_materials_volume": {"thicknessFactor": 0.01, "attenuationColor": list(ATTENUATION_COLOR),
                                                   "attenuationDistance": attenuation_distance}}}
    images = ()
    if decal:
        mat["pbrMetallicRoughness"]["baseColorTexture"] = {"index": 0}
        images = (_decal_texture(),)
    h = embedded_gltf({"POSITION": p, "NORMAL": n, "TEXCOORD_0": uv}, f, mat, images)
    h["extensionsUsed"] = ["KHR_materials_transmission", "KHR_materials_volume"]
    if decal:     # clamp: the inner wall (u + 2) and the flat faces (u = v = 3) read the white border
        h["samplers"] = [{"wrapS": 33071, "wrapT": 33071}]
        h["textures"][0]["sampler"] = 0
    return h


def polished_metal(*, segments=24, roughness=0.05):
    """The glTF header of a smooth-shaded chrome vessel (the shell of :func:`hurricane_mesh`, opaque): metallic 1,
    base colour 0.95, ``roughness``."""
    p, n, uv, f = hurricane_mesh(segments=segments)
    mat = {"pbrMetallicRoughness": {"baseColorFactor": [0.95, 0.95, 0.95, 1.0], "metallicFactor": 1.0,
                                    "roughnessFactor": roughness}}
    return embedded_gltf({"POSITION": p, "NORMAL": n}, f, mat)


def merge_gltf(a, b):
    """One glTF header holding the meshes of headers ``a`` and ``b`` (each of :func:`embedded_gltf`: one mesh, one
    material, data-URI buffers), ``b``'s indices shifted past ``a``'s."""
    out = json.loads(json.dumps(a))
    nb, nv, na, nm, ni = (len(out.get(k, [])) for k in ("buffers", "bufferViews", "accessors", "materials", "images"))
    for v in b["bufferViews"]:
        out["bufferViews"].append({**v, "buffer": v["buffer"] + nb})
    for acc in b["accessors"]:
        out["accessors"].append({**acc, "bufferView": acc["bufferView"] + nv})
    out["buffers"] += b["buffers"]
    mat = json.loads(json.dumps(b["materials"][0]))
    tex = mat.get("pbrMetallicRoughness", {}).get("baseColorTexture")
    if tex is not None:
        tex["index"] += len(out.get("textures", []))
    out["materials"].append(mat)
    if "images" in b:
        out.setdefault("images", []).extend(b["images"])
        out.setdefault("textures", []).extend({**t, "source": t["source"] + ni} for t in b["textures"])
    prim = b["meshes"][0]["primitives"][0]
    out["meshes"].append({"primitives": [{"attributes": {k: i + na for k, i in prim["attributes"].items()},
                                          "indices": prim["indices"] + na, "material": nm}]})
    out["nodes"].append({"mesh": len(out["meshes"]) - 1})
    out["scenes"][0]["nodes"].append(len(out["nodes"]) - 1)
    for k in ("extensionsUsed",):
        if k in b:
            out[k] = sorted(set(out.get(k, [])) | set(b[k]))
    return out


def _decal_rgba(size=64):
    """(size, size, 4) uint8: a red band (the decal's ink, opaque) over ``0.1 < u < 0.9``, ``0.3 < v < 0.7``, clear
    (alpha 0) elsewhere."""
    img = np.zeros((size, size, 4), dtype=np.uint8)
    c = (np.arange(size) + 0.5) / size
    img[np.ix_((c > 0.3) & (c < 0.7), (c > 0.1) & (c < 0.9))] = (230, 60, 30, 255)
    return img


def decal_layer(*, segments=24, offset=0.0005, span=0.9):
    """The clear thick glass of :func:`hurricane_glass` with a decal as a separate layer: a patch of the outer wall
    ``span`` radians wide (facing the camera's default azimuth side, +z), ``offset`` outside it, alpha-blended
    (``alphaMode`` BLEND, the ink opaque, the rest clear), one-sided, as exporters write label decals on glass."""
    glass = hurricane_glass(segments=segments)
    n_u, n_v = 16, 8
    a = np.pi / 2 + span * (np.linspace(0.0, 1.0, n_u + 1) - 0.5)
    y = 0.3 * np.linspace(0.25, 0.75, n_v + 1)
    A, Y = np.meshgrid(a, y)
    r = 0.09 * (1.0 + 0.25 * np.sin(np.pi * Y / 0.3)) + offset
    pos = np.stack([r * np.cos(A), Y, r * np.sin(A)], axis=-1).reshape(-1, 3).astype(np.float32)
    nrm = np.stack([np.cos(A), np.zeros_like(A), np.sin(A)], axis=-1).reshape(-1, 3).astype(np.float32)
    uv = np.stack([1.0 - (A - a[0]) / span, 1.0 - (Y - y[0]) / (y[-1] - y[0])], axis=-1).reshape(-1, 2)
    k = np.arange(n_u)
    faces = []
    for j in range(n_v):
        i0, i1 = j * (n_u + 1) + k, (j + 1) * (n_u + 1) + k
        faces += [np.stack([i0, i1, i1 + 1], 1), np.stack([i0, i1 + 1, i0 + 1], 1)]
    f = _orient(pos, nrm, np.concatenate(faces))
    mat = {"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}, "metallicFactor": 0.0, "roughnessFactor": 0.6},
           "alphaMode": "BLEND"}
    decal = embedded_gltf({"POSITION": pos, "NORMAL": nrm, "TEXCOORD_0": uv.astype(np.float32)}, f, mat,
                          (_decal_rgba(),))
    return merge_gltf(glass, decal)


def _rough(h, roughness=0.15):
    h["materials"][0]["pbrMetallicRoughness"]["roughnessFactor"] = roughness
    return h


MODELS = {"glass": lambda: hurricane_glass(), "glass_rough": lambda: _rough(hurricane_glass(attenuation_distance=0.004)),
          "glass_decal": lambda: hurricane_glass(decal=True), "metal": lambda: polished_metal(),
          "decal_layer": lambda: decal_layer()}
#: the models of the picture
PICTURE = ("glass_rough", "glass_decal", "metal")
#: the reference's options: every path to its end (unbiased; split_depth 2 keeps the tree's width bounded)
REFERENCE = {"glossy_depth": 40, "dielectric_depth": 40, "dielectric_cutoff": 0.0, "split_depth": 2}


def render_views(path, *, width, height, spp, seeds, seed0=0, **options):
    """``(images (S, H, W, 3), model mask (H, W), preview scene of the last seed)``: ``seeds`` previews of ``path`` at
    ``spp`` each (the previewer's defaults and ``options``), fixed exposure 0."""
    from pyrt.apps.preview import PreviewOptions, PreviewScene
    from pyrt.io.assets import load_asset

    imgs = []
    for k in range(seeds):
        o = PreviewOptions(width=width, height=height, spp=spp, exposure=0.0, seed=seed0 + k, **options)
        ps = PreviewScene(load_asset(path), o)
        try:
            imgs.append(ps.render_view(ps.azimuth).image)
            mask = ps.model_mask()
        finally:
            ps.close()
    return np.stack(imgs), mask


def picture(paths, out_png, *, width, height, spp, seeds, ref_spp):
    """Render :data:`PICTURE` (defaults and references), print the means, write the sheet; returns the rows."""
    from pyrt.apps.preview.rig import auto_exposure
    from pyrt.core.image_io import encode_png, tonemap_to_display, write_bytes
    from pyrt.shaders import color as _color

    rows, tiles = [], []
    for name in PICTURE:
        dflt, mask = render_views(paths[name], width=width, height=height, spp=max(1, spp // seeds), seeds=seeds)
        ref, _ = render_views(paths[name], width=width, height=height, spp=max(1, ref_spp // 2), seeds=2, seed0=100,
                              **REFERENCE)
        per_seed = dflt[:, mask].mean(axis=1)                       # (seeds, 3)
        m_d, se = per_seed.mean(axis=0), per_seed.std(axis=0, ddof=1) / np.sqrt(seeds)
        m_r = ref[:, mask].mean(axis=(0, 1))
        rows.append((name, m_d, se, m_r))
        print(f"{name:12s} default {np.round(m_d, 4)} +- {np.round(se, 4)}   reference {np.round(m_r, 4)}   "
              f"(default - reference) / se {np.round((m_d - m_r) / np.maximum(se, 1e-12), 1)}", flush=True)
        a, b = dflt.mean(axis=0), ref.mean(axis=0)
        exposure, white = auto_exposure(b, mask)
        row = [tonemap_to_display(x, exposure=exposure, L_white=white) for x in (a, b)]
        row.append(np.clip(4.0 * np.abs(a - b) * 2.0 ** exposure, 0.0, 1.0))
        tiles.append(np.concatenate([np.pad(t, ((2, 2), (2, 2), (0, 0)), constant_values=1.0) for t in row], axis=1))
    sheet = np.concatenate(tiles, axis=0)
    write_bytes(out_png, encode_png(np.round(_color.srgb_encode(sheet) * 255).astype(np.uint8)))
    return rows


def write_models(out_dir):
    """Write every model of :data:`MODELS` as ``OUT_DIR/NAME.gltf``; returns {name: path}."""
    os.makedirs(out_dir, exist_ok=True)
    paths = {}
    for name, make in MODELS.items():
        paths[name] = os.path.join(out_dir, f"{name}.gltf")
        with open(paths[name], "w") as fh:
            json.dump(make(), fh)
    return paths


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out_dir")
    ap.add_argument("--picture", help="render and write the comparison sheet here (PNG)")
    ap.add_argument("--width", type=int, default=96)
    ap.add_argument("--height", type=int, default=120)
    ap.add_argument("--spp", type=int, default=16)
    ap.add_argument("--seeds", type=int, default=4)
    ap.add_argument("--ref-spp", type=int, default=128)
    args = ap.parse_args(argv)
    paths = write_models(args.out_dir)
    for name, path in paths.items():
        print(name, path)
    if args.picture:
        picture(paths, args.picture, width=args.width, height=args.height, spp=args.spp, seeds=args.seeds,
                ref_spp=args.ref_spp)


if __name__ == "__main__":
    main()
