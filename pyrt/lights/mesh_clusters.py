"""The ``selection="oriented"`` triangle choice of :class:`pyrt.lights.mesh.EmissiveMeshLight`: clusters of
emitter triangles chosen per shading point, then a triangle inside the cluster by power.

``selection="power"`` chooses a triangle with pmf proportional to its power ``area x emission bound``
wherever the shading point is (pbrt-v4's ``PowerLightSampler``). On models whose emitters are one-sided solids
(glTF ``doubleSided`` false cubes) half of those samples reach a back face and emit nothing toward the point,
and distant emitters get as many samples as near ones. ``"oriented"`` groups the light's triangles into at most
:data:`MAX_CLUSTERS` clusters — the triangles of one mesh with one face normal (the faces of a cube, a panel),
or one cluster per mesh when there are more such groups, or a single cluster — and chooses cluster ``k`` at a
point ``p`` with probability proportional to

    ``P_k / max(|p - c_k|^2, r_k^2)``, and 0 when ``p`` lies behind a planar cluster whose triangles emit nothing
    from their backs (``n_k . p <= min_y n_k . y`` over its vertices),

``P_k`` the cluster's power, ``c_k`` and ``r_k`` the centre and radius of a sphere around its vertices (a
simplified form of pbrt-v4's ``BVHLightSampler`` importance, without the normal cone of curved clusters and the
receiver's cosine, which the light interface does not see). Inside the cluster a triangle is chosen by power,
as with ``"power"``. The probability of a triangle is ``P(k | p) x P_j / P_k``; it is positive wherever the
triangle can send light to ``p`` (a back-face cut only removes triangles that are zero there), so the estimate
is unbiased, and the same density is what :meth:`EmissiveMeshLight.pdf_hit` gives glossy rays for MIS.
"""
from __future__ import annotations

import numpy as np

from pyrt.shaders.vec import dot, take_rows

#: at most this many clusters (the per-point probabilities are an (N, K) array)
MAX_CLUSTERS = 64


class ClusterChoice:
    """Clusters of a light's triangles and the per-point choice of one (module docstring).

    Parameters
    ----------
    vertices : (V, 3) float64 ndarray
    faces : (F, 3) int64 ndarray
    face_normals : (F, 3) float64 ndarray
        Unit winding normals.
    tri_mesh : (F,) int64 ndarray
        The mesh of each triangle.
    weight : (F,) float64 ndarray
        Power of each triangle (area x emission bound); triangles of weight 0 are in no cluster.
    one_sided : (F,) bool ndarray
        True where the triangle emits nothing from its back (at its probe points).
    """

    def __init__(self, vertices, faces, face_normals, tri_mesh, weight, one_sided):
        n_f = weight.size
        live = np.flatnonzero(weight > 0)
        groups = np.column_stack([tri_mesh[live], np.round(take_rows(face_normals, live) * 2.0 ** 20)])
        _, inv = np.unique(groups, axis=0, return_inverse=True)
        inv = np.asarray(inv).reshape(-1)
        planar = True
        if live.size and inv.max() + 1 > MAX_CLUSTERS:      # too many planes: one cluster per mesh, or one
            _, inv = np.unique(tri_mesh[live], return_inverse=True)
            inv = np.asarray(inv).reshape(-1)
            planar = False
            if inv.max() + 1 > MAX_CLUSTERS:
                inv = np.zeros(live.size, dtype=np.int64)
        k_n = int(inv.max()) + 1 if live.size else 0
        sort = np.argsort(inv, kind="stable")
        #: (L,) light triangles ordered by cluster; (K,) first row of each cluster in that order
        self.order = live[sort]
        cl = inv[sort]
        self.start = np.searchsorted(cl, np.arange(k_n))
        self.end = np.append(self.start[1:], cl.size)
        #: (K,) cluster power
        self.power = np.bincount(inv, weights=weight[live], minlength=k_n)
        #: (F,) each triangle's probability inside its cluster; its cluster (-1: none)
        self.pmf_in = np.zeros(n_f)
        self.pmf_in[live] = weight[live] / self.power[inv]
        self.tri_cluster = np.full(n_f, -1, dtype=np.int64)
        self.tri_cluster[live] = inv
        c = np.cumsum(self.pmf_in[self.order])
        base = np.concatenate([[0.0], c])[self.start]
        #: cluster index + cumulative probability inside it (increasing over the ordered triangles)
        self.seg = cl + (c - np.repeat(base, self.end - self.start))
        self.seg[self.end - 1] = np.arange(k_n) + 1.0
        self.center = np.zeros((k_n, 3))
        self.radius2 = np.zeros(k_n)
        self.normal = np.zeros((k_n, 3))
        self.offset = np.zeros(k_n)
        #: (K,) planar clusters that emit nothing from their back: no samples from points behind them
        self.cut = np.zeros(k_n, dtype=bool)
        for k in range(k_n):
            tris = self.order[self.start[k]:self.end[k]]
            vs = take_rows(vertices, faces[tris].reshape(-1))
            lo, hi = vs.min(axis=0), vs.max(axis=0)
            self.center[k] = 0.5 * (lo + hi)
            self.radius2[k] = float(np.max(dot(vs - self.center[k], vs - self.center[k])))
            if planar:
                self.normal[k] = face_normals[tris[0]]
                self.offset[k] = float(np.min(vs @ self.normal[k]))
                self.cut[k] = bool(np.all(one_sided[tris]))
        self.any_cut = bool(self.cut.any())
        self._cc = dot(self.center, self.center)
        self._m2c = np.ascontiguousarray(-2.0 * self.center.T)
        self._nT = np.ascontiguousarray(np.where(self.cut[:, None], self.normal, 0.0).T)
        self._cut_offset = np.where(self.cut, self.offset, -np.inf)

    @property
    def clusters(self):
        """Number of clusters."""
        return int(self.power.size)

    def probabilities(self, p):
        """(N, K) probability of each cluster at the points ``p`` (N, 3); rows of zeros where no cluster can light
        the point. (Whole-array operations in place on one (N, K) array: this runs once per light sample and
        batch.)"""
        imp = _rows_times(p, self._m2c)                      # |p - c|^2 = |p|^2 - 2 p.c + |c|^2
        imp += self._cc
        imp += dot(p, p)[:, None]
        np.maximum(imp, self.radius2, out=imp)
        np.divide(self.power, imp, out=imp)
        if self.any_cut:    # n.p - min n.y > 0: in front of the cluster (offset -inf: clusters never cut)
            side = _rows_times(p, self._nT)
            side -= self._cut_offset
            np.multiply(imp, side > 0, out=imp)
        tot = imp.sum(axis=1)
        inv = np.divide(1.0, tot, out=np.zeros_like(tot), where=tot > 0)
        imp *= inv[:, None]
        return imp

    def choose(self, p, u0):
        """Light triangles (N,) for the points ``p`` and the random numbers ``u0`` (N,), the number re-used inside
        the triangle (N,) in [0, 1], and each triangle's probability ``P(k | p) P_j / P_k`` (N,) (0: none)."""
        n = p.shape[0]
        rows = np.arange(n)
        probs = self.probabilities(p)
        cdf = np.cumsum(probs, axis=1)
        k = np.minimum(np.sum(u0[:, None] >= cdf, axis=1), self.clusters - 1)
        pk = probs[rows, k]
        r = np.clip(np.divide(u0 - (cdf[rows, k] - pk), pk, out=np.zeros(n), where=pk > 0), 0.0, 1.0)
        j = np.clip(np.searchsorted(self.seg, k + r, side="right"), self.start[k], self.end[k] - 1)
        tri = self.order[j]
        pin = self.pmf_in[tri]
        lo = np.where(j > self.start[k], self.seg[np.maximum(j - 1, 0)], k)
        r2 = np.clip(np.divide(k + r - lo, pin, out=np.zeros(n), where=pin > 0), 0.0, 1.0)
        return tri, r2, pk * pin

    def triangle_probability(self, p, tri):
        """(N,) probability of light triangle ``tri`` (N,) at the points ``p`` (N, 3)."""
        k = np.take(self.tri_cluster, tri)
        probs = self.probabilities(p)
        return np.where(k >= 0, probs[np.arange(tri.size), np.maximum(k, 0)] * np.take(self.pmf_in, tri), 0.0)

    def triangle_probabilities(self, p, tris):
        """(N, T) probability of each light triangle ``tris`` (T,) at each point ``p`` (N, 3)."""
        k = np.take(self.tri_cluster, tris)
        probs = self.probabilities(p)
        return np.where(k[None, :] >= 0, probs[:, np.maximum(k, 0)] * np.take(self.pmf_in, tris)[None, :], 0.0)


def _rows_times(p, m):
    """``p @ m`` for (N, 3) rows and a (3, K) matrix by ``np.einsum`` (its own sum-of-products loop: NumPy's BLAS
    matmul would start threads of its own beside the renderer's, pyrt.core.transforms.apply_matrix measured it).
    N = 131 072, K = 30: 6.0 ms against 25.3 ms for three broadcast column products (20 calls each; the values
    agree to rounding)."""
    return np.einsum("ij,jk->ik", p, m)
