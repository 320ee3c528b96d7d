"""The sampling tables of the compiled environment light: searches of a :class:`pyrt.shaders.distribution.
Distribution2D` packed into a flat float64 array (:mod:`pyrt.lights.compiled_env`'s data), for nopython code.

Every function is ``numba.extending.register_jitable`` (callable from nopython code and from plain Python).
:func:`sample_cells` gives the cells and in-cell offsets of :func:`pyrt.shaders.distribution.
distribution2d_sample_cells` for one ``u``: the same comparisons as its search, so the same cells. Each CDF row is
searched from a guide table (Chen & Asau's cut points, :func:`guide_table`): the bucket of ``u`` bounds the cell
between two entries, a few cells apart, so a search reads one guide entry and one or two cache lines of the row
instead of ~9 dependent entries across the row (the rows and tables of a 512 x 256 map are several MB, mostly
outside the cache).
"""
from __future__ import annotations

import numpy as np
from numba.extending import register_jitable

#: the largest float64 below 1 (``np.nextafter(1, 0)``: the samplers' in-cell offsets are clipped to it)
BELOW_ONE = 1.0 - 2.0 ** -53


@register_jitable
def guide_buckets(n):
    """The number of guide-table buckets of a CDF of ``n`` cells: the largest power of two ``g`` with ``4 g <= n``
    (1 for fewer than 8 cells). A power of two, so that a sample's bucket ``u g`` is exact."""
    g = 1
    while 8 * g <= n:
        g *= 2
    return g


def guide_table(cdf, shift):
    """The guide tables (float64, ``(R, G + 1)``, G = :func:`guide_buckets` of the cells) of the CDF rows ``cdf``
    (``(R, n + 1)``), row ``r`` searched with the shift ``shift[r]`` (:func:`_find`): entry ``j`` of a row is
    :func:`_find` of ``u = j / G``, except entry 0 (0) and entry ``G`` (``n - 1``), so that the cell of any ``u`` in
    bucket ``j`` (``j / G <= u < (j + 1) / G``) lies between entries ``j`` and ``j + 1`` (:func:`_find_guided`)."""
    cdf = np.atleast_2d(np.asarray(cdf, dtype=np.float64))
    rows, n = cdf.shape[0], cdf.shape[1] - 1
    g = guide_buckets(n)
    shift = np.broadcast_to(np.asarray(shift, dtype=np.float64), (rows,))
    out = np.empty((rows, g + 1))
    keys = np.arange(g) / g
    for r in range(rows):
        # the largest k whose cdf[k] + shift <= u + shift, by the kernel's float64 sums (0 where none is)
        k = np.searchsorted(cdf[r, :n] + shift[r], keys + shift[r], side="right") - 1
        out[r, :g] = np.maximum(k, 0)
    out[:, 0] = 0.0
    out[:, g] = n - 1
    return out


@register_jitable
def _find(data, o, n, shift, u):
    """The cell ``k`` in ``[0, n)`` with ``cdf[k] + shift <= u + shift`` largest (0 if none) of the CDF row at
    ``data[o:]`` (``shift``: the row's index, as :func:`pyrt.shaders.distribution._sample_cdf_rows` compares its
    shifted CDF)."""
    key = u + shift
    if not data[o] + shift <= key:
        return 0
    return _bisect(data, o, shift, key, 0, n - 1)


@register_jitable
def _bisect(data, o, shift, key, lo, hi):
    """The largest ``k`` in ``[lo, hi]`` with ``data[o + k] + shift <= key``, given that ``lo`` has it."""
    while lo < hi:
        mid = (lo + hi + 1) >> 1
        if data[o + mid] + shift <= key:
            lo = mid
        else:
            hi = mid - 1
    return lo


@register_jitable
def _find_guided(data, o, n, shift, u, og, g):
    """:func:`_find` (the same cell for every ``u``) searched between the entries of the guide table at
    ``data[og:]`` (``g`` buckets, :func:`guide_table`) for ``u``'s bucket: ~2 steps in one cache line instead of a
    search of the whole row."""
    key = u + shift
    j = min(max(int(u * g), 0), g - 1)
    lo, hi = int(data[og + j]), int(data[og + j + 1])
    if not data[o + lo] + shift <= key:
        return _find(data, o, n, shift, u)       # (only for a u outside [0, 1) or NaN: the full search decides)
    return _bisect(data, o, shift, key, lo, hi)


@register_jitable
def _offset(data, o, k, u):
    """The offset of ``u`` in cell ``k`` of the CDF row at ``data[o:]``, in ``[0, 1)``."""
    lo = data[o + k]
    width = data[o + k + 1] - lo
    f = 0.0
    if width > 0.0:
        f = (u - lo) / width
    return min(max(f, 0.0), BELOW_ONE)


@register_jitable
def sample_cells(data, o, rows, w, u0, u1):
    """``(row, col, fu, fv)`` of the table at ``data[o:]`` (``rows x w``) for ``u``: the cells and in-cell offsets of
    :func:`pyrt.shaders.distribution.distribution2d_sample_cells` (the row from ``u1`` by the marginal CDF, the
    column from ``u0`` by the row's conditional CDF)."""
    o_cond = o + rows * w
    o_marg = o_cond + rows * (w + 1)
    gc, gm = guide_buckets(w), guide_buckets(rows)
    o_gcond = o_marg + rows + 1
    o_gmarg = o_gcond + rows * (gc + 1)
    row = _find_guided(data, o_marg, rows, 0.0, u1, o_gmarg, gm)
    fv = _offset(data, o_marg, row, u1)
    oc = o_cond + row * (w + 1)
    col = _find_guided(data, oc, w, float(row), u0, o_gcond + row * (gc + 1), gc)
    return row, col, _offset(data, oc, col, u0), fv


@register_jitable(forceinline=True)
def cell_pdf(data, o, integral, w, row, col):
    """``func / integral`` of a cell (1 for an all-zero table): :func:`pyrt.shaders.distribution._cell_pdf`."""
    if integral <= 0.0:
        return 1.0
    return data[o + row * w + col] / integral
