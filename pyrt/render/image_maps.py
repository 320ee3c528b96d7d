"""Whole-image arithmetic of the adaptive passes (:mod:`pyrt.render.adaptive`) on per-pixel maps: box means, box
maxima and the water fill that turns a pass's per-pixel shares into sample counts.

Each runs a few vector operations over the whole map and no fresh temporary per step: on a 320 x 240 film NumPy's
cumulative sums (``add.accumulate``: one element at a time), ``(N, 3)`` by ``(N, 1)`` broadcasts (three elements
at a time) and freshly allocated maps (their pages faulted in on first touch) cost more than the arithmetic.
"""
from __future__ import annotations

import numpy as np


def box_smooth(a, radius):
    """Mean of ``a`` (H, W) over the (2 radius + 1)^2 box around each pixel (the box clipped at the border): window
    sums along the rows, then along the columns (:func:`_window_sums`), over the boxes' pixel counts."""
    H, W = a.shape
    s = _window_sums(_window_sums(np.asarray(a, dtype=np.float64), radius, 0), radius, 1)
    s /= _window_counts(H, radius)[:, None]
    s /= _window_counts(W, radius)[None, :]
    return s


def _window_sums(a, radius, axis):
    """Sums of ``a`` (H, W) over the windows ``[i - radius, i + radius]`` (clipped) along ``axis``: ``a`` plus its
    shifts by 1 .. ``radius`` either way, added slice by slice (2 radius vector additions, ~0.016 ms each on a
    320 x 240 map; a cumulative sum along the rows, NumPy's ``add.accumulate``, runs one element at a time: 0.57 ms.
    The box mean of a 2-D cumulative sum's corners gathered by index arrays took 1.3 ms, this one 0.46)."""
    out = np.array(a, dtype=np.float64)
    n = out.shape[axis]
    for d in range(1, min(radius, n - 1) + 1):
        lo, hi = [slice(None)] * 2, [slice(None)] * 2
        lo[axis], hi[axis] = slice(0, n - d), slice(d, n)
        lo, hi = tuple(lo), tuple(hi)
        out[hi] += a[lo]
        out[lo] += a[hi]
    return out


def _window_counts(n, radius):
    """The number of indices in each clipped window ``[i - radius, i + radius]`` of ``range(n)``."""
    i = np.arange(n)
    return (np.minimum(i + radius + 1, n) - np.maximum(i - radius, 0)).astype(np.float64)


def max_filter(a, radius):
    """Maximum of ``a`` (H, W) over the (2 radius + 1)^2 box around each pixel (the box clipped at the border):
    along the rows, then along the columns (a box's maximum is the maximum of its rows' maxima: the same values as
    the (2 radius + 1)^2 shifts, in 4 radius)."""
    out = a
    for axis in (0, 1):
        src, out = out, out.copy()
        n = src.shape[axis]
        for d in range(1, radius + 1):
            if d >= n:
                break
            a_lo, a_hi = [slice(None)] * 2, [slice(None)] * 2
            a_lo[axis], a_hi[axis] = slice(0, n - d), slice(d, n)
            a_lo, a_hi = tuple(a_lo), tuple(a_hi)
            np.maximum(out[a_hi], src[a_lo], out=out[a_hi])
            np.maximum(out[a_lo], src[a_hi], out=out[a_lo])
    return out if out is not a else a.copy()


def fill_level(share, have, room, lam, out):
    """``clip(lam share - have, 0, room)`` into ``out``: what every pixel takes to reach ``lam`` times its share,
    capped by its room (one level of :func:`water_fill`); returns ``out``."""
    np.multiply(share, lam, out=out)
    np.subtract(out, have, out=out)
    np.clip(out, 0.0, room, out=out)
    return out


def full_level(share, have, room):
    """The smallest level of :func:`fill_level` at which every pixel with a share is at its cap."""
    ok = share > 0
    return float(np.max((have[ok] + room[ok]) / share[ok]))


def water_fill(share, have, room, total):
    """``clip(lam share - have, 0, room)`` (the samples that bring every pixel towards ``lam share`` samples, capped by
    its ``room``) with ``lam`` such that they add up to ``total`` (to 0.5 %; all the room if that is less). Every
    pixel below its cap is filled to the same ``lam``: the pixels that need more than their cap do not starve the
    others, as rescaling only the uncapped pixels did (0 for all of them once the capped ones took the total).

    The sum is piecewise linear and increasing in ``lam``: regula falsi with the Illinois rule (on the diffuse bench
    scene's passes ~7 evaluations where bisection took ~21; 13-23 on random shares), each evaluated in one buffer
    (fresh temporaries page-faulted: 0.6 ms an evaluation on a 320 x 240 film against 0.1)."""
    if room.sum() <= total:
        return room.copy()
    buf = np.empty_like(share, dtype=np.float64)

    def excess(lam):
        return float(fill_level(share, have, room, lam, buf).sum()) - total

    lo, hi = 0.0, full_level(share, have, room)
    f_lo, f_hi = excess(lo), excess(hi)
    side = 0
    for _ in range(60):
        lam = hi - f_hi * (hi - lo) / (f_hi - f_lo) if f_hi != f_lo else 0.5 * (lo + hi)
        if not lo < lam < hi:
            lam = 0.5 * (lo + hi)
        got = excess(lam)
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
    return buf
