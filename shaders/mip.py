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

__all__ = ["reduce_axis", "reduce_level", "reduce_levels"]


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
