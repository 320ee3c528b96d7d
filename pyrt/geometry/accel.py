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
- Its ``TriangleMesh`` copies vertices and indices element by element through Python indexing (measured
  ~1.1 us per triangle: 5.7 s for 5.24 M triangles). :class:`Accel` hands Embree the arrays instead
  (:class:`_SharedBuffers`: Embree's own ``rtcSetSharedGeometryBuffer``, reached through the binding's
  library with ``ctypes``; no copy at all): the same float32 vertices and uint32 indices, so the same
  BVH and bitwise the same hits (tested against the binding's copy). The binding exposes no handle to its
  Embree scene, so the handle is read from the ``EmbreeScene`` object's C layout, and that reading is
  verified on a probe scene every time (its public ``is_committed`` field found where the layout puts it,
  and a mesh the binding built read back through the handle); if anything does not check out, the
  binding's copy is used (``Accel.buffers`` says which: ``"shared"`` or ``"copy"``).
"""
from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor
import ctypes
from dataclasses import dataclass
import os

import numpy as np
from embreex import mesh_construction, rtcore_scene
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


# Embree 4's constants (embree4/rtcore_common.h, rtcore_buffer.h, rtcore_geometry.h)
_RTC_BUFFER_TYPE_INDEX, _RTC_BUFFER_TYPE_VERTEX = 0, 1
_RTC_FORMAT_UINT3, _RTC_FORMAT_FLOAT3 = 0x5003, 0x9003
_RTC_GEOMETRY_TYPE_TRIANGLE = 0
#: Embree's BVH build qualities (``RTCBuildQuality``), by name
BUILD_QUALITIES = {"low": 0, "medium": 1, "high": 2}


class _SharedBuffers:
    """Embree's C API on the binding's scenes: shared vertex and index buffers, the scene's build quality.

    Reached through the binding's own library (``ctypes.CDLL`` of ``embreex.mesh_construction``: its dependency
    ``libembree4`` provides the ``rtc*`` symbols, whatever the install). :meth:`open` returns None unless the
    scene handle read from an ``EmbreeScene``'s C layout is verified on a probe scene (see the module docstring).
    """

    def __init__(self, lib):
        #: the ``rtc*`` functions used, by name, with their C signatures
        self.fn = {}
        vp, u, i, sz = ctypes.c_void_p, ctypes.c_uint, ctypes.c_int, ctypes.c_size_t
        for name, res, args in (("rtcGetSceneDevice", vp, [vp]), ("rtcReleaseDevice", None, [vp]),
                                ("rtcGetDeviceError", i, [vp]), ("rtcNewGeometry", vp, [vp, i]),
                                ("rtcSetSharedGeometryBuffer", None, [vp, i, u, i, vp, sz, sz, sz]),
                                ("rtcCommitGeometry", None, [vp]), ("rtcAttachGeometry", u, [vp, vp]),
                                ("rtcReleaseGeometry", None, [vp]), ("rtcGetGeometry", vp, [vp, u]),
                                ("rtcGetGeometryBufferData", vp, [vp, i, u]), ("rtcSetSceneBuildQuality", None, [vp, i]),
                                ("rtcSetGeometryBuildQuality", None, [vp, i])):
            fn = lib[name]
            fn.restype, fn.argtypes = res, args
            self.fn[name] = fn

    @classmethod
    def open(cls):
        """The API, or None if the library, a symbol or the verified scene handle is not available."""
        try:
            api = cls(ctypes.CDLL(mesh_construction.__file__))
        except (OSError, AttributeError):      # no loadable library, or a symbol missing (an older Embree)
            return None
        probe = rtcore_scene.EmbreeScene()
        v = np.array([[0.5, 0, 0], [1, 0.25, 0], [0, 1, 0.125]], dtype=np.float32)
        TriangleMesh(probe, v, np.array([[0, 1, 2]], dtype=np.int32))    # the binding's copy, read back below
        handle = api.handle(probe)
        if handle is None:
            return None
        geom = api.fn["rtcGetGeometry"](handle, 0)
        data = api.fn["rtcGetGeometryBufferData"]
        vdata = data(geom, _RTC_BUFFER_TYPE_VERTEX, 0) if geom else None
        idata = data(geom, _RTC_BUFFER_TYPE_INDEX, 0) if geom else None
        if not (vdata and idata):
            return None
        got_v = np.ctypeslib.as_array((ctypes.c_float * 12).from_address(vdata)).reshape(3, 4)[:, :3]
        got_f = np.ctypeslib.as_array((ctypes.c_uint * 3).from_address(idata))
        return api if np.array_equal(got_v, v) and got_f.tolist() == [0, 1, 2] else None

    @staticmethod
    def handle(scene):
        """The ``RTCScene`` of an ``EmbreeScene`` (fields: the object header, ``scene_i``, ``is_committed``,
        ``device``), or None if the object does not have that layout: its size, and its public ``is_committed``
        seen at its offset when set to a marker."""
        head, ptr = object.__basicsize__, ctypes.sizeof(ctypes.c_void_p)
        if type(scene).__basicsize__ != head + 3 * ptr:      # an int padded to a pointer's alignment
            return None
        field = ctypes.c_int.from_address(id(scene) + head + ptr)
        old = scene.is_committed
        scene.is_committed = 0x5A17
        seen = field.value
        scene.is_committed = old
        return ctypes.c_void_p.from_address(id(scene) + head).value if seen == 0x5A17 else None

    def attach(self, handle, v4, faces, nf, quality="medium"):
        """Attach a triangle mesh reading ``v4`` ((V, 4) float32: x, y, z, pad) and the first ``nf`` rows of
        ``faces`` ((nf + 1, 3) uint32: one row of padding, as Embree may read 16 bytes at a time), built at
        ``quality`` (a :data:`BUILD_QUALITIES` name); returns its geometry id, or None (nothing attached) if
        Embree reports an error. The arrays must outlive the scene."""
        fn = self.fn
        dev = fn["rtcGetSceneDevice"](handle)
        try:
            fn["rtcGetDeviceError"](dev)                      # clear an earlier error (it reports the last one)
            geom = fn["rtcNewGeometry"](dev, _RTC_GEOMETRY_TYPE_TRIANGLE)
            if not geom:
                return None
            fn["rtcSetSharedGeometryBuffer"](geom, _RTC_BUFFER_TYPE_VERTEX, 0, _RTC_FORMAT_FLOAT3, v4.ctypes.data,
                                             0, 16, v4.shape[0])
            fn["rtcSetSharedGeometryBuffer"](geom, _RTC_BUFFER_TYPE_INDEX, 0, _RTC_FORMAT_UINT3, faces.ctypes.data,
                                             0, 12, nf)
            if quality != "medium":
                fn["rtcSetGeometryBuildQuality"](geom, BUILD_QUALITIES[quality])
            fn["rtcCommitGeometry"](geom)
            gid = fn["rtcAttachGeometry"](handle, geom) if fn["rtcGetDeviceError"](dev) == 0 else None
            fn["rtcReleaseGeometry"](geom)                   # the scene holds it now (or nobody: freed)
            return gid
        finally:
            fn["rtcReleaseDevice"](dev)                      # rtcGetSceneDevice took a reference

    def set_build_quality(self, handle, quality):
        """Set the scene's BVH build quality (a :data:`BUILD_QUALITIES` name) before its commit (a triangle mesh
        is built at its own geometry's quality as well: :meth:`attach` sets that; measured, the scene's alone
        changes nothing on one big mesh)."""
        self.fn["rtcSetSceneBuildQuality"](handle, BUILD_QUALITIES[quality])


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
    buffers : {"shared", "copy"}
        How meshes reach Embree. "shared" (default): Embree reads the arrays :meth:`add_mesh` makes (no copy;
        the same geometry, see the module docstring), or the binding's copy where that is not available;
        "copy": always the binding's element-by-element copy. :attr:`buffers` says what was used.
    build_quality : {"medium", "low", "high"}
        Embree's BVH build quality, of the scene and of every mesh (``rtcSetSceneBuildQuality``,
        ``rtcSetGeometryBuildQuality``; Embree's default is "medium"). "low" builds faster and traces slower;
        it needs the shared path's scene handle (ignored, and :attr:`build_quality` is "medium", when the
        binding's copy is used).
    """

    def __init__(self, *, threads=None, buffers="shared", build_quality="medium"):
        self.threads = (os.cpu_count() or 1) if threads is None else checks.integer("render", "threads", threads,
                                                                                    RenderError)
        if buffers not in ("shared", "copy"):
            raise RenderError(f"Accel: buffers must be 'shared' or 'copy', got {buffers!r}")
        if build_quality not in BUILD_QUALITIES:
            raise RenderError(f"Accel: build_quality must be one of {sorted(BUILD_QUALITIES)}, got {build_quality!r}")
        self._scene = rtcore_scene.EmbreeScene()
        api = _SharedBuffers.open() if buffers == "shared" else None
        self._handle = None if api is None else api.handle(self._scene)
        self._api = api if self._handle is not None else None
        #: "shared" (Embree reads pyrt's arrays) or "copy" (the binding copied them)
        self.buffers = "shared" if self._api is not None else "copy"
        #: the BVH build quality applied at :meth:`commit`
        self.build_quality = build_quality if self._api is not None else "medium"
        self._meshes = []  # keep the float32 arrays alive (Embree reads the shared ones)
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
        gid = None
        if self._api is not None:
            v4 = np.zeros((v.shape[0], 4), dtype=np.float32)
            v4[:, :3] = v
            f3 = np.zeros((f.shape[0] + 1, 3), dtype=np.uint32)
            f3[:-1] = f
            gid = self._api.attach(self._handle, v4, f3, f.shape[0], self.build_quality)
            if gid is not None and gid != len(self._meshes):
                raise RuntimeError(f"Accel: Embree gave mesh {len(self._meshes)} the geometry id {gid}")
            v, f = v4, f3
        if gid is None:
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
            if self._api is not None and self.build_quality != "medium":
                self._api.set_build_quality(self._handle, self.build_quality)
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

    def single_threaded(self):
        """Answer every batch on the calling thread from now on: what a forked worker process does with an
        accelerator it inherited (the parent's thread pool has no threads in the child)."""
        self.threads = 1
        self._pool = None

    def close(self):
        if self._pool is not None:
            self._pool.shutdown()
            self._pool = None
