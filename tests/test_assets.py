"""Asset loading (pyrt.io.assets): glTF round trips through trimesh, OBJ/MTL, PLY, STL, errors."""
import json
import math
import os
import re

import numpy as np
import pytest
import trimesh
from PIL import Image
from trimesh.visual.material import PBRMaterial

import pyrt
from pyrt.io import assets as A
from pyrt.io.assets import AssetError, load_asset, pack_glb, read_gltf
from pyrt.shaders import color as C
from pyrt.shaders import textures as T

ASSETS = os.path.join(os.path.dirname(__file__), "..", "assets", "models")


def _tex(rng, n=8, m=4):
    return rng.integers(0, 256, size=(m, n, 3), dtype=np.uint8)


def _patched_glb(tmp_path, scene, patch, name="x.glb"):
    """Export ``scene`` with trimesh, let ``patch(header)`` edit the JSON, write a GLB; returns its path."""
    raw = tmp_path / ("raw_" + name)
    raw.write_bytes(scene.export(file_type="glb"))
    header, buffers = read_gltf(raw)
    patch(header)
    out = tmp_path / name
    out.write_bytes(pack_glb(header, buffers[0]))
    return str(out)


@pytest.fixture
def round_trip(tmp_path, rng):
    """A GLB exported by trimesh: a textured box (all five textures), a plain icosphere, lights, camera."""
    imgs = {k: _tex(rng) for k in ("base", "mr", "normal", "occ", "emi")}
    box = trimesh.creation.box(extents=(1.0, 2.0, 0.5))
    uv = rng.random((len(box.vertices), 2))
    box.visual = trimesh.visual.TextureVisuals(uv=uv, material=PBRMaterial(
        name="textured", baseColorTexture=Image.fromarray(imgs["base"]),
        metallicRoughnessTexture=Image.fromarray(imgs["mr"]), normalTexture=Image.fromarray(imgs["normal"]),
        occlusionTexture=Image.fromarray(imgs["occ"]), emissiveTexture=Image.fromarray(imgs["emi"])))
    ball = trimesh.creation.icosphere(subdivisions=1, radius=0.3)
    ball.visual = trimesh.visual.TextureVisuals(material=PBRMaterial(name="plain"))
    sc = trimesh.Scene()
    sc.add_geometry(box, node_name="box", geom_name="box",
                    transform=trimesh.transformations.translation_matrix([1.0, 0.0, 0.0]))
    sc.add_geometry(ball, node_name="ball", geom_name="ball")

    def patch(h):
        m0, m1 = h["materials"]
        m0["pbrMetallicRoughness"].update(baseColorFactor=[0.9, 0.5, 0.25, 1.0], metallicFactor=0.3,
                                          roughnessFactor=0.45)
        m0["normalTexture"]["scale"] = 0.7
        m0["occlusionTexture"]["strength"] = 0.6
        m0["emissiveFactor"] = [0.5, 1.5, 2.0]
        m0["doubleSided"] = True
        m0.setdefault("extensions", {})["KHR_materials_emissive_strength"] = {"emissiveStrength": 3.0}
        for k in ("pbrMetallicRoughness", "emissiveFactor", "doubleSided", "alphaMode"):
            m1.pop(k, None)          # every factor absent: glTF defaults apply
        nodes = h["nodes"]
        box_node = next(i for i, n in enumerate(nodes) if n.get("name") == "box")
        # a parent with TRS and a child instancing the box mesh
        nodes.append({"name": "parent", "translation": [0.0, 2.0, 0.0],
                      "rotation": [0.0, math.sin(math.pi / 4), 0.0, math.cos(math.pi / 4)], "scale": [2.0, 2.0, 2.0],
                      "children": [len(nodes) + 1]})
        nodes.append({"name": "child_box", "mesh": nodes[box_node]["mesh"], "translation": [0.5, 0.0, 0.0]})
        h["cameras"] = [{"type": "perspective", "perspective": {"yfov": 0.6, "aspectRatio": 1.5, "znear": 0.1}}]
        nodes.append({"name": "cam", "camera": 0, "translation": [0.0, 1.0, 5.0]})
        h["extensions"] = {"KHR_lights_punctual": {"lights": [
            {"type": "point", "color": [1.0, 0.5, 0.25], "intensity": 683.0, "range": 10.0},
            {"type": "spot", "intensity": 1366.0, "spot": {"innerConeAngle": 0.2, "outerConeAngle": 0.5}},
            {"type": "directional", "intensity": 6830.0},
        ]}}
        q = [math.sin(-math.pi / 4), 0.0, 0.0, math.cos(-math.pi / 4)]  # -90 deg about x: -Z -> -Y (down)
        nodes.append({"name": "lamp", "translation": [1.0, 3.0, 0.0],
                      "extensions": {"KHR_lights_punctual": {"light": 0}}})
        nodes.append({"name": "spot", "translation": [0.0, 4.0, 0.0], "rotation": q,
                      "extensions": {"KHR_lights_punctual": {"light": 1}}})
        nodes.append({"name": "sun", "rotation": q, "extensions": {"KHR_lights_punctual": {"light": 2}}})
        roots = h["scenes"][0]["nodes"]
        roots += [len(nodes) - 6, len(nodes) - 4, len(nodes) - 3, len(nodes) - 2, len(nodes) - 1]
        h["extensionsUsed"] = ["KHR_lights_punctual", "KHR_materials_emissive_strength"]

    path = _patched_glb(tmp_path, sc, patch)
    return path, imgs, uv


def test_gltf_factors_exact_and_defaults_where_absent(round_trip):
    path, _, _ = round_trip
    a = load_asset(path)
    m0, m1 = a.materials
    np.testing.assert_array_equal(m0.base_color_factor, [0.9, 0.5, 0.25, 1.0])   # exact, not 8-bit
    assert (m0.metallic_factor, m0.roughness_factor) == (0.3, 0.45)
    assert (m0.normal_scale, m0.occlusion_strength, m0.emissive_strength) == (0.7, 0.6, 3.0)
    np.testing.assert_array_equal(m0.emissive_factor, [0.5, 1.5, 2.0])
    assert m0.double_sided is True
    # glTF 2.0 defaults
    np.testing.assert_array_equal(m1.base_color_factor, [1, 1, 1, 1])
    assert (m1.metallic_factor, m1.roughness_factor) == (1.0, 1.0)
    np.testing.assert_array_equal(m1.emissive_factor, [0, 0, 0])
    assert (m1.double_sided, m1.alpha_mode, m1.normal_texture, m1.base_color_texture) == (False, "OPAQUE", None, None)


def test_gltf_textures_come_back_with_the_right_encoding(round_trip):
    path, imgs, _ = round_trip
    m0 = load_asset(path).materials[0]
    f = lambda x: x.astype(np.float32) / 255.0  # noqa: E731
    # colour textures are sRGB -> linearised; data textures are linear and split per channel
    np.testing.assert_allclose(m0.base_color_texture.texture.image, C.srgb_decode(f(imgs["base"])), atol=1e-6)
    np.testing.assert_allclose(m0.emissive_texture.texture.image, C.srgb_decode(f(imgs["emi"])), atol=1e-6)
    np.testing.assert_allclose(m0.metallic_texture.image[..., 0], f(imgs["mr"])[..., 2], atol=1e-7)   # B
    np.testing.assert_allclose(m0.roughness_texture.image[..., 0], f(imgs["mr"])[..., 1], atol=1e-7)  # G
    np.testing.assert_allclose(m0.occlusion_texture.image[..., 0], f(imgs["occ"])[..., 0], atol=1e-7)  # R
    np.testing.assert_allclose(m0.normal_texture.image, f(imgs["normal"]), atol=1e-7)
    assert m0.normal_texture.strength == 0.7


def test_gltf_uvs_match_trimesh_convention(round_trip):
    path, _, uv = round_trip
    a = load_asset(path)
    box = next(m for m in a.meshes if m.material == 0)
    # trimesh wrote 1 - v into the file; pyrt flips back: the UVs equal the original (float32 storage)
    np.testing.assert_allclose(box.uv, uv, atol=1e-7)


def test_gltf_node_transforms_and_instancing(round_trip):
    path, _, _ = round_trip
    a = load_asset(path)
    by_node = {i.node: i for i in a.instances}
    np.testing.assert_allclose(by_node["box"].world_from_object, trimesh.transformations.translation_matrix([1, 0, 0]))
    parent = (trimesh.transformations.translation_matrix([0, 2, 0])
              @ trimesh.transformations.rotation_matrix(math.pi / 2, [0, 1, 0]) @ np.diag([2.0, 2.0, 2.0, 1.0]))
    expected = parent @ trimesh.transformations.translation_matrix([0.5, 0, 0])
    np.testing.assert_allclose(by_node["child_box"].world_from_object, expected, atol=1e-12)
    # the instanced mesh is decoded once and shared
    assert by_node["child_box"].mesh == by_node["box"].mesh
    assert len(a.meshes) == 2 and len(a.instances) == 3
    # world-space triangles agree with trimesh's own loader for the nodes trimesh exported
    ref = trimesh.load(path, force="scene")
    for node in ("box", "ball"):
        T_ref, gname = ref.graph[node]
        v_ref = trimesh.transformations.transform_points(ref.geometry[gname].vertices, T_ref)
        inst = by_node[node]
        v = trimesh.transformations.transform_points(a.meshes[inst.mesh].vertices, inst.world_from_object)
        np.testing.assert_allclose(v, v_ref, atol=1e-6)
    # shared in the scene too: one material for both instances, the same object-space data
    scene = pyrt.Scene()
    ids = a.add_to_scene(scene, lights=False)
    box_ids = [i for i in ids if scene.meshes[i].name.startswith(("box", "child_box"))]
    assert len(box_ids) == 2
    m0, m1 = (scene.meshes[i] for i in box_ids)
    assert m0.material_id == m1.material_id
    np.testing.assert_array_equal(m0.uv, m1.uv)
    np.testing.assert_array_equal(m0.vertices_object, m1.vertices_object)


def test_gltf_lights_converted_to_radiometric(round_trip):
    path, _, _ = round_trip
    a = load_asset(path)
    point, spot, sun = (L.to_pyrt() for L in a.lights)
    # 683 cd of colour c -> I = 1 W/sr * c; the photometric value is 683 * luminance(I)
    np.testing.assert_allclose(point.I, [1.0, 0.5, 0.25], rtol=1e-12)
    np.testing.assert_allclose(point.position, [1, 3, 0])
    assert point.falloff == "gltf_range" and point.range == 10.0
    np.testing.assert_allclose(spot.I, [2.0, 2.0, 2.0], rtol=1e-12)
    np.testing.assert_allclose(spot.direction, [0, -1, 0], atol=1e-12)      # the node's -Z, rotated
    assert spot.spot_falloff == "gltf"
    assert math.isclose(spot.inner_angle, math.degrees(0.2)) and math.isclose(spot.outer_angle, math.degrees(0.5))
    np.testing.assert_allclose(sun.E, [10.0, 10.0, 10.0], rtol=1e-12)      # 6830 lux -> 10 W/m^2
    np.testing.assert_allclose(sun.direction, [0, -1, 0], atol=1e-12)
    assert math.isclose(sun.lux, 6830.0, rel_tol=1e-12)


def test_gltf_camera(round_trip):
    path, _, _ = round_trip
    cam = load_asset(path).cameras[0]
    np.testing.assert_allclose(cam.position, [0, 1, 5])
    np.testing.assert_allclose(cam.forward, [0, 0, -1])
    assert math.isclose(cam.yfov_deg, math.degrees(0.6)) and cam.aspect == 1.5
    pc = cam.to_pyrt(30, 20)
    assert math.isclose(pc.fov, math.degrees(0.6))


def test_gltf_texcoord_orientation_top_left_texel():
    """glTF UV (0, 0) is the image's top-left texel; after pyrt's flip the lookup returns that texel."""
    img = np.zeros((4, 4, 3), np.uint8)
    img[0, 0] = (255, 0, 0)            # row 0 = top
    tex = pyrt.ImageTexture(img, filter="nearest", srgb=False)
    uv_gltf = np.array([[0.1, 0.1]])
    uv_pyrt = np.column_stack([uv_gltf[:, 0], 1.0 - uv_gltf[:, 1]])
    np.testing.assert_allclose(tex.lookup(uv_pyrt), [[1.0, 0.0, 0.0]])


@pytest.mark.parametrize("ext", [{"offset": [0.25, -0.1], "scale": [2.0, 0.5], "rotation": 0.3},
                                 {"scale": [3.0, 1.0]}, {"rotation": -1.1, "offset": [0.0, 0.4]}])
def test_khr_texture_transform_in_flipped_space(ext, rng):
    """pyrt's transform of flipped UVs equals the flip of glTF's ``T R S uv`` (KHR_texture_transform spec)."""
    uv = rng.random((50, 2))
    tx, ty = ext.get("offset", (0, 0))
    sx, sy = ext.get("scale", (1, 1))
    r = ext.get("rotation", 0.0)
    c, s = math.cos(r), math.sin(r)
    M = np.array([[1, 0, tx], [0, 1, ty], [0, 0, 1]]) @ np.array([[c, s, 0], [-s, c, 0], [0, 0, 1]]) \
        @ np.diag([sx, sy, 1.0])                                             # the spec's matrix
    g = (M @ np.column_stack([uv, np.ones(50)]).T).T[:, :2]
    scale, offset, rot = A.gltf_uv_transform(ext)
    p = np.column_stack([uv[:, 0], 1 - uv[:, 1]])
    pt, _, _ = T.transform_uv(p, scale=scale, offset=offset, rotation=math.radians(rot))
    np.testing.assert_allclose(pt, np.column_stack([g[:, 0], 1 - g[:, 1]]), atol=1e-12)


def test_gltf_material_is_metallic_roughness_with_extras(round_trip):
    from pyrt.materials import MetallicRoughness

    a = load_asset(path := round_trip[0])
    mat = A.to_pyrt_material(a.materials[0])
    assert isinstance(mat, MetallicRoughness) and isinstance(mat, A.GltfMaterial)
    assert mat.normal_map is a.materials[0].normal_texture and mat.double_sided
    default = A.to_pyrt_material(a.materials[1])
    assert (default.metallic, default.roughness) == (1.0, 1.0) and default.normal_map is None
    assert path


def test_missing_metallic_roughness_class_fails_loudly(monkeypatch, round_trip):
    monkeypatch.setattr(A.materials, "GltfMaterial", None)   # the module make_metallic_roughness reads
    a = load_asset(round_trip[0])
    with pytest.raises(AssetError, match="MetallicRoughness is not available"):
        a.add_to_scene(pyrt.Scene())


def test_gltf_emission_renders_as_radiance(tmp_path):
    """An emissive quad (factor x strength, no lights) renders exactly that radiance."""
    quad = trimesh.Trimesh([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], [[0, 1, 2], [0, 2, 3]], process=False)
    quad.visual = trimesh.visual.TextureVisuals(material=PBRMaterial(name="e"))

    def patch(h):
        h["materials"][0] = {"name": "e", "emissiveFactor": [0.25, 0.5, 1.0],
                             "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 4.0}}}

    path = _patched_glb(tmp_path, trimesh.Scene(quad), patch)
    scene = pyrt.Scene(pyrt.Camera((0, 0, 3), (0, 0, 0), fov=20, width=8, height=8, spp=1, jitter=False))
    load_asset(path).add_to_scene(scene)
    img = pyrt.render(scene)
    np.testing.assert_allclose(img, np.broadcast_to([1.0, 2.0, 4.0], img.shape), rtol=1e-6)


def test_crease_normals_flat_box_smooth_sphere_and_soup():
    box = trimesh.creation.box()
    src, f, n = A.crease_normals(box.vertices, box.faces, 30.0)
    assert len(src) == 24                          # every corner split: flat faces
    np.testing.assert_allclose(np.abs(n).max(axis=1), 1.0)
    ball = trimesh.creation.icosphere(subdivisions=3)
    src, f, n = A.crease_normals(ball.vertices, ball.faces, 30.0)
    assert len(src) == len(ball.vertices)          # nothing split
    radial = ball.vertices[src] / np.linalg.norm(ball.vertices[src], axis=1, keepdims=True)
    assert np.min(np.einsum("ij,ij->i", n, radial)) > 0.9999
    # an unindexed triangle soup (STL) is welded by position: same normals as the indexed sphere
    soup_v = ball.vertices[ball.faces].reshape(-1, 3)
    soup_f = np.arange(len(soup_v)).reshape(-1, 3)
    src2, f2, n2 = A.crease_normals(soup_v, soup_f, 30.0)
    corner_n = n2[f2].reshape(-1, 3)
    radial2 = soup_v / np.linalg.norm(soup_v, axis=1, keepdims=True)
    assert np.min(np.einsum("ij,ij->i", corner_n, radial2)) > 0.9999


MTL = """newmtl tex
Kd 0.5 0.5 0.5
Ks 0.2 0.2 0.2
Ns 64
Ke 0.1 0.2 0.3
map_Kd -s 2 2 -o 0.5 0 t.png
newmtl bright
Kd 0.9 0.9 0.9
Ks 0.4 0.4 0.4
Ns 10
newmtl glass
Kd 1 1 1
Ni 1.33
d 0.2
illum 7
"""

OBJ = """mtllib m.mtl
v 0 0 0
v 1 0 0
v 1 1 0
v 0 1 0
vt 0 0
vt 1 0
vt 1 1
vt 0 1
usemtl tex
f 1/1 2/2 3/3
usemtl bright
f 1/1 3/3 4/4
usemtl glass
f 2/2 3/3 4/4
"""


def _write_obj(tmp_path, mtl=MTL, texture=True):
    (tmp_path / "m.obj").write_text(OBJ)
    (tmp_path / "m.mtl").write_text(mtl)
    if texture:
        Image.fromarray(np.full((2, 2, 3), 128, np.uint8)).save(tmp_path / "t.png")
    return str(tmp_path / "m.obj")


def test_obj_mtl_mapping(tmp_path):
    a = load_asset(_write_obj(tmp_path))
    names = {m.name: m for m in a.materials}
    assert set(names) == {"tex", "bright", "glass"}
    mats = {a.materials[m.material].name: A.to_pyrt_material(a.materials[m.material]) for m in a.meshes}
    tex = mats["tex"]
    assert isinstance(tex, A.ObjMaterial) and isinstance(tex, pyrt.BlinnPhong)
    np.testing.assert_array_equal(tex.ks, [0.2, 0.2, 0.2])
    assert tex.exponent == 64.0
    np.testing.assert_array_equal(tex.emission_value, [0.1, 0.2, 0.3])
    kd_tex = tex.kd
    assert isinstance(kd_tex, A.ScaledTexture) and kd_tex.texture.scale == (2.0, 2.0)
    assert kd_tex.texture.offset == (0.5, 0.0)
    np.testing.assert_allclose(kd_tex.texture.image, C.srgb_decode(np.float32(128 / 255)), atol=1e-6)
    # Kd + Ks > 1: Ks scaled uniformly to 0.1 (energy conservation), with a warning
    np.testing.assert_allclose(mats["bright"].ks, [0.1, 0.1, 0.1], atol=1e-12)
    assert any("Ks scaled" in w for w in a.warnings)
    assert isinstance(mats["glass"], pyrt.Glass) and mats["glass"].ior == 1.33
    # OBJ UVs are already bottom-left: unchanged
    m = next(m for m in a.meshes if a.materials[m.material].name == "tex")
    np.testing.assert_allclose(m.uv[np.argsort(m.vertices[:, 0] + 2 * m.vertices[:, 1])],
                               [[0, 0], [1, 0], [1, 1]])
    assert m.normals is None                       # no vn: crease normals at add_to_scene


def test_ply_vertex_colours_linearised_and_rendered(tmp_path):
    quad = trimesh.Trimesh([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], [[0, 1, 2], [0, 2, 3]],
                           vertex_colors=np.tile([[200, 100, 50, 255]], (4, 1)).astype(np.uint8), process=False)
    p = tmp_path / "q.ply"
    p.write_bytes(quad.export(file_type="ply"))
    a = load_asset(str(p))
    expect = C.srgb_decode(np.array([200, 100, 50]) / 255.0)
    np.testing.assert_allclose(a.meshes[0].colors, np.tile(expect, (4, 1)), atol=1e-12)
    scene = pyrt.Scene(pyrt.Camera((0, 0, 3), (0, 0, 0), fov=20, width=6, height=6, spp=1, jitter=False))
    a.add_to_scene(scene)
    res = pyrt.render_full(scene, aovs=True)
    # the albedo AOV is the base colour = vertex colour x the default base colour (0.8)
    np.testing.assert_allclose(res.aovs["albedo"], np.broadcast_to(0.8 * expect, res.aovs["albedo"].shape),
                               rtol=1e-6)


def test_stl_soup_gets_smooth_normals(tmp_path):
    p = tmp_path / "s.stl"
    p.write_bytes(trimesh.creation.icosphere(subdivisions=2).export(file_type="stl"))
    a = load_asset(str(p))
    assert a.format == "stl" and a.n_triangles == 320 and a.meshes[0].normals is None
    scene = pyrt.Scene()
    a.add_to_scene(scene)
    md = scene.meshes[0]
    assert md.smooth and md.normals is not None
    radial = md.vertices / np.linalg.norm(md.vertices, axis=1, keepdims=True)
    assert np.min(np.einsum("ij,ij->i", md.normals, radial)) > 0.999


@pytest.mark.parametrize("name", ["studio_sample.glb", "crate.obj", "blob.ply", "bracket.stl"])
def test_committed_assets_load(name):
    a = load_asset(os.path.join(ASSETS, name))
    assert a.n_triangles > 0 and not a.warnings
    scene = pyrt.Scene()
    a.add_to_scene(scene)
    assert len(scene.meshes) == len(a.instances)


def test_committed_gltf_has_instancing_lights_camera_and_no_normals_mesh():
    a = load_asset(os.path.join(ASSETS, "studio_sample.glb"))
    cubes = [i for i in a.instances if i.node.startswith("cube")]
    assert len(cubes) == 2 and cubes[0].mesh == cubes[1].mesh
    assert [L.kind for L in a.lights] == ["spot", "directional"] and len(a.cameras) == 1
    pedestal = next(m for m in a.meshes if m.name.startswith("pedestal"))
    assert pedestal.normals is None and pedestal.uv is None


# ----------------------------------------------------------------------------- errors

def test_malformed_glb_and_gltf_errors_name_the_file(tmp_path):
    bad = tmp_path / "bad.glb"
    bad.write_bytes(b"this is not a glb")
    with pytest.raises(AssetError, match=r"bad\.glb: not a GLB file"):
        load_asset(str(bad))
    trunc = tmp_path / "trunc.glb"
    good = trimesh.Scene(trimesh.creation.box()).export(file_type="glb")
    trunc.write_bytes(good[: len(good) // 2])
    with pytest.raises(AssetError, match="trunc.glb: GLB header says"):
        load_asset(str(trunc))
    js = tmp_path / "bad.gltf"
    js.write_text("{ not json")
    with pytest.raises(AssetError, match="bad.gltf: not valid glTF JSON"):
        load_asset(str(js))
    with pytest.raises(AssetError, match="unsupported file type"):
        load_asset(__file__)


def test_accessor_past_buffer_end(tmp_path):
    def patch(h):
        h["accessors"][h["meshes"][0]["primitives"][0]["attributes"]["POSITION"]]["count"] = 10 ** 6

    path = _patched_glb(tmp_path, trimesh.Scene(trimesh.creation.box()), patch)
    with pytest.raises(AssetError, match=r"accessor \d+ reads \d+ bytes past bufferView"):
        load_asset(path)


def test_missing_gltf_texture_file(tmp_path):
    box = trimesh.creation.box()
    box.visual = trimesh.visual.TextureVisuals(uv=np.zeros((8, 2)), material=PBRMaterial(
        baseColorTexture=Image.fromarray(np.zeros((2, 2, 3), np.uint8))))
    files = trimesh.Scene(box).export(file_type="gltf")
    header = json.loads(files["model.gltf"])
    for name, data in files.items():
        (tmp_path / name).write_bytes(data)
    header["images"] = [{"uri": "textures/gone.png"}]
    (tmp_path / "model.gltf").write_text(json.dumps(header))
    a = load_asset(str(tmp_path / "model.gltf"))      # a substitution (the factor alone), not an error
    assert a.materials[0].base_color_texture is None
    assert len(a.substitutions) == 1 and a.substitutions[0] in a.warnings
    assert re.search(r"model\.gltf: material 0 .*baseColorTexture: image 0 file not found: .*textures/gone\.png; "
                     "rendered with the factor alone", a.substitutions[0])


def test_missing_map_kd_texture(tmp_path):
    path = _write_obj(tmp_path, texture=False)
    a = load_asset(path)
    assert {m.name: m.map_Kd for m in a.materials}["tex"] is None
    assert [s for s in a.substitutions if re.search(r"m\.mtl:6: map_Kd: texture file not found: .*t\.png; rendered "
                                                     "with the factor alone", s)]
    with pytest.raises(AssetError, match=r"m\.mtl:6: map_Kd: texture file not found: .*t\.png"):
        A.parse_mtl(str(tmp_path / "m.mtl"))           # parse_mtl alone (no substitutions list) stays strict


def test_unsupported_required_extension(tmp_path):
    path = _patched_glb(tmp_path, trimesh.Scene(trimesh.creation.box()),
                        lambda h: h.update(extensionsRequired=["KHR_texture_basisu"]))
    with pytest.raises(AssetError, match="requires unsupported glTF extension"):
        load_asset(path)


def test_missing_file_and_empty_stl(tmp_path):
    with pytest.raises(AssetError, match="asset file not found"):
        load_asset(str(tmp_path / "nope.obj"))
    p = tmp_path / "empty.stl"
    p.write_text("solid empty\nendsolid empty\n")
    with pytest.raises(AssetError, match="no triangles"):
        load_asset(str(p))


def test_gltf_color_0_is_linear_and_multiplies_base_colour(tmp_path):
    quad = trimesh.Trimesh([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], [[0, 1, 2], [0, 2, 3]],
                           vertex_colors=np.tile([[200, 100, 50, 255]], (4, 1)).astype(np.uint8), process=False)
    p = tmp_path / "c.glb"
    p.write_bytes(trimesh.Scene(quad).export(file_type="glb"))
    a = load_asset(str(p))
    np.testing.assert_allclose(a.meshes[0].colors, np.tile([200 / 255, 100 / 255, 50 / 255], (4, 1)), atol=1e-12)
    scene = pyrt.Scene(pyrt.Camera((0, 0, 3), (0, 0, 0), fov=20, width=6, height=6, spp=1, jitter=False))
    a.add_to_scene(scene)
    alb = pyrt.render_full(scene, aovs=True).aovs["albedo"]
    # no material: the glTF default (base colour factor 1) times COLOR_0, not sRGB-decoded
    np.testing.assert_allclose(alb, np.broadcast_to([200 / 255, 100 / 255, 50 / 255], alb.shape), rtol=1e-6)


def test_gltf_16bit_png_texture_keeps_16_bits(tmp_path):
    png = pytest.importorskip("png")
    img = (np.arange(2 * 3 * 3, dtype=np.uint16).reshape(2, 3, 3) * 3001 + 7)
    buf = tmp_path / "t16.png"
    with open(buf, "wb") as fh:
        png.Writer(3, 2, greyscale=False, bitdepth=16).write(fh, img.reshape(2, -1).tolist())
    box = trimesh.creation.box()
    box.visual = trimesh.visual.TextureVisuals(uv=np.zeros((8, 2)), material=PBRMaterial(
        metallicRoughnessTexture=Image.fromarray(np.zeros((2, 2, 3), np.uint8))))
    blob = buf.read_bytes()
    files = trimesh.Scene(box).export(file_type="gltf")
    header = json.loads(files["model.gltf"])
    for name, data in files.items():
        (tmp_path / name).write_bytes(data)
    header["images"] = [{"uri": "t16.png"}]
    (tmp_path / "model.gltf").write_text(json.dumps(header))
    # the same image embedded as a data URI
    import base64
    header["images"] = [{"uri": "data:image/png;base64," + base64.b64encode(blob).decode()}]
    (tmp_path / "embedded.gltf").write_text(json.dumps(header))
    for name in ("model.gltf", "embedded.gltf"):
        m = load_asset(str(tmp_path / name)).materials[0]
        np.testing.assert_allclose(m.roughness_texture.image[..., 0], img[..., 1] / 65535.0, rtol=1e-6)
        np.testing.assert_allclose(m.metallic_texture.image[..., 0], img[..., 2] / 65535.0, rtol=1e-6)
