"""Display pipelines of the course notes (issue 16, item 5) against their closed forms.

Per-channel Reinhard ``L / (1 + L)``, plain gamma ``x ** (1 / gamma)`` beside the sRGB curve,
``pow(x, 2.2)`` texture decoding and constant-linear-quadratic light attenuation.
"""
import numpy as np
import pytest

import pyrt
from pyrt.core.image_io import read_image
from pyrt.lights.base import LightError
from pyrt.lights.punctual import PointLight, SpotLight
from pyrt.shaders import color, tonemap
from pyrt.shaders import lights as kernels
from pyrt.textures.base import TextureError
from pyrt.textures.image import ImageTexture


def test_reinhard_rgb_is_per_channel_l_over_1_plus_l(rng):
    L = rng.uniform(0.0, 20.0, (50, 3))
    np.testing.assert_allclose(tonemap.reinhard_rgb(L), L / (1.0 + L), rtol=1e-15)
    np.testing.assert_allclose(tonemap.reinhard_rgb(L, exposure=1.0), 2 * L / (1.0 + 2 * L), rtol=1e-15)
    # differs from the luminance form for a saturated colour; equal for grey
    c = np.array([[4.0, 0.5, 0.1]])
    assert not np.allclose(tonemap.reinhard_rgb(c), tonemap.reinhard(c))
    g = np.full((1, 3), 3.0)
    np.testing.assert_allclose(tonemap.reinhard_rgb(g), tonemap.reinhard(g), rtol=1e-12)
    assert np.all(tonemap.reinhard_rgb(np.array([[-1.0, 0.0, 1e30]])) == [[0.0, 0.0, 1.0]])


def test_gamma_encode_decode_closed_form(dtype):
    x = np.linspace(0.0, 1.0, 101).astype(dtype)
    enc = color.gamma_encode(x, 2.2)
    assert enc.dtype == dtype
    np.testing.assert_allclose(enc, x.astype(np.float64) ** (1 / 2.2), rtol=1e-6)
    np.testing.assert_allclose(color.gamma_decode(enc, 2.2), x, atol=1e-6)
    np.testing.assert_allclose(color.gamma_encode(x, 1.8), x.astype(np.float64) ** (1 / 1.8), rtol=1e-6)
    # the plain curve is close to, not equal to, the exact sRGB curve (largest gap near black)
    gap = np.max(np.abs(color.gamma_encode(x.astype(np.float64)) - color.srgb_encode(x.astype(np.float64))))
    assert 0.01 < gap < 0.04


def test_write_png_gamma_encoding(tmp_path):
    img = np.linspace(0.0, 1.0, 16 * 3).reshape(4, 4, 3).astype(np.float32)
    pyrt.write_png(tmp_path / "g.png", img, tonemap="linear", encoding="gamma", gamma=2.2)
    pyrt.write_png(tmp_path / "s.png", img, tonemap="linear")
    g = read_image(tmp_path / "g.png").astype(np.float64)
    s = read_image(tmp_path / "s.png").astype(np.float64)
    np.testing.assert_array_equal(g, np.round(img.astype(np.float64) ** (1 / 2.2) * 255))
    np.testing.assert_array_equal(s, np.round(color.srgb_encode(img) * 255))
    with pytest.raises(ValueError, match="encoding"):
        pyrt.write_png(tmp_path / "x.png", img, encoding="rec709")
    with pytest.raises(ValueError, match="gamma"):
        pyrt.write_png(tmp_path / "x.png", img, encoding="gamma", gamma=0.0)


def test_write_png_reinhard_rgb(tmp_path):
    img = np.array([[[4.0, 0.5, 0.1]]], dtype=np.float32)
    pyrt.write_png(tmp_path / "r.png", img, tonemap="reinhard_rgb")
    got = read_image(tmp_path / "r.png")[0, 0]
    L = img[0, 0].astype(np.float64)
    np.testing.assert_array_equal(got, np.round(color.srgb_encode(L / (1 + L)) * 255))


def test_cli_accepts_reinhard_rgb_and_gamma():
    from pyrt.apps.cli import _parser

    a = _parser().parse_args(["render", "s.toml", "-o", "x.png", "--tonemap", "reinhard_rgb",
                              "--encoding", "gamma", "--gamma", "2.4"])
    assert (a.tonemap, a.encoding, a.gamma) == ("reinhard_rgb", "gamma", 2.4)


def test_texture_decode_gamma22():
    texels = np.array([[[0, 64, 128], [191, 230, 255]]], dtype=np.uint8)
    v = texels.astype(np.float64) / 255
    for decode, want in (("gamma2.2", v ** 2.2), ("srgb", color.srgb_decode(v)), ("linear", v)):
        tex = ImageTexture(texels, decode=decode, filter="nearest")
        assert tex.decode == decode
        np.testing.assert_allclose(tex.image[0].astype(np.float64), want[0], rtol=1e-6, atol=1e-7)
    assert ImageTexture(texels).decode == "srgb"           # default unchanged: integer images are sRGB
    assert ImageTexture(v.astype(np.float32)).decode == "linear"
    with pytest.raises(TextureError, match="decode"):
        ImageTexture(texels, decode="gamma2.4")
    with pytest.raises(TextureError, match="contradicts"):
        ImageTexture(texels, srgb=True, decode="gamma2.2")


def test_clq_attenuation_closed_form(dtype):
    d = np.array([0.0, 0.5, 1.0, 2.0, 10.0], dtype=dtype)
    kc, kl, kq = 1.0, 0.09, 0.032          # LearnOpenGL "Light casters": the 50-unit row
    f = kernels.distance_falloff(d, "clq", clq=(kc, kl, kq))
    assert f.dtype == dtype
    np.testing.assert_allclose(f, 1.0 / (kc + kl * d.astype(np.float64) + kq * d.astype(np.float64) ** 2),
                               rtol=1e-6)
    # (0, 0, 1) is the inverse square law, finite (0) at r = 0
    np.testing.assert_allclose(kernels.distance_falloff(d, "clq", clq=(0, 0, 1)),
                               kernels.distance_falloff(d, "inverse_square"), rtol=1e-7)


def test_point_and_spot_lights_clq():
    p = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, 3.0]])
    k = (1.0, 0.5, 0.25)
    r = np.array([1.0, 3.0])
    want = 2.0 / (k[0] + k[1] * r + k[2] * r * r)
    pl = PointLight((0, 0, 0), intensity=2.0, falloff="clq", clq=k)
    s = pl.sample_li(p, np.zeros((2, 2)))
    np.testing.assert_allclose(s.E if s.E is not None else s.scale[:, None] * s.rgb, want[:, None] * [1, 1, 1])
    sl = SpotLight((0, 0, 0), (0, 0, 1), intensity=2.0, falloff="clq", clq=k)
    np.testing.assert_allclose(sl.sample(p, None)[2], want[:, None] * [1, 1, 1])
    with pytest.raises(LightError, match="needs clq"):
        PointLight((0, 0, 0), intensity=1.0, falloff="clq")
    with pytest.raises(LightError, match="only used"):
        PointLight((0, 0, 0), intensity=1.0, clq=k)
    with pytest.raises(LightError, match="clq must be"):
        PointLight((0, 0, 0), intensity=1.0, falloff="clq", clq=(0, 0, 0))
    with pytest.raises(LightError, match="clq must be"):
        PointLight((0, 0, 0), intensity=1.0, falloff="clq", clq=(1, -1, 0))
