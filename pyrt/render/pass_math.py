"""The per-pass arithmetic of adaptive rendering (:mod:`pyrt.render.adaptive`), compiled with Numba.

After every pass the adaptive renderer estimates each pixel's error from the two half-buffers, smooths and dilates
it, and shares out the next pass's samples (:func:`pyrt.render.adaptive.pixel_errors`, ``box_smooth``,
``max_filter``, ``allocate``). In NumPy each of these is several passes over the image with temporaries: at 320 x
240 about 10 ms per pass, as much as the compiled kernel takes for a pass of 100,000 samples. Here each is one loop:
the same arithmetic operation for operation (the box sums from the same prefix sums, the errors with the same
divisions), so the results are the NumPy formulas' bit for bit, except :func:`fill_total`, a sequential sum where
NumPy sums pairwise (the water filling's bisection compares it with a tolerance of 0.5 %).

Cached in the kernels' cache directory (:func:`pyrt.integrators.kernel_cache.cache_dir`); :func:`warm` loads (or
compiles, a few seconds the first time) every function, which :func:`pyrt.render.adaptive.render_adaptive` does
before its time budget starts.
"""
from __future__ import annotations

import numba
import numpy as np

from pyrt.integrators import kernel_cache

kernel_cache.use_cache_dir()      # before the decorators below run

_jit = numba.njit(cache=True, nogil=True, error_model="numpy")


@_jit
def box_smooth(a, radius):
    """Mean of ``a`` (H, W) over the (2 radius + 1)^2 box around each pixel, the box clipped at the border: the
    prefix sums of ``np.cumsum(np.cumsum(a, 0), 1)`` combined as :func:`pyrt.render.adaptive.box_smooth` does."""
    H, W = a.shape
    c = np.zeros((H + 1, W + 1))
    for i in range(H):
        for j in range(W):
            c[i + 1, j + 1] = c[i, j + 1] + a[i, j]          # down the columns first, as cumsum over axis 0
    for i in range(1, H + 1):
        for j in range(1, W + 1):
            c[i, j] = c[i, j - 1] + c[i, j]                  # then along the rows
    out = np.empty((H, W))
    for i in range(H):
        r0, r1 = max(i - radius, 0), min(i + radius + 1, H)
        for j in range(W):
            c0, c1 = max(j - radius, 0), min(j + radius + 1, W)
            s = c[r1, c1] - c[r0, c1] - c[r1, c0] + c[r0, c0]
            out[i, j] = s / ((r1 - r0) * (c1 - c0))
    return out


@_jit
def max_filter(a, radius):
    """Maximum of ``a`` (H, W) over the (2 radius + 1)^2 box around each pixel (the box clipped at the border)."""
    H, W = a.shape
    rows = np.empty((H, W))
    for i in range(H):
        for j in range(W):
            m = a[i, j]
            for k in range(max(j - radius, 0), min(j + radius + 1, W)):
                m = max(m, a[i, k])
            rows[i, j] = m
    out = np.empty((H, W))
    for i in range(H):
        for j in range(W):
            m = rows[i, j]
            for k in range(max(i - radius, 0), min(i + radius + 1, H)):
                m = max(m, rows[k, j])
            out[i, j] = m
    return out


@_jit
def pixel_errors(total, weight, half, half_weight, eps):
    """Per-pixel estimated relMSE (N,) of the film's mean from its sums ``total`` (N, 3) and ``weight`` (N,) and
    half B's ``half``, ``half_weight``: :func:`pyrt.render.adaptive.pixel_errors` (NaN where a half has no
    sample)."""
    n = weight.shape[0]
    out = np.empty(n)
    for p in range(n):
        wb = half_weight[p]
        wa = weight[p] - wb
        if not (wa > 0 and wb > 0):
            out[p] = np.nan
            continue
        acc = 0.0
        for c in range(3):
            sb = half[p, c]
            d = (total[p, c] - sb) / wa
            d -= sb / wb
            d *= d
            d /= 4.0
            m = total[p, c] / weight[p]
            r = m * m
            r += eps
            if c == 0:
                acc = d / r
            else:
                acc += d / r
        out[p] = acc / 3.0
    return out


@_jit
def fill_total(lam, share, have, room):
    """``sum(clip(lam share - have, 0, room))``: the samples a water level ``lam`` gives (:func:`pyrt.render.
    adaptive._water_fill`)."""
    s = 0.0
    for p in range(share.shape[0]):
        x = lam * share[p] - have[p]
        s += min(max(x, 0.0), room[p])
    return s


@_jit
def add_rows(dst, rows, src):
    """``dst[rows] += src`` for unique ``rows`` (a film's pixel sums, (N, k) or (N,))."""
    if dst.ndim == 1:
        for i in range(rows.shape[0]):
            dst[rows[i]] += src[i]
    else:
        for i in range(rows.shape[0]):
            for c in range(dst.shape[1]):
                dst[rows[i], c] += src[i, c]


def warm():
    """Load every function from the cache (compile it on a cold one) with tiny inputs."""
    a = np.ones((3, 3))
    box_smooth(a, 1)
    max_filter(a, 1)
    rgb, w = np.ones((2, 3)), np.full(2, 2.0)
    pixel_errors(rgb, w, rgb, np.ones(2), 1e-2)
    fill_total(1.0, w, w, w)
    add_rows(w, np.zeros(1, dtype=np.int64), w)
    add_rows(rgb, np.zeros(1, dtype=np.int64), rgb)


kernel_cache.restore()
