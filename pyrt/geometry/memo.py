"""Per-hit values computed once per batch of hits, whichever views of the batch ask for them.

A bounce's shading cuts its :class:`~pyrt.geometry.surface.SurfaceBatch` into many views: the hits of each
material, of each light's samples, of the glossy rays, the hits repeated once per BSDF sample. A texture lookup
at a hit gives the same value on every one of them, so :func:`row_memo` keeps what one view computed on the base
batch, row by row, and the other views gather it (measured on the helmet-like textured model at the previewer's
defaults: 6.6 M texel lookups -> 2.4 M, the render's CPU time x0.90, the pixels bit-identical).
"""
from __future__ import annotations

import numpy as np

from pyrt.geometry.surface import SurfaceBatch, take_view_rows

__all__ = ["row_memo", "rows_cached"]

#: row sets :func:`rows_cached` keeps per key and batch (the views of one bounce's batch ask on few distinct ones:
#: the hits of a material, its lit hits, the glossy ones)
ROWS_CACHE_SETS = 4


def row_memo(ctx, key, compute):
    """``compute(ctx)`` for a per-hit kernel, each hit computed at most once per batch of hits.

    Every view of a :class:`SurfaceBatch` (:meth:`SurfaceBatch.subset`, through any number of views) shares its
    base batch's memo: a dict ``key -> (values, done)`` of per-row results and a mask of the rows computed. A view
    gets the rows already computed gathered, and only the missing ones computed, each once (on the view itself
    when all of its rows are missing and distinct, so that caches kept on the view, e.g. a texture's lookup plan,
    serve the other kernels evaluated on it; otherwise on a view of the missing rows, one view object for all the
    kernels that ask for the same rows). Valid only for kernels whose row ``i`` depends on the hit of row ``i``
    alone and not on fields changed after the batch was built (the texture lookups: UVs and footprints; the
    shading normals that normal maps replace are not read by them). A view whose rows repeat hits (several BSDF
    samples per hit) thus computes each hit once; views cut from one batch in different ways (the hits of a
    material, of a light's samples, of the glossy rays) share what they computed.

    Parameters
    ----------
    ctx : SurfaceBatch or view, or any object with ``n_hits`` (then ``compute(ctx)`` is returned as is)
    key : hashable
        What is computed (the same key must mean the same per-hit function).
    compute : callable
        ``compute(batch) -> (n, ...) ndarray`` for a batch of ``n`` hits.

    Returns
    -------
    ndarray, a new array (callers may change it).
    """
    if not isinstance(ctx, SurfaceBatch):
        return compute(ctx)
    root, rows = ctx.base_rows()
    memo = root.__dict__.setdefault("_row_memo", {})
    entry = memo.get(key)
    n_root = root.n_hits
    if entry is None:
        done = np.zeros(n_root, dtype=bool)
        done[rows] = True
        n = ctx.n_hits
        if isinstance(rows, slice) or np.count_nonzero(done) == n:    # distinct rows: on the view itself
            out = compute(ctx)
            values = np.empty((n_root,) + out.shape[1:], dtype=out.dtype)
            values[rows] = out
            memo[key] = (values, done)
            return out
        missing = np.flatnonzero(done)
        out = compute(_missing_view(ctx, root, missing))
        values = np.empty((n_root,) + out.shape[1:], dtype=out.dtype)
        values[missing] = out
        memo[key] = (values, done)
        return take_view_rows(values, rows)
    values, done = entry
    need = ~done[rows]
    if need.any():
        mark = np.zeros(n_root, dtype=bool)
        if isinstance(rows, slice):
            mark[rows] = need
        else:
            mark[rows[need]] = True
        missing = np.flatnonzero(mark)
        values[missing] = compute(_missing_view(ctx, root, missing))
        done[missing] = True
    out = take_view_rows(values, rows)
    return out.copy() if isinstance(rows, slice) else out


def _missing_view(ctx, root, missing):
    """The view of ``root``'s rows ``missing`` that ``ctx`` computes on: the same view object for every kernel that
    ``ctx`` needs on the same missing rows (kept on ``ctx``), so that what those kernels cache on their batch (the
    trilinear plan that a material's same-sized maps share) is shared as it is on ``ctx`` itself."""
    cached = ctx.__dict__.get("_memo_missing")
    if cached is not None and cached[0].shape == missing.shape and np.array_equal(cached[0], missing):
        return cached[1]
    view = root.subset(missing)
    ctx.__dict__["_memo_missing"] = (missing, view)
    return view


def rows_cached(ctx, key, compute):
    """``compute(ctx)`` once per batch of hits and set of rows: every view of one :class:`SurfaceBatch` on the same
    rows (in the same order) gets the object the first one computed.

    For whole-batch structures that depend on the rows' hits only, not on the view object: a texture's trilinear
    plan (:meth:`pyrt.textures.ImageTexture.evaluate`), shared by the same-sized maps a material reads. A
    bounce's shading asks for them on several view objects of the same rows (the emission at a material's hits,
    its glossy alpha, its BSDF at the lit hits); kept per view, the helmet-like model of
    ``tools/make_textured_model.py`` computed 614 trilinear plans, 357 on distinct row sets. At most
    :data:`ROWS_CACHE_SETS` row sets are kept per key (the oldest is dropped).

    ``ctx`` that is not a :class:`SurfaceBatch` (any object with a ``__dict__``): cached on the object itself.
    """
    if not isinstance(ctx, SurfaceBatch):
        cache = ctx.__dict__.setdefault("_rows_cache", {})
        if key not in cache:
            cache[key] = compute(ctx)
        return cache[key]
    root, rows = ctx.base_rows()
    entries = root.__dict__.setdefault("_rows_cache", {}).setdefault(key, [])
    for seen, value in entries:
        if _same_rows(seen, rows):
            return value
    value = compute(ctx)
    entries.append((rows, value))
    if len(entries) > ROWS_CACHE_SETS:
        del entries[0]
    return value


def _same_rows(a, b):
    """Whether two row selections of one batch (slices of step 1, or index arrays) are the same rows in order."""
    if a is b:
        return True
    if isinstance(a, slice) or isinstance(b, slice):
        if isinstance(a, slice) and isinstance(b, slice):
            return (a.start, a.stop) == (b.start, b.stop)
        s, arr = (a, b) if isinstance(a, slice) else (b, a)
        n = s.stop - s.start
        return arr.shape == (n,) and (n == 0 or (arr[0] == s.start and arr[-1] == s.stop - 1
                                                 and bool(np.all(np.diff(arr) == 1))))
    return a.shape == b.shape and bool(np.array_equal(a, b))
