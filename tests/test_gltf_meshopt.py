"""EXT_meshopt_compression / KHR_meshopt_compression (pyrt.io.assets.gltf_meshopt): GLB fixtures compressed by
meshoptimizer's own C encoder (tests/data/meshopt/, written by tools/make_meshopt_fixtures.py with the PyPI package
``meshoptimizer`` 0.2.30a0; not needed here), against two independent ground truths the generator stored in
``expected.npz``:

- ``<file>_view<i>``: the bytes meshoptimizer's C decoder makes of each compressed bufferView (filters applied).
  The codecs are lossless, so pyrt's bytes must be the same; the OCTAHEDRAL and QUATERNION filters are specified to
  one unit in the last place of their integer outputs (Appendix B), the bound used for them; EXPONENTIAL is exact;
- ``src_*``: the mesh before encoding. Unfiltered attributes and indices come back exactly; filtered ones within
  the filter's quantisation (K-bit octahedral: a step of 2 / (2^(K-1) - 1) in the octahedral square, at most that
  many radians; exponential with b-bit mantissas: a relative error of 2^-(b-1); quaternion with K bits: a component
  error of 1/sqrt(2) / (2^(K-1) - 1)).

The fixtures cover vertex codec versions 0 (sphere_ext, sphere_used) and 1 at level 3 (sphere_khr: its streams use
control modes 0-3 and channel modes 0, 1 and 2, checked below), the triangle codec versions 1 (uint32) and 0
(uint16), the index sequence codec (uint16), every filter the encoder has (OCTAHEDRAL 8 and 16-bit, QUATERNION,
EXPONENTIAL) and a placeholder and a real fallback buffer. The COLOR filter (KHR only) has no encoder in that
package: ``color_khr.json`` holds colours encoded and decoded by meshoptimizer's npm package 1.3.0 (its official
JavaScript/WebAssembly build; tools/make_meshopt_color_fixture.mjs), and the filter is also checked on
hand-computed elements, as are small hand-made streams of each codec (the specification's own examples).
"""
import base64
import json
import os
import shutil

import numpy as np
import pytest

from pyrt.apps import preview as P
from pyrt.io.assets import AssetError, load_asset, pack_glb
from pyrt.io.assets import gltf_meshopt as M
from pyrt.io.assets.gltf_file import SUPPORTED_EXTENSIONS, GltfFile, read_gltf

DATA = os.path.join(os.path.dirname(__file__), "data", "meshopt")
FILES = ("sphere_ext", "sphere_khr", "sphere_used")


@pytest.fixture(scope="module")
def expected():
    with np.load(os.path.join(DATA, "expected.npz")) as z:
        return {k: z[k] for k in z.files}


def _path(name):
    return os.path.join(DATA, name + ".glb")


def _ext(bv):
    name, ext = M.meshopt_extension(bv)
    return name, ext


def _patched(tmp_path, name, edit, fname=None):
    """A copy of fixture ``name`` with ``edit(header, bin)`` applied (in place: the JSON dict, a bytearray)."""
    header, buffers = read_gltf(_path(name))
    binary = bytearray(buffers[0])
    edit(header, binary)
    out = tmp_path / (fname or f"{name}.glb")
    out.write_bytes(pack_glb(header, bytes(binary)))
    return str(out)


def _plain(tmp_path, name, expected):
    """Fixture ``name`` without the extension: each bufferView holds the bytes meshoptimizer's C decoder makes of
    its compressed data, in buffer 0."""
    header, _ = read_gltf(_path(name))
    blob = bytearray()
    for i, bv in enumerate(header["bufferViews"]):
        data = expected[f"{name}_view{i}"].tobytes()
        bv.pop("extensions")
        bv.update(buffer=0, byteOffset=len(blob), byteLength=len(data))
        blob += data + b"\0" * (-len(data) % 4)
    header["buffers"] = [{"byteLength": len(blob)}]
    for key in ("extensionsUsed", "extensionsRequired"):
        header[key] = [e for e in header.get(key, []) if e not in M.MESHOPT_EXTENSIONS]
    out = tmp_path / f"{name}_plain.glb"
    out.write_bytes(pack_glb(header, bytes(blob)))
    return str(out)


# ---------------------------------------------------------------------------------------------------------------
# the fixtures against meshoptimizer's C decoder and against the source mesh

@pytest.mark.parametrize("name", FILES)
def test_every_view_decodes_as_meshoptimizers_own_decoder(name, expected):
    g = GltfFile(_path(name))
    filters = set()
    for i, bv in enumerate(g.header["bufferViews"]):
        ext_name, ext = _ext(bv)
        assert ext_name == ("KHR_meshopt_compression" if name == "sphere_khr" else "EXT_meshopt_compression")
        mine, ref = np.frombuffer(g.view_bytes(i)[0], np.uint8), expected[f"{name}_view{i}"]
        assert mine.size == ref.size == bv["byteLength"] == ext["count"] * ext["byteStride"]
        filt = ext.get("filter", "NONE")
        filters.add((ext["mode"], filt))
        if filt in ("OCTAHEDRAL", "QUATERNION"):             # one unit in the last place (Appendix B)
            dt = "<i1" if ext["byteStride"] == 4 else "<i2"
            assert np.abs(mine.view(dt).astype(int) - ref.view(dt).astype(int)).max() <= 1
        else:
            np.testing.assert_array_equal(mine, ref)
    assert g.view_bytes(0)[0] is g.view_bytes(0)[0]          # decoded once per bufferView
    want = {"sphere_ext": {("ATTRIBUTES", "NONE"), ("ATTRIBUTES", "OCTAHEDRAL"), ("TRIANGLES", "NONE")},
            "sphere_khr": {("ATTRIBUTES", "EXPONENTIAL"), ("ATTRIBUTES", "OCTAHEDRAL"), ("ATTRIBUTES", "NONE"),
                           ("INDICES", "NONE"), ("ATTRIBUTES", "QUATERNION")},
            "sphere_used": {("ATTRIBUTES", "NONE"), ("TRIANGLES", "NONE")}}[name]
    assert filters == want


def test_version_1_fixture_uses_every_control_and_channel_mode():
    """So that the test above covers the whole version 1 vertex codec: control modes (2 bits per byte position
    in each block header) 0..3 and channel modes (tail) 0, 1 and 2 with a rotation."""
    g = GltfFile(_path("sphere_khr"))
    ctrl, chan = set(), set()
    for bv in g.header["bufferViews"]:
        _, e = _ext(bv)
        if e["mode"] != "ATTRIBUTES":
            continue
        s = g.buffers[0][e["byteOffset"]: e["byteOffset"] + e["byteLength"]]
        assert s[0] == 0xA1
        n = e["byteStride"] // 4
        ctrl |= {(b >> (2 * j)) & 3 for b in s[1: 1 + n] for j in range(4)}    # first block's control bytes
        chan |= {(b & 15, b >> 4 > 0) for b in s[-n:]}
    assert ctrl == {0, 1, 2, 3}
    assert {0, 1, 2} <= {m for m, _ in chan} and (2, True) in chan


def _same_triangles(faces, src):
    """Triangle by triangle the same corners in the same cyclic order (the triangle codec may start a triangle at
    another corner: winding and triangle order are kept)."""
    f, s = np.asarray(faces).reshape(-1, 3), np.asarray(src).reshape(-1, 3)
    assert f.shape == s.shape
    return bool(np.all(np.any([np.all(f == np.roll(s, -r, axis=1), axis=1) for r in range(3)], axis=0)))


def _angle(a, b):
    a = a / np.linalg.norm(a, axis=1, keepdims=True)
    b = b / np.linalg.norm(b, axis=1, keepdims=True)
    return np.arccos(np.clip(np.einsum("ij,ij->i", a, b), -1, 1))


def test_ext_file_geometry_equals_the_source(expected):
    mesh, = load_asset(_path("sphere_ext")).meshes
    np.testing.assert_array_equal(mesh.vertices, expected["src_pos"].astype(np.float32))
    assert _same_triangles(mesh.faces, expected["src_faces"])
    assert not np.array_equal(mesh.faces, expected["src_faces"])     # (some triangles do start elsewhere)
    uv = expected["src_uv"].astype(np.float32).astype(np.float64)
    np.testing.assert_array_equal(mesh.uv, np.c_[uv[:, 0], 1.0 - uv[:, 1]])      # pyrt's v is up
    err = _angle(mesh.normals, expected["src_normals"])
    assert err.max() <= 2 / 127                                  # OCTAHEDRAL, 8 bits
    assert err.max() > 1e-4                                      # (quantised: not the float normals)


def test_khr_file_geometry_and_instances_equal_the_source(expected):
    a = load_asset(_path("sphere_khr"))
    mesh, = a.meshes
    src = expected["src_pos"]
    assert np.all(np.abs(mesh.vertices - src) <= np.abs(src) * 2.0 ** -17 + 1e-30)     # EXPONENTIAL, 18 bits
    assert np.abs(mesh.vertices - src).max() > 0
    np.testing.assert_array_equal(mesh.faces, expected["src_faces"])            # INDICES: as they were
    uv16 = expected["src_uv16"] / 65535.0
    np.testing.assert_array_equal(mesh.uv, np.c_[uv16[:, 0], 1.0 - uv16[:, 1]])
    assert _angle(mesh.normals, expected["src_normals"]).max() <= 2 / 2047          # OCTAHEDRAL, 12 bits
    assert len(a.instances) == 3
    for inst, t, q in zip(a.instances, expected["src_translation"], expected["src_rotation"]):
        m = inst.world_from_object
        np.testing.assert_allclose(m[:3, 3], t, rtol=2.0 ** -22, atol=0)               # EXPONENTIAL, 23 bits
        x, y, z, w = q
        rot = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])
        np.testing.assert_allclose(m[:3, :3], rot, atol=4 * (0.5 ** 0.5 / 2047 + 1 / 32767))   # QUATERNION, 12


@pytest.mark.parametrize("name", FILES)
def test_loads_as_the_uncompressed_file(tmp_path, name, expected):
    """The loaded asset is the asset of the same file uncompressed (meshoptimizer's decoding of each view)."""
    a, b = load_asset(_path(name)), load_asset(_plain(tmp_path, name, expected))
    assert len(a.meshes) == len(b.meshes) == 1 and not a.warnings
    for key in ("vertices", "faces", "normals", "uv"):
        np.testing.assert_array_equal(getattr(a.meshes[0], key), getattr(b.meshes[0], key))
    for x, y in zip(a.instances, b.instances, strict=True):
        np.testing.assert_array_equal(x.world_from_object, y.world_from_object)


def test_render_matches_the_uncompressed_file(tmp_path, expected):
    """Previews at 48x36, 1 spp: the compressed files render exactly as their uncompressed versions."""
    o = P.PreviewOptions(width=48, height=36, spp=1)
    for name in ("sphere_ext", "sphere_khr"):
        img = P.render_preview(_path(name), o, name="v").images[0]
        ref = P.render_preview(_plain(tmp_path, name, expected), o, name="v").images[0]
        assert img.mean() > 0.01
        np.testing.assert_array_equal(img, ref)


def test_used_only_file_decodes_to_its_fallback_and_does_not_need_it(tmp_path):
    """sphere_used.glb uses the extension without requiring it; sphere_used.bin is its uncompressed fallback
    (buffer 1, marked ``fallback``). The decoded views are the fallback's bytes; the fallback file is not read
    (the file loads without it); unmarked, it is read as a buffer and the compressed data still wins."""
    g = GltfFile(_path("sphere_used"))
    assert "EXT_meshopt_compression" not in g.header.get("extensionsRequired", [])
    fallback = open(os.path.join(DATA, "sphere_used.bin"), "rb").read()
    for i, bv in enumerate(g.header["bufferViews"]):
        assert bv["buffer"] == 1
        assert g.view_bytes(i)[0] == fallback[bv["byteOffset"]: bv["byteOffset"] + bv["byteLength"]]
    ref = load_asset(_path("sphere_used")).meshes[0]
    alone = tmp_path / "alone"
    alone.mkdir()
    shutil.copy(_path("sphere_used"), alone)                     # without sphere_used.bin
    np.testing.assert_array_equal(load_asset(str(alone / "sphere_used.glb")).meshes[0].vertices, ref.vertices)

    def unmark(h, binary):
        del h["buffers"][1]["extensions"]
    shutil.copy(os.path.join(DATA, "sphere_used.bin"), tmp_path)
    path = _patched(tmp_path, "sphere_used", unmark)
    g = GltfFile(path)
    assert g.buffers[1] == fallback and not g.placeholders
    np.testing.assert_array_equal(load_asset(path).meshes[0].vertices, ref.vertices)


def test_both_extensions_are_supported():
    assert set(M.MESHOPT_EXTENSIONS) <= SUPPORTED_EXTENSIONS


def _color_source(count):
    """The colours tools/make_meshopt_color_fixture.mjs encodes (its formula, float32)."""
    t = np.arange(count) / (count - 1)
    return np.stack([0.5 + 0.5 * np.sin(6.2831853 * t), 0.5 + 0.5 * np.sin(6.2831853 * t + 2.0944),
                     0.5 + 0.5 * np.sin(6.2831853 * t + 4.1888), 0.25 + 0.75 * t], 1).astype(np.float32)


@pytest.fixture(scope="module")
def color():
    with open(os.path.join(DATA, "color_khr.json")) as fh:
        return json.load(fh)


def test_color_filter_decodes_as_the_js_decoder_and_within_the_quantisation(color):
    """8-bit (K = 8, 6) and 16-bit (K = 12) YCoCg colours: pyrt's decoding is the npm decoder's within one unit
    in the last place (Appendix B), and the source colour within 2^-(K-1) (two steps of the K-bit grid)."""
    src = _color_source(color["count"])
    for s in color["streams"]:
        stream = base64.b64decode(s["compressed"])
        assert stream[0] == 0xA1
        mine = M.decode(stream, color["count"], s["stride"], "ATTRIBUTES", "COLOR", M.KHR_MESHOPT)
        dt = "<u1" if s["stride"] == 4 else "<u2"
        a = np.frombuffer(mine, dt).astype(int)
        b = np.frombuffer(base64.b64decode(s["decoded"]), dt).astype(int)
        assert np.abs(a - b).max() <= 1
        err = np.abs(a.reshape(-1, 4) / np.iinfo(dt).max - src).max()
        assert 0 < err <= 2.0 ** -(s["bits"] - 1)


def test_color_filtered_vertex_colours_load(tmp_path, color):
    """sphere_khr.glb with a COLOR_0 (uint8 normalized RGBA) whose view holds the 8-bit, K = 8 stream."""
    s = color["streams"][0]
    stream = base64.b64decode(s["compressed"])

    def add(h, binary):
        off = len(binary)
        binary.extend(stream + b"\0" * (-len(stream) % 4))
        h["bufferViews"].append({"buffer": 1, "byteLength": 4 * color["count"], "byteStride": 4, "extensions": {
            "KHR_meshopt_compression": {"buffer": 0, "byteOffset": off, "byteLength": len(stream), "byteStride": 4,
                                        "count": color["count"], "mode": "ATTRIBUTES", "filter": "COLOR"}}})
        h["accessors"].append({"bufferView": len(h["bufferViews"]) - 1, "componentType": 5121, "type": "VEC4",
                               "count": color["count"], "normalized": True})
        h["meshes"][0]["primitives"][0]["attributes"]["COLOR_0"] = len(h["accessors"]) - 1
        h["buffers"][0]["byteLength"] = len(binary)
    mesh, = load_asset(_patched(tmp_path, "sphere_khr", add)).meshes
    ref = np.frombuffer(base64.b64decode(s["decoded"]), np.uint8).reshape(-1, 4) / 255.0
    np.testing.assert_array_equal(mesh.colors, ref[:, :3])
    np.testing.assert_array_equal(mesh.alpha, ref[:, 3])


# ---------------------------------------------------------------------------------------------------------------
# malformed data: AssetError naming the file and the bufferView

def _set(view, **kw):
    def edit(h, binary):
        _, e = _ext(h["bufferViews"][view])
        e.update(kw)
    return edit


def _poke(view, offset, value):
    """Overwrite byte ``offset`` (negative: from the end) of bufferView ``view``'s compressed data."""
    def edit(h, binary):
        _, e = _ext(h["bufferViews"][view])
        binary[e["byteOffset"] + (offset if offset >= 0 else e["byteLength"] + offset)] = value
    return edit


@pytest.mark.parametrize("name, view, edit, reason", [
    ("sphere_ext", 0, "truncate", r"ATTRIBUTES stream has -?\d+ bytes left|ATTRIBUTES stream ends"),
    ("sphere_ext", 0, _poke(0, 0, 0xB0), r"ATTRIBUTES stream header 0xB0, expected 0xA0 or 0xA1"),
    ("sphere_ext", 1, "extend", r"ATTRIBUTES stream has \d+ bytes left between its blocks and its tail"),
    ("sphere_ext", 3, "truncate", r"TRIANGLES stream"),
    ("sphere_ext", 3, _poke(3, 0, 0xE2), r"TRIANGLES stream header 0xE2"),
    ("sphere_ext", 3, _poke(3, 1, 0x00), r"TRIANGLES stream reads an edge or vertex FIFO entry that was never "
                                         r"written"),
    ("sphere_khr", 3, "truncate", r"INDICES stream ends early|INDICES stream: \d+ bytes left"),
    ("sphere_khr", 3, _poke(3, 0, 0xD7), r"INDICES stream header 0xD7"),
    ("sphere_khr", 0, _poke(0, -1, 0x07), r"invalid channel mode 0x07"),
    ("sphere_khr", 1, _set(1, filter="SHARPEN"), r"filter 'SHARPEN' is not one of"),
    ("sphere_ext", 1, _set(1, filter="COLOR"), r"filter 'COLOR' is not one of .* \(EXT_meshopt_compression\)"),
    ("sphere_khr", 3, _set(3, mode="STRIPS"), r"mode 'STRIPS' is not one of ATTRIBUTES, TRIANGLES, INDICES"),
    ("sphere_khr", 5, _set(5, byteStride=12), r"filter QUATERNION needs a byteStride of 8, got 12"),
    ("sphere_ext", 3, _set(3, count=2881), r"mode TRIANGLES needs a count divisible by 3"),
    ("sphere_ext", 0, _set(0, byteOffset=10 ** 6), r"compressed bytes \d+\.\.\d+ run past the end of buffer 0"),
    ("sphere_ext", 0, _set(0, buffer=1), r"compressed data in buffer 1, a fallback buffer without data"),
    ("sphere_ext", 0, _set(0, count=558), r"byteLength 6708 is more than the 558 x 12 bytes"),
    ("sphere_ext", 0, _set(0, byteLength=None), r"extension byteLength must be an integer"),
])
def test_malformed_stream_names_the_file_and_the_bufferview(tmp_path, name, view, edit, reason):
    if edit == "truncate":
        edit = lambda h, b: _ext(h["bufferViews"][view])[1].update(byteLength=_ext(h["bufferViews"][view])[1]
                                                                    ["byteLength"] - 7)
    elif edit == "extend":
        def edit(h, b):
            _, e = _ext(h["bufferViews"][view])
            e["byteLength"] += 4                                 # the next view's first bytes
    path = _patched(tmp_path, name, edit, "bad.glb")
    ext = "KHR" if name == "sphere_khr" else "EXT"
    with pytest.raises(AssetError, match=rf"bad\.glb: bufferView {view} \({ext}_meshopt_compression\): .*"
                                         rf"(?:{reason})"):
        load_asset(path)


def test_plain_view_in_a_fallback_buffer_names_the_bufferview(tmp_path):
    def plain(h, binary):
        del h["bufferViews"][2]["extensions"]
    path = _patched(tmp_path, "sphere_ext", plain, "bad.glb")
    with pytest.raises(AssetError, match=r"bad\.glb: bufferView 2 has no meshopt-compressed data but its buffer 1 "
                                         r"is a meshopt fallback buffer, which is not read"):
        load_asset(path)


# ---------------------------------------------------------------------------------------------------------------
# hand-made streams (the specification's examples) and the COLOR filter

def _vertex_stream(version, blocks, tail_elem, channels=b""):
    tail = bytes(tail_elem) + channels
    pad = max(len(tail), 24 if version else 32)
    return bytes([0xA0 | version]) + b"".join(blocks) + b"\0" * (pad - len(tail)) + tail


def test_vertex_codec_spec_example_4bit_sentinels():
    """Appendix A's example: 0x17 0x5f 0xf0 0xbc 0x77 0xa9 0x21 0x00 0x34 0xb5 are 16 4-bit deltas, 0xf the
    sentinel of elements 3 and 4 (whose zigzag bytes follow), decoding to -1 -4 -3 26 -91 0 -6 6 -4 -4 5 -5 1 -1
    0 0. Byte 0 of 16 four-byte elements; bytes 1..3 all-zero groups (header 0); baseline 100, 1, 2, 3."""
    group = bytes([0x17, 0x5F, 0xF0, 0xBC, 0x77, 0xA9, 0x21, 0x00, 0x34, 0xB5])
    blocks = [bytes([0b10]) + group, b"\0", b"\0", b"\0"]         # header: group 0 uses mode 2 (4 bits)
    out = np.frombuffer(M.decode_vertex_buffer(_vertex_stream(0, blocks, [100, 1, 2, 3]), 16, 4),
                        np.uint8).reshape(16, 4)
    deltas = [-1, -4, -3, 26, -91, 0, -6, 6, -4, -4, 5, -5, 1, -1, 0, 0]
    np.testing.assert_array_equal(out[:, 0], (100 + np.cumsum(deltas)) % 256)
    np.testing.assert_array_equal(out[:, 1:], np.tile([1, 2, 3], (16, 1)))
    with pytest.raises(M.MeshoptError, match="bytes left"):
        M.decode_vertex_buffer(_vertex_stream(0, blocks + [b"\0"], [100, 1, 2, 3]), 16, 4)


def test_vertex_codec_version_1_literal_zero_and_16bit_channel():
    """Version 1, 3 elements of 4 bytes, channel mode 1 (16-bit zigzag deltas): the control byte 0b10_10_11_11
    stores bytes 0 and 1 literally (3 bytes each, no header) and bytes 2 and 3 as all-zero. Deltas (zigzag 16-bit)
    2, 5, 0x1FF -> +1, -3, -256 from the baseline 0x1234."""
    lit0, lit1 = bytes([2, 5, 0xFF]), bytes([0, 0, 0x01])
    stream = _vertex_stream(1, [bytes([0b10101111]), lit0, lit1], [0x34, 0x12, 7, 9], channels=bytes([1]))
    out = np.frombuffer(M.decode_vertex_buffer(stream, 3, 4), np.uint8).reshape(3, 4)
    words = out[:, :2].copy().view("<u2")[:, 0]
    np.testing.assert_array_equal(words, [0x1235, 0x1232, 0x1132])
    np.testing.assert_array_equal(out[:, 2:], [[7, 9]] * 3)


def test_triangle_codec_hand_stream():
    """0xF0: a new triangle from the code table entry 0 (0x00: b and c are new too) -> (0, 1, 2); 0x00: edge 0 of
    the FIFO (the last pushed, (a, c) = (0, 2)) and the next new vertex -> (0, 2, 3); 0x01 (version 1): edge 0
    ((a, c) = (0, 3)) and vertex FIFO entry 1 (vertices pushed 0, 1, 2, 3: entry 1 is 2) -> (0, 3, 2)."""
    table = bytes(16)
    idx = M.decode_index_buffer(bytes([0xE1, 0xF0, 0x00, 0x01]) + table, 9)
    np.testing.assert_array_equal(idx, [0, 1, 2, 0, 2, 3, 0, 3, 2])
    # 0xFF, extra byte 0xFF: all three indices explicit, zigzag varint deltas from last: 20 (+10: 10), 0x80 0x04
    # (512: +256: 266), 0x03 (-2: 264)
    idx = M.decode_index_buffer(bytes([0xE1, 0xFF, 0xFF, 20, 0x80, 0x04, 0x03]) + table, 3)
    np.testing.assert_array_equal(idx, [10, 266, 264])
    with pytest.raises(M.MeshoptError, match="bytes of extra data left"):
        M.decode_index_buffer(bytes([0xE1, 0xF0, 0x00, 0x01, 0x00]) + table, 9)
    assert M.decode(bytes([0xE1, 0xFF, 0xFF, 20, 0x80, 0x04, 0x03]) + table, 3, 2, "TRIANGLES") \
        == np.array([10, 266, 264], "<u2").tobytes()


def test_index_sequence_hand_stream_and_varints():
    """The specification's varints 0x7f and 0x81 0x04 (= 0x201), and 0x85 0xa0 0x7f (= 0x1fd005: 7-bit groups
    least significant first, as 0x81 0x04 and the reference decoder have them; the specification's third example
    lists that value's bytes as 0xff 0xa0 0x05, most significant group first). Each value's bit 0 picks the
    baseline, the rest is a zigzag delta: 0x7f -> baseline 1, delta -32 (wraps below 0); 0x201 -> baseline 1, +128;
    0x1fd005 -> baseline 1, +0x7f401; then 0x04 -> baseline 0, +1."""
    stream = bytes([0xD1, 0x7F, 0x81, 0x04, 0x85, 0xA0, 0x7F, 0x04]) + bytes(4)
    v = M.decode_index_sequence(stream, 4)
    b1 = (-32) % 2 ** 32
    b2 = (b1 + 128) % 2 ** 32
    d = 0x1FD005 >> 1
    b3 = (b2 + (~(d >> 1) if d & 1 else d >> 1)) % 2 ** 32
    np.testing.assert_array_equal(v, [b1, b2, b3, 1])
    assert M.decode(stream, 4, 2, "INDICES") == np.array([b1, b2, b3, 1], np.uint32).astype("<u2").tobytes()
    with pytest.raises(M.MeshoptError, match="ends early"):
        M.decode_index_sequence(stream, 5)
    with pytest.raises(M.MeshoptError, match="longer than 5 bytes"):
        M.decode_index_sequence(bytes([0xD1, 0x80, 0x80, 0x80, 0x80, 0x80, 0x01]) + bytes(4), 1)


def test_filters_on_hand_computed_elements():
    oct8 = np.array([[0, 0, 127, 5], [127, 0, 127, -9], [0, -3, 7, 0]], np.int8)        # K = 8, 8, 4
    out = np.frombuffer(M.apply_filter(oct8.tobytes(), 3, 4, "OCTAHEDRAL"), np.int8).reshape(3, 4)
    s = 1 / np.sqrt(2)
    np.testing.assert_array_equal(out, [[0, 0, 127, 5], [127, 0, 0, -9],                # (0, -3/7, 4/7): 5/7 long
                                        [0, round(-127 * 0.6), round(127 * 0.8), 0]])
    quat = np.array([[0, 0, 0, 2047], [2047, 0, 0, 2047 & ~3 | 1]], np.int16)           # K = 12; max comp 3, 1
    out = np.frombuffer(M.apply_filter(quat.tobytes(), 2, 8, "QUATERNION"), "<i2").reshape(2, 4)
    np.testing.assert_array_equal(out[0], [0, 0, 0, 32767])                             # identity
    # maxcomp 1: input x goes to component 2, y to 3, z to 0, w to 1: x = 1/sqrt(2), w = 1/sqrt(2)
    np.testing.assert_array_equal(out[1], [0, round(32767 * s), round(32767 * s), 0])
    exp = np.array([((-2 << 24) | 3) & 0xFFFFFFFF, 0x00FFFFFF, (5 << 24) | 0x800000, 0], "<u4").view("<i4")
    np.testing.assert_array_equal(np.frombuffer(M.apply_filter(exp.tobytes(), 1, 16, "EXPONENTIAL"), "<f4"),
                                  [0.75, -1.0, -(2.0 ** 23) * 32, 0.0])
    # COLOR, 8-bit components: K = 8 (alpha byte 0x80 | 7-bit alpha) and K = 6 (0x20 | 5-bit alpha)
    col = np.array([[100, 20, -10 & 255, 0x80 | 127], [40, 5, -3 & 255, 0x20 | 10]], np.uint8)
    out = np.frombuffer(M.apply_filter(col.tobytes(), 2, 4, "COLOR"), np.uint8).reshape(2, 4)
    np.testing.assert_array_equal(out[0], [130, 90, 90, 255])
    k6 = np.floor(np.array([48, 37, 38, 20]) * 255 / 63 + 0.5)   # r, g, b = y+co-cg, y+cg, y-co-cg; a = 10*2+0
    np.testing.assert_array_equal(out[1], k6)
    col16 = np.array([[1000, 100, 0, 0x8000 | 0x7FFF]], "<u2")   # K = 16: scale 1
    out = np.frombuffer(M.apply_filter(col16.tobytes(), 1, 8, "COLOR"), "<u2")
    np.testing.assert_array_equal(out, [1100, 1000, 900, 65535])
    with pytest.raises(M.MeshoptError, match="filter 'COLOR' is not one of"):
        M.decode(b"", 1, 4, "ATTRIBUTES", "COLOR", M.EXT_MESHOPT)
