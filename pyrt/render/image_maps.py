"""Whole-image arithmetic of the adaptive passes (:mod:`pyrt.render.adaptive`) on per-pixel maps: box means, box
maxima and the water fill that turns a pass's per-pixel shares into sample counts.

Compiled loops (Numba, cached with the render kernels: :func:`pyrt.integrators.kernel_cache.use_cache_dir`), each one
or two passes over the map and no temporary per step: on a 320 x 240 film the same arithmetic as NumPy vector
operations took ~20 ms of the ~70 ms of an adaptive render of the diffuse benchmark scene to Mitsuba's 64-spp error
(every operation a pass over memory, temporaries page-faulted on first touch). This module and
:mod:`pyrt.render.pass_plan` are kernel sources (:data:`pyrt.integrators.kernel_cache.KERNEL_SOURCES`): their
compiled functions call each other, and an edit to either gives a new cache.
"""
from __future__ import annotations

import numpy as np

from pyrt.integrators import kernel_cache

kernel_cache.use_cache_dir()      # before the decorators below run

import numba  # noqa: E402

#: a compiled map loop (no Python objects, no bounds checks; a division by 0 gives inf or NaN as in NumPy)
_jit = numba.njit(cache=True, nogil=True, error_model="numpy")


def box_smooth(a, radius):
    """Mean of ``a`` (H, W) over the (2 radius + 1)^2 box around each pixel (the box clipped at the border): window
    sums along the columns, then along the rows, over the boxes' pixel counts (a fresh (H, W) array)."""
    a = np.ascontiguousarray(a, dtype=np.float64)
    out = np.empty_like(a)
    _box_smooth(a, int(radius), out)
    return out


@_jit
def _box_smooth(a, radius, out):
    """:func:`box_smooth` of ``a`` (H, W) into ``out`` (H, W). Each window sum adds the centre, then the
    neighbours at distance 1, 2, ... before (above, left) and after (below, right); the sums are divided by the
    window's rows, then its columns (the order fixes the bits). The loops run along the rows (they vectorise)."""
    H, W = a.shape
    row = np.empty(W)
    for y in range(H):
        o = out[y]
        o[:] = a[y]
        for d in range(1, radius + 1):
            if y - d >= 0:
                o += a[y - d]
            if y + d < H:
                o += a[y + d]
        row[:] = o
        for d in range(1, min(radius, W - 1) + 1):
            for x in range(d, W):
                o[x] += row[x - d]
            for x in range(W - d):
                o[x] += row[x + d]
        rows = min(y + radius + 1, H) - max(y - radius, 0)
        for x in range(W):
            o[x] = o[x] / rows / (min(x + radius + 1, W) - max(x - radius, 0))


def max_filter(a, radius):
    """Maximum of ``a`` (H, W) over the (2 radius + 1)^2 box around each pixel (the box clipped at the border):
    along the columns, then along the rows (a box's maximum is the maximum of its rows' maxima); a fresh array."""
    a = np.ascontiguousarray(a, dtype=np.float64)
    out = np.empty_like(a)
    _max_filter(a, int(radius), out)
    return out


@_jit
def _max_filter(a, radius, out):
    H, W = a.shape
    row = np.empty(W)
    for y in range(H):
        o = out[y]
        o[:] = a[y]
        for yy in range(max(y - radius, 0), min(y + radius + 1, H)):
            np.maximum(o, a[yy], o)
        row[:] = o
        for d in range(1, min(radius, W - 1) + 1):
            for x in range(d, W):
                o[x] = max(o[x], row[x - d])
            for x in range(W - d):
                o[x] = max(o[x], row[x + d])


#: a scalar helper of the map loops (inlined into them)
_inline = numba.njit(cache=True, nogil=True, error_model="numpy", forceinline=True)


@_inline
def fill_at(share, have, room, lam):
    """What one pixel takes at level ``lam`` of :func:`water_fill`: ``clip(lam share - have, 0, room)``."""
    return min(max(share * lam - have, 0.0), room)


@_jit
def fill_level(share, have, room, lam, out):
    """:func:`fill_at` of every pixel into ``out``: what every pixel takes to reach ``lam`` times its share, capped
    by its room (one level of :func:`water_fill`); returns ``out``."""
    for i in range(share.shape[0]):
        out[i] = fill_at(share[i], have[i], room[i], lam)
    return out


@_jit
def fill_sum(share, have, room, lam, stride):
    """The sum of :func:`fill_level` at ``lam`` over every ``stride``-th pixel, without the map."""
    s = 0.0
    for i in range(0, share.shape[0], stride):
        s += fill_at(share[i], have[i], room[i], lam)
    return s


@_jit
def full_level(share, have, room):
    """The smallest level of :func:`fill_level` at which every pixel with a share is at its cap."""
    top = -np.inf
    for i in range(share.shape[0]):
        if share[i] > 0.0:
            top = max(top, (have[i] + room[i]) / share[i])
    return top


def water_fill(share, have, room, total):
    """``clip(lam share - have, 0, room)`` (the samples that bring every pixel towards ``lam share`` samples, capped by
    its ``room``) with ``lam`` such that they add up to ``total`` (to 0.5 %; all the room if that is less). Every
    pixel below its cap is filled to the same ``lam``: the pixels that need more than their cap do not starve the
    others, as rescaling only the uncapped pixels did (0 for all of them once the capped ones took the total).

    The sum is piecewise linear and increasing in ``lam``: regula falsi with the Illinois rule (on the diffuse bench
    scene's passes ~7 evaluations where bisection took ~21; 13-23 on random shares)."""
    share, have, room = (np.ascontiguousarray(x, dtype=np.float64) for x in (share, have, room))
    out = np.empty_like(share)
    _water_fill(share, have, room, float(total), out)
    return out


@_jit
def _water_fill(share, have, room, total, out):
    if room.sum() <= total:
        out[:] = room
        return
    lo, hi = 0.0, full_level(share, have, room)
    f_lo, f_hi = fill_sum(share, have, room, lo, 1) - total, fill_sum(share, have, room, hi, 1) - total
    side = 0
    lam = lo
    for _ in range(60):
        lam = hi - f_hi * (hi - lo) / (f_hi - f_lo) if f_hi != f_lo else 0.5 * (lo + hi)
        if not lo < lam < hi:
            lam = 0.5 * (lo + hi)
        got = fill_sum(share, have, room, lam, 1) - total
        if abs(got) <= 0.005 * total:
            break
        if got < 0.0:
            lo, f_lo = lam, got
            if side < 0:
                f_hi *= 0.5
            side = -1
        else:
            hi, f_hi = lam, got
            if side > 0:
                f_lo *= 0.5
            side = 1
    fill_level(share, have, room, lam, out)


kernel_cache.restore()
