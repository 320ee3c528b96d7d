"""Piecewise-constant 2D distributions over a grid of weights (the importance-sampling tables).

Rows are sampled from the marginal CDF, then a column from the row's conditional CDF (pbrt-v4
``PiecewiseConstant2D``). Tables are float64: a float32 CDF over a 2048 x 1024 map is wrong by up to
100 % per texel. Used by the lat-long and cube-map environments (:mod:`.envmap`).
"""
from typing import NamedTuple

import numpy as np


class Distribution2D(NamedTuple):
    """Piecewise-constant density on ``[0, 1)^2`` with ``H x W`` cells (row j <-> v, column i <-> u).

    Attributes (all float64)
    ------------------------
    func : (H, W)  non-negative cell weights (as given)
    cdf_cond : (H, W + 1)  per-row conditional CDFs (uniform for rows of zero weight)
    cdf_marg : (H + 1,)  marginal CDF over rows (uniform if every weight is zero)
    integral : float  mean weight ``sum(func) / (H W)``; 0 means "uniform fallback"
    cdf_shifted : (H (W + 1),)  ``cdf_cond`` row r plus r, flattened: one monotone array in which every lane's
        column is found (:func:`distribution2d_sample`); built once with the table
    guide_cond, guide_marg : (H, G) and (1, G) int32  guide tables of the conditional and marginal CDFs
        (:func:`_guide`): where the search for a ``u`` in ``[j / G, (j + 1) / G)`` starts; built with the table
    """

    func: np.ndarray
    cdf_cond: np.ndarray
    cdf_marg: np.ndarray
    integral: float
    cdf_shifted: np.ndarray | None = None
    guide_cond: np.ndarray | None = None
    guide_marg: np.ndarray | None = None


def _cdf(w, axis):
    """Normalised CDF along the last axis with a leading 0; uniform where the total is 0."""
    n = w.shape[-1]
    c = np.concatenate([np.zeros(w.shape[:-1] + (1,)), np.cumsum(w, axis=-1)], axis=-1)
    tot = c[..., -1:]
    uniform = np.broadcast_to(np.arange(n + 1) / n, c.shape)
    out = np.where(tot > 0, c / np.where(tot > 0, tot, 1.0), uniform)
    out[..., -1] = 1.0
    return out


def distribution2d_build(weights):
    """Build a :class:`Distribution2D` from non-negative cell weights ``(H, W)`` (float64 throughout).

    Raises ``ValueError`` for negative or non-finite weights. An all-zero table becomes the
    uniform density (``integral == 0`` flags it).
    """
    f = np.asarray(weights, dtype=np.float64)
    if f.ndim != 2 or f.size == 0:
        raise ValueError(f"weights must be a non-empty (H, W) array, got shape {f.shape}")
    if not np.all(np.isfinite(f)) or np.any(f < 0):
        raise ValueError("weights must be finite and >= 0")
    cdf_cond = _cdf(f, -1)
    cdf_marg = _cdf(f.sum(axis=1), -1)
    return Distribution2D(f, cdf_cond, cdf_marg, float(f.mean()), _shifted(cdf_cond), _guide(cdf_cond),
                          _guide(cdf_marg[None, :]))


def _shifted(cdf):
    """Row r of ``cdf`` (R, K) plus r, flattened: a global monotone array (values of row r in [r, r + 1]; float64
    keeps ~1e-13 accuracy)."""
    return (cdf + np.arange(cdf.shape[0])[:, None]).ravel()


#: linear steps from a guide-table entry before the lanes still moving are searched (:func:`_sample_cdf_rows`)
_GUIDE_STEPS = 2


def _guide(cdf):
    """Guide table (Chen & Asau 1974's cutpoints) of the CDF rows ``cdf`` (R, K + 1): ``(R, K)`` int32, entry
    ``(r, j)`` the last cell of row ``r`` that starts at or below ``j / K`` (the number of CDF values
    ``cdf[r, :K] <= j / K``, less one), counted in one pass. A search for a ``u`` in bucket ``j`` starts there
    (:func:`_sample_cdf_rows`, which corrects a start that rounding put one cell too far): any start gives the
    same cells, a good one only makes the search short."""
    n_rows, width = cdf.shape
    g = width - 1
    first = np.clip(np.ceil(cdf[:, :g] * g), 0, g).astype(np.int64)    # the first bucket each cell starts in
    counts = np.bincount((np.arange(n_rows)[:, None] * (g + 1) + first).ravel(), minlength=n_rows * (g + 1))
    k = np.cumsum(counts.reshape(n_rows, g + 1)[:, :g], axis=1) - 1
    return np.clip(k, 0, g - 1).astype(np.int32)


def _sample_cdf_rows(cdf, rows, u, shifted=None, guide=None):
    """For each lane, the cell index k with ``cdf[row, k] <= u < cdf[row, k+1]`` and the offset in the cell
    (``shifted``: :func:`_shifted` of ``cdf``, ``guide``: its :func:`_guide`, if at hand).

    The cell is the largest ``k < K`` whose shifted CDF value ``cdf[row, k] + row`` is at most ``u + row`` (the
    same comparisons as a binary search of the shifted array, whose rows are one monotone sequence): from the
    guide table's entry for ``u``'s bucket the lanes step on while the next value is still at most theirs (0-2
    steps for most: a bucket holds ~1 cell on average, and a bright cell that holds many buckets is reached at
    once); the few still moving after :data:`_GUIDE_STEPS` (a bucket of many dim cells) are binary-searched.
    About 2x faster than sorting the keys for one search, and the same cells."""
    n_cells = cdf.shape[1] - 1
    if shifted is None:
        shifted = _shifted(cdf)
    if guide is None:
        guide = _guide(cdf)
    key = u + rows
    width = n_cells + 1
    j = np.minimum((u * n_cells).astype(np.int64), n_cells - 1)
    k = guide[rows, j].astype(np.int64)
    base = rows * width
    # u * G rounded up to the next integer (u just below a bucket's edge) starts a cell too far: step back
    back = np.flatnonzero(np.take(shifted, base + k) > key)
    while back.size:
        k[back] -= 1
        back = back[(k[back] > 0) & (np.take(shifted, np.take(base, back) + np.take(k, back)) > np.take(key, back))]
    move = np.flatnonzero(k < n_cells - 1)
    for _ in range(_GUIDE_STEPS):
        if not move.size:
            break
        km = k[move]
        step = np.take(shifted, np.take(base, move) + km + 1) <= np.take(key, move)
        move = move[step]
        k[move] = km[step] + 1
        move = move[k[move] < n_cells - 1]
    if move.size:   # buckets of many cells (dim ones after a bright cell): the binary search for the few left
        pos = np.searchsorted(shifted, np.take(key, move), side="right") - 1
        k[move] = np.clip(pos - np.take(base, move), 0, n_cells - 1)
    # skip zero-width cells at the top end (u exactly at a CDF plateau)
    lo = cdf[rows, k]
    hi = cdf[rows, k + 1]
    width = hi - lo
    frac = np.divide(u - lo, width, out=np.zeros_like(u), where=width > 0)
    return k, np.clip(frac, 0.0, np.nextafter(1.0, 0.0))


def distribution2d_sample_cells(dist, u):
    """The cells and in-cell offsets :func:`distribution2d_sample` draws for ``u`` (N, 2): ``(row, col, fu, fv, p)``,
    int64 row and column, the offsets in [0, 1) along u and v (uniform within the cell, from ``u`` as there) and
    the density ``p`` (N,) with respect to area in ``[0, 1)^2`` (``func / integral``; 1 for the uniform fallback)."""
    u = np.asarray(u, dtype=np.float64)
    zeros = np.zeros(u.shape[0], dtype=np.int64)
    row, fv = _sample_cdf_rows(dist.cdf_marg[None, :], zeros, u[:, 1], dist.cdf_marg, dist.guide_marg)
    col, fu = _sample_cdf_rows(dist.cdf_cond, row, u[:, 0], dist.cdf_shifted, dist.guide_cond)
    return row, col, fu, fv, _cell_pdf(dist, row, col)


def distribution2d_sample(dist, u):
    """Sample ``(u, v)`` in ``[0, 1)^2`` from ``dist`` with random numbers ``u`` (N, 2).

    ``u[:, 1]`` picks the row (v) from the marginal, ``u[:, 0]`` the column (u) from the row's
    conditional, so stratifying ``u[:, 1]`` stratifies latitude.

    Returns
    -------
    uv : (N, 2) float64
    pdf : (N,) float64
        Density with respect to area in ``[0, 1)^2`` (``func / integral``; 1 for the uniform fallback).
    """
    h, w = dist.func.shape
    row, col, fu, fv, p = distribution2d_sample_cells(dist, u)
    uv = np.stack([(col + fu) / w, (row + fv) / h], axis=1)
    return uv, p


def _cell_pdf(dist, row, col):
    if dist.integral <= 0:
        return np.ones(row.shape[0])
    return dist.func[row, col] / dist.integral


def distribution2d_pdf(dist, uv):
    """Density of :func:`distribution2d_sample` at ``uv`` (N, 2) (area measure on ``[0, 1)^2``)."""
    uv = np.asarray(uv, dtype=np.float64)
    h, w = dist.func.shape
    col = np.clip(np.floor(uv[:, 0] * w).astype(np.int64), 0, w - 1)
    row = np.clip(np.floor(uv[:, 1] * h).astype(np.int64), 0, h - 1)
    return _cell_pdf(dist, row, col)


def compensated_weights(func, measure):
    """MIS-compensated cell weights ``max(0, func - m * measure)`` (H, W) float64 (Karlik et al. 2019).

    ``func`` (H, W) are the weights of an importance table proportional to ``luminance * measure``, where
    ``measure`` (broadcastable to (H, W)) is each cell's solid-angle weight (``sin theta`` of a lat-long row,
    the Jacobian of a cube texel). ``m = sum(func) / sum(measure)`` is then the luminance averaged over the
    sphere, and the result is the table of ``max(0, luminance - m) * measure``: sampling it leaves the part of
    the map below its mean to BSDF sampling. Valid only in a multiple-importance-sampling combination with
    a strategy that covers every direction where the result is 0 (pbrt-v4's ``allowIncompletePDF``).
    All zero for a constant map.
    """
    f = np.asarray(func, dtype=np.float64)
    a = np.broadcast_to(np.asarray(measure, dtype=np.float64), f.shape)
    total = a.sum()
    m = f.sum() / total if total > 0 else 0.0
    return np.maximum(f - m * a, 0.0)
