"""KHR_draco_mesh_compression (pyrt.io.assets.gltf_draco): GLB files written here, their geometry encoded with
DracoPy's encoder, against the same mesh uncompressed.

Ground truth: the source mesh (a UV sphere with normals, UVs and RGBA vertex colours) and Draco's quantization
bounds. With ``q`` bits over a range ``r`` (positions: the largest extent of the bounding box, 2 for the unit
sphere; UVs: 1), a value is rounded to a grid of step ``r / (2^q - 1)``, so it moves at most half a step, plus
float32 rounding (the decoder returns float32). Normals are octahedral-quantized (``QN`` bits per coordinate on
[-1, 1]^2): an error of a few steps of ``2 / (2^QN - 1)`` rad, checked against 4 steps. Draco reorders and merges
vertices, so decoded vertices are matched to source vertices by (position, uv) — distinct source vertices are
>= 1/32 apart there, a hundred times the quantization error — and triangles are compared through that matching,
each as its vertex cycle (winding kept, starting vertex free).
"""
import io
import sys

import numpy as np
import pytest
from PIL import Image
from scipy.spatial import cKDTree

from pyrt.apps import preview as P
from pyrt.io.assets import AssetError, load_asset, pack_glb

DracoPy = pytest.importorskip("DracoPy")

QP, QT, QN = 14, 12, 10                  # quantization bits: positions, texture coordinates, normals
POS_TOL = 2.0 / (2 ** QP - 1) / 2 + 1e-6          # unit sphere: extent 2; + float32
UV_TOL = 1.0 / (2 ** QT - 1) / 2 + 1e-6
NORMAL_TOL = 4 * 2.0 / (2 ** QN - 1)             # radians
_DRACO_TYPES = {0: "POSITION", 1: "NORMAL", 2: "COLOR_0", 3: "TEXCOORD_0"}   # draco::GeometryAttribute::Type


def _sphere(nu=32, nv=16):
    """A unit UV sphere (seam and poles duplicated per UV, no degenerate triangles): pos, faces, normals, uv (glTF:
    v down), RGBA uint8 colours."""
    u, v = np.meshgrid(np.arange(nu + 1) / nu, np.arange(nv + 1) / nv)
    th, ph = v.ravel() * np.pi, u.ravel() * 2 * np.pi
    pos = np.stack([np.sin(th) * np.cos(ph), np.cos(th), -np.sin(th) * np.sin(ph)], axis=1)
    i, j = np.meshgrid(np.arange(nv), np.arange(nu), indexing="ij")
    a = (i * (nu + 1) + j).ravel()
    faces = np.concatenate([np.stack([a, a + nu + 1, a + 1], 1), np.stack([a + 1, a + nu + 1, a + nu + 2], 1)])
    area = np.linalg.norm(np.cross(pos[faces[:, 1]] - pos[faces[:, 0]], pos[faces[:, 2]] - pos[faces[:, 0]]), axis=1)
    colors = np.round(np.c_[pos * 0.4 + 0.5, 1.0 - 0.5 * v.ravel()] * 255).astype(np.uint8)
    return {"pos": pos, "faces": faces[area > 1e-9], "normals": pos.copy(), "uv": np.stack([u.ravel(), v.ravel()], 1),
            "colors": colors}


def _encode(m):
    """(Draco bytes of mesh ``m``, glTF name -> Draco unique id, the mesh as DracoPy decodes it)."""
    buf = DracoPy.encode(m["pos"], m["faces"].astype(np.uint32), quantization_bits=QP, normals=m["normals"],
                         tex_coord=m["uv"], colors=m["colors"], tex_coord_quantization_bits=QT,
                         normal_quantization_bits=QN)
    d = DracoPy.decode(buf)
    ids = {_DRACO_TYPES[a["attribute_type"]]: a["unique_id"] for a in d.attributes}
    key = {"POSITION": "pos", "NORMAL": "normals", "TEXCOORD_0": "uv", "COLOR_0": "colors"}
    dec = {key[n]: np.asarray(d.get_attribute_by_unique_id(i)["data"]) for n, i in ids.items()}
    dec["faces"] = np.asarray(d.faces)
    return buf, ids, dec


def _png(h=8, w=8):
    y, x = np.mgrid[0:h, 0:w]
    img = np.stack([x * 255 // (w - 1), y * 255 // (h - 1), np.full_like(x, 128)], -1).astype(np.uint8)
    out = io.BytesIO()
    Image.fromarray(img).save(out, format="PNG")
    return out.getvalue()


def write_glb(path, m, *, draco=None, required=True):
    """A GLB of mesh ``m``: one primitive with POSITION, NORMAL, TEXCOORD_0, COLOR_0 (uint8, normalized) and uint32
    indices; its material textured (an embedded 8x8 PNG gradient) and lit by the vertex colours.

    ``draco=(bytes, ids)``: the primitive has ``KHR_draco_mesh_compression`` and ``m`` should be the decoded mesh
    (the accessors describe it, as the extension requires); ``required``: in extensionsRequired, the indices and
    the attributes in ``ids`` without bufferViews; else in extensionsUsed only, ``m`` written as the uncompressed
    fallback.
    """
    blob = bytearray()
    views, accessors = [], []
    compressed = set(draco[1]) | {"indices"} if draco is not None and required else set()

    def view(data):
        views.append({"buffer": 0, "byteOffset": len(blob), "byteLength": len(data)})
        blob.extend(data)
        blob.extend(b"\0" * (-len(blob) % 4))
        return len(views) - 1

    def accessor(name, arr, comp, typ, **extra):
        arr = np.ascontiguousarray(arr)
        acc = {"componentType": comp, "count": int(arr.shape[0]), "type": typ, **extra}
        if name not in compressed:
            acc["bufferView"] = view(arr.tobytes())
        accessors.append(acc)
        return len(accessors) - 1

    p32 = np.asarray(m["pos"], np.float32)
    attrs = {"POSITION": accessor("POSITION", p32, 5126, "VEC3", min=p32.min(0).tolist(), max=p32.max(0).tolist()),
             "NORMAL": accessor("NORMAL", np.asarray(m["normals"], np.float32), 5126, "VEC3"),
             "TEXCOORD_0": accessor("TEXCOORD_0", np.asarray(m["uv"], np.float32), 5126, "VEC2"),
             "COLOR_0": accessor("COLOR_0", np.asarray(m["colors"], np.uint8), 5121, "VEC4", normalized=True)}
    prim = {"attributes": attrs, "material": 0, "mode": 4,
            "indices": accessor("indices", np.asarray(m["faces"], np.uint32).ravel(), 5125, "SCALAR")}
    if draco is not None:
        prim["extensions"] = {"KHR_draco_mesh_compression": {"bufferView": view(draco[0]), "attributes": draco[1]}}
    h = {"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
         "meshes": [{"name": "ball", "primitives": [prim]}],
         "materials": [{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}, "roughnessFactor": 0.6,
                                                 "metallicFactor": 0.0}}],
         "textures": [{"source": 0, "sampler": 0}], "samplers": [{"magFilter": 9729, "minFilter": 9729}],
         "images": [{"bufferView": view(_png()), "mimeType": "image/png"}],
         "accessors": accessors, "bufferViews": views, "buffers": [{"byteLength": len(blob)}]}
    if draco is not None:
        h["extensionsUsed"] = ["KHR_draco_mesh_compression"]
        if required:
            h["extensionsRequired"] = ["KHR_draco_mesh_compression"]
    path.write_bytes(pack_glb(h, bytes(blob)))
    return str(path)


@pytest.fixture(scope="module")
def sphere():
    m = _sphere()
    buf, ids, dec = _encode(m)
    return m, (buf, ids), dec


def _no_dracopy(monkeypatch):
    monkeypatch.setitem(sys.modules, "DracoPy", None)          # makes ``import DracoPy`` fail


def _cycles(faces):
    """Each triangle as its vertex cycle started at its smallest index (winding kept), sorted."""
    f = np.asarray(faces)
    r = np.argmin(f, axis=1)[:, None]
    return sorted(map(tuple, np.take_along_axis(f, (r + np.arange(3)) % 3, axis=1).tolist()))


def test_draco_sphere_loads_within_the_quantization_error(tmp_path, sphere):
    m, draco, dec = sphere
    mesh, = load_asset(write_glb(tmp_path / "d.glb", dec, draco=draco)).meshes
    assert 0 < mesh.vertices.shape[0] <= m["pos"].shape[0]          # Draco reorders (and may merge) vertices
    uv = mesh.uv.copy()
    uv[:, 1] = 1.0 - uv[:, 1]                                         # pyrt's v up -> glTF's v down
    dist, src = cKDTree(np.c_[m["pos"], m["uv"]]).query(np.c_[mesh.vertices, uv])
    assert dist.max() < 1e-3                                          # each decoded vertex has its source vertex
    assert np.abs(mesh.vertices - m["pos"][src]).max() <= POS_TOL
    assert np.abs(uv - m["uv"][src]).max() <= UV_TOL
    cos = np.clip(np.einsum("ij,ij->i", mesh.normals, m["normals"][src]), -1.0, 1.0)
    assert np.arccos(cos).max() <= NORMAL_TOL
    np.testing.assert_allclose(np.linalg.norm(mesh.normals, axis=1), 1.0, atol=1e-12)   # renormalised as usual
    np.testing.assert_array_equal(mesh.colors, m["colors"][src, :3] / 255.0)           # uint8: exact
    np.testing.assert_array_equal(mesh.alpha, m["colors"][src, 3] / 255.0)
    assert _cycles(src[mesh.faces]) == _cycles(m["faces"])           # the same triangles, same winding


def test_draco_render_matches_the_uncompressed_file(tmp_path, sphere):
    """Previews at 64x48, 1 spp. The Draco file renders exactly as the uncompressed GLB of the mesh DracoPy decodes
    (the loader adds nothing). Against the uncompressed source mesh, the quantization moves vertices by <= 6.1e-5
    (a pixel is ~0.05 units here) and normals by <= 7.8e-3 rad, and Draco's vertex order changes which random
    numbers a few pixels draw: the mean |difference| must stay below the noise (the same file rendered with another
    seed differs by ~7% of the mean; Draco by ~0.4%) and the image means agree to 0.5%."""
    m, draco, dec = sphere
    o = P.PreviewOptions(width=64, height=48, spp=1)
    img = P.render_preview(write_glb(tmp_path / "d.glb", dec, draco=draco), o, name="v").images[0]
    same = P.render_preview(write_glb(tmp_path / "decoded.glb", dec), o, name="v").images[0]
    np.testing.assert_array_equal(img, same)
    ref = P.render_preview(write_glb(tmp_path / "plain.glb", m), o, name="v").images[0]
    noise = P.render_preview(write_glb(tmp_path / "plain.glb", m), P.PreviewOptions(width=64, height=48, spp=1,
                                                                                      seed=1), name="v").images[0]
    assert np.abs(img - ref).mean() < 0.25 * np.abs(noise - ref).mean()
    assert abs(img.mean() - ref.mean()) <= 0.005 * ref.mean()


def test_an_attribute_the_extension_does_not_list_is_read_from_its_accessor(tmp_path, sphere):
    """COLOR_0 left out of the extension's attributes, its accessor holding other colours than the Draco data's."""
    _, (buf, ids), dec = sphere
    ids = {k: v for k, v in ids.items() if k != "COLOR_0"}
    path = write_glb(tmp_path / "c.glb", {**dec, "colors": 255 - dec["colors"]}, draco=(buf, ids))
    mesh, = load_asset(path).meshes
    np.testing.assert_array_equal(mesh.vertices, dec["pos"])
    np.testing.assert_array_equal(mesh.colors, (255 - dec["colors"][:, :3]) / 255.0)


def test_required_draco_without_dracopy_names_the_extra(tmp_path, sphere, monkeypatch, capsys):
    _, draco, dec = sphere
    path = write_glb(tmp_path / "d.glb", dec, draco=draco)
    _no_dracopy(monkeypatch)
    with pytest.raises(AssetError, match=r"d\.glb: requires .*KHR_draco_mesh_compression \(Draco-compressed "
                                         r"geometry, which needs the DracoPy package: pip install "
                                         r"'pyrt-embree\[draco\]'\)"):
        load_asset(path)
    rc = P.main([path, "-o", str(tmp_path / "out.png"), "--width", "24", "--height", "18", "--quiet"])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and err[0].startswith("pyrt-preview: error: ")
    assert "pip install 'pyrt-embree[draco]'" in err[0]


def test_used_draco_without_dracopy_or_fallback_names_the_primitive(tmp_path, sphere, monkeypatch):
    """A file that uses the extension without requiring it but has no fallback (an exporter's mistake)."""
    _, draco, dec = sphere
    path = write_glb(tmp_path / "d.glb", dec, draco=draco)
    raw = bytearray(open(path, "rb").read())
    i = raw.index(b',"extensionsRequired":["KHR_draco_mesh_compression"]')
    n = len(b',"extensionsRequired":["KHR_draco_mesh_compression"]')
    raw[i:i + n] = b" " * n                                          # same JSON chunk length, no longer required
    open(path, "wb").write(raw)
    _no_dracopy(monkeypatch)
    with pytest.raises(AssetError, match=r"d\.glb: mesh 0 \(ball\) primitive 0: .*without an uncompressed "
                                         r"fallback needs the DracoPy package: pip install 'pyrt-embree\[draco\]'"):
        load_asset(path)


def test_corrupt_draco_buffer_names_the_primitive(tmp_path, sphere):
    _, (buf, ids), dec = sphere
    bad = buf[:len(buf) // 2] + b"\xff" * (len(buf) - len(buf) // 2)
    path = write_glb(tmp_path / "bad.glb", dec, draco=(bad, ids))
    with pytest.raises(AssetError, match=r"bad\.glb: mesh 0 \(ball\) primitive 0: KHR_draco_mesh_compression: "
                                         r"bufferView \d+: the Draco decoder failed: \w+: .+"):
        load_asset(path)
    path = write_glb(tmp_path / "ids.glb", dec, draco=(buf, {**ids, "NORMAL": 77}))
    with pytest.raises(AssetError, match=r"primitive 0: KHR_draco_mesh_compression: NORMAL: the Draco data has no "
                                         r"attribute with unique id 77"):
        load_asset(path)


def test_draco_vertex_count_must_match_the_position_accessor(tmp_path, sphere):
    _, draco, dec = sphere
    short = {**dec, "pos": dec["pos"][:-1]}                          # POSITION accessor count one less
    with pytest.raises(AssetError, match=r"primitive 0: KHR_draco_mesh_compression: the Draco data has "
                                         rf"{len(dec['pos'])} vertices, the POSITION accessor says "
                                         rf"{len(dec['pos']) - 1}"):
        load_asset(write_glb(tmp_path / "n.glb", short, draco=draco))


def test_used_not_required_prefers_draco_and_falls_back_without_dracopy(tmp_path, sphere, monkeypatch):
    """The fallback is the decoded mesh (as the extension asks exporters to write it) shifted by +10 in x, so the
    loaded positions say which one was read."""
    _, draco, dec = sphere
    fallback = {**dec, "pos": dec["pos"] + [10.0, 0.0, 0.0]}
    path = write_glb(tmp_path / "u.glb", fallback, draco=draco, required=False)
    a = load_asset(path)
    np.testing.assert_array_equal(a.meshes[0].vertices, dec["pos"])            # Draco takes precedence
    np.testing.assert_array_equal(a.meshes[0].faces, dec["faces"])
    assert not a.warnings
    _no_dracopy(monkeypatch)
    a = load_asset(path)
    np.testing.assert_array_equal(a.meshes[0].vertices, fallback["pos"].astype(np.float32))
    np.testing.assert_array_equal(a.meshes[0].faces, dec["faces"])
    assert any("DracoPy package is not installed: the uncompressed fallback is read" in w for w in a.warnings)
