"""Files from outside: corrupt, truncated or hostile images, EXRs, glTF/GLBs and OBJs give a ``pyrt.Error`` that
names the file and the part, absurd sizes are refused from the header (before memory is allocated), remote URIs
are refused, and no third-party traceback or hint ("pip install imageio[pyav]") reaches the user."""
import base64
import json
import struct
import zlib

import numpy as np
import pytest
from pathlib import Path

import pyrt

from pyrt.core.image_io import MAX_IMAGE_PIXELS, ImageFileError, read_exr, read_image
from pyrt.io.assets import AssetError, load_asset, pack_glb
from pyrt.textures import ImageTexture, TextureError, load_image

ROOT_MODELS = Path(__file__).resolve().parents[1] / "assets" / "models"


def _png_chunk(tag, payload):
    return struct.pack(">I", len(payload)) + tag + payload + struct.pack(">I", zlib.crc32(tag + payload) & 0xFFFFFFFF)


def _png(width, height, *, depth=8, ctype=2, idat=None):
    ihdr = struct.pack(">IIBBBBB", width, height, depth, ctype, 0, 0, 0)
    if idat is None:
        row = b"\0" + b"\x80" * (width * 3 * depth // 8)
        idat = zlib.compress(row * height)
    return (b"\x89PNG\r\n\x1a\n" + _png_chunk(b"IHDR", ihdr) + _png_chunk(b"IDAT", idat) + _png_chunk(b"IEND", b""))


def _exr_bytes(tmp_path, h=64, w=40):
    p = tmp_path / "src.exr"
    pyrt.write_exr(p, np.random.default_rng(1).random((h, w, 3)).astype(np.float32))
    return p.read_bytes()


def _refused(exc_info, *parts):
    """The error is a pyrt.Error whose message holds every part and no third-party hint."""
    msg = str(exc_info.value)
    assert isinstance(exc_info.value, pyrt.Error)
    assert "pip install" not in msg and "backend" not in msg, msg
    for part in parts:
        assert part in msg, msg


# ----------------------------------------------------------------------------- images

def test_a_valid_png_still_reads(tmp_path):
    (tmp_path / "ok.png").write_bytes(_png(5, 4))
    img, is_int = load_image(tmp_path / "ok.png")
    assert img.shape == (4, 5, 3) and is_int and np.all(img == np.float32(0x80 / 255))


@pytest.mark.parametrize("cut", [10, 20, 40, -13, -5])
def test_truncated_png_names_file_and_byte(tmp_path, cut):
    data = _png(16, 16)
    (tmp_path / "wood.png").write_bytes(data[:cut])
    with pytest.raises(TextureError) as e:
        ImageTexture(tmp_path / "wood.png")
    _refused(e, "wood.png: not a readable PNG file (truncated at byte")


def test_garbage_and_empty_files_are_not_images(tmp_path):
    (tmp_path / "junk.png").write_bytes(b"hello world" * 10)
    (tmp_path / "empty.png").write_bytes(b"")
    with pytest.raises(TextureError) as e:
        load_image(tmp_path / "junk.png")
    _refused(e, "junk.png: not a readable image", "b'hello wo'")
    with pytest.raises(TextureError) as e:
        load_image(tmp_path / "empty.png")
    _refused(e, "empty.png: not a readable image (the file is empty)")


def test_corrupt_png_data_is_a_clear_error(tmp_path):
    data = bytearray(_png(32, 32, idat=zlib.compress(np.random.default_rng(0).bytes(33 * 96 * 32))))
    data[45:80] = bytes(b ^ 0x5A for b in data[45:80])  # inside the zlib stream; chunk lengths intact
    (tmp_path / "bad.png").write_bytes(bytes(data))
    with pytest.raises(TextureError) as e:
        load_image(tmp_path / "bad.png")
    _refused(e, "bad.png: not a readable PNG file (corrupt or truncated image data")


@pytest.mark.parametrize("depth", [8, 16])
def test_png_bomb_is_refused_from_the_header(tmp_path, depth):
    """100000 x 100000 claimed in IHDR, 1 kB of data: refused before decoding (no 30 GB allocation)."""
    (tmp_path / "bomb.png").write_bytes(_png(100000, 100000, depth=depth, idat=zlib.compress(b"\0" * 1000)))
    with pytest.raises(TextureError) as e:
        load_image(tmp_path / "bomb.png")
    _refused(e, "bomb.png: PNG header says 100000 x 100000 pixels", f"limit is {MAX_IMAGE_PIXELS}")


def test_png_with_zero_size_or_bad_colour_type(tmp_path):
    (tmp_path / "z.png").write_bytes(_png(0, 5))
    with pytest.raises(TextureError) as e:
        load_image(tmp_path / "z.png")
    _refused(e, "z.png: PNG header says 0 x 5 pixels")
    (tmp_path / "c.png").write_bytes(_png(2, 2, ctype=5))
    with pytest.raises(TextureError) as e:
        load_image(tmp_path / "c.png")
    _refused(e, "c.png: not a readable PNG file (IHDR colour type 5")


def test_truncated_jpeg(tmp_path):
    from PIL import Image

    Image.fromarray(np.random.default_rng(0).integers(0, 255, (32, 32, 3), dtype=np.uint8)).save(tmp_path / "a.jpg")
    data = (tmp_path / "a.jpg").read_bytes()
    (tmp_path / "t.jpg").write_bytes(data[: len(data) // 2])
    with pytest.raises(TextureError) as e:
        load_image(tmp_path / "t.jpg")
    _refused(e, "t.jpg: not a readable JPEG file")


@pytest.mark.parametrize("frac", [0.0, 0.05, 0.3, 0.5, 0.9, 0.999])
def test_truncated_exr(tmp_path, frac):
    data = _exr_bytes(tmp_path)
    p = tmp_path / "sky.exr"
    p.write_bytes(data[: max(4, int(len(data) * frac))])
    with pytest.raises(ImageFileError) as e:
        read_exr(p)
    _refused(e, "sky.exr: not a readable EXR file")
    assert isinstance(e.value, OSError)  # callers that caught OSError before still do
    with pytest.raises(TextureError) as e:
        ImageTexture(p)
    _refused(e, "sky.exr: not a readable EXR file")
    with pytest.raises(pyrt.Error):
        pyrt.LatLongEnvironment(p)


def test_exr_header_claiming_a_huge_image_is_refused(tmp_path):
    data = bytearray(_exr_bytes(tmp_path))
    i = data.index(b"dataWindow\0box2i\0") + len(b"dataWindow\0box2i\0") + 4
    data[i:i + 16] = struct.pack("<4i", 0, 0, 99999, 99999)
    (tmp_path / "huge.exr").write_bytes(bytes(data))
    with pytest.raises(ImageFileError) as e:
        read_exr(tmp_path / "huge.exr")
    _refused(e, "huge.exr: EXR header says 100000 x 100000 pixels", "limit")


def test_exr_errors_are_pyrt_errors(tmp_path):
    with pytest.raises(FileNotFoundError) as e:
        read_exr(tmp_path / "none.exr")
    assert isinstance(e.value, pyrt.Error)
    (tmp_path / "x.exr").write_bytes(b"not an exr at all")
    with pytest.raises(ImageFileError) as e:
        read_exr(tmp_path / "x.exr")
    _refused(e, "x.exr: not an EXR file")


def test_image_type_comes_from_the_bytes_not_the_name(tmp_path):
    (tmp_path / "really_png.exr").write_bytes(_png(3, 2))
    assert read_image(tmp_path / "really_png.exr").shape == (2, 3, 3)


# ----------------------------------------------------------------------------- glTF / GLB

def _triangle(uri=None):
    """A one-triangle glTF header and its 36-byte binary buffer (buffer 0: GLB chunk or ``uri``)."""
    binary = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], np.float32).tobytes()
    buf = {"byteLength": len(binary)} if uri is None else {"byteLength": len(binary), "uri": uri}
    header = {"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
              "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
              "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                             "min": [0, 0, 0], "max": [1, 1, 0]}],
              "bufferViews": [{"buffer": 0, "byteLength": len(binary)}], "buffers": [buf]}
    return header, binary


def _glb(tmp_path, patch=None, name="model.glb"):
    header, binary = _triangle()
    if patch:
        patch(header)
    p = tmp_path / name
    p.write_bytes(pack_glb(header, binary))
    return str(p)


def test_the_triangle_glb_loads(tmp_path):
    assert len(load_asset(_glb(tmp_path)).meshes) == 1


def test_glb_buffer_claiming_more_bytes_than_exist(tmp_path):
    path = _glb(tmp_path, lambda h: h["buffers"][0].update(byteLength=10_000_000))
    with pytest.raises(AssetError) as e:
        load_asset(path)
    _refused(e, "model.glb: buffer 0 claims 10000000 bytes (byteLength), the GLB binary chunk has 36")


def test_glb_chunk_claiming_more_bytes_than_the_file(tmp_path):
    data = bytearray(open(_glb(tmp_path), "rb").read())
    struct.pack_into("<I", data, 12, 1_000_000)           # the JSON chunk's length
    struct.pack_into("<I", data, 8, len(data))            # the header's total stays honest
    (tmp_path / "c.glb").write_bytes(bytes(data))
    with pytest.raises(AssetError) as e:
        load_asset(str(tmp_path / "c.glb"))
    _refused(e, "c.glb: GLB chunk 0 at byte 12 claims 1000000 bytes")


@pytest.mark.parametrize("cut", [3, 12, 19, 30, -40, -1])
def test_truncated_glb(tmp_path, cut):
    data = open(_glb(tmp_path), "rb").read()
    (tmp_path / "t.glb").write_bytes(data[:cut])
    with pytest.raises(AssetError) as e:
        load_asset(str(tmp_path / "t.glb"))
    _refused(e, "t.glb")


def test_accessor_counts_beyond_the_file(tmp_path):
    path = _glb(tmp_path, lambda h: h["accessors"][0].update(count=10 ** 9))
    with pytest.raises(AssetError) as e:
        load_asset(path)
    _refused(e, "model.glb: accessor 0 reads", "1000000000 elements claimed")
    path = _glb(tmp_path, lambda h: h["accessors"].__setitem__(0, {"componentType": 5126, "count": 10 ** 12, "type": "VEC3"}))
    with pytest.raises(AssetError) as e:
        load_asset(path)
    _refused(e, "accessor 0 has no bufferView and claims 1000000000000 elements")
    path = _glb(tmp_path, lambda h: h["bufferViews"][0].update(byteOffset=-8))
    with pytest.raises(AssetError) as e:
        load_asset(path)
    _refused(e, "bufferView 0 byteOffset must be an integer >= 0, got -8")
    path = _glb(tmp_path, lambda h: h["bufferViews"][0].update(byteStride=4))
    with pytest.raises(AssetError) as e:
        load_asset(path)
    _refused(e, "byteStride 4 is shorter than one element (12 bytes)")


@pytest.mark.parametrize("patch, part", [
    (lambda h: h["buffers"][0].update(byteLength="lots"), "buffer 0 byteLength must be an integer"),
    (lambda h: h["accessors"][0].update(count="3"), "accessor 0 count must be an integer"),
    (lambda h: h.update(accessors={"0": {}}), "'accessors' must be an array"),
    (lambda h: h["accessors"][0].update(componentType=[5126]), "accessor 0: missing or invalid"),
    (lambda h: h.update(nodes=[{"mesh": 0, "translation": "up"}]), "model.glb"),
    (lambda h: h["meshes"][0].update(primitives=[{"attributes": []}]), "model.glb"),
    (lambda h: h.update(scenes=[{"nodes": 0}]), "model.glb"),
    (lambda h: h.update(asset="2.0"), "not a glTF file"),
    (lambda h: h.update(extensionsRequired=7), "model.glb"),
])
def test_wrong_json_types_are_asset_errors(tmp_path, patch, part):
    with pytest.raises(AssetError) as e:
        load_asset(_glb(tmp_path, patch))
    _refused(e, part)


def test_deeply_nested_json(tmp_path):
    (tmp_path / "deep.gltf").write_text('{"asset": {"version": "2.0"}, "x": ' + "[" * 100000 + "]" * 100000 + "}")
    with pytest.raises(AssetError) as e:
        load_asset(str(tmp_path / "deep.gltf"))
    _refused(e, "deep.gltf: not valid glTF JSON")


@pytest.mark.parametrize("uri", ["https://example.com/tri.bin", "http://10.0.0.1/tri.bin", "file:///etc/passwd",
                                 "ftp://x/y", "/etc/passwd", "C:/Windows/win.ini", "//server/share/tri.bin"])
def test_remote_and_absolute_buffer_uris_are_refused(tmp_path, uri):
    header, _ = _triangle(uri)
    (tmp_path / "remote.gltf").write_text(json.dumps(header))
    with pytest.raises(AssetError) as e:
        load_asset(str(tmp_path / "remote.gltf"))
    _refused(e, "remote.gltf: buffer 0: uri")
    assert "not read" in str(e.value) or "absolute path" in str(e.value)


def test_remote_image_uri_is_refused(tmp_path):
    header, binary = _triangle()
    header.update(images=[{"uri": "https://example.com/wood.png"}], textures=[{"source": 0}],
                  materials=[{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}])
    header["meshes"][0]["primitives"][0]["material"] = 0
    (tmp_path / "m.glb").write_bytes(pack_glb(header, binary))
    with pytest.raises(AssetError) as e:
        load_asset(str(tmp_path / "m.glb"))
    _refused(e, "m.glb: image 0", "only relative paths and data: URIs are allowed")


def test_relative_uris_with_dotdot_are_read_inside_the_root_and_data_uris_are_read(tmp_path):
    header, binary = _triangle("../shared/tri%20mesh.bin")
    (tmp_path / "shared").mkdir()
    (tmp_path / "shared" / "tri mesh.bin").write_bytes(binary)
    (tmp_path / "models").mkdir()
    (tmp_path / "models" / "a.gltf").write_text(json.dumps(header))
    with pytest.raises(AssetError, match="'../shared/tri mesh.bin' leaves the model's folder .*models: not read"):
        load_asset(str(tmp_path / "models" / "a.gltf"))          # the default root: the model's own folder
    assert len(load_asset(str(tmp_path / "models" / "a.gltf"), root=tmp_path).meshes) == 1
    header, binary = _triangle("data:application/octet-stream;base64," + base64.b64encode(binary).decode())
    (tmp_path / "d.gltf").write_text(json.dumps(header))
    assert len(load_asset(str(tmp_path / "d.gltf")).meshes) == 1


def test_data_uri_shorter_than_its_byte_length(tmp_path):
    binary = _triangle()[1]
    header, _ = _triangle("data:application/octet-stream;base64," + base64.b64encode(binary[:20]).decode())
    (tmp_path / "d.gltf").write_text(json.dumps(header))
    with pytest.raises(AssetError) as e:
        load_asset(str(tmp_path / "d.gltf"))
    _refused(e, "d.gltf: buffer 0 claims 36 bytes (byteLength), its data URI holds 20")


def test_embedded_truncated_png_names_the_glb_and_the_image(tmp_path):
    png = _png(8, 8)[:-20]
    header, binary = _triangle()
    header["bufferViews"].append({"buffer": 0, "byteOffset": len(binary), "byteLength": len(png)})
    header["buffers"][0]["byteLength"] = len(binary) + len(png)
    header.update(images=[{"bufferView": 1, "mimeType": "image/png"}], textures=[{"source": 0}],
                  materials=[{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}])
    header["meshes"][0]["primitives"][0]["material"] = 0
    (tmp_path / "e.glb").write_bytes(pack_glb(header, binary + png))
    with pytest.raises(AssetError) as e:
        load_asset(str(tmp_path / "e.glb"))
    _refused(e, "e.glb: image 0 (embedded)", "not a readable PNG file (truncated at byte")


# ----------------------------------------------------------------------------- OBJ

def test_obj_with_a_nan_vertex_names_the_file_and_line(tmp_path):
    (tmp_path / "nan.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 nan\nf 1 2 3\nf 1 2 4\n")
    with pytest.raises(AssetError) as e:
        load_asset(str(tmp_path / "nan.obj"))
    _refused(e, "nan.obj: line 4: vertex 4 'v 0 0 nan' is not finite")


def test_obj_with_an_overflowing_vertex(tmp_path):
    (tmp_path / "inf.obj").write_text("v 0 0 0\nv 1 0 0\nv 1e400 1 0\nf 1 2 3\n")
    with pytest.raises(AssetError) as e:
        load_asset(str(tmp_path / "inf.obj"))
    _refused(e, "inf.obj: line 3: vertex 3")


@pytest.mark.parametrize("body", ["", "v 0 0 0\nv 1 0 0\nv 0 1 0\n", "# only a comment\n", "f 1 2 3\n"])
def test_obj_without_faces_says_no_triangles(tmp_path, body):
    (tmp_path / "empty.obj").write_text(body)
    with pytest.raises(AssetError) as e:
        load_asset(str(tmp_path / "empty.obj"))
    _refused(e, "empty.obj")
    assert "no triangles" in str(e.value) or "cannot read OBJ" in str(e.value)


def test_obj_of_random_bytes(tmp_path):
    (tmp_path / "r.obj").write_bytes(np.random.default_rng(3).bytes(4000))
    with pytest.raises(AssetError) as e:
        load_asset(str(tmp_path / "r.obj"))
    _refused(e, "r.obj")
    assert "ModuleNotFoundError" not in str(e.value)


def test_obj_with_latin1_comment_still_loads(tmp_path):
    (tmp_path / "l.obj").write_bytes("# caf\xe9\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n".encode("latin-1"))
    assert load_asset(str(tmp_path / "l.obj")).meshes[0].faces.shape == (1, 3)


@pytest.mark.parametrize("body, part", [("v 0 0 0\nv 1 0 0\nv 0 0 nan\nf 1 2 3\n", "vertex 3 is not finite"),
                                        ("v 0 0 0\nv 1 0 0\nv 0 1 0\n", "no triangles found")])
def test_scene_file_mesh_with_nan_or_no_faces(tmp_path, body, part):
    (tmp_path / "m.obj").write_text(body)
    (tmp_path / "s.toml").write_text('[camera]\nwidth = 4\nheight = 4\n[materials.m]\ntype = "lambert"\n'
                                     '[[meshes]]\nfile = "m.obj"\nmaterial = "m"\n')
    with pytest.raises(pyrt.SceneFileError) as e:
        pyrt.load_scene(tmp_path / "s.toml")
    _refused(e, "m.obj", part)


def test_an_obj_naming_a_non_mtl_file_does_not_echo_its_content(tmp_path):
    """A hostile OBJ may name any readable file as its MTL: the error says it is not an MTL, without quoting it."""
    secret = tmp_path / "secret.txt"
    secret.write_text("zqxj:x:0:0:qwzkv\n")
    obj = tmp_path / "m.obj"
    obj.write_text(f"mtllib {secret}\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    with pytest.raises(pyrt.Error) as exc:
        pyrt.load_asset(str(obj))
    assert "not an MTL file" in str(exc.value) and "zqxj" not in str(exc.value) and "qwzkv" not in str(exc.value)


def test_missing_scene_file_is_a_pyrt_error_and_a_file_not_found_error(tmp_path):
    with pytest.raises(pyrt.Error) as exc:
        pyrt.load_scene(str(tmp_path / "nope.toml"))
    assert isinstance(exc.value, FileNotFoundError) and "scene file not found" in str(exc.value)


def test_truncated_binary_stl_and_out_of_range_ply_faces_are_named_errors(tmp_path):
    good = (ROOT_MODELS / "bracket.stl").read_bytes()
    stl = tmp_path / "t.stl"
    stl.write_bytes(good[:120])
    with pytest.raises(pyrt.Error, match=r"binary header says \d+ triangles"):
        pyrt.load_asset(str(stl))
    ply = tmp_path / "f.ply"
    ply.write_text("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
                   "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n")
    with pytest.raises(pyrt.Error, match="does not exist"):
        pyrt.load_asset(str(ply))
