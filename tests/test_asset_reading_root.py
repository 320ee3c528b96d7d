"""What a model may read (pyrt.io.assets.find_file's root, pyrt.io.assets.archive): nothing outside its folder or
archive, whatever its URIs say; archives refused before extraction when a member is too large or too compressed,
and only the members the model names extracted."""
import json
import os
import time
import zipfile

import numpy as np
import pytest

from pyrt.io.assets import AssetError, archive, load_asset, pack_glb
from pyrt.io.assets.find_file import OutsideRootError, find_file, reading_root

SECRET = b"TOP-SECRET-BYTES"


def _triangle_gltf(image_uri=None):
    """A one-triangle glTF header (its buffer a data-free GLB chunk) and the buffer; ``image_uri``: a base-colour
    texture read from that URI."""
    binary = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], np.float32).tobytes()
    header = {"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
              "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
              "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                             "min": [0, 0, 0], "max": [1, 1, 0]}],
              "bufferViews": [{"buffer": 0, "byteLength": len(binary)}], "buffers": [{"byteLength": len(binary)}]}
    if image_uri is not None:
        header.update(images=[{"uri": image_uri}], textures=[{"source": 0}],
                      materials=[{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}])
        header["meshes"][0]["primitives"][0]["material"] = 0
    return header, binary


def _secret(tmp_path):
    """A file outside every model folder of these tests, whose bytes must never be read."""
    d = tmp_path / "elsewhere"
    d.mkdir()
    (d / "hostname").write_bytes(SECRET)
    return d / "hostname"


def _climb(path):
    """A relative URI from anywhere up to ``/`` and down to ``path``."""
    return "../" * 40 + str(path).lstrip("/")


def _no_secret(exc):
    assert SECRET.decode() not in str(exc.value)


def test_an_archived_gltf_cannot_read_outside_the_archive(tmp_path):
    secret = _secret(tmp_path)
    header, binary = _triangle_gltf(_climb(secret))
    z = tmp_path / "m.zip"
    with zipfile.ZipFile(z, "w") as zf:
        zf.writestr("m/model.glb", pack_glb(header, binary))
    with pytest.raises(AssetError, match=r"leaves the archive .*m\.zip: not read") as e:
        load_asset(str(z))
    assert "'../../" in str(e.value)        # the URI is named (its middle elided when long), and the member that names it
    assert str(e.value).startswith(f"{z}!m/model.glb: ") and isinstance(e.value, OutsideRootError)
    _no_secret(e)


def test_an_archived_obj_cannot_read_outside_the_archive(tmp_path):
    secret = _secret(tmp_path)
    z = tmp_path / "m.zip"
    with zipfile.ZipFile(z, "w") as zf:
        zf.writestr("model.obj", "mtllib model.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nusemtl a\nf 1/1 2/1 3/1\n")
        zf.writestr("model.mtl", f"newmtl a\nKd 1 1 1\nmap_Kd {_climb(secret)}\n")
    with pytest.raises(AssetError, match="leaves the archive") as e:
        load_asset(str(z))
    _no_secret(e)


def test_a_loose_model_reads_nothing_outside_its_folder(tmp_path):
    secret = _secret(tmp_path)
    model = tmp_path / "download"
    model.mkdir()
    header, binary = _triangle_gltf("../elsewhere/hostname")
    (model / "m.glb").write_bytes(pack_glb(header, binary))
    with pytest.raises(AssetError, match=r"'../elsewhere/hostname' leaves the model's folder .*download: not read") as e:
        load_asset(str(model / "m.glb"))
    assert str(e.value).startswith(f"{model / 'm.glb'}: ")
    _no_secret(e)


def test_a_link_out_of_the_model_folder_is_not_followed(tmp_path):
    secret = _secret(tmp_path)
    model = tmp_path / "download"
    model.mkdir()
    os.symlink(secret, model / "wood.png")
    header, binary = _triangle_gltf("wood.png")
    (model / "m.glb").write_bytes(pack_glb(header, binary))
    with pytest.raises(AssetError, match="'wood.png' is a link to a file outside the model's folder") as e:
        load_asset(str(model / "m.glb"))
    _no_secret(e)


def test_an_absolute_path_outside_the_folder_is_looked_for_by_name_inside_it(tmp_path):
    secret = _secret(tmp_path)
    model = tmp_path / "download"
    model.mkdir()
    assert find_file(str(model), str(secret)) == (None, None)       # not opened: not found inside the root
    (model / "textures").mkdir()
    (model / "textures" / "hostname").write_bytes(b"x")
    assert find_file(str(model), str(secret)) == (str(model / "textures" / "hostname"), "found by its file name")


def test_a_wider_root_lets_a_model_read_a_shared_folder(tmp_path):
    (tmp_path / "shared").mkdir()
    (tmp_path / "shared" / "a.png").write_bytes(b"x")
    (tmp_path / "models").mkdir()
    with pytest.raises(AssetError, match="leaves the model's folder"):
        find_file(str(tmp_path / "models"), "../shared/a.png")
    with reading_root(tmp_path):
        assert find_file(str(tmp_path / "models"), "../shared/a.png") == (
            os.path.join(str(tmp_path / "models"), "../shared/a.png"), None)


def test_a_zip_bomb_member_is_refused_before_extraction_naming_its_sizes(tmp_path, monkeypatch):
    z = tmp_path / "bomb.zip"
    with zipfile.ZipFile(z, "w", compression=zipfile.ZIP_DEFLATED) as zf:
        zf.writestr("big.obj", b"v 0 0 0\n" * (3 << 20))        # 24 MiB of one line: ~1000x compressed
    extracted = []
    monkeypatch.setattr(archive, "_extract", lambda *a: extracted.append(a) or 1 / 0)
    t0 = time.perf_counter()
    with pytest.raises(AssetError, match=r"bomb\.zip: member 'big\.obj' unpacks from .* to 24\.0 MiB, \d+ times "
                                         r"\(at most 100 .*zip bomb"):
        load_asset(str(z))
    print(f"refused in {time.perf_counter() - t0:.3f} s")
    assert extracted == []


def test_a_member_too_large_for_a_model_is_refused(tmp_path, monkeypatch):
    z = tmp_path / "big.zip"
    with zipfile.ZipFile(z, "w") as zf:
        zf.writestr("m.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n" * 100)
    monkeypatch.setattr(archive, "MAX_MEMBER_BYTES", 1000)
    with pytest.raises(AssetError, match=r"member 'm\.obj' unpacks to 3200 bytes \(at most 1000 bytes per member"):
        load_asset(str(z))


def test_only_the_members_the_model_names_are_extracted(tmp_path):
    header, binary = _triangle_gltf("Textures/Wood%20Grain.PNG")
    header["buffers"][0]["uri"] = "tri.bin"
    z = tmp_path / "pack.zip"
    with zipfile.ZipFile(z, "w") as zf:
        zf.writestr("pack/model.gltf", json.dumps(header))
        zf.writestr("pack/tri.bin", binary)
        zf.writestr("pack/textures/wood grain.png", b"\x89PNG not read here")
        zf.writestr("pack/junk.bin", b"\0" * 100_000)
        zf.writestr("pack/readme.txt", b"hello")
    seen = []

    def load(inner):
        base = os.path.dirname(os.path.dirname(inner))
        seen.extend(sorted(os.path.relpath(os.path.join(r, f), base) for r, _, fs in os.walk(base) for f in fs))
        return load_asset(inner)

    with pytest.raises(AssetError):          # the PNG is not a PNG: loading stops there, after the listing
        archive.load_zip(str(z), load)
    assert seen == ["pack/model.gltf", "pack/textures/wood grain.png", "pack/tri.bin"]


def test_an_obj_archive_extracts_its_mtl_and_maps(tmp_path):
    z = tmp_path / "o.zip"
    with zipfile.ZipFile(z, "w") as zf:
        zf.writestr("o/model.obj", "mtllib Model.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl a\nf 1 2 3\n")
        zf.writestr("o/model.mtl", "newmtl a\nKd 0.5 0.5 0.5\n")
        zf.writestr("o/other.mtl", "newmtl b\n")
    seen = []

    def load(inner):
        seen.extend(sorted(os.listdir(os.path.dirname(inner))))
        return load_asset(inner)

    asset = archive.load_zip(str(z), load)
    assert seen == ["model.mtl", "model.obj"] and len(asset.meshes) == 1
