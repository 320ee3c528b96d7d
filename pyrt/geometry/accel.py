"""Embree acceleration structure: the only module of pyrt that imports ``embreex``.

:class:`Accel` builds one Embree scene from all meshes (geometry id -> mesh index) and answers
batched closest-hit (:meth:`Accel.intersect`) and any-hit (:meth:`Accel.occluded`) queries.

The binding's sharp edges, and how they are guarded here
--------------------------------------------------------
- It does no bounds checking and silently refuses float64: every array handed to it is built here,
  float32, C-contiguous, with the shape checked.
- It writes ``dists`` in place: we always pass our own copy, never a caller's array.
- On a miss ``tfar`` keeps its input (1e37 by default): misses are masked (``geom_id == -1``,
  ``t = inf``) before anyone computes ``o + t d``.
- Geometry added after the first query is silently ignored: :meth:`Accel.add_mesh` raises after
  :meth:`Accel.commit`.
- tnear is fixed at 0: callers offset ray origins themselves (see :mod:`pyrt.geometry.offsets`).
- Each ``run`` is a single-threaded loop that releases the GIL, so large batches are split into
  chunks run on a thread pool (``threads`` workers, default: all cores).
"""
from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
import os

import numpy as np
from embreex import rtcore_scene
from embreex.mesh_construction import TriangleMesh

from pyrt.core import checks
from pyrt.core.errors import RenderError
from pyrt.shaders.vec import converted, to_float32

#: Larger batches are split over threads; below this a single call is cheaper.
_CHUNK = 65536
#: ``tmax`` values at or above this are "unbounded" (Embree's own default is 1e37; float32 max ~3.4e38).
T_INFINITE = np.float32(1e37)


@dataclass
class Hits:
    """Closest-hit results for a batch of N rays.

    Attributes
    ----------
    hit : (N,) bool
    t : (N,) float64
        Distance along the ray in units of |d| (``inf`` on a miss).
    mesh_id, prim_id : (N,) int64
        Mesh index (order of :meth:`Accel.add_mesh`) and triangle index; -1 on a miss.
    u, v : (N,) float64
        Barycentrics: hit = (1-u-v) v0 + u v1 + v v2 (0 on a miss).
    ng : (N, 3) float64
        Unnormalised geometric normal, (v1-v0) x (v2-v0) orientation (zero on a miss).
    """

    hit: np.ndarray
    t: np.ndarray
    mesh_id: np.ndarray
    prim_id: np.ndarray
    u: np.ndarray
    v: np.ndarray
    ng: np.ndarray


def _as_rays(origins, dirs, tmax):
    origins = np.asarray(origins)
    dirs = np.asarray(dirs)
    if origins.ndim != 2 or origins.shape[1] != 3:
        raise ValueError(f"origins must have shape (N, 3), got {origins.shape}")
    if dirs.shape != origins.shape:
        raise ValueError(f"dirs must have the same shape as origins {origins.shape}, got {dirs.shape}")
    n = origins.shape[0]
    o = to_float32(origins)
    d = to_float32(dirs)
    if tmax is None:
        tm = np.full(n, T_INFINITE, dtype=np.float32)
    else:
        tm = np.asarray(tmax, dtype=np.float64)
        if tm.ndim == 0:
            tm = np.full(n, tm)
        if tm.shape != (n,):
            raise ValueError(f"tmax must be a scalar or have shape ({n},), got {tm.shape}")
        # always a fresh array: the binding writes it in place
        tm = to_float32(np.minimum(tm, T_INFINITE))
    if not (_all_finite(o) and _all_finite(d)):
        raise ValueError("ray origins and directions must be finite")
    return o, d, tm


def _all_finite(a):
    """True when every element of ``a`` is finite: one sum (NaN/Inf propagate; it releases the GIL, unlike a
    float64-accumulating sum of float32 data), and the exact elementwise test only if the sum overflowed."""
    with np.errstate(over="ignore", invalid="ignore"):
        return bool(np.isfinite(a.sum())) or bool(np.isfinite(a).all())


class Accel:
    """One Embree scene over all meshes.

    Parameters
    ----------
    threads : int, optional
        Worker threads for large batches (default: ``os.cpu_count()``).
    """

    def __init__(self, *, threads=None):
        self.threads = (os.cpu_count() or 1) if threads is None else checks.integer("render", "threads", threads,
                                                                                    RenderError)
        self._scene = rtcore_scene.EmbreeScene()
        self._meshes = []  # keep the float32 arrays alive
        self._committed = False
        self._pool = None

    @property
    def n_meshes(self):
        return len(self._meshes)

    def add_mesh(self, vertices, faces):
        """Add an indexed triangle mesh; returns its mesh id (0, 1, ...).

        ``vertices`` (V, 3) finite floats, ``faces`` (F, 3) ints in [0, V). Raises after :meth:`commit`.
        """
        if self._committed:
            raise RuntimeError("Accel: cannot add geometry after the scene is committed (first query)")
        v = np.ascontiguousarray(vertices, dtype=np.float32)
        f = np.ascontiguousarray(faces, dtype=np.int32)
        if v.ndim != 2 or v.shape[1] != 3:
            raise ValueError(f"vertices must have shape (V, 3), got {v.shape}")
        if f.ndim != 2 or f.shape[1] != 3 or f.shape[0] == 0:
            raise ValueError(f"faces must have shape (F, 3) with F > 0, got {f.shape}")
        if not np.all(np.isfinite(v)):
            raise ValueError("vertices must be finite")
        if f.min() < 0 or f.max() >= v.shape[0]:
            raise ValueError("face indices out of range of the vertex array")
        TriangleMesh(self._scene, v, f)
        self._meshes.append((v, f))
        return len(self._meshes) - 1

    def commit(self):
        """Freeze the geometry and build Embree's BVH now (done implicitly by the first query).

        The binding builds the BVH at its first ``run``; one occlusion ray is traced here so that the build
        happens (and can be timed: :attr:`pyrt.PreparedScene.timings` ``"bvh"``) before any render.
        """
        if not self._meshes:
            raise RuntimeError("Accel: the scene has no geometry")
        if not self._committed:
            self._committed = True
            self._scene.run(np.zeros((1, 3), dtype=np.float32), np.array([[0.0, 0.0, 1.0]], dtype=np.float32),
                            dists=np.full(1, T_INFINITE, dtype=np.float32), query="OCCLUDED")

    # -- threading ---------------------------------------------------------------------------
    def _map(self, fn, n):
        """Run ``fn(lo, hi)`` over [0, n) in chunks, on the pool when worthwhile."""
        if n <= _CHUNK or self.threads == 1:
            fn(0, n)
            return
        bounds = [(lo, min(lo + _CHUNK, n)) for lo in range(0, n, _CHUNK)]
        if self._pool is None:
            self._pool = ThreadPoolExecutor(max_workers=self.threads)
        for fut in [self._pool.submit(fn, lo, hi) for lo, hi in bounds]:
            fut.result()

    def intersect(self, origins, dirs, tmax=None):
        """Closest hit for each ray; see :class:`Hits`. ``t`` is in units of |dir|."""
        if not self._committed:
            self.commit()
        o, d, tm = _as_rays(origins, dirs, tmax)
        n = o.shape[0]
        geom = np.full(n, -1, dtype=np.int64)
        prim = np.full(n, -1, dtype=np.int64)
        u = np.zeros(n)
        v = np.zeros(n)
        t = np.full(n, np.inf)
        ng = np.zeros((n, 3))

        def run(lo, hi):
            dists = tm[lo:hi].copy()
            res = self._scene.run(o[lo:hi], d[lo:hi], dists=dists, query="INTERSECT", output=True)
            g = np.asarray(res["geomID"])
            hit = g >= 0
            geom[lo:hi] = g
            prim[lo:hi] = np.where(hit, res["primID"], -1)
            u[lo:hi] = np.where(hit, res["u"], 0.0)
            v[lo:hi] = np.where(hit, res["v"], 0.0)
            t[lo:hi] = np.where(hit, res["tfar"], np.inf)
            ng[lo:hi] = np.where(hit[:, None], res["Ng"], 0.0)

        if n:
            self._map(run, n)
        return Hits(hit=geom >= 0, t=t, mesh_id=geom, prim_id=prim, u=u, v=v, ng=ng)

    def intersect_hits(self, origins, dirs, tmax=None):
        """Closest hits of only the rays that hit: ``(idx, hits)``, ``hits`` restricted to the rays ``idx``.

        Same values as ``intersect(...)`` restricted to ``idx = flatnonzero(hit)``, without building and
        masking the full-size arrays first (what a renderer needs: misses are just the other rays).
        """
        if not self._committed:
            self.commit()
        o, d, tm = _as_rays(origins, dirs, tmax)
        n = o.shape[0]
        parts = {}

        def run(lo, hi):
            dists = tm[lo:hi].copy()
            res = self._scene.run(o[lo:hi], d[lo:hi], dists=dists, query="INTERSECT", output=True)
            k = np.flatnonzero(np.asarray(res["geomID"]) >= 0)
            parts[lo] = (k + lo, {f: np.take(res[f], k, axis=0) for f in ("geomID", "primID", "u", "v", "tfar", "Ng")})

        if n:
            self._map(run, n)
        order = sorted(parts)
        if len(order) == 1:
            idx, r = parts[order[0]]
        else:
            idx = np.concatenate([parts[lo][0] for lo in order]) if order else np.zeros(0, dtype=np.int64)
            r = {f: np.concatenate([parts[lo][1][f] for lo in order]) for f in ("geomID", "primID", "u", "v", "tfar", "Ng")} \
                if order else {f: np.zeros((0, 3) if f == "Ng" else 0, np.float32) for f in ("geomID", "primID", "u", "v", "tfar", "Ng")}
        f64, i64 = np.float64, np.int64
        return idx, Hits(hit=np.ones(idx.size, dtype=bool), t=converted(r["tfar"], f64),
                         mesh_id=converted(r["geomID"], i64), prim_id=converted(r["primID"], i64),
                         u=converted(r["u"], f64), v=converted(r["v"], f64), ng=converted(r["Ng"], f64))

    def occluded(self, origins, dirs, tmax=None):
        """True where something blocks the ray within (0, tmax) (units of |dir|)."""
        if not self._committed:
            self.commit()
        o, d, tm = _as_rays(origins, dirs, tmax)
        n = o.shape[0]
        out = np.zeros(n, dtype=bool)

        def run(lo, hi):
            dists = tm[lo:hi].copy()
            res = self._scene.run(o[lo:hi], d[lo:hi], dists=dists, query="OCCLUDED")
            out[lo:hi] = np.asarray(res) == 0

        if n:
            self._map(run, n)
        return out

    def replay(self, query, origins32, dirs32, tmax32):
        """Run the binding alone on prepared float32 rays (benchmarks: "Embree-only" time).

        Same chunking and thread pool as :meth:`intersect` / :meth:`occluded`, no post-processing.
        ``query`` is "intersect" or "occluded"; arrays must already be float32 and C-contiguous.
        """
        if not self._committed:
            self.commit()
        n = origins32.shape[0]
        q = "INTERSECT" if query == "intersect" else "OCCLUDED"

        def run(lo, hi):
            dists = tmax32[lo:hi].copy()
            self._scene.run(origins32[lo:hi], dirs32[lo:hi], dists=dists, query=q, output=(q == "INTERSECT"))

        if n:
            self._map(run, n)

    def close(self):
        if self._pool is not None:
            self._pool.shutdown()
            self._pool = None
