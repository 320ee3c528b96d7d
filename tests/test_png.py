"""PNG output: one encoder (pyrt.core.image_io.encode_png) behind write_png and the previewer's in-memory files."""
import io

import numpy as np
import png
import pytest
from PIL import Image

import pyrt
from pyrt.core.image_io import PNG_COMPRESS_LEVEL, encode_png, tonemap_to_display
from pyrt.shaders import color as C


def _display(img, scale):
    return np.round(C.srgb_encode(tonemap_to_display(img)) * scale)


def test_write_png_8bit_is_encode_png_of_the_quantised_image(tmp_path, rng):
    img = (3 * rng.random((9, 13, 3))).astype(np.float32)
    pyrt.write_png(tmp_path / "a.png", img)
    q = _display(img, 255).astype(np.uint8)
    data = (tmp_path / "a.png").read_bytes()
    assert data == encode_png(q)
    buf = io.BytesIO()
    Image.fromarray(q).save(buf, format="PNG", compress_level=PNG_COMPRESS_LEVEL)     # the previewer's files: same bytes
    assert data == buf.getvalue()
    np.testing.assert_array_equal(np.asarray(Image.open(tmp_path / "a.png")), q)
    default = io.BytesIO()
    Image.fromarray(q).save(default, format="PNG")        # Pillow's default level (files before): the same pixels
    np.testing.assert_array_equal(np.asarray(Image.open(default)), q)


def test_write_png_16bit_keeps_16_bits(tmp_path, rng):
    img = (3 * rng.random((7, 5, 3))).astype(np.float32)
    pyrt.write_png(tmp_path / "b.png", img, bits=16)
    w, h, rows, info = png.Reader(filename=str(tmp_path / "b.png")).asDirect()
    assert (w, h, info["bitdepth"]) == (5, 7, 16)
    got = np.vstack([np.asarray(r, dtype=np.uint16) for r in rows]).reshape(h, w, 3)
    np.testing.assert_array_equal(got, _display(img, 65535).astype(np.uint16))


def test_encode_png_rejects_other_shapes_and_dtypes():
    with pytest.raises(ValueError, match="shape"):
        encode_png(np.zeros((4, 4), np.uint8))
    with pytest.raises(ValueError, match="uint8 or uint16"):
        encode_png(np.zeros((4, 4, 3), np.float32))
