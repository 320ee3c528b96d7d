"""Fast MIP-pyramid construction: each level from the previous one by one vectorised 2x2 box reduction.

Pure functions of NumPy arrays (no pyrt, no I/O, no module state). Used by the lazy texture pyramid
:class:`pyrt.textures.MipPyramid`; :func:`pyrt.shaders.textures.build_mip_level` (the exact area
average of level 0, in float64) stays the reference and serves the environment-map prefilter.

Conventions
-----------
Level shapes
    As :func:`pyrt.shaders.textures.mip_level_shape`: ``(max(1, H >> l), max(1, W >> l))``, so level
    ``l`` is level ``l - 1`` with each axis ``n`` reduced to ``max(1, n // 2)``.
Reduction of one axis, ``n -> m = max(1, n // 2)``
    - ``n`` even: the mean of each pair ``(a[2k] + a[2k + 1]) / 2`` (the 2x2 box, separable).
    - ``n = 1``: unchanged.
    - ``n = 2m + 1`` odd: the exact box (area) average onto ``m`` equal cells of width ``n / m``
      (at most 4 taps with fractional edge weights), the filter of ``build_mip_level`` applied to
      the *previous* level instead of level 0. Each step preserves the image mean exactly (up to
      rounding); for power-of-two sizes the cascade equals the area average of level 0.
Precision
    Arithmetic in the input's floating dtype (float32 textures stay float32: 4 bytes per channel,
    a whole pyramid about 4/3 of level 0); integer or other input is promoted to float64.
"""
from __future__ import annotations

import numpy as np

__all__ = ["reduce_axis", "reduce_level", "reduce_levels", "pair_table", "reduce_coded_level"]


def _float(a):
    a = np.asarray(a)
    return a if a.dtype in (np.float32, np.float64) else a.astype(np.float64)


def reduce_axis(a, axis):
    """Halve ``a`` along ``axis`` (``n -> max(1, n // 2)``) by the box filter of the module notes.

    Parameters
    ----------
    a : ndarray
        Any shape; float32 or float64 kept, other dtypes promoted to float64.
    axis : int

    Returns
    -------
    ndarray, dtype of ``a`` (after promotion), the ``axis`` length reduced.
    """
    a = _float(a)
    n = a.shape[axis]
    m = max(1, n // 2)
    if m == n:
        return a
    a = np.moveaxis(a, axis, 0)
    half = a.dtype.type(0.5)
    if n == 2 * m:
        out = (a[0::2] + a[1::2]) * half
    else:
        # Exact area average onto m cells [k r, (k + 1) r), r = n / m in (2, 3]: up to 4 taps.
        r = n / m
        lo = np.arange(m) * r
        hi = lo + r
        first = np.floor(lo).astype(np.int64)
        out = np.zeros((m,) + a.shape[1:], dtype=a.dtype)
        wshape = (m,) + (1,) * (a.ndim - 1)
        for t in range(4):
            i = first + t
            w = np.clip(np.minimum(i + 1, hi) - np.maximum(i, lo), 0.0, None) / r
            if not np.any(w > 0):
                continue
            out += w.astype(a.dtype).reshape(wshape) * a[np.minimum(i, n - 1)]
    return np.moveaxis(out, 0, axis)


def reduce_level(level):
    """The next MIP level of an ``(H, W[, C])`` level: rows, then columns, by :func:`reduce_axis`."""
    return reduce_axis(reduce_axis(level, 0), 1)


def reduce_levels(level, steps):
    """``steps`` successive :func:`reduce_level` reductions of ``level`` (``steps >= 0``)."""
    if steps < 0:
        raise ValueError(f"steps must be >= 0, got {steps}")
    out = _float(level)
    for _ in range(int(steps)):
        out = reduce_level(out)
    return out


def pair_table(table):
    """The mean of every ordered pair of 8-bit codes' values: ``(table[a] + table[b]) * 0.5`` at index
    ``a * 256 + b``, in the dtype of ``table`` ((256,) float; the same floating-point operations as
    :func:`reduce_axis` on decoded rows, so the results are bit-identical)."""
    table = _float(table)
    if table.shape != (256,):
        raise ValueError(f"pair_table needs the 256 values of 8-bit codes, got shape {table.shape}")
    return ((table[:, None] + table[None, :]) * table.dtype.type(0.5)).ravel()


def reduce_coded_level(codes, table, pairs=None):
    """The next MIP level of 8-bit coded texels, decoded by ``table`` (``values = table[codes]``).

    Equal, bit for bit, to ``reduce_level(table[codes])`` and faster (3-4x on a 2048^2 RGB level): the
    row pairs are decoded and averaged by one lookup of :func:`pair_table` at ``row_2k * 256 + row_2k+1``
    instead of two decodes and a sum; columns then as :func:`reduce_axis`. An odd row count falls back to
    the decode-then-reduce path (its 3-tap area weights are not pair means).

    Parameters
    ----------
    codes : (H, W[, C]) uint8 ndarray
    table : (256,) float ndarray
    pairs : (65536,) ndarray, optional
        ``pair_table(table)``, when the caller keeps it across strips.

    Returns
    -------
    ndarray, dtype of ``table``, shape ``(max(1, H // 2), max(1, W // 2)[, C])``.
    """
    codes = np.asarray(codes)
    if codes.dtype != np.uint8:
        raise ValueError(f"reduce_coded_level needs uint8 codes, got {codes.dtype}")
    if codes.shape[0] % 2:
        return reduce_level(_float(table)[codes])
    if pairs is None:
        pairs = pair_table(table)
    idx = codes[0::2].astype(np.uint16)
    idx <<= 8
    idx |= codes[1::2]
    return reduce_axis(pairs[idx], 1)
