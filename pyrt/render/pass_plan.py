"""The adaptive passes' arithmetic between two passes (:mod:`pyrt.render.adaptive`, whose module notes give the
method): each pixel's estimated error from the half-buffers, the image's estimate with its neighbourhood floor, the
allocation of a pass's samples over the pixels and the size of the next pass: compiled loops over the film's
per-pixel arrays (H*W,), as in :mod:`pyrt.render.image_maps`; no rendering."""
from __future__ import annotations

import math

import numpy as np

from pyrt.core.metrics import RELMSE_EPS
from pyrt.integrators import kernel_cache

kernel_cache.use_cache_dir()      # before the decorators below run

from pyrt.render import image_maps as IM  # noqa: E402
from pyrt.render.image_maps import _jit, box_smooth  # noqa: E402

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


def error_maps(film, half, shape, rows=None, err=None):
    """What the passes read after a pass, in one compiled call: ``(err, box, floored, est)``, the
    :func:`pixel_errors` (with ``rows`` and ``err``: those of the pixels the last pass rendered, written into
    ``err``), their :func:`smoothed_errors`, :func:`floored_errors` and :func:`estimated_error` (the same values as
    those functions, tested)."""
    n = film.weight.shape[0]
    if rows is None:
        err, rows = np.empty(n), np.arange(n)
    box, a, ok = np.empty(n), np.empty(n), np.empty(n, dtype=np.bool_)
    est = _error_maps(film.weight, half.weight, film.sum, half.sum, np.asarray(rows, dtype=np.int64), err,
                      RELMSE_EPS, shape[0], shape[1], SMOOTH_RADIUS, NEIGHBOURHOOD, box, a, ok)
    return err, box, (a, ok), est


@_jit
def _error_maps(w, wb, sums, sums_b, rows, err, eps, H, W, radius, floor, box, a, ok):
    _pixel_errors(w, wb, sums, sums_b, rows, err, eps)
    _per_sample(err, w, a)
    IM._box_smooth(a.reshape((H, W)), radius, box.reshape((H, W)))
    _floored(err, w, box, floor, a, ok)
    return _mean_over(a, ok, w, None, 1)


def pixel_errors(film, half, rows=None, out=None):
    """Per-pixel estimated relMSE of the film's mean (H*W,) from the half-buffers (``half`` holds half B);
    NaN where a pixel has no sample: :func:`pyrt.core.metrics.relmse_per_pixel` of the variance
    ``(mean_A - mean_B)^2 / 4`` (the same bits, tested). With ``rows`` (the pixels the last pass rendered: only theirs
    changed) those alone, written into ``out`` (the errors before the pass) and returned."""
    if rows is None:
        out, rows = np.empty(film.weight.shape[0]), np.arange(film.weight.shape[0])
    _pixel_errors(film.weight, half.weight, film.sum, half.sum, np.asarray(rows, dtype=np.int64), out, RELMSE_EPS)
    return out


@_jit
def _pixel_errors(w, wb, sums, sums_b, rows, out, eps):
    for r in range(rows.shape[0]):
        i = rows[r]
        wa = w[i] - wb[i]
        if not (wa > 0.0 and wb[i] > 0.0):
            out[i] = np.nan
            continue
        ia, ib, iw = 1.0 / wa, 1.0 / wb[i], 1.0 / w[i]
        acc = 0.0
        for c in range(sums.shape[1]):
            d = (sums[i, c] - sums_b[i, c]) * ia - sums_b[i, c] * ib       # mean_A - mean_B
            d = d * d * 0.25                                                # the variance of the mean
            m = sums[i, c] * iw                                             # the mean
            acc += d / (m * m + eps)
        out[i] = acc / sums.shape[1]


def floored_errors(film, err, shape, box=None):
    """``(a, ok)``: the per-sample errors ``a_p = max(err_p n_p, NEIGHBOURHOOD box(err n)_p)`` (H*W,) that the
    estimate and the samples a target needs are computed from, and ``ok`` (H*W,) the pixels with an estimate;
    ``box``: :func:`smoothed_errors` of the same arguments if at hand."""
    box = smoothed_errors(film, err, shape) if box is None else box
    a, ok = np.empty_like(box), np.empty(box.shape[0], dtype=np.bool_)
    _floored(err, film.weight, box, NEIGHBOURHOOD, a, ok)
    return a, ok


@_jit
def _floored(err, w, box, floor, a, ok):
    for i in range(err.shape[0]):
        ok[i] = np.isfinite(err[i])
        a[i] = max(err[i] * w[i] if ok[i] else 0.0, floor * box[i])


def smoothed_errors(film, err, shape):
    """``box(err n)`` (H*W,): the per-sample errors ``err_p n_p`` (0 where a pixel has no estimate) averaged over the
    (2 SMOOTH_RADIUS + 1)^2 pixels around (:func:`box_smooth`), what :func:`floored_errors` and :func:`allocate`
    both read."""
    a = np.empty(shape)
    _per_sample(err, film.weight, a.ravel())
    return box_smooth(a, SMOOTH_RADIUS).ravel()


@_jit
def _per_sample(err, w, out):
    for i in range(err.shape[0]):
        out[i] = err[i] * w[i] if np.isfinite(err[i]) else 0.0


def estimated_error(film, err, shape, floored=None):
    """The image's estimated relMSE from the per-pixel estimates ``err`` (:func:`pixel_errors`): the mean over the
    pixels with samples of ``max(a_p, NEIGHBOURHOOD box(a)_p) / n_p``, ``a_p = err_p n_p`` the per-sample error
    and ``box`` its mean over the (2 SMOOTH_RADIUS + 1)^2 pixels around (:func:`box_smooth`, the allocation's
    smoothing): a pixel whose halves agree by chance is counted at 0.6 of its neighbourhood's error
    (:mod:`pyrt.render.adaptive`'s notes, step 2); ``floored``: :func:`floored_errors` of the same arguments if at
    hand. ``inf`` when no pixel has an estimate."""
    a, ok = floored if floored is not None else floored_errors(film, err, shape)
    return _mean_over(a, ok, film.weight, None, 1)


@_jit
def _mean_over(a, ok, w, new, stride):
    """The mean of ``a_p / (w_p + new_p)`` (``new`` None: 0) over every ``stride``-th pixel where ``ok``; inf when
    there is none."""
    s, n = 0.0, 0
    for i in range(0, a.shape[0], stride):
        if ok[i]:
            if new is None:
                s += a[i] / w[i]
            else:
                s += a[i] / (w[i] + new[i])
            n += 1
    return s / n if n else np.inf


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
    share, have, room = (np.ascontiguousarray(x, dtype=np.float64) for x in (share, have, room))
    out = np.empty(share.shape[0], dtype=np.int64)
    _counts(share, have, room, float(total), rng.random(share.shape[0]), out)
    return out


@_jit
def _counts(share, have, room, total, u, out):
    new = np.empty(share.shape[0])
    IM._water_fill(share, have, room, total, new)
    for i in range(new.shape[0]):
        out[i] = int(min(2.0 * math.floor(new[i] / 2.0 + u[i]), 2.0 * math.floor(room[i] / 2.0)))


def allocation_shares(film, err, max_spp, cap, shape, box=None):
    """``(share, room)`` (H*W,) of :func:`allocate`: each pixel's share of a pass (90 % by its dilated ``sqrt(a_p)``,
    10 % uniform) and the samples it may take (``GROWTH x`` its own, ``cap``, ``max_spp``)."""
    a = smoothed_errors(film, err, shape) if box is None else box
    share, room = np.empty_like(a), np.empty_like(a)
    _shares(a, film.weight, shape[0], shape[1], float(max_spp), float(cap), GROWTH, DEFENSIVE, DILATE_RADIUS, share,
            room)
    return share, room


@_jit
def _shares(a, w, H, W, max_spp, cap, growth, defensive, dilate, share, room):
    """:func:`allocation_shares`: ``s = sqrt(max(a, 1e-3 mean(a)))`` (1 everywhere when ``a`` has no error), its
    box maximum, the shares and rooms."""
    mean_a = a.sum() / a.shape[0]
    roots = np.empty(a.shape[0])
    for i in range(a.shape[0]):
        roots[i] = math.sqrt(max(a[i], 1e-3 * mean_a)) if mean_a > 0.0 else 1.0
    s = np.empty(a.shape[0])
    IM._max_filter(roots.reshape((H, W)), dilate, s.reshape((H, W)))
    total = s.sum()
    for i in range(s.shape[0]):
        room[i] = max(min(min(max_spp - w[i], growth * w[i]), cap), 0.0)
        share[i] = (1.0 - defensive) * s[i] / total + defensive / s.shape[0]


def predicted_error(floored, w, new):
    """The estimate :func:`estimated_error` expects after ``new`` (H*W,) more samples if every pixel's per-sample
    error stayed ``a_p`` (``floored``: :func:`floored_errors`): the mean of ``a_p / (n_p + new_p)``."""
    a, ok = floored
    return _mean_over(a, ok, w, np.asarray(new, dtype=np.float64), 1)


def plan_samples(floored, w, share, room, est, target, k, lo, hi):
    """The samples of the next pass, in ``[lo, hi]``: about the fewest whose allocation (:func:`allocation_shares`,
    water filling: every pixel towards ``lam`` times its share, capped by its room) brings the estimate to
    ``PLAN_MARGIN target`` by ``est (p / est)^k``, ``p`` the :func:`predicted_error` of the allocation; ``k`` >= 1
    how much faster than ``1 / n`` the estimate fell in the last pass (a pixel's stratified samples, its
    neighbourhood converging: :mod:`pyrt.render.adaptive`'s notes, step 3). ``lam`` is found by bisection on every
    :data:`PLAN_STRIDE`-th pixel (the sums scaled up). None when ``hi`` samples would not do (the pass is then sized
    as the first one)."""
    a, ok = floored
    if hi <= lo or not ok[::PLAN_STRIDE].any():
        return lo
    goal = est * (PLAN_MARGIN * target / est) ** (1.0 / k)
    got = _plan(a, ok, w, share, room, goal, float(lo), float(hi), PLAN_STRIDE, PLAN_STEPS)
    return None if got < 0.0 else got


@_jit
def _plan(a, ok, w, share, room, goal, lo, hi, stride, steps):
    """:func:`plan_samples`' search up to the level at which every pixel is full: the samples, or -1 for None."""
    top = IM.full_level(share, w, room)
    p_top, n_top = _at(a, ok, w, share, room, top, stride)
    if p_top > goal:
        return -1.0
    if n_top <= lo:
        return lo
    below, above = 0.0, top
    for _ in range(steps):
        mid = 0.5 * (below + above)
        p, n = _at(a, ok, w, share, room, mid, stride)
        if n > hi or p <= goal:
            above = mid
        else:
            below = mid
    p, n = _at(a, ok, w, share, room, above, stride)
    if p > goal:
        return -1.0
    return min(max(n, lo), hi)


@_jit
def _at(a, ok, w, share, room, lam, stride):
    """The predicted estimate and the samples (scaled up by ``stride``) of the water fill at level ``lam`` on every
    ``stride``-th pixel."""
    s, n, total = 0.0, 0, 0.0
    for i in range(0, a.shape[0], stride):
        new = IM.fill_at(share[i], w[i], room[i], lam)
        total += new
        if ok[i]:
            s += a[i] / (w[i] + new)
            n += 1
    return (s / n if n else np.inf), stride * total


kernel_cache.restore()
