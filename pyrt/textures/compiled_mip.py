"""Texel lookups of the compiled texture table: wrapping, bilinear taps, and the trilinear MIP lookup with a ray
differential footprint (the MIP record of :mod:`pyrt.textures.compiled`).

The MIP record is an IMAGE record (:mod:`pyrt.textures.compiled`: 0 H, 1 W, 2 where its block starts in the table's
flat data, 3-4 wrap, 6 1 when lookups are rounded to float32, 7-13 the UV transform) with 5 the number of MIP levels
and 14 the footprint scale. Its block holds the ``n`` levels' offsets (relative to the block) and then each level's
texels (float64 of the pyramid's float32 values, row-major ``(H_l, W_l, 3)``): the levels of the texture's own
:class:`pyrt.textures.image.MipPyramid`, all built when the scene is packed.

:func:`mip_rgb` is the scalar twin of :func:`pyrt.shaders.textures.lookup_trilinear` (the level of
:func:`~pyrt.shaders.textures.mip_level_isotropic`, the split of :func:`~pyrt.shaders.textures.trilinear_levels`,
each level's bilinear lookup rounded to the level's dtype, the blend in float64 and rounded again), held to it by
tests/test_compiled_mip.py.
"""
from __future__ import annotations

import math

import numpy as np
from numba.extending import register_jitable

from pyrt.shaders import jit as J
from pyrt.shaders.textures import n_mip_levels

#: the wrap modes' codes (:func:`pyrt.shaders.textures.wrap_index`)
WRAPS = ("repeat", "clamp", "mirror")


@register_jitable
def wrap_index(i, n, mode):
    """:func:`pyrt.shaders.textures.wrap_index` of one index (``mode``: 0 repeat, 1 clamp, 2 mirror)."""
    if mode == 0:
        return J.wrap_int(i, n)
    if mode == 1:
        return min(max(i, 0), n - 1)
    j = J.wrap_int(i, 2 * n)
    return 2 * n - 1 - j if j >= n else j




@register_jitable
def bilinear_rgb(pars, o, h, w, wu, wv, x, y):
    """The bilinear lookup (float64 sums, :func:`pyrt.shaders.textures.bilinear_channels`' order) at texel
    coordinates ``(x, y)`` of the ``(h, w, 3)`` texels at ``pars[o:]`` with wrap codes ``wu``, ``wv``."""
    x0, y0 = math.floor(x), math.floor(y)
    fx, fy = x - x0, y - y0
    ix, iy = int(x0), int(y0)
    c0, c1 = wrap_index(ix, w, wu), wrap_index(ix + 1, w, wu)
    r0, r1 = wrap_index(iy, h, wv) * w, wrap_index(iy + 1, h, wv) * w
    w0, w1, w2, w3 = (1 - fx) * (1 - fy), fx * (1 - fy), (1 - fx) * fy, fx * fy
    k0, k1, k2, k3 = o + 3 * (r0 + c0), o + 3 * (r0 + c1), o + 3 * (r1 + c0), o + 3 * (r1 + c1)
    r = w0 * pars[k0] + w1 * pars[k1] + w2 * pars[k2] + w3 * pars[k3]
    g = w0 * pars[k0 + 1] + w1 * pars[k1 + 1] + w2 * pars[k2 + 1] + w3 * pars[k3 + 1]
    bb = w0 * pars[k0 + 2] + w1 * pars[k1 + 2] + w2 * pars[k2 + 2] + w3 * pars[k3 + 2]
    return r, g, bb


@register_jitable
def mip_rgb(pars, b, u, v, fp):
    """The MIP record at ``pars[b:]`` looked up at mesh uv ``(u, v)`` with the footprint ``fp = (du/dx, dv/dx, du/dy,
    dv/dy)``: the UV transform (footprints by its linear part), the continuous level ``log2(scale * max(|dx|,
    |dy|))`` of the footprint in level-0 texels (level 0 for a zero footprint), bilinear lookups on the two levels
    around it, blended (:func:`pyrt.shaders.textures.lookup_trilinear`)."""
    dux, dvx, duy, dvy = fp
    if pars[b + 7] != 0.0:
        l00, l01, l10, l11 = pars[b + 8], pars[b + 9], pars[b + 10], pars[b + 11]
        u, v = u * l00 + v * l10 + pars[b + 12], u * l01 + v * l11 + pars[b + 13]
        dux, dvx = dux * l00 + dvx * l10, dux * l01 + dvx * l11
        duy, dvy = duy * l00 + dvy * l10, duy * l01 + dvy * l11
    h, w = int(pars[b]), int(pars[b + 1])
    n = int(pars[b + 5])
    o = int(pars[b + 2])
    wu, wv = int(pars[b + 3]), int(pars[b + 4])
    width = pars[b + 14] * max(math.hypot(dux * w, -dvx * h), math.hypot(duy * w, -dvy * h))
    lam = math.log2(width) if width > 0.0 else 0.0
    lam = min(max(lam, 0.0), n - 1.0)
    l0 = int(math.floor(lam))
    l1 = min(l0 + 1, n - 1)
    w1 = lam - l0 if l1 > l0 else 0.0
    r, g, bb = _level_rgb(pars, o, l0, h, w, wu, wv, u, v, pars[b + 6] != 0.0)
    w0 = 1.0 - w1
    r, g, bb = w0 * r, w0 * g, w0 * bb
    if w1 > 0.0:
        r1, g1, b1 = _level_rgb(pars, o, l1, h, w, wu, wv, u, v, pars[b + 6] != 0.0)
        r, g, bb = r + w1 * r1, g + w1 * g1, bb + w1 * b1
    if pars[b + 6] != 0.0:
        return float(np.float32(r)), float(np.float32(g)), float(np.float32(bb))
    return r, g, bb


@register_jitable
def _level_rgb(pars, o, level, h, w, wu, wv, u, v, f32):
    """The bilinear lookup on MIP level ``level`` of the block at ``pars[o:]`` (level 0 of ``(h, w)`` texels), rounded
    to float32 with ``f32``."""
    hl, wl = max(1, h >> level), max(1, w >> level)
    r, g, bb = bilinear_rgb(pars, o + int(pars[o + level]), hl, wl, wu, wv, u * wl - 0.5, (1.0 - v) * hl - 0.5)
    if f32:
        return float(np.float32(r)), float(np.float32(g)), float(np.float32(bb))
    return r, g, bb


def mip_record(tex, rec, transform):
    """``(record, levels)`` of a trilinear RGB :class:`pyrt.ImageTexture` (the module notes): its fields written into
    the zero record ``rec``, ``transform`` (fields 7-13, :func:`pyrt.textures.compiled.transform_fields`); the block
    of texels is made only when the table is packed (:class:`MipLevels`), so deciding whether a scene can take the
    compiled path builds no pyramid."""
    h, w = tex.texels.shape[:2]
    rec[0], rec[1] = h, w
    rec[3], rec[4] = (WRAPS.index(m) for m in tex.wrap)
    rec[5] = n_mip_levels((h, w))
    rec[6] = 1.0 if (tex.table if tex.table is not None else tex.texels).dtype == np.float32 else 0.0
    rec[7:14] = transform
    rec[14] = tex.footprint_scale
    return rec, MipLevels(tex)


class MipLevels:
    """The texels of a MIP record, made when the texture table is packed (:func:`pyrt.textures.compiled.pack_table`)."""

    def __init__(self, tex):
        self.tex = tex
        self._levels = None

    def levels(self):
        """The pyramid's levels (:meth:`pyrt.ImageTexture.mip_levels`: the whole pyramid, built on the first call)."""
        if self._levels is None:
            self._levels = self.tex.mip_levels()
        return self._levels

    @property
    def size(self):
        """Words of the block: one offset per level, then every level's texels."""
        levels = self.levels()
        return len(levels) + sum(lev.size for lev in levels)

    def write(self, out):
        """The block into ``out`` ((:attr:`size`,) float64): the levels' offsets in the block, then every level's
        texels, each converted once on its way in (no intermediate copies: a 2048² map's pyramid is ~17 M words)."""
        levels = self.levels()
        at = len(levels)
        for k, lev in enumerate(levels):
            out[k] = at
            out[at:at + lev.size] = np.ravel(lev)
            at += lev.size
