"""Texel lookups of the compiled texture table: wrapping, bilinear taps, the trilinear MIP lookup with a ray
differential footprint (the MIP record of :mod:`pyrt.textures.compiled`), and the texel blocks the table is packed
from (:class:`TexelBlock`).

The MIP record is an IMAGE record (:mod:`pyrt.textures.compiled`: 0 H, 1 W, 2 where level 0's texels start in the
table's float32 words, 3-4 wrap, 6 1 when lookups are rounded to float32, 7-13 the UV transform) with 5 the number
``n`` of MIP levels, 14 the footprint scale and 15 where its ``n`` level offsets start in the table's float64 words
(each where that level's texels start in the float32 words). Its texels are the levels of the texture's own
:class:`pyrt.textures.image.MipPyramid` (float32, row-major ``(H_l, W_l, 3)``), all built when the scene is packed.

:func:`mip_rgb` is the scalar twin of :func:`pyrt.shaders.textures.lookup_trilinear` (the level of
:func:`~pyrt.shaders.textures.mip_level_isotropic`, the split of :func:`~pyrt.shaders.textures.trilinear_levels`,
each level's bilinear lookup rounded to the level's dtype, the blend in float64 and rounded again), held to it by
tests/test_compiled_mip.py.
"""
from __future__ import annotations

import math

import numpy as np
from numba.extending import register_jitable

from pyrt.core.unmanaged import float32_pointer
from pyrt.shaders import jit as J
from pyrt.shaders.textures import mip_level_shape, n_mip_levels

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
def bilinear_rgb(tx, o, h, w, wu, wv, x, y):
    """The bilinear lookup (float64 sums, :func:`pyrt.shaders.textures.bilinear_channels`' order) at texel
    coordinates ``(x, y)`` of the ``(h, w, 3)`` float32 texels at ``tx[o:]`` with wrap codes ``wu``, ``wv``."""
    x0, y0 = math.floor(x), math.floor(y)
    fx, fy = x - x0, y - y0
    ix, iy = int(x0), int(y0)
    c0, c1 = wrap_index(ix, w, wu), wrap_index(ix + 1, w, wu)
    r0, r1 = wrap_index(iy, h, wv) * w, wrap_index(iy + 1, h, wv) * w
    w0, w1, w2, w3 = (1 - fx) * (1 - fy), fx * (1 - fy), (1 - fx) * fy, fx * fy
    k0, k1, k2, k3 = o + 3 * (r0 + c0), o + 3 * (r0 + c1), o + 3 * (r1 + c0), o + 3 * (r1 + c1)
    r = w0 * tx[k0] + w1 * tx[k1] + w2 * tx[k2] + w3 * tx[k3]
    g = w0 * tx[k0 + 1] + w1 * tx[k1 + 1] + w2 * tx[k2 + 1] + w3 * tx[k3 + 1]
    bb = w0 * tx[k0 + 2] + w1 * tx[k1 + 2] + w2 * tx[k2 + 2] + w3 * tx[k3 + 2]
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
    lo = int(pars[b + 15])
    wu, wv = int(pars[b + 3]), int(pars[b + 4])
    tx = float32_pointer(pars)
    width = pars[b + 14] * max(math.hypot(dux * w, -dvx * h), math.hypot(duy * w, -dvy * h))
    lam = math.log2(width) if width > 0.0 else 0.0
    lam = min(max(lam, 0.0), n - 1.0)
    l0 = int(math.floor(lam))
    l1 = min(l0 + 1, n - 1)
    w1 = lam - l0 if l1 > l0 else 0.0
    r, g, bb = _level_rgb(tx, int(pars[lo + l0]), l0, h, w, wu, wv, u, v, pars[b + 6] != 0.0)
    w0 = 1.0 - w1
    r, g, bb = w0 * r, w0 * g, w0 * bb
    if w1 > 0.0:
        r1, g1, b1 = _level_rgb(tx, int(pars[lo + l1]), l1, h, w, wu, wv, u, v, pars[b + 6] != 0.0)
        r, g, bb = r + w1 * r1, g + w1 * g1, bb + w1 * b1
    if pars[b + 6] != 0.0:
        return float(np.float32(r)), float(np.float32(g)), float(np.float32(bb))
    return r, g, bb


@register_jitable
def _level_rgb(tx, o, level, h, w, wu, wv, u, v, f32):
    """The bilinear lookup on MIP level ``level`` (of a level 0 of ``(h, w)`` texels), whose texels are at
    ``tx[o:]``, rounded to float32 with ``f32``."""
    hl, wl = max(1, h >> level), max(1, w >> level)
    r, g, bb = bilinear_rgb(tx, o, hl, wl, wu, wv, u * wl - 0.5, (1.0 - v) * hl - 0.5)
    if f32:
        return float(np.float32(r)), float(np.float32(g)), float(np.float32(bb))
    return r, g, bb


def mip_record(tex, rec, transform):
    """``(record, texels)`` of a trilinear RGB :class:`pyrt.ImageTexture` (the module notes): its fields written into
    the zero record ``rec``, ``transform`` (fields 7-13, :func:`pyrt.textures.compiled.transform_fields`); the texels
    (its whole pyramid) are written only when the table is packed (:class:`TexelBlock`), so deciding whether a scene
    can take the compiled path builds no pyramid. Fields 2 and 15 are set by the packing."""
    h, w = tex.texels.shape[:2]
    rec[0], rec[1] = h, w
    rec[3], rec[4] = (WRAPS.index(m) for m in tex.wrap)
    rec[5] = n_mip_levels((h, w))
    rec[6] = 1.0 if (tex.table if tex.table is not None else tex.texels).dtype == np.float32 else 0.0
    rec[7:14] = transform
    rec[14] = tex.footprint_scale
    return rec, TexelBlock(tex, int(rec[5]))


class TexelBlock:
    """The texels of an IMAGE or MIP record: the first ``n_levels`` MIP levels of an RGB :class:`pyrt.ImageTexture`
    (1: level 0 alone, what the ``nearest`` and ``bilinear`` filters read), written as float32 into the packed table
    (:func:`pyrt.textures.compiled.pack_table`). Nothing is decoded or built before :meth:`write`."""

    #: rows of coded (8/16-bit) texels decoded at a time into the table (no decoded copy of the whole level)
    STRIP_ROWS = 256

    def __init__(self, tex, n_levels):
        self.tex = tex
        self.n_levels = n_levels

    def level_sizes(self):
        """Float32 words of each level, finest first (from the shapes: builds nothing)."""
        shape = self.tex.texels.shape
        return [3 * math.prod(mip_level_shape(shape, k)) for k in range(self.n_levels)]

    @property
    def size(self):
        """Float32 words of every level's texels."""
        return sum(self.level_sizes())

    def write(self, out):
        """Every level's texels into ``out`` ((:attr:`size`,) float32, a view of the table), finest first: level 0
        copied from the texture's float32 texels or decoded through its code table strip by strip, the coarser
        levels copied from its pyramid (:meth:`pyrt.ImageTexture.mip_level`: built now where they are not yet, and
        kept by the texture). Each texel is written once, with no float64 or whole-level intermediate."""
        tex = self.tex
        texels, table = tex.texels, tex.table
        at = 0
        for k, n in enumerate(self.level_sizes()):
            dst = out[at:at + n]
            if k > 0:
                dst[:] = tex.mip_level(k).ravel()
            elif table is None:
                dst[:] = texels.ravel()
            else:
                rows = dst.reshape(texels.shape)
                for r in range(0, texels.shape[0], self.STRIP_ROWS):
                    rows[r:r + self.STRIP_ROWS] = table[texels[r:r + self.STRIP_ROWS]]
            at += n
