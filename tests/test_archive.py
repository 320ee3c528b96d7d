"""Models inside ZIP archives (pyrt.io.assets.archive): the model picked, loaded as from the unpacked folder, paths
reported as ARCHIVE!member, the temporary folder removed, unsafe or ambiguous archives refused."""
import os
import tempfile
import zipfile

import numpy as np
import pytest

from pyrt.io.assets import AssetError, archive, load_asset

ROOT = os.path.join(os.path.dirname(__file__), "..")
MODELS = os.path.join(ROOT, "assets", "models")
CRATE = ("crate.obj", "crate.mtl", "crate_wood.png")


def _zip(path, members):
    with zipfile.ZipFile(path, "w") as z:
        for name, data in members.items():
            z.writestr(name, data)
    return str(path)


def _crate_members(folder="crate_model/", skip=()):
    out = {}
    for f in CRATE:
        if f not in skip:
            with open(os.path.join(MODELS, f), "rb") as fh:
                out[folder + f] = fh.read()
    return out


@pytest.fixture
def private_tmp(tmp_path, monkeypatch):
    """tempfile's folder redirected, so that the extraction folders can be counted."""
    d = tmp_path / "tmp"
    d.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(d))
    return d


def test_zipped_obj_loads_as_the_unpacked_one_and_leaves_no_folder(tmp_path, private_tmp):
    members = dict(_crate_members(), **{"crate_model/readme.txt": b"hi", "__MACOSX/crate_model/._crate.obj": b"x"})
    z = _zip(tmp_path / "crate.zip", members)
    a, b = load_asset(os.path.join(MODELS, "crate.obj")), load_asset(z)
    assert b.path == f"{z}!crate_model/crate.obj" and b.format == "obj"
    assert len(a.meshes) == len(b.meshes)
    for ma, mb in zip(a.meshes, b.meshes):
        assert np.array_equal(ma.vertices, mb.vertices) and np.array_equal(ma.faces, mb.faces)
    ta = [m.map_Kd for m in a.materials if getattr(m, "map_Kd", None) is not None]
    tb = [m.map_Kd for m in b.materials if getattr(m, "map_Kd", None) is not None]
    assert len(ta) == len(tb) == 1      # the texture was found beside the OBJ inside the archive
    assert os.listdir(private_tmp) == []


def test_missing_texture_in_a_zip_is_reported_with_the_archive_path(tmp_path, private_tmp):
    z = _zip(tmp_path / "crate.zip", _crate_members(skip=("crate_wood.png",)))
    a = load_asset(z)
    assert a.substitutions and all(str(private_tmp) not in w for w in a.warnings)
    assert any(f"{z}!" in w and "crate_wood.png" in w for w in a.substitutions), a.substitutions
    assert os.listdir(private_tmp) == []


def test_gltf_is_preferred_to_a_source_scan_and_the_shallowest_wins(tmp_path):
    with open(os.path.join(MODELS, "studio_sample.glb"), "rb") as fh:
        glb = fh.read()
    with open(os.path.join(MODELS, "blob.ply"), "rb") as fh:
        ply = fh.read()
    z = _zip(tmp_path / "m.zip", {"source/scan.ply": ply, "deep/er/other.glb": glb, "scene.glb": glb})
    assert load_asset(z).path.endswith("!scene.glb")
    assert archive.model_member("m.zip", ["a/x.ply", "b.stl", "c/d/e.obj"]) == "c/d/e.obj"


def test_an_obj_up_comment_is_read_inside_the_archive(tmp_path):
    m = _crate_members()
    m["crate_model/crate.obj"] = b"# exported Z-up\n" + m["crate_model/crate.obj"]
    assert load_asset(_zip(tmp_path / "c.zip", m)).stated_up_axis == "+z"


@pytest.mark.parametrize("members, message", [
    ({"a.obj": b"v 0 0 0\n", "b.obj": b"v 0 0 0\n"}, r"holds 2 models \(a.obj, b.obj\): name one as '.*bad.zip!a.obj'"),
    ({"readme.txt": b"no model"}, "holds no model file"),
    ({"../evil.obj": b"v 0 0 0\n", "x.obj": b"v 0 0 0\n"}, "outside its folder"),
    ({"/abs/evil.obj": b"v 0 0 0\n"}, "outside its folder"),
])
def test_ambiguous_empty_or_unsafe_archives_are_refused(tmp_path, members, message):
    z = _zip(tmp_path / "bad.zip", members)
    with pytest.raises(AssetError, match=message) as exc:
        load_asset(z)
    assert z in str(exc.value)


def test_corrupt_and_oversized_archives_are_refused(tmp_path, monkeypatch):
    p = tmp_path / "broken.zip"
    p.write_bytes(b"PK\x03\x04 not really a zip")
    with pytest.raises(AssetError, match="not a readable ZIP archive"):
        load_asset(str(p))
    z = _zip(tmp_path / "big.zip", _crate_members())
    monkeypatch.setattr(archive, "MAX_BYTES", 1000)
    with pytest.raises(AssetError, match="unpack to .*at most 1000 bytes"):
        load_asset(z)


def test_an_error_inside_the_archive_names_the_member_not_the_temporary_folder(tmp_path, private_tmp):
    z = _zip(tmp_path / "nan.zip", {"m/nan.obj": b"v 0 0 0\nv 1 0 nan\nv 0 1 0\nf 1 2 3\n"})
    with pytest.raises(AssetError) as exc:
        load_asset(z)
    assert str(exc.value).startswith(f"{z}!m/nan.obj: ") and str(private_tmp) not in str(exc.value)
    assert os.listdir(private_tmp) == []


def test_the_previewer_renders_a_zip_like_the_unpacked_model(tmp_path):
    from pyrt.apps import preview as P
    z = _zip(tmp_path / "crate.zip", _crate_members())
    o = P.PreviewOptions(width=40, height=30, spp=1)
    a = P.render_preview(os.path.join(MODELS, "crate.obj"), o)
    b = P.render_preview(z, o)
    assert np.array_equal(a.images[0], b.images[0])
    assert P.collect_inputs([str(tmp_path)]) == [z]          # folders' archives are batch inputs too


def test_a_member_named_after_the_bang_is_loaded(tmp_path, capsys):
    from pyrt.apps import preview as P
    with open(os.path.join(MODELS, "blob.ply"), "rb") as fh:
        ply = fh.read()
    members = dict(_crate_members("a/"), **{"b/blob.ply": ply, "b/notes.txt": b"x"})
    z = _zip(tmp_path / "pack.zip", members)
    assert load_asset(z).path == f"{z}!a/crate.obj"                     # picked: OBJ before PLY
    assert load_asset(f"{z}!b/blob.ply").path == f"{z}!b/blob.ply"      # named
    with pytest.raises(AssetError, match="has no member 'b/nothing.ply'"):
        load_asset(f"{z}!b/nothing.ply")
    with pytest.raises(AssetError, match="unsupported file type '.txt'"):
        load_asset(f"{z}!b/notes.txt")
    out = tmp_path / "v.png"
    assert P.main([f"{z}!b/blob.ply", "-o", str(out), "--width", "24", "--height", "18", "--spp", "1", "--quiet"]) == 0
    assert out.stat().st_size > 0
