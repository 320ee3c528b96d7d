"""Forgiving asset loading (pyrt.io.assets): missing textures and MTLs are substitutions, image modes are converted,
PLY face colours and triangle strips are read; truly broken files still fail naming the file and the part."""
import json
import os
import re
import struct

import numpy as np
import pytest
import trimesh
from PIL import Image
from trimesh.visual.material import PBRMaterial

import pyrt
from pyrt.io import assets as A
from pyrt.io.assets import AssetError, load_asset, pack_glb, read_gltf
from pyrt.shaders import color as C
from pyrt.textures import load_image
import pyrt.apps.preview as P


# ----------------------------------------------------------------------------- image modes

def test_image_modes_decode_to_known_pixels(tmp_path, rng):
    rgb = rng.integers(0, 256, (4, 5, 3), dtype=np.uint8)
    g = rng.integers(0, 256, (4, 5), dtype=np.uint8)
    a = (255 - g).astype(np.uint8)
    Image.fromarray(g, "L").save(tmp_path / "L.png")
    Image.fromarray(np.dstack([g, a]), "LA").save(tmp_path / "LA.png")
    pal = Image.fromarray(rgb).convert("P", palette=Image.ADAPTIVE, colors=8)
    pal.save(tmp_path / "P.png")
    pal.save(tmp_path / "Pt.png", transparency=0)
    Image.fromarray(g.astype(np.uint16) * 257).save(tmp_path / "I16.png")
    Image.fromarray(rgb).convert("CMYK").save(tmp_path / "cmyk.tif")      # lossless: CMYK = 255 - RGB, K = 0
    im, is_int = load_image(tmp_path / "L.png")
    assert is_int and im.shape == (4, 5)
    np.testing.assert_array_equal(im, g / np.float32(255))
    im = load_image(tmp_path / "LA.png")[0]                                 # skimage.io returned (5, 2, 4) here
    assert im.shape == (4, 5, 2)
    np.testing.assert_array_equal(im, np.dstack([g, a]) / np.float32(255))
    want = np.asarray(pal.convert("RGB"))
    np.testing.assert_array_equal(load_image(tmp_path / "P.png")[0], want / np.float32(255))
    im = load_image(tmp_path / "Pt.png")[0]                                 # palette + tRNS: RGBA
    assert im.shape == (4, 5, 4)
    np.testing.assert_array_equal(im[..., :3], want / np.float32(255))
    np.testing.assert_array_equal(im[..., 3], np.where(np.asarray(pal) == 0, 0.0, 1.0))
    np.testing.assert_array_equal(load_image(tmp_path / "I16.png")[0], (g.astype(np.float32) * 257) / 65535)
    im = load_image(tmp_path / "cmyk.tif")[0]                               # RGB, not four ink channels
    assert im.shape == (4, 5, 3)
    np.testing.assert_array_equal(im, rgb / np.float32(255))


def test_colour_texels_expand_grey_and_keep_alpha():
    g = np.arange(6, dtype=np.float32).reshape(2, 3)
    np.testing.assert_array_equal(A.colour_texels(g), np.dstack([g, g, g]))
    ga = np.dstack([g, g + 10])
    np.testing.assert_array_equal(A.colour_texels(ga), np.dstack([g, g, g, g + 10]))
    rgb = np.zeros((2, 3, 3))
    assert A.colour_texels(rgb) is rgb


def _textured_gltf(tmp_path, image, name="model.gltf"):
    """A .gltf (files beside it) of a box whose base colour texture is replaced by ``image`` (a PIL image) or by a
    reference to a missing file when ``image`` is None."""
    box = trimesh.creation.box()
    box.visual = trimesh.visual.TextureVisuals(uv=np.full((8, 2), 0.5), material=PBRMaterial(
        baseColorTexture=Image.fromarray(np.zeros((2, 2, 3), np.uint8)), baseColorFactor=[255, 128, 64, 255]))
    files = trimesh.Scene(box).export(file_type="gltf")
    header = json.loads(files["model.gltf"])
    for n, data in files.items():
        if n != "model.gltf":
            (tmp_path / n).write_bytes(data)
    header["images"] = [{"uri": "tex.png"}]
    if image is not None:
        image.save(tmp_path / "tex.png")
    (tmp_path / name).write_text(json.dumps(header))
    return str(tmp_path / name)


def test_grey_alpha_base_colour_png_renders_as_grey(tmp_path):
    g = np.array([[10, 200], [90, 255]], np.uint8)
    a = load_asset(_textured_gltf(tmp_path, Image.fromarray(np.dstack([g, 255 - g]), "LA")))
    tex = a.materials[0].base_color_texture.texture
    assert tex.channels == 3 and not a.substitutions
    np.testing.assert_allclose(tex.image, np.dstack([C.srgb_decode(g / 255.0)] * 3), rtol=1e-6)


def test_grey_map_kd_reads_as_rgb(tmp_path):
    (tmp_path / "m.obj").write_text("mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nusemtl a\n"
                                    "f 1/1 2/2 3/3\n")
    (tmp_path / "m.mtl").write_text("newmtl a\nKd 1 1 1\nmap_Kd g.png\n")
    Image.fromarray(np.full((2, 2), 128, np.uint8), "L").save(tmp_path / "g.png")
    a = load_asset(str(tmp_path / "m.obj"))
    tex = a.materials[0].map_Kd
    assert tex.channels == 3
    np.testing.assert_allclose(tex.image, C.srgb_decode(np.float32(128 / 255)), rtol=1e-6)


# ----------------------------------------------------------------------------- substitutions

def test_missing_gltf_texture_renders_with_the_factor(tmp_path):
    path = _textured_gltf(tmp_path, None)
    a = load_asset(path)
    assert a.materials[0].base_color_texture is None and len(a.substitutions) == 1
    assert "tex.png" in a.substitutions[0] and "factor alone" in a.substitutions[0]
    scene = pyrt.Scene(pyrt.Camera((0, 0, 4), (0, 0, 0), fov=20, width=8, height=8, spp=1, jitter=False))
    a.add_to_scene(scene)
    alb = pyrt.render_full(scene, aovs=True).aovs["albedo"][4, 4]
    np.testing.assert_allclose(alb, a.materials[0].base_color_factor[:3], rtol=1e-6)   # factor alone


def test_missing_mtl_gives_the_default_material(tmp_path):
    (tmp_path / "m.obj").write_text("mtllib gone.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl red\nf 1 2 3\n")
    a = load_asset(str(tmp_path / "m.obj"))
    assert a.meshes[0].material == -1 and a.materials == []
    assert len(a.substitutions) == 1 and "material library not found" in a.substitutions[0]
    assert "gone.mtl" in a.substitutions[0] and "default material" in a.substitutions[0]
    assert not [w for w in a.warnings if "not defined in the MTL" in w]      # one message for one cause


def test_corrupt_texture_file_is_still_an_error(tmp_path):
    path = _textured_gltf(tmp_path, None)
    (tmp_path / "tex.png").write_bytes(b"\x89PNG\r\n\x1a\n" + b"\0" * 30)
    with pytest.raises(AssetError, match=r"model\.gltf: image 0 \(tex\.png\): .*tex\.png: not a readable PNG"):
        load_asset(path)


def test_batch_summary_lists_every_substitution(tmp_path):
    d = tmp_path / "models"
    d.mkdir()
    (d / "m.obj").write_text("mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nusemtl a\nf 1/1 2/1 3/1\n")
    (d / "m.mtl").write_text("newmtl a\nKd 1 1 1\nmap_Kd gone.png\nmap_Ke gone2.png\n")
    (d / "n.obj").write_text("mtllib nothere.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    out = tmp_path / "out"
    reps = P.preview_batch([str(d)], str(out), P.PreviewOptions(width=24, height=18, spp=1), progress=False)
    assert [r.status for r in reps] == ["ok", "ok"]
    assert [len(r.substitutions) for r in reps] == [2, 1]
    table = (out / "summary.txt").read_text()
    for r in reps:
        for s in r.substitutions:
            assert s in table
    csv = (out / "summary.csv").read_text()
    assert "gone2.png" in csv and "nothere.mtl" in csv and "substitutions" in csv.splitlines()[0]
    assert all(r.phases and set(r.phases) >= {"load", "normals", "bvh", "render", "write"} for r in reps)


def test_preview_summary_line_has_every_phase(tmp_path, capsys):
    blob = os.path.join(os.path.dirname(__file__), "..", "assets", "models", "blob.ply")
    assert P.main([blob, "-o", str(tmp_path / "v.png"), "--width", "24", "--height", "18", "--spp", "1"]) == 0
    line = [ln for ln in capsys.readouterr().out.splitlines() if "triangles" in ln][0]
    for phase in ("load", "frame", "normals", "scene", "geometry", "BVH", "render", "encode", "write", "total"):
        assert re.search(rf"\b{phase} \d+\.\d\d s", line), (phase, line)


# ----------------------------------------------------------------------------- PLY face colours and strips

def test_ply_face_colours_shade_each_face(tmp_path):
    v = np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], float)
    # a degenerate face first: add_mesh skips it, and the colours must stay with their faces
    f = np.array([[0, 0, 1], [0, 1, 2], [0, 2, 3]])
    fc = np.array([[255, 255, 255, 255], [200, 30, 30, 255], [30, 200, 60, 255]], np.uint8)
    m = trimesh.Trimesh(v, f, face_colors=fc, process=False)
    (tmp_path / "q.ply").write_bytes(trimesh.exchange.ply.export_ply(m, encoding="binary"))
    a = load_asset(str(tmp_path / "q.ply"))
    np.testing.assert_allclose(a.meshes[0].face_colors, C.srgb_decode(fc[:, :3] / 255.0))
    scene = pyrt.Scene(pyrt.Camera((0, 0, 5), (0, 0, 0), fov=30, width=16, height=16, spp=1, jitter=False))
    with pytest.warns(UserWarning, match="degenerate"):
        a.add_to_scene(scene)
    alb = pyrt.render_full(scene, aovs=True).aovs["albedo"]
    base = 0.8                                               # DefaultParams clay
    lower_right, upper_left = alb[12, 11], alb[3, 4]         # faces (0, 1, 2) and (0, 2, 3)
    np.testing.assert_allclose(lower_right, base * C.srgb_decode(fc[1, :3] / 255.0), rtol=1e-5)
    np.testing.assert_allclose(upper_left, base * C.srgb_decode(fc[2, :3] / 255.0), rtol=1e-5)


def _strip_header(fmt, nv, ns, extra_face=False):
    h = f"ply\nformat {fmt} 1.0\nelement vertex {nv}\nproperty float x\nproperty float y\nproperty float z\n"
    if extra_face:
        h += "element dummy 2\nproperty uchar k\nproperty list uchar int idx\n"
    return h + f"element tristrips {ns}\nproperty list int int vertex_indices\nend_header\n"


STRIP_V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0], [0, 2, 0], [1, 2, 0], [0, 3, 0]], np.float32)
STRIPS = [[0, 1, 2, 3, -1, 2, 3, 4, 5, 5, 6], [4, 5, 6]]
STRIP_FACES = [[0, 1, 2], [2, 1, 3], [2, 3, 4], [4, 3, 5], [4, 5, 6]]   # (5, 5, 6) stitches: dropped


@pytest.mark.parametrize("fmt", ["ascii", "binary_little_endian", "binary_big_endian"])
def test_ply_tristrips_read(tmp_path, fmt):
    p = tmp_path / "s.ply"
    if fmt == "ascii":
        body = "".join(f"{x} {y} {z}\n" for x, y, z in STRIP_V)
        body += "".join(f"{len(s)} {' '.join(map(str, s))}\n" for s in STRIPS)
        p.write_text(_strip_header(fmt, len(STRIP_V), len(STRIPS)) + body)
    else:
        e = "<" if fmt.endswith("little_endian") else ">"
        raw = STRIP_V.astype(e + "f4").tobytes()
        dummy = struct.pack(e + "BBii", 7, 2, 1, 2) + struct.pack(e + "BB", 8, 0)    # rows with lists to skip
        raw += dummy + b"".join(struct.pack(f"{e}i{len(s)}i", len(s), *s) for s in STRIPS)
        p.write_bytes(_strip_header(fmt, len(STRIP_V), len(STRIPS), extra_face=True).encode() + raw)
    a = load_asset(str(p))
    assert a.meshes[0].faces.tolist() == STRIP_FACES
    assert any("triangle strips read (2 strip(s), 5 triangles)" in w for w in a.warnings)
    n = trimesh.Trimesh(STRIP_V, a.meshes[0].faces, process=False).face_normals
    np.testing.assert_allclose(n, np.tile([0, 0, 1.0], (5, 1)), atol=1e-6)      # one winding throughout


def test_tristrip_faces_restart_and_stitches():
    f = A.tristrip_faces([np.array([0, 1, 2, 3, 4]), np.array([5, 6, 7, -1, 8, 9, 10, 10, 11])])
    assert f.tolist() == [[0, 1, 2], [2, 1, 3], [2, 3, 4], [5, 6, 7], [8, 9, 10]]
    assert A.tristrip_faces([]).shape == (0, 3)


# ----------------------------------------------------------------------------- truly broken files

def _glb(tmp_path, patch=None, cut=None):
    raw = trimesh.Scene(trimesh.creation.box()).export(file_type="glb")
    (tmp_path / "raw.glb").write_bytes(raw)
    header, buffers = read_gltf(tmp_path / "raw.glb")
    if patch:
        patch(header)
    data = pack_glb(header, buffers[0])
    (tmp_path / "x.glb").write_bytes(data[:cut] if cut else data)
    return str(tmp_path / "x.glb")


def _bad_json(tmp_path):
    (tmp_path / "x.gltf").write_text('{"asset": {"version": "2.0"}, "meshes": [')
    return str(tmp_path / "x.gltf")


def _index_out_of_range(tmp_path):
    def patch(h):
        h["meshes"][0]["primitives"][0]["material"] = 7
    return _glb(tmp_path, patch)


def _truncated(tmp_path):
    return _glb(tmp_path, cut=-40)


def _ply_face_out_of_range(tmp_path):
    (tmp_path / "x.ply").write_text("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                                    "property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
                                    "end_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 9\n")
    return str(tmp_path / "x.ply")


def _truncated_tristrips(tmp_path):
    raw = STRIP_V.astype("<f4").tobytes() + struct.pack("<i3i", 4, 0, 1, 2)
    (tmp_path / "x.ply").write_bytes(_strip_header("binary_little_endian", len(STRIP_V), 1).encode() + raw)
    return str(tmp_path / "x.ply")


def _tristrip_index_out_of_range(tmp_path):
    body = "".join(f"{x} {y} {z}\n" for x, y, z in STRIP_V) + "3 0 1 99\n"
    (tmp_path / "x.ply").write_text(_strip_header("ascii", len(STRIP_V), 1) + body)
    return str(tmp_path / "x.ply")


@pytest.mark.parametrize("make, part", [
    (_bad_json, r"x\.gltf: not valid glTF JSON"),
    (_truncated, r"x\.glb: GLB header says \d+ bytes but the file has \d+ \(truncated\)"),
    (_index_out_of_range, r"x\.glb: mesh 0 .*primitive 0: material 7 does not exist"),
    (_ply_face_out_of_range, r"x\.ply: face 0 refers to a vertex that does not exist"),
    (_truncated_tristrips, r"x\.ply: the PLY data ends at byte \d+ inside the tristrips \(truncated\)"),
    (_tristrip_index_out_of_range, r"x\.ply: tristrips refer to vertex 99 but the file has 7 vertices"),
])
def test_broken_files_still_fail_naming_file_and_part(tmp_path, make, part):
    with pytest.raises(AssetError, match=part):
        load_asset(make(tmp_path))


def test_missing_extension_texture_is_a_substitution_too(tmp_path):
    path = _textured_gltf(tmp_path, None)
    header = json.loads(open(path).read())
    header["materials"][0]["extensions"] = {"KHR_materials_clearcoat": {
        "clearcoatFactor": 0.5, "clearcoatTexture": {"index": 0}, "clearcoatNormalTexture": {"index": 0}}}
    open(path, "w").write(json.dumps(header))
    a = load_asset(path)
    P = a.materials[0]
    assert P.clearcoat_texture is None and P.clearcoat_normal_texture is None and P.clearcoat_factor == 0.5
    assert len(a.substitutions) == 3 and all("tex.png" in s for s in a.substitutions)


# ----------------------------------------------------------------------------- files named as the exporter had them

def _red_png(path):
    path.parent.mkdir(parents=True, exist_ok=True)
    Image.fromarray(np.full((2, 2, 3), (200, 10, 10), np.uint8)).save(path)


@pytest.mark.parametrize("named, where", [
    (r"C:\Users\someone\Desktop\car\textures\Paint.JPG.png", "textures/paint.jpg.png"),   # Windows absolute path
    (r"textures\PAINT.jpg.png", "textures/paint.jpg.png"),                                  # backslashes, other case
    ("/home/other/models/paint.jpg.png", "paint.jpg.png"),                                 # foreign absolute path
    ("paint.jpg.png", "sub/deeper/paint.jpg.png"),                                          # moved two folders down
])
def test_textures_are_found_where_the_exporter_did_not_put_them(tmp_path, named, where):
    _red_png(tmp_path / where)
    (tmp_path / "M.MTL").write_text(f"newmtl a\nKd 1 1 1\nmap_Kd {named}\n")
    (tmp_path / "m.obj").write_text("mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\n"
                                    "usemtl a\nf 1/1 2/2 3/3\n")
    a = load_asset(str(tmp_path / "m.obj"))
    notes = "\n".join(a.substitutions)
    assert "material library 'm.mtl' not found as named; using" in notes and "M.MTL (found by its name in another " \
        "case)" in notes
    assert f"texture {named!r} not found as named; using {tmp_path / where}" in notes
    (mat,) = a.materials
    assert "texture file not found" not in notes
    np.testing.assert_array_equal(mat.map_Kd.texels[..., :3], np.full((2, 2, 3), (200, 10, 10), np.uint8))


def test_texture_found_as_named_is_not_a_substitution_and_nothing_found_still_is(tmp_path):
    _red_png(tmp_path / "t.png")
    (tmp_path / "m.mtl").write_text("newmtl a\nmap_Kd t.png\nnewmtl b\nmap_Kd C:\\nowhere\\gone.png\n")
    (tmp_path / "m.obj").write_text("mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl a\nf 1 2 3\n")
    a = load_asset(str(tmp_path / "m.obj"))
    assert len(a.substitutions) == 1 and "gone.png; rendered with the factor alone" in a.substitutions[0]


def test_find_file_prefers_the_shortest_path_and_bounds_the_search(tmp_path, monkeypatch):
    from pyrt.io.assets import find_file as F
    for p in ("a/b/x.png", "z/x.png", "a/b/c/d/x.png"):
        _red_png(tmp_path / p)
    path, how = F.find_file(str(tmp_path), "x.png")
    assert path == str(tmp_path / "z" / "x.png") and how == "found by its file name"
    (tmp_path / "only_deep").mkdir()
    _red_png(tmp_path / "only_deep/1/2/3/deep.png")
    assert F.find_file(str(tmp_path), "deep.png") == (None, None)          # below SEARCH_DEPTH
    assert F.find_file(str(tmp_path), "X.PNG")[0] == str(tmp_path / "z" / "x.png")
    monkeypatch.setattr(F, "SEARCH_ENTRIES", 2)        # the model's own folder already has 3 entries: stop there
    assert F.find_file(str(tmp_path), "x.png") == (None, None)


def test_gltf_image_and_buffer_in_another_case_are_found_and_named(tmp_path):
    g = np.array([[10, 200], [90, 255]], np.uint8)
    path = _textured_gltf(tmp_path, Image.fromarray(np.dstack([g, g, g]), "RGB"))
    header = json.loads(open(path).read())
    header["images"] = [{"uri": "TEX.png"}]                 # the file is tex.png
    buf = header["buffers"][0]
    os.rename(tmp_path / buf["uri"], tmp_path / buf["uri"].upper())
    with open(path, "w") as fh:
        json.dump(header, fh)
    a = load_asset(path)
    tex = a.materials[0].base_color_texture.texture
    np.testing.assert_allclose(tex.image[..., 0], C.srgb_decode(g / 255.0), rtol=1e-6)
    notes = "\n".join(a.substitutions)
    assert "'TEX.png' not found as named; using " in notes and "tex.png (found by its name in another case)" in notes
    assert f"{buf['uri']!r} not found as named; using " in notes and len(a.substitutions) == 2, notes


_PLY_HEAD = """ply
format ascii 1.0
comment TextureFile {tex}
element vertex 4
property float x
property float y
property float z
{vprops}element face 2
property list uchar int vertex_indices
{fprops}end_header
"""


@pytest.mark.parametrize("layout", ["vertex_st", "face_texcoord"])
def test_ply_texture_file_becomes_the_diffuse_colour(tmp_path, layout):
    """A PLY scan's ``comment TextureFile`` (MeshLab, photogrammetry tools) is its colour, read as an OBJ scan's map_Kd,
    with the UVs of vertex s t or face texcoord lists; the file is found in another case too."""
    quad = np.array([[[200, 10, 10], [10, 200, 10]], [[10, 10, 200], [200, 200, 10]]], np.uint8)
    Image.fromarray(quad).save(tmp_path / "Scan_Texture.png")
    if layout == "vertex_st":
        head = _PLY_HEAD.format(tex="scan_texture.png", vprops="property float s\nproperty float t\n", fprops="")
        body = "0 0 0 0 0\n1 0 0 1 0\n1 1 0 1 1\n0 1 0 0 1\n3 0 1 2\n3 0 2 3\n"
    else:
        head = _PLY_HEAD.format(tex="scan_texture.png", vprops="", fprops="property list uchar float texcoord\n")
        body = "0 0 0\n1 0 0\n1 1 0\n0 1 0\n3 0 1 2 6 0 0 1 0 1 1\n3 0 2 3 6 0 0 1 1 0 1\n"
    (tmp_path / "scan.ply").write_text(head + body)
    a = load_asset(str(tmp_path / "scan.ply"))
    (m,) = a.meshes
    assert m.material == 0 and m.uv is not None and m.uv.shape == (4, 2)
    np.testing.assert_array_equal(a.materials[0].map_Kd.texels[..., :3], quad)
    np.testing.assert_array_equal(a.materials[0].Kd, [1, 1, 1])
    assert len(a.substitutions) == 1 and "found by its name in another case" in a.substitutions[0]
    # rendered, the quad shows its texture's red corner (u, v) = (0, 1): image row 0, column 0
    cam = pyrt.Camera(position=(0.5, 0.5, 2), target=(0.5, 0.5, 0), fov=40, width=16, height=16, spp=1, jitter=False)
    scene = pyrt.Scene(cam)
    a.add_to_scene(scene)
    scene.add_light(pyrt.DirectionalLight((0, 0, -1), irradiance=3.0))
    img = pyrt.render(scene, seed=0, progress=False)
    assert img[4, 4, 0] > 5 * img[4, 4, 1] and img[11, 11, 1] > 5 * img[11, 11, 2]     # red top left, yellow bottom right


def test_ply_texture_file_missing_or_without_uvs(tmp_path):
    head = _PLY_HEAD.format(tex="gone.png", vprops="property float s\nproperty float t\n", fprops="")
    (tmp_path / "a.ply").write_text(head + "0 0 0 0 0\n1 0 0 1 0\n1 1 0 1 1\n0 1 0 0 1\n3 0 1 2\n3 0 2 3\n")
    a = load_asset(str(tmp_path / "a.ply"))
    assert a.meshes[0].material == -1 and a.materials == []
    assert len(a.substitutions) == 1 and "gone.png; rendered with the clay material" in a.substitutions[0]
    head = _PLY_HEAD.format(tex="t.png", vprops="", fprops="")
    Image.fromarray(np.zeros((2, 2, 3), np.uint8)).save(tmp_path / "t.png")
    (tmp_path / "b.ply").write_text(head + "0 0 0\n1 0 0\n1 1 0\n0 1 0\n3 0 1 2\n3 0 2 3\n")
    b = load_asset(str(tmp_path / "b.ply"))
    assert b.meshes[0].material == -1 and any("no texture coordinates" in w for w in b.warnings)
