"""Image textures on the compiled path (:data:`pyrt.textures.compiled.IMAGE`): the lookup twin against
:meth:`pyrt.ImageTexture.lookup`, and textured renders against the NumPy path pixel by pixel."""
import numba
import numpy as np
import pytest

import pyrt
from pyrt.integrators import compiled
from pyrt.textures import compiled as TC


@numba.njit(cache=False)
def _lookup_all(tags, data, uv):
    flat = data.ravel()
    out = np.zeros((uv.shape[0], 3))
    for i in range(uv.shape[0]):
        r = TC.texture_rgb(tags, flat, 0, uv[i, 0], uv[i, 1], TC.NO_FOOTPRINT)
        out[i, 0], out[i, 1], out[i, 2] = r
    return out


def _image(rng, h, w, dtype):
    if dtype == np.uint8:
        return rng.integers(0, 256, (h, w, 3)).astype(np.uint8)
    return rng.random((h, w, 3)).astype(dtype) * 4.0


@pytest.mark.parametrize("filt", ["nearest", "bilinear"])
@pytest.mark.parametrize("wrap", ["repeat", "clamp", "mirror", ("mirror", "clamp")])
@pytest.mark.parametrize("dtype", [np.float32, np.float64, np.uint8])
def test_lookup_is_the_numpy_lookup(filt, wrap, dtype, rng):
    """Random UVs far outside [0, 1) (every wrap), a non-square image whose width is not a power of two, float32,
    float64 and 8-bit sRGB texels, with and without a UV transform: the NumPy lookup's values (1e-12; the same
    float32 rounding)."""
    img = _image(rng, 7, 12, dtype)
    uv = rng.uniform(-3.0, 4.0, (3000, 2))
    uv[:6] = [[0, 0], [1, 1], [0.5, 0.5], [1 / 12, 1 / 7], [-1 / 24, 0.5], [0.999999, 1e-9]]
    for kw in ({}, dict(scale=(2.0, 3.0), offset=(0.25, -0.5), rotation_deg=30.0)):
        tex = pyrt.ImageTexture(img, filter=filt, wrap=wrap, **kw)
        tags, data = TC.pack_table(*([x] for x in tex.compiled_record()))
        got = _lookup_all(tags, data, uv)
        want = tex.lookup(uv)
        np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12 if not kw else 1e-6)


def test_anisotropic_bicubic_and_grey_are_not_compiled_and_say_why():
    img = np.ones((4, 4, 3), dtype=np.float32)
    assert pyrt.ImageTexture(img).compiled_record()[0] == TC.MIP                  # trilinear: compiled
    assert pyrt.ImageTexture(img, filter="anisotropic").compiled_record() is None
    assert pyrt.ImageTexture(img, filter="bicubic").compiled_record() is None
    assert pyrt.ImageTexture(img[..., :1], filter="bilinear").compiled_record() is None
    cubic = pyrt.ImageTexture(img, filter="bicubic", name="b")
    assert TC.image_refusal(cubic) == "texture ImageTexture 'b': filter 'bicubic'"
    assert "1 channel(s)" in TC.image_refusal(pyrt.ImageTexture(img[..., :1], filter="bilinear"))
    assert TC.image_refusal(pyrt.ImageTexture(img)) is None
    for filt, tag in (("bilinear", TC.IMAGE), ("trilinear", TC.MIP)):         # other UV sets: their set in the record
        rec = pyrt.ImageTexture(img, filter=filt, texcoord=2).compiled_record()
        assert rec[0] == tag and rec[1][TC.UV_SET] == 2


def test_textured_render_matches_the_numpy_path_pixel_by_pixel(rng):
    """Lambert and Blinn-Phong with bilinear and nearest image textures (one transformed, one 8-bit sRGB) next to
    a checker, point light, pixel centres: the same image as the NumPy path."""
    cam = pyrt.Camera(position=(0, 1.3, 3.5), target=(0, 0.3, 0), fov=45, width=40, height=30, jitter=False)
    s = pyrt.Scene(cam, background=(0.05, 0.05, 0.1))
    ground = pyrt.ImageTexture(_image(rng, 64, 48, np.float32), filter="bilinear", scale=(3.0, 2.0), rotation_deg=20)
    s.add_plane((0, 0, 0), 6.0, pyrt.Lambert(albedo=ground))
    ball = pyrt.ImageTexture(_image(rng, 16, 32, np.uint8), filter="nearest", wrap="clamp")
    s.add_sphere((-0.5, 0.5, 0), 0.5, pyrt.BlinnPhong(kd=ball, ks=0.2, exponent=30), subdivisions=3)
    s.add_sphere((0.6, 0.4, 0.2), 0.4, pyrt.Lambert(albedo=pyrt.CheckerTexture(0.1, 0.9, scale=8, filtered=False)))
    s.add_light(pyrt.PointLight((1, 3, 2), intensity=15.0))
    assert compiled.unsupported(pyrt.PreparedScene(s)) == []
    c = pyrt.render_full(s, backend="compiled", progress=False)
    n = pyrt.render_full(s, backend="numpy", progress=False)
    diff = np.abs(c.image.astype(np.float64) - n.image)
    bad = diff > 1e-5 * (1.0 + np.abs(n.image))
    assert bad.any(axis=2).mean() < 0.002, f"{bad.any(axis=2).sum()} pixels differ, max {diff.max()}"
