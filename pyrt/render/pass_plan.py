"""The adaptive passes' arithmetic between two passes (:mod:`pyrt.render.adaptive`, whose module notes give the
method): each pixel's estimated error from the half-buffers, the image's estimate with its neighbourhood floor, the
allocation of a pass's samples over the pixels and the size of the next pass. NumPy over the film's per-pixel arrays
(H*W,); no rendering."""
from __future__ import annotations

import math

import numpy as np

from pyrt.core.metrics import relmse_per_pixel
from pyrt.render.image_maps import box_smooth, fill_level, full_level, max_filter, water_fill

#: a pass gives a pixel at most this many times the samples it has
GROWTH = 3
#: half-width in pixels of the box the per-pixel error is smoothed over
SMOOTH_RADIUS = 2
#: share of every pass spread uniformly over the pixels: a pixel whose two halves agree by chance (error
#: estimate 0: frequent where the integrand takes few values) still gets samples, so every pixel converges
DEFENSIVE = 0.1
#: a pass with a target adds at least this share of the samples so far (each pass costs a few ms of its own: at
#: 0.05 the renders of tools/adaptive_chart.py's scenes ended in 9-13 passes of a few percent each)
MIN_GROWTH = 0.25
#: from the second pass after the base on, a pass with a target is sized to bring the estimate to this fraction of
#: the target (:func:`plan_samples`), ...
PLAN_MARGIN = 0.85
#: ... and adds at least this share of the samples so far
PLAN_MIN = 0.05
#: :func:`plan_samples` predicts on every this-many-th pixel, in this many bisection steps of the fill level
PLAN_STRIDE = 3
PLAN_STEPS = 16
#: the largest fall power :func:`plan_samples` takes from a pass (the estimate fell as the predicted error to it)
MAX_FALL_POWER = 1.3
#: the allocation gives a pixel at least the share of the neighbour with the most error within this many pixels (a
#: max filter of ``sqrt(a_p)``): an edge pixel whose halves agreed by chance gets its detected neighbours' samples,
#: and is found at the next pass (:mod:`pyrt.render.adaptive`'s notes, step 3)
DILATE_RADIUS = 1
#: :func:`estimated_error` counts a pixel at least at this fraction of its neighbourhood's mean per-sample error
#: (:mod:`pyrt.render.adaptive`'s notes, step 2: chosen from true / estimated relMSE on the benchmark scenes and the
#: edge test scene)
NEIGHBOURHOOD = 0.6


def pixel_errors(film, half, rows=None, out=None):
    """Per-pixel estimated relMSE of the film's mean (H*W,) from the half-buffers (``half`` holds half B);
    NaN where a pixel has no sample: :func:`pyrt.core.metrics.relmse_per_pixel` of the variance
    ``(mean_A - mean_B)^2 / 4``, computed on every pixel at once (masked rows cost more than the arithmetic), the
    variance and the mean a channel at a time into two channel-major buffers ((N, 3) by (N, 1) broadcasts run three
    elements at a time, and every fresh (N, 3) temporary page-faults: 1.5 -> 1.0-1.1 ms on 320 x 240). With ``rows``
    (the pixels the last pass rendered: only theirs changed) those alone, written into ``out`` (the errors before the
    pass) and returned: the same values (tested), 0.2-0.9 ms a pass where the whole map took 1-5.7."""
    if rows is not None:
        out[rows] = _pixel_errors(film.weight[rows], half.weight[rows], film.sum[rows], half.sum[rows])
        return out
    return _pixel_errors(film.weight, half.weight, film.sum, half.sum)


def _pixel_errors(w, wb, sums, sums_b):
    wa = w - wb
    ok = (wa > 0) & (wb > 0)
    if not ok.any():
        return np.full(w.shape[0], np.nan)
    with np.errstate(divide="ignore", invalid="ignore"):
        ia, ib, iw = 1.0 / wa, 1.0 / wb, 1.0 / w
        var, mean = np.empty(sums.shape[::-1]).T, np.empty(sums.shape[::-1]).T     # channel-major
        for c in range(sums.shape[1]):
            s, sb, d, m = sums[:, c], sums_b[:, c], var[:, c], mean[:, c]
            np.subtract(s, sb, out=d)
            d *= ia                                     # mean_A
            np.multiply(sb, ib, out=m)
            d -= m                                      # - mean_B
            d *= d
            d *= 0.25                                   # the variance of the mean
            np.multiply(s, iw, out=m)                   # the mean
        err = relmse_per_pixel(var, mean)
    err[~ok] = np.nan
    return err


def floored_errors(film, err, shape, box=None):
    """``(a, ok)``: the per-sample errors ``a_p = max(err_p n_p, NEIGHBOURHOOD box(err n)_p)`` (H*W,) that the
    estimate and the samples a target needs are computed from, and ``ok`` (H*W,) the pixels with an estimate;
    ``box``: :func:`smoothed_errors` of the same arguments if at hand."""
    ok = np.isfinite(err)
    a = np.where(ok, err, 0.0) * film.weight
    box = smoothed_errors(film, err, shape) if box is None else box
    return np.maximum(a, NEIGHBOURHOOD * box), ok


def smoothed_errors(film, err, shape):
    """``box(err n)`` (H*W,): the per-sample errors ``err_p n_p`` (0 where a pixel has no estimate) averaged over the
    (2 SMOOTH_RADIUS + 1)^2 pixels around (:func:`box_smooth`), what :func:`floored_errors` and :func:`allocate`
    both read."""
    a = np.where(np.isfinite(err), err, 0.0) * film.weight
    return box_smooth(a.reshape(shape), SMOOTH_RADIUS).ravel()


def estimated_error(film, err, shape, floored=None):
    """The image's estimated relMSE from the per-pixel estimates ``err`` (:func:`pixel_errors`): the mean over the
    pixels with samples of ``max(a_p, NEIGHBOURHOOD box(a)_p) / n_p``, ``a_p = err_p n_p`` the per-sample error
    and ``box`` its mean over the (2 SMOOTH_RADIUS + 1)^2 pixels around (:func:`box_smooth`, the allocation's
    smoothing): a pixel whose halves agree by chance is counted at 0.6 of its neighbourhood's error
    (:mod:`pyrt.render.adaptive`'s notes, step 2); ``floored``: :func:`floored_errors` of the same arguments if at
    hand. ``inf`` when no pixel has an estimate."""
    a, ok = floored if floored is not None else floored_errors(film, err, shape)
    if not ok.any():
        return math.inf
    return float(np.mean(a[ok] / film.weight[ok]))


def allocate(film, err, total_new, max_spp, cap, rng, shape, box=None):
    """New samples per pixel (even ints, (H*W,)) for a pass of about ``total_new`` samples: towards
    ``n_p`` proportional to ``sqrt(a_p)`` (``a_p = err_p n_p`` smoothed, then the largest ``sqrt(a)`` of the
    3 x 3 pixels around: :data:`DILATE_RADIUS`), at most ``GROWTH x`` a pixel's
    samples, ``cap`` per pass and ``max_spp`` in all; randomised rounding to even counts from ``rng``. ``box``:
    :func:`smoothed_errors` of ``film`` and ``err`` if at hand."""
    share, room = allocation_shares(film, err, max_spp, cap, shape, box)
    return pass_counts(share, room, film.weight, total_new, rng)


def pass_counts(share, room, have, total, rng):
    """The pass's new samples per pixel (even ints) for about ``total`` samples over the shares and rooms of
    :func:`allocation_shares`: water filling (:func:`pyrt.render.image_maps.water_fill`), then a randomised rounding
    to even counts from ``rng``, within each room."""
    new = water_fill(share, have, room, total)
    even = 2 * np.floor(new / 2 + rng.random(new.shape[0]))
    return np.minimum(even, 2 * np.floor(room / 2)).astype(np.int64)


def allocation_shares(film, err, max_spp, cap, shape, box=None):
    """``(share, room)`` (H*W,) of :func:`allocate`: each pixel's share of a pass (90 % by its dilated ``sqrt(a_p)``,
    10 % uniform) and the samples it may take (``GROWTH x`` its own, ``cap``, ``max_spp``)."""
    w = film.weight
    a = smoothed_errors(film, err, shape) if box is None else box
    mean_a = a.mean()
    if not mean_a > 0:                        # no error anywhere: spread uniformly
        a = np.ones_like(a)
    else:
        a = np.maximum(a, 1e-3 * mean_a)
    s = np.sqrt(a)
    s = max_filter(s.reshape(shape), DILATE_RADIUS).ravel()
    room = np.minimum(np.minimum(max_spp - w, GROWTH * w), cap)
    room = np.maximum(room, 0.0)
    share = (1.0 - DEFENSIVE) * s / s.sum() + DEFENSIVE / s.shape[0]
    return share, room


def predicted_error(floored, w, new):
    """The estimate :func:`estimated_error` expects after ``new`` (H*W,) more samples if every pixel's per-sample
    error stayed ``a_p`` (``floored``: :func:`floored_errors`): the mean of ``a_p / (n_p + new_p)``."""
    a, ok = floored
    return float(np.mean(a[ok] / (w[ok] + new[ok])))


def plan_samples(floored, w, share, room, est, target, k, lo, hi):
    """The samples of the next pass, in ``[lo, hi]``: about the fewest whose allocation (:func:`allocation_shares`,
    water filling: every pixel towards ``lam`` times its share, capped by its room) brings the estimate to
    ``PLAN_MARGIN target`` by ``est (p / est)^k``, ``p`` the :func:`predicted_error` of the allocation; ``k`` >= 1
    how much faster than ``1 / n`` the estimate fell in the last pass (a pixel's stratified samples, its
    neighbourhood converging: :mod:`pyrt.render.adaptive`'s notes, step 3). ``lam`` is found by bisection on every
    :data:`PLAN_STRIDE`-th pixel (the sums scaled up). None when ``hi`` samples would not do (the pass is then sized
    as the first one)."""
    goal = est * (PLAN_MARGIN * target / est) ** (1.0 / k)
    a, ok = floored
    sl = slice(None, None, PLAN_STRIDE)
    a, ok, w, share, room = a[sl], ok[sl], w[sl], share[sl], room[sl]
    scale = PLAN_STRIDE * 1.0
    buf = np.empty_like(share)

    def at(lam):        # (predicted estimate, samples) of the allocation at level lam
        fill_level(share, w, room, lam, buf)
        return predicted_error((a, ok), w, buf), scale * float(buf.sum())

    if not ok.any() or hi <= lo:
        return lo
    top = full_level(share, w, room)
    p_top, n_top = at(top)
    if p_top > goal or n_top <= lo:
        return None if p_top > goal else lo
    below, above = 0.0, top
    for _ in range(PLAN_STEPS):
        mid = 0.5 * (below + above)
        p, n = at(mid)
        if n > hi or p <= goal:
            above = mid
        else:
            below = mid
    p, n = at(above)
    if p > goal:
        return None
    return min(max(n, lo), hi)
