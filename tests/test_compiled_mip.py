"""Trilinear MIP textures on the compiled path (:data:`pyrt.textures.compiled.MIP`): the lookup twin against
:meth:`pyrt.ImageTexture.lookup` with footprints, from magnification to the coarsest level."""
import numba
import numpy as np
import pytest

import pyrt
from pyrt.textures import compiled as TC

from test_compiled_textures import _image


@numba.njit(cache=False)
def _lookup_all(tags, data, uv, duvdx, duvdy):
    flat = data.ravel()
    out = np.zeros((uv.shape[0], 3))
    for i in range(uv.shape[0]):
        d = (duvdx[i, 0], duvdx[i, 1], duvdy[i, 0], duvdy[i, 1], 0.0, 0.0, 0.0, 0.0)
        fp = TC.footprint(d, 0, 0, 0, 0.0, 0.0, 0.0)
        r = TC.texture_rgb(tags, flat, 0, uv[i, 0], uv[i, 1], fp)
        out[i, 0], out[i, 1], out[i, 2] = r
    return out


def _footprints(rng, n):
    """Footprints over ten octaves (magnified to past the coarsest level), some anisotropic, some zero, some grazing
    (one axis 1000x the other)."""
    scale = 2.0 ** rng.uniform(-12, 3, (n, 1))
    dx = rng.normal(size=(n, 2)) * scale
    dy = rng.normal(size=(n, 2)) * scale
    dy[: n // 4] *= 1e-3                      # grazing: one axis much longer
    dx[n // 4: n // 3] = 0.0                  # one axis zero
    dx[-10:] = 0.0
    dy[-10:] = 0.0                            # no footprint: level 0
    return dx, dy


@pytest.mark.parametrize("wrap", ["repeat", "clamp", "mirror", ("mirror", "clamp")])
@pytest.mark.parametrize("dtype", [np.float32, np.uint8])
@pytest.mark.parametrize("shape", [(7, 12), (32, 32), (1, 5)])
def test_trilinear_lookup_is_the_numpy_lookup(wrap, dtype, shape, rng):
    """Random UVs far outside [0, 1), random footprints (every level, the blends between them, zero), non-square
    and non-power-of-two images, float32 and 8-bit sRGB texels, with and without a UV transform: the NumPy
    lookup's values to 1e-6 relative (both round to float32; the level's log2 may round differently)."""
    img = _image(rng, *shape, dtype)
    n = 4000
    uv = rng.uniform(-3.0, 4.0, (n, 2))
    dx, dy = _footprints(rng, n)
    for kw in ({}, dict(scale=(2.0, 3.0), offset=(0.25, -0.5), rotation_deg=30.0), dict(footprint_scale=2.0)):
        tex = pyrt.ImageTexture(img, filter="trilinear", wrap=wrap, **kw)
        tag, rec, block = tex.compiled_record()
        assert tag == TC.MIP
        tags, data = TC.pack_table([tag], [rec], [block])
        got = _lookup_all(tags, data, uv, dx, dy)
        want = tex.lookup(uv, dx, dy)
        np.testing.assert_allclose(got, want, rtol=1e-6, atol=1e-7)


def test_the_levels_are_the_pyramids_and_a_two_texture_table_keeps_them_apart(rng):
    """Two MIP textures and an IMAGE one in one table: each lookup reads its own block."""
    a = pyrt.ImageTexture(_image(rng, 16, 8, np.float32), filter="trilinear")
    b = pyrt.ImageTexture(_image(rng, 9, 13, np.uint8), filter="trilinear", wrap="clamp")
    c = pyrt.ImageTexture(_image(rng, 5, 5, np.float32), filter="bilinear")
    recs = [t.compiled_record() for t in (a, b, c)]
    tags, data = TC.pack_table([r[0] for r in recs], [r[1] for r in recs], [r[2] for r in recs])
    uv = rng.uniform(0, 1, (500, 2))
    dx, dy = _footprints(rng, 500)
    flat = data.ravel()
    for t, tex in enumerate((a, b, c)):
        got = _lookup_t(tags, flat, t, uv, dx, dy)
        want = tex.lookup(uv, dx, dy)
        np.testing.assert_allclose(got, want, rtol=1e-6, atol=1e-7)


@numba.njit(cache=False)
def _lookup_t(tags, flat, t, uv, duvdx, duvdy):
    out = np.zeros((uv.shape[0], 3))
    for i in range(uv.shape[0]):
        d = (duvdx[i, 0], duvdx[i, 1], duvdy[i, 0], duvdy[i, 1], 0.0, 0.0, 0.0, 0.0)
        fp = TC.footprint(d, 0, 0, 0, 0.0, 0.0, 0.0)
        out[i, 0], out[i, 1], out[i, 2] = TC.texture_rgb(tags, flat, t, uv[i, 0], uv[i, 1], fp)
    return out
