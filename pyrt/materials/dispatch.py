"""Per-material-type dispatch of a batch of hits: one kernel call per material type on its hits.

:class:`BSDFBatch` is what the integrators' estimators query (``f_cos``, ``sample``, ``pdf`` in world
space at a subset of hits); it groups the hits by material once per bounce. Isotropic materials
(:class:`pyrt.materials.IsotropicMaterial`) are evaluated from world-space cosines on the queried lanes,
the others in their local frame.
"""
from __future__ import annotations

import numpy as np

from pyrt.materials.base import CosineQuery, IsotropicMaterial
from pyrt.shaders.vec import dot, put_rows, take_rows


class _Group:
    """The hits of one material inside a :class:`BSDFBatch` (lazy local ``wo`` and ``n.wo``)."""

    __slots__ = ("idx", "ctx", "_wo_l", "_cos_o")

    def __init__(self, idx, ctx):
        self.idx, self.ctx, self._wo_l, self._cos_o = idx, ctx, None, None

    @property
    def wo_l(self):
        if self._wo_l is None:
            self._wo_l = self.ctx.to_local(self.ctx.wo)
        return self._wo_l

    @property
    def cos_o(self):
        if self._cos_o is None:
            self._cos_o = self._wo_l[:, 2] if self._wo_l is not None else dot(self.ctx.wo, self.ctx.ns)
        return self._cos_o


class BSDFBatch:
    """The BSDFs of all hits of a :class:`SurfaceBatch`, dispatched per material type.

    Each material's hits form a persistent group context (built once per bounce), so texture lookups
    cached by :meth:`pyrt.materials.Material.param` are shared by all lights. Materials with the
    isotropic fast path (``f_cos_cosines``) are evaluated on the queried lanes from world-space
    cosines; for the others a query on most of a group evaluates the whole group in its local frame
    (inactive lanes are computed and discarded, cheaper than gathering every field) and a query on a
    small part of it gathers a lazy subset instead.
    """

    #: below this fraction of a group's hits, a query gathers a subset instead of evaluating the group
    GATHER_FRACTION = 0.35

    def __init__(self, surf, materials):
        self.surf = surf
        self.materials = materials
        self.mat_id = mat_id = surf.material_id
        self.groups = {}
        self.cosine_path = {}
        counts = np.bincount(mat_id)
        present = np.flatnonzero(counts)
        # Hits sorted by material (the integrator orders them so): each group is a contiguous range and a
        # query's sorted hit indices split into groups by two binary searches, no per-query partitioning.
        self.contiguous = mat_id.size < 2 or not np.any(mat_id[1:] < mat_id[:-1])
        self.pos = None if self.contiguous else np.zeros(mat_id.size, dtype=np.int64)  # position inside the group
        starts = np.concatenate([[0], np.cumsum(counts[present])]) if self.contiguous else None
        for j, k in enumerate(present):
            if self.contiguous:     # the group's fields are views of the batch's (no gathers)
                idx_k = np.arange(starts[j], starts[j + 1])
                ctx_k = surf.subset(slice(int(starts[j]), int(starts[j + 1])))
            else:
                idx_k = np.flatnonzero(mat_id == k)
                self.pos[idx_k] = np.arange(idx_k.size)
                ctx_k = surf.subset(idx_k)
            self.groups[int(k)] = _Group(idx_k, ctx_k)
            self.cosine_path[int(k)] = isinstance(materials[k], IsotropicMaterial)
        self.bounds = starts

    def _groups(self, idx):
        """Yield ``(material, sel, p, group)``: ``sel`` (slice or index array) picks the query entries of the
        group, ``p`` their positions inside it."""
        if self.contiguous and (idx.size < 2 or not np.any(idx[1:] <= idx[:-1])):   # strictly increasing
            b = np.searchsorted(idx, self.bounds)
            for j, (k, grp) in enumerate(self.groups.items()):
                lo, hi = int(b[j]), int(b[j + 1])
                if hi > lo:
                    yield k, slice(lo, hi), idx[lo:hi] - self.bounds[j], grp
            return
        pos = self.pos if self.pos is not None else self._positions()
        mids = self.mat_id[idx]
        for k in np.flatnonzero(np.bincount(mids)):
            sel = np.flatnonzero(mids == k)
            yield int(k), sel, pos[idx[sel]], self.groups[int(k)]

    def _positions(self):
        pos = np.zeros(self.mat_id.size, dtype=np.int64)
        for grp in self.groups.values():
            pos[grp.idx] = np.arange(grp.idx.size)
        self.pos = pos
        return pos

    @staticmethod
    def _take(a, sel, n):
        """``a[sel]`` for a slice (a view) or an index array (a gather; ``a`` itself if it selects all ``n``)."""
        if isinstance(sel, slice):
            return a[sel]
        return a if sel.size == n else take_rows(a, sel)

    def f_cos(self, idx, wi):
        """BSDF * cos(theta_i) at hits ``idx`` for world directions ``wi`` (k, 3)."""
        out = None
        for k, sel, p, grp in self._groups(idx):
            mat, ctx, n_k = self.materials[k], grp.ctx, grp.idx.size
            wi_s = self._take(wi, sel, idx.size)
            if self.cosine_path[k]:
                # all lanes, in order (p strictly increasing: always on the contiguous path)
                full = p.size == n_k and (isinstance(sel, slice) or not np.any(p[1:] <= p[:-1]))
                ns = ctx.ns if full else take_rows(ctx.ns, p)
                cos_o = grp.cos_o if full else np.take(grp.cos_o, p)
                val = mat.f_cos_cosines(CosineQuery(ctx, None if full else p, wi_s, dot(wi_s, ns), cos_o))
            elif p.size >= self.GATHER_FRACTION * n_k:
                w_full = ctx.ns.copy()          # harmless direction for lanes not queried
                put_rows(w_full, p, wi_s)
                val = take_rows(mat.f_cos(grp.wo_l, ctx.to_local(w_full), ctx), p)
            else:
                sub = ctx.subset(p)
                val = mat.f_cos(take_rows(grp.wo_l, p), sub.to_local(wi_s), sub)
            if p.size == idx.size:
                return np.asarray(val, dtype=np.float64)
            if out is None:
                out = np.zeros((idx.shape[0], 3))
            if isinstance(sel, slice):
                out[sel] = val
            else:
                put_rows(out, sel, val)
        return out if out is not None else np.zeros((idx.shape[0], 3))

    def sample(self, idx, u):
        """Sample the non-delta lobes at hits ``idx``: world ``wi``, weight f_cos/pdf, pdf."""
        wi = np.zeros((idx.shape[0], 3))
        weight = np.zeros((idx.shape[0], 3))
        pdf = np.zeros(idx.shape[0])
        for k, sel, p, grp in self._groups(idx):
            sub = grp.ctx.subset(p)
            w, wt, pd = self.materials[k].sample(grp.wo_l[p], u[sel], sub)
            wi[sel], weight[sel], pdf[sel] = sub.to_world(w), wt, pd
        return wi, weight, pdf

    def pdf(self, idx, wi):
        """Solid-angle density (k,) of :meth:`sample` at hits ``idx`` for world directions ``wi`` (k, 3)."""
        out = np.zeros(idx.shape[0])
        for k, sel, p, grp in self._groups(idx):
            sub = grp.ctx.subset(p)
            out[sel] = self.materials[k].pdf(grp.wo_l[p], sub.to_local(wi[sel]), sub)
        return out
