"""Every file pyrt writes replaces the previous one all at once: a failure in the middle of a write leaves
the previous file byte-identical and no temporary file behind."""
import os

import numpy as np
import pytest

import pyrt
from pyrt.core import image_io
from pyrt.apps.preview import batch as P_batch, render as P_render

IMG = np.full((6, 8, 3), 0.25, np.float32)
OTHER = np.full((6, 8, 3), 2.0, np.float32)


def _only(folder, name):
    assert sorted(os.listdir(folder)) == [name]


def test_atomic_write_replaces_or_keeps(tmp_path):
    p = tmp_path / "f.bin"
    image_io.write_bytes(p, b"old")
    image_io.write_bytes(p, b"new")
    assert p.read_bytes() == b"new"

    def half_then_fail(tmp):
        with open(tmp, "wb") as fh:
            fh.write(b"partial")
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        pyrt.atomic_write(p, half_then_fail)
    assert p.read_bytes() == b"new"
    _only(tmp_path, "f.bin")


def test_atomic_write_keeps_the_permissions(tmp_path):
    p = tmp_path / "f.bin"
    image_io.write_bytes(p, b"a")
    os.chmod(p, 0o640)
    image_io.write_bytes(p, b"b")
    assert os.stat(p).st_mode & 0o777 == 0o640
    q = tmp_path / "g.bin"
    image_io.write_bytes(q, b"a")
    umask = os.umask(0)
    os.umask(umask)
    assert os.stat(q).st_mode & 0o777 == 0o666 & ~umask


def test_exr_encoder_failure_keeps_the_previous_file(tmp_path, monkeypatch):
    p = tmp_path / "a.exr"
    pyrt.write_exr(p, IMG)
    before = p.read_bytes()

    class Broken:
        def __init__(self, header, channels):
            pass

        def __enter__(self):
            return self

        def __exit__(self, *exc):
            return False

        def write(self, path):
            with open(path, "wb") as fh:
                fh.write(before[:100])          # half a file, then the encoder dies
            raise RuntimeError("encoder failed")

    import OpenEXR           # (image_io imports it where an EXR is written: the module's attribute is what it reads)

    monkeypatch.setattr(OpenEXR, "File", Broken)
    with pytest.raises(RuntimeError, match="encoder failed"):
        pyrt.write_exr(p, OTHER)
    assert p.read_bytes() == before
    _only(tmp_path, "a.exr")


@pytest.mark.parametrize("where", ["encode", "disk"])
def test_png_failure_keeps_the_previous_file(tmp_path, monkeypatch, where):
    p = tmp_path / "a.png"
    pyrt.write_png(p, IMG)
    before = p.read_bytes()
    if where == "encode":
        def broken(pixels):
            raise RuntimeError("encoder failed")
        monkeypatch.setattr(image_io, "encode_png", broken)
    else:  # the data is in the temporary file, the flush to disk fails (disk full)
        def broken(fd):
            raise OSError(28, "No space left on device")
        monkeypatch.setattr(image_io.os, "fsync", broken)
    with pytest.raises((RuntimeError, OSError)):
        pyrt.write_png(p, OTHER)
    assert p.read_bytes() == before
    _only(tmp_path, "a.png")


def test_preview_files_and_summary_are_atomic(tmp_path, monkeypatch):
    P_render.write_files({"v.png": b"old"}, str(tmp_path))
    rep = P_batch.AssetReport(path="m.ply", name="m_ply")
    P_batch.write_summary([rep], str(tmp_path))
    csv_before = (tmp_path / "summary.csv").read_bytes()
    txt_before = (tmp_path / "summary.txt").read_bytes()

    def broken(fd):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(image_io.os, "fsync", broken)
    with pytest.raises(OSError):
        P_render.write_files({"v.png": b"new"}, str(tmp_path))
    with pytest.raises(OSError):
        P_batch.write_summary([rep, rep], str(tmp_path))
    assert (tmp_path / "v.png").read_bytes() == b"old"
    assert (tmp_path / "summary.csv").read_bytes() == csv_before
    assert (tmp_path / "summary.txt").read_bytes() == txt_before
    assert sorted(os.listdir(tmp_path)) == ["summary.csv", "summary.txt", "v.png"]


def test_writing_to_a_folder_or_a_nan_image_is_a_named_pyrt_error(tmp_path):
    img = np.zeros((4, 4, 3), np.float32)
    with pytest.raises(pyrt.Error, match="is a folder"):
        pyrt.write_png(tmp_path, img)
    img[1, 2, 0] = np.nan
    with pytest.raises(pyrt.Error, match="1 NaN or Inf"):
        pyrt.write_exr(tmp_path / "x.exr", img)
    assert sorted(os.listdir(tmp_path)) == []
