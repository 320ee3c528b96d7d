"""Radiance ``.hdr`` (RGBE) environment maps, read with OpenCV (the optional ``[hdr]`` extra).

Ground truth: files written here byte by byte (flat and run-length-encoded scanlines) with known mantissas
and exponents. OpenCV's decoder (Greg Ward's reference code) maps (m, e) to ``m / 256 * 2^(e - 128)`` (no
half-step offset; the other convention, ``(m + 0.5) / 256 * 2^(e - 128)``, would be off by 0.5 / m relative) and
returns BGR: pyrt returns RGB. Every value of this form is a float32, so the comparisons are exact.
"""
import os
import sys

import numpy as np
import pytest

import pyrt
from pyrt.apps import cli
from pyrt.apps import preview as P
from pyrt.core.image_io import ImageFileError, read_hdr, read_image
from pyrt.lights import LatLongEnvironment
from pyrt.textures import load_image

BLOB = os.path.join(os.path.dirname(__file__), "..", "assets", "models", "blob.ply")


def _header(h, w, fmt=b"32-bit_rle_rgbe", res=None):
    res = res if res is not None else f"-Y {h} +X {w}".encode()
    return b"#?RADIANCE\n# written by tests/test_hdr.py\nFORMAT=" + fmt + b"\nEXPOSURE=1.0\n\n" + res + b"\n"


def write_flat(path, rgbe, **kw):
    """(H, W, 4) uint8 (R, G, B mantissas, shared exponent) as a flat (uncompressed) Radiance file."""
    h, w = rgbe.shape[:2]
    path.write_bytes(_header(h, w, **kw) + np.ascontiguousarray(rgbe, dtype=np.uint8).tobytes())
    return path


def _rle_channel(row):
    """One component of one scanline, run-length encoded: runs (128 + n, value) of >= 3 equal bytes, else literals
    (n, bytes...), n <= 127 (Radiance's new-style RLE)."""
    out, i, n = bytearray(), 0, len(row)
    while i < n:
        j = i
        while j < n and j - i < 127 and row[j] == row[i]:
            j += 1
        if j - i >= 3:
            out += bytes([128 + j - i, row[i]])
            i = j
            continue
        k = i
        while k < n and k - i < 127 and not (k + 2 < n and row[k] == row[k + 1] == row[k + 2]):
            k += 1
        out += bytes([k - i]) + bytes(row[i:k])
        i = k
    return bytes(out)


def write_rle(path, rgbe):
    """(H, W, 4) uint8 with 8 <= W < 32768 as new-style RLE scanlines (2, 2, W >> 8, W & 255, then 4 components)."""
    h, w = rgbe.shape[:2]
    body = bytearray()
    for y in range(h):
        body += bytes([2, 2, w >> 8, w & 255])
        for c in range(4):
            body += _rle_channel(rgbe[y, :, c].tobytes())
    path.write_bytes(_header(h, w) + bytes(body))
    return path


def rgbe_to_float(rgbe):
    """Ward's decode, m / 256 * 2^(e - 128), e = 0 -> 0, as float32 RGB (exact)."""
    m, e = rgbe[..., :3].astype(np.float64), rgbe[..., 3:4].astype(np.int64)
    return np.where(e > 0, np.ldexp(m / 256.0, e - 128), 0.0).astype(np.float32)


def _random_rgbe(rng, h, w):
    rgbe = rng.integers(0, 256, (h, w, 4), dtype=np.uint8)
    rgbe[..., 3] = rng.integers(100, 160, (h, w))
    rgbe[0, 0, 3] = 0           # black
    return rgbe


def test_known_pixels_rgb_order_and_convention(tmp_path):
    pytest.importorskip("cv2")
    px = np.array([[[128, 64, 32, 129], [255, 1, 0, 128]],
                   [[10, 20, 30, 0], [200, 100, 50, 140]]], dtype=np.uint8)
    img = read_hdr(write_flat(tmp_path / "k.hdr", px))
    assert img.dtype == np.float32 and img.shape == (2, 2, 3)
    expected = np.array([[[1.0, 0.5, 0.25], [255 / 256, 1 / 256, 0.0]],
                         [[0.0, 0.0, 0.0], [200 / 256 * 4096, 100 / 256 * 4096, 50 / 256 * 4096]]], dtype=np.float32)
    np.testing.assert_array_equal(img, expected)          # red first (OpenCV's BGR flipped), row 0 at the top
    assert img[0, 0, 0] != np.float32((128 + 0.5) / 256 * 2)   # not the (m + 0.5) convention


def test_random_flat_and_rle_files_decode_exactly(tmp_path, rng):
    pytest.importorskip("cv2")
    rgbe = _random_rgbe(rng, 5, 40)
    rgbe[2, 5:30] = (7, 7, 7, 131)   # long runs in every component
    rgbe[3, :, 3] = 135
    want = rgbe_to_float(rgbe)
    np.testing.assert_array_equal(read_hdr(write_flat(tmp_path / "flat.hdr", rgbe)), want)
    rle = write_rle(tmp_path / "rle.hdr", rgbe)
    assert rle.stat().st_size < (tmp_path / "flat.hdr").stat().st_size   # it really is run-length encoded
    np.testing.assert_array_equal(read_hdr(rle), want)


def test_read_image_and_environments_read_hdr(tmp_path, rng):
    pytest.importorskip("cv2")
    rgbe = _random_rgbe(rng, 8, 16)
    rgbe[0, 0, 3] = 130
    p = write_rle(tmp_path / "sky.hdr", rgbe)
    want = rgbe_to_float(rgbe)
    np.testing.assert_array_equal(read_image(write_flat(tmp_path / "sky.dat", rgbe)), want)   # by content
    np.testing.assert_array_equal(LatLongEnvironment(str(p)).image, want)
    scene, _ = pyrt.load_dict({"camera": {"width": 4, "height": 4},
                               "environment": {"type": "latlong", "file": "sky.hdr"}}, base_dir=str(tmp_path))
    np.testing.assert_array_equal(scene.environment.image, want)
    img, is_integer = load_image(p)                       # an image texture from .hdr: linear float, as EXR
    assert not is_integer
    np.testing.assert_array_equal(img, want)


@pytest.mark.parametrize("make, match", [
    (lambda p: p.write_bytes(b"#?RADIANCE\n"), "no end of header"),
    (lambda p: write_flat(p, np.ones((2, 2, 4), np.uint8), fmt=b"32-bit_rle_xyze"), "XYZE"),
    (lambda p: write_flat(p, np.ones((2, 2, 4), np.uint8), res=b"+Y 2 +X 2"), "orientation"),
    (lambda p: p.write_bytes(_header(100000, 100000) + b"\0" * 64), "limit is"),
    (lambda p: p.write_bytes(b"P6\n2 2\n255\n" + b"\0" * 12), "not a Radiance"),
])
def test_bad_headers_are_refused_naming_the_file(tmp_path, make, match):
    p = tmp_path / "bad.hdr"
    make(p)
    with pytest.raises(ImageFileError, match=match) as e:
        read_hdr(p)
    assert str(p) in str(e.value)


def test_truncated_pixel_data_is_an_image_file_error(tmp_path, rng, capfd):
    pytest.importorskip("cv2")
    p = write_rle(tmp_path / "t.hdr", _random_rgbe(rng, 6, 20))
    p.write_bytes(p.read_bytes()[:-30])
    with pytest.raises(ImageFileError, match="could not decode") as e:
        read_hdr(p)
    assert str(p) in str(e.value)
    assert "ERROR" not in capfd.readouterr().err      # OpenCV's own log line is silenced: one message, ours


def test_missing_opencv_gives_one_line_naming_the_file_and_the_extra(tmp_path, monkeypatch, capsys):
    p = write_flat(tmp_path / "sky.hdr", np.full((2, 4, 4), 128, np.uint8))
    monkeypatch.setitem(sys.modules, "cv2", None)         # `import cv2` now raises ImportError
    with pytest.raises(ImageFileError) as e:
        LatLongEnvironment(str(p))
    msg = str(e.value)
    assert str(p) in msg and "pyrt-embree[hdr]" in msg and "\n" not in msg
    scene = tmp_path / "s.toml"
    scene.write_text('[camera]\nwidth = 4\nheight = 4\n[environment]\ntype = "latlong"\nfile = "sky.hdr"\n')
    assert cli.main(["render", str(scene), "-o", str(tmp_path / "o.exr")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("pyrt: error: ") and "pyrt-embree[hdr]" in err[0]


def test_preview_env_hdr_renders_as_the_same_map_in_exr(tmp_path, rng):
    """``pyrt-preview --env sky.hdr``: the same pixels as the same radiance stored in an EXR."""
    pytest.importorskip("cv2")
    rgbe = _random_rgbe(rng, 8, 16)
    rgbe[..., 3] = rng.integers(126, 130, (8, 16))
    write_rle(tmp_path / "sky.hdr", rgbe)
    pyrt.write_exr(tmp_path / "sky.exr", rgbe_to_float(rgbe))
    images = []
    for name in ("sky.hdr", "sky.exr"):
        o = P.PreviewOptions(environment=str(tmp_path / name), width=16, height=12, spp=1)
        images.append(P.render_preview(BLOB, o).images[0])
    np.testing.assert_array_equal(images[0], images[1])
    assert images[0].max() > 0
