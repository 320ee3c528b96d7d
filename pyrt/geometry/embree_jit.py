"""Embree's ray queries called from Numba ``nopython`` code: single rays and 4/8/16-wide packets, cacheable.

How the calls are made
----------------------
The library is the Embree the ``embreex`` wheel bundles (``libembree4``, version 4.4.0 here), reached the way
:mod:`pyrt.geometry.accel` reaches it: ``ctypes.CDLL`` of the binding's ``mesh_construction`` extension, whose
dependency provides the ``rtc*`` symbols (this module does not import ``embreex``: only accel.py does). At
import, each function used here is registered once with LLVM under its own name
(``llvmlite.binding.add_symbol(name, address)``) and declared to Numba as
``numba.types.ExternalFunction(name, signature)``. Kernels then call the symbol *by name*, resolved when their
machine code is loaded, so they can be cached (``cache=True``; a ctypes function pointer would bake this
process's address into the code). The registration runs when this module is imported: a module whose cached
kernels call these helpers must import it at module level (it then always runs before a kernel is loaded).

Structures (include/embree4/rtcore_ray.h, rtcore_scene.h, rtcore_common.h of Embree 4)
--------------------------------------------------------------------------------------
Fields are 4-byte words; a packet of width N stores field ``f`` of lane ``l`` at word ``f * N + l``
(``RTCRayN_*`` / ``RTCHitN_*`` accessors of rtcore_ray.h), a single ray at word ``f``:

====  ============================================  ====  ========================================
word  RTCRay (``RTC_ALIGN(16)``, 48 B)              word  RTCHit (``RTC_ALIGN(16)``)
====  ============================================  ====  ========================================
0-2   org_x, org_y, org_z (float)                   12-14 Ng_x, Ng_y, Ng_z (float, unnormalised)
3     tnear (float)                                 15-16 u, v (float)
4-6   dir_x, dir_y, dir_z (float)                   17    primID (uint)
7     time (float)                                  18    geomID (uint)
8     tfar (float): the hit distance on a hit       19    instID[RTC_MAX_INSTANCE_LEVEL_COUNT = 1]
9-11  mask, id, flags (uint)                        20    instPrimID[1] (uint): present when built with
                                                          ``RTC_GEOMETRY_INSTANCE_ARRAY``
====  ============================================  ====  ========================================

With instPrimID, ``RTCHit`` is 36 B padded to 48 and ``RTCRayHit`` 96 B; ``RTCRayHit16`` is 21 arrays of 16
(64 B each) = 1344 B. Verified on this library (tests/test_embree_jit.py): a hit writes instID[0] *and*
instPrimID[0] (words 19 and 20, to -1), for a single ray and for a packet lane, so the wheel's Embree is built
with instance arrays and a buffer sized without instPrimID (80 B / 1280 B) would be overrun. Nothing past word
20 is written (checked with markers).
``RTCIntersectArguments`` / ``RTCOccludedArguments`` (x86-64): ``flags`` (``RTCRayQueryFlags``, int32, byte
0), ``feature_mask`` (``RTCFeatureFlags``, int32, byte 4), ``context`` (byte 8), ``filter`` (byte 16),
``intersect`` / ``occluded`` (byte 24), and ``minWidthDistanceFactor`` (float, byte 32) only when
``RTC_MIN_WIDTH``: 64 zeroed bytes are reserved. ``rtcInitIntersectArguments`` sets flags
``RTC_RAY_QUERY_FLAG_INCOHERENT`` (0; ``COHERENT`` is ``1 << 16``), feature_mask ``RTC_FEATURE_FLAG_ALL``
(0xffffffff) and every pointer NULL; a NULL ``context`` (or NULL args) makes Embree use
``rtcInitRayQueryContext``'s default context (kernels/common/rtcore.cpp, ``rtcIntersect1`` ...).

Query contract (rtcIntersect1/rtcOccluded1 docs, checked by tests/test_embree_jit.py): before a query, ``mask``
= 0xffffffff (ray masks are compiled in: ``RTC_DEVICE_PROPERTY_RAY_MASK_SUPPORTED`` = 1), ``flags`` = 0,
``time`` = 0, ``geomID`` = ``instID[0]`` = ``RTC_INVALID_GEOMETRY_ID`` (0xffffffff). A miss leaves tfar, Ng,
u, v, primID unwritten (geomID stays invalid); a blocked ``rtcOccluded*`` sets ``tfar = -inf``. Packets need
the ray data aligned to 4 N bytes (16 wide: 64 B) and ``valid`` (int32 a lane, -1 active, 0 inactive; inactive
lanes are not touched) likewise. NumPy and Numba allocate with 16/32-byte alignment only: the buffers here come
from :func:`aligned_f32`.

Answers (tests/test_embree_jit.py, on an Accel's scene, which embreex makes ``RTC_SCENE_FLAG_ROBUST``)
-----------------------------------------------------------------------------------------------------
:func:`intersect1` / :func:`occluded1` give bit for bit what ``Accel.intersect`` / ``Accel.occluded`` (embreex's
``run``: ``rtcIntersect1`` / ``rtcOccluded1`` with default arguments) give: ids, t, u, v, Ng. Packets give the
same bits with the incoherent flag, and with the coherent flag too except at exact ties: a ray through a shared
vertex or edge may be reported on another of the triangles there (same mesh, same point but for float32
rounding; ~1 % of rays aimed exactly at vertices and edges, no random ray). Occlusion agrees in every mode. A
packet wider than the CPU's native width works (rtcore.cpp traces it ray by ray: the answers of
:func:`intersect1`; checked on devices made with ``isa=sse2`` and ``isa=avx2``), but is no faster.

Using it in a kernel
--------------------
``scene`` is the ``RTCScene`` address as an integer (:func:`scene_handle`); the :class:`~pyrt.geometry.accel.Accel`
must stay alive while kernels use it. Buffers are scratch: one per thread (in a ``prange`` body, allocate one per
chunk of work, not per ray)::

    @numba.njit(nogil=True, cache=True)
    def kernel(scene, o, d, out_t):
        buf = ray_alloc()
        for k in range(o.shape[0]):
            hit, t, prim, geom, u, v, ngx, ngy, ngz = intersect1(scene, o[k, 0], o[k, 1], o[k, 2],
                                                                 d[k, 0], d[k, 1], d[k, 2], 0.0, np.inf, buf)
            out_t[k] = t

A packet: ``p = packet_alloc(16)``; ``packet_clear(p)``; ``packet_set_ray(p, lane, ...)`` for the lanes in use
(it activates them; :func:`packet_valid` can switch one off again); ``intersect_packet(scene, p, coherent)``;
then ``packet_hit(p, lane)`` per lane (or ``occluded_packet`` and ``packet_blocked``).

Cost: Embree's traversal is ~65 ns a camera ray on one core here, so per-ray overhead shows. Creating an array
(a view, a slice) or passing a tuple of arrays to a non-inlined jitted function costs reference counting on
every call: the first version of these helpers took ``buf.view(np.int32)`` per ray and ran at 10.5 Mrays/s
against 16 for bare calls; the integer fields are therefore read and written through the intrinsics below,
and kernels should likewise keep array creation out of their per-ray loops. Measured on one core (AVX-512,
320x240x16 camera rays, a 20k-triangle sphere and a plane; ``python tests/test_embree_jit.py``): embreex
``run`` 15 Mrays/s, an :func:`intersect1` loop 15.4, coherent packets of 16 50 (4-wide 28, 8-wide 42), incoherent
packets 16-20.
"""
from __future__ import annotations

import ctypes
import functools

import llvmlite.binding as llvm
import numba
import numpy as np
from llvmlite import ir
from numba import types
from numba.core import cgutils
from numba.extending import intrinsic

from pyrt.geometry import accel as _accel

# -- layout (words; see the module docstring) ------------------------------------------------------------------
ORG_X, ORG_Y, ORG_Z, TNEAR, DIR_X, DIR_Y, DIR_Z, TIME, TFAR, MASK, ID, FLAGS = range(12)
NG_X, NG_Y, NG_Z, U, V, PRIM_ID, GEOM_ID, INST_ID = range(12, 20)
#: words a lane of an RTCRayHit(N): 12 of RTCRay, 9 of RTCHit (with instPrimID[1])
LANE_WORDS = 21
#: words of the single-ray buffer: an RTCRayHit with instPrimID, 96 B
RAY_WORDS = 24
#: the packet buffer after the RTCRayHitN: ``valid`` (padded to 16 words), then the arguments (16 words)
_VALID_WORDS, _ARGS_WORDS = 16, 16
#: the alignment of every buffer made here (an RTCRayHit16 needs 64)
ALIGN = 64

# -- constants (rtcore_common.h, rtcore_device.h) -----------------------------------------------------------------
RTC_INVALID_GEOMETRY_ID = 0xFFFFFFFF
RTC_RAY_QUERY_FLAG_INCOHERENT = 0
RTC_RAY_QUERY_FLAG_COHERENT = 1 << 16
RTC_FEATURE_FLAG_ALL = 0xFFFFFFFF
RTC_DEVICE_PROPERTY_VERSION = 0
RTC_DEVICE_PROPERTY_NATIVE_RAY4_SUPPORTED = 32
RTC_DEVICE_PROPERTY_NATIVE_RAY8_SUPPORTED = 33
RTC_DEVICE_PROPERTY_NATIVE_RAY16_SUPPORTED = 34
# the same bit patterns as int32 (what _set_i32 stores)
_INVALID = -1
_FEATURES_ALL = -1

# -- the library and its symbols ---------------------------------------------------------------------------------
_LIB = ctypes.CDLL(_accel.mesh_construction.__file__)
_vp = types.voidptr
#: every rtc* function called from nopython code, with its C signature (all arguments are pointers)
SIGNATURES = {"rtcIntersect1": types.void(_vp, _vp, _vp),           # (scene, RTCRayHit*, RTCIntersectArguments*)
              "rtcOccluded1": types.void(_vp, _vp, _vp)}            # (scene, RTCRay*, RTCOccludedArguments*)
for _n in (4, 8, 16):                                                   # (valid*, scene, RTCRay(Hit)N*, args*)
    SIGNATURES[f"rtcIntersect{_n}"] = types.void(_vp, _vp, _vp, _vp)
    SIGNATURES[f"rtcOccluded{_n}"] = types.void(_vp, _vp, _vp, _vp)


def _register():
    """Give LLVM each symbol's address (once: this runs at import) and declare them to Numba."""
    for name in SIGNATURES:
        llvm.add_symbol(name, ctypes.cast(_LIB[name], ctypes.c_void_p).value)
    return {name: types.ExternalFunction(name, sig) for name, sig in SIGNATURES.items()}


_FN = _register()
_rtcIntersect1, _rtcOccluded1 = _FN["rtcIntersect1"], _FN["rtcOccluded1"]
_rtcIntersect4, _rtcOccluded4 = _FN["rtcIntersect4"], _FN["rtcOccluded4"]
_rtcIntersect8, _rtcOccluded8 = _FN["rtcIntersect8"], _FN["rtcOccluded8"]
_rtcIntersect16, _rtcOccluded16 = _FN["rtcIntersect16"], _FN["rtcOccluded16"]


# -- Python-side helpers -------------------------------------------------------------------------------------------
def scene_handle(accel):
    """The ``RTCScene`` of ``accel`` as an integer, after committing it (building its BVH).

    Parameters
    ----------
    accel : pyrt.geometry.accel.Accel
        Must have been built with ``buffers="shared"`` (the default), the mode in which the handle is known,
        and must outlive every kernel call given the handle.

    Raises
    ------
    RuntimeError
        When the accelerator has no scene handle (``accel.buffers == "copy"``).
    """
    handle = accel._handle
    if handle is None:
        raise RuntimeError(f"scene_handle: this Accel has no Embree scene handle (buffers={accel.buffers!r}); "
                           "build it with Accel(buffers='shared') on an embreex whose scene layout is verified")
    accel.commit()
    return int(handle)


def _c(name, restype, argtypes):
    """The library's function ``name`` for ctypes calls from Python."""
    fn = _LIB[name]
    fn.restype, fn.argtypes = restype, argtypes
    return fn


def device_packet_width(device):
    """The widest native packet of an Embree device (an ``RTCDevice`` address): 16, 8, 4, or 1 if none.

    Reads ``RTC_DEVICE_PROPERTY_NATIVE_RAY16/8/4_SUPPORTED`` (34/33/32; rtcore_device.h). It follows the ISA
    the device runs (measured: a device made with config ``"isa=sse4.2"`` says 4, ``"isa=avx2"`` 8).
    """
    prop = _c("rtcGetDeviceProperty", ctypes.c_ssize_t, [ctypes.c_void_p, ctypes.c_int])
    for width, p in ((16, RTC_DEVICE_PROPERTY_NATIVE_RAY16_SUPPORTED), (8, RTC_DEVICE_PROPERTY_NATIVE_RAY8_SUPPORTED),
                     (4, RTC_DEVICE_PROPERTY_NATIVE_RAY4_SUPPORTED)):
        if prop(device, p):
            return width
    return 1


@functools.cache
def native_packet_width():
    """The widest ray packet Embree traces natively on this CPU, by default: 16 (AVX-512), 8 (AVX/AVX2) or 4.

    :func:`device_packet_width` of a fresh default device (what embreex makes). A wider packet still works:
    Embree traces it ray by ray (rtcore.cpp, when the scene has no intersector of that width), with the
    answers of :func:`intersect1`.
    """
    dev = _c("rtcNewDevice", ctypes.c_void_p, [ctypes.c_char_p])(None)
    if not dev:
        raise RuntimeError("native_packet_width: rtcNewDevice failed")
    try:
        return device_packet_width(dev)
    finally:
        _c("rtcReleaseDevice", None, [ctypes.c_void_p])(dev)


# -- raw word access in nopython code (no array views: a view costs reference counting on every call) ---------
@intrinsic
def _addr(typingctx, value):
    """``void*`` from an integer address (a scene handle; 0 for NULL)."""
    if not isinstance(value, types.Integer):
        return None

    def codegen(context, builder, sig, args):
        return builder.inttoptr(args[0], cgutils.voidptr_t)
    return types.voidptr(value), codegen


def _buffer(ty):
    """True for what the word intrinsics take: a 4-byte-element array or a pointer to 4-byte words
    (:func:`pyrt.core.unmanaged.pointer` of one)."""
    return (isinstance(ty, types.Array) or isinstance(ty, types.CPointer) and ty.dtype in (types.float32, types.int32))


def _word_ptr(context, builder, arrty, arr, idx, idxty, lltype):
    """LLVM pointer to word ``idx`` of a contiguous 4-byte-element array (or of a pointer to words), as ``lltype*``."""
    data = arr if isinstance(arrty, types.CPointer) else context.make_array(arrty)(context, builder, arr).data
    k = context.cast(builder, idx, idxty, types.intp)
    return builder.gep(builder.bitcast(data, lltype.as_pointer()), [k])


@intrinsic
def _ptr(typingctx, arr, idx):
    """``void*`` to word ``idx`` of a float32 buffer."""
    if not (_buffer(arr) and isinstance(idx, types.Integer)):
        return None

    def codegen(context, builder, sig, args):
        ptr = _word_ptr(context, builder, sig.args[0], args[0], args[1], sig.args[1], ir.IntType(32))
        return builder.bitcast(ptr, cgutils.voidptr_t)
    return types.voidptr(arr, idx), codegen


@intrinsic
def _get_i32(typingctx, arr, idx):
    """The int32 stored at word ``idx`` of a float32 buffer (bits reinterpreted)."""
    if not (_buffer(arr) and isinstance(idx, types.Integer)):
        return None

    def codegen(context, builder, sig, args):
        return builder.load(_word_ptr(context, builder, sig.args[0], args[0], args[1], sig.args[1], ir.IntType(32)))
    return types.int32(arr, idx), codegen


@intrinsic
def _set_i32(typingctx, arr, idx, value):
    """Store ``value`` as an int32 at word ``idx`` of a float32 buffer."""
    if not (_buffer(arr) and isinstance(idx, types.Integer) and isinstance(value, types.Integer)):
        return None

    def codegen(context, builder, sig, args):
        ptr = _word_ptr(context, builder, sig.args[0], args[0], args[1], sig.args[1], ir.IntType(32))
        builder.store(context.cast(builder, args[2], sig.args[2], types.int32), ptr)
        return context.get_dummy_value()
    return types.none(arr, idx, value), codegen


# -- buffers ------------------------------------------------------------------------------------------------------
@numba.njit(nogil=True, cache=True)
def aligned_f32(n):
    """A float32 array of ``n`` zeros whose data starts on a 64-byte boundary (Python or nopython).

    Over-allocates ``4 n + 64`` bytes and returns the aligned slice viewed as float32 (the view keeps the whole
    allocation alive). Use ``a.view(np.int32)`` for the integer fields of the same memory.
    """
    raw = np.zeros(4 * n + ALIGN, np.uint8)
    off = (-np.int64(raw.ctypes.data)) & (ALIGN - 1)
    return raw[off:off + 4 * n].view(np.float32)


@numba.njit(nogil=True, cache=True)
def ray_alloc():
    """A single-ray scratch buffer for :func:`intersect1` / :func:`occluded1`: an RTCRayHit (96 B, aligned)."""
    return aligned_f32(RAY_WORDS)


@numba.njit(nogil=True, cache=True)
def packet_alloc(width):
    """A packet buffer of ``width`` (4, 8 or 16) lanes, all inactive.

    Layout (float32 words): the RTCRayHitN (``21 * width``), ``valid`` (``width`` int32, padded to 16 words),
    then the query arguments (16 words: flags, feature_mask = ALL, NULL pointers). 64-byte aligned, so the
    RTCRayHitN and ``valid`` are aligned to ``4 * width`` bytes as Embree requires.
    """
    if width != 4 and width != 8 and width != 16:
        raise ValueError("packet_alloc: width must be 4, 8 or 16")
    p = aligned_f32(LANE_WORDS * width + _VALID_WORDS + _ARGS_WORDS)
    _set_i32(p, LANE_WORDS * width + _VALID_WORDS + 1, _FEATURES_ALL)
    packet_clear(p)
    return p


@numba.njit(nogil=True, cache=True, forceinline=True)
def packet_width(p):
    """The lane count of a buffer made by :func:`packet_alloc`."""
    return (p.shape[0] - _VALID_WORDS - _ARGS_WORDS) // LANE_WORDS


@numba.njit(nogil=True, cache=True, forceinline=True)
def packet_valid(p):
    """The packet's ``valid`` mask, an int32 view: -1 = active lane, 0 = inactive."""
    w = packet_width(p)
    return p.view(np.int32)[LANE_WORDS * w:LANE_WORDS * w + w]


@numba.njit(nogil=True, cache=True, forceinline=True)
def packet_clear(p):
    """Deactivate every lane and mark it a miss (before filling a packet with :func:`packet_set_ray`).

    Embree leaves an inactive lane as it was: cleared, it reads as a miss in :func:`packet_hit` and as not
    blocked in :func:`packet_blocked` instead of repeating an earlier query's answer.
    """
    w = packet_width(p)
    for lane in range(w):
        _set_i32(p, LANE_WORDS * w + lane, 0)
        _set_i32(p, GEOM_ID * w + lane, _INVALID)
        p[TFAR * w + lane] = 0.0


# -- single rays ---------------------------------------------------------------------------------------------------
@numba.njit(nogil=True, cache=True, forceinline=True)
def _set_ray(f, n, lane, ox, oy, oz, dx, dy, dz, tnear, tfar):
    """Write one ray (lane ``lane`` of width ``n``; a single ray is n = 1, lane 0) and reset its hit ids."""
    f[ORG_X * n + lane] = ox
    f[ORG_Y * n + lane] = oy
    f[ORG_Z * n + lane] = oz
    f[TNEAR * n + lane] = tnear
    f[DIR_X * n + lane] = dx
    f[DIR_Y * n + lane] = dy
    f[DIR_Z * n + lane] = dz
    f[TIME * n + lane] = 0.0
    f[TFAR * n + lane] = tfar
    _set_i32(f, MASK * n + lane, _INVALID)          # 0xffffffff: every geometry mask
    _set_i32(f, ID * n + lane, lane)
    _set_i32(f, FLAGS * n + lane, 0)
    _set_i32(f, GEOM_ID * n + lane, _INVALID)
    _set_i32(f, INST_ID * n + lane, _INVALID)


@numba.njit(nogil=True, cache=True, forceinline=True)
def _get_hit(f, n, lane):
    geom = _get_i32(f, GEOM_ID * n + lane)
    if geom == _INVALID:
        z = np.float32(0.0)
        return False, np.float32(np.inf), np.int32(-1), np.int32(-1), z, z, z, z, z
    return (True, f[TFAR * n + lane], _get_i32(f, PRIM_ID * n + lane), geom, f[U * n + lane], f[V * n + lane],
            f[NG_X * n + lane], f[NG_Y * n + lane], f[NG_Z * n + lane])


@numba.njit(nogil=True, cache=True, forceinline=True)
def intersect1(scene, ox, oy, oz, dx, dy, dz, tnear, tfar, buf):
    """Closest hit of one ray (``rtcIntersect1``, default arguments: what embreex's ``run`` does).

    Parameters
    ----------
    scene : int
        The RTCScene address (:func:`scene_handle`).
    ox, oy, oz, dx, dy, dz, tnear, tfar : float
        The ray (rounded to float32, as Embree stores it); hits are searched in [tnear, tfar] in units of
        |d|. ``tfar`` may be ``inf``.
    buf : float32 array
        A buffer from :func:`ray_alloc` (per thread).

    Returns
    -------
    hit : bool
    t : float32
        Hit distance (``inf`` on a miss).
    prim, geom : int32
        Triangle and geometry (mesh) id; -1 on a miss.
    u, v, ngx, ngy, ngz : float32
        Barycentrics and the unnormalised geometric normal; 0 on a miss.
    """
    _set_ray(buf, 1, 0, ox, oy, oz, dx, dy, dz, tnear, tfar)
    _rtcIntersect1(_addr(scene), _ptr(buf, 0), _addr(0))
    return _get_hit(buf, 1, 0)


@numba.njit(nogil=True, cache=True, forceinline=True)
def occluded1(scene, ox, oy, oz, dx, dy, dz, tnear, tfar, buf):
    """True when something blocks the ray within [tnear, tfar] (``rtcOccluded1``; arguments as :func:`intersect1`)."""
    _set_ray(buf, 1, 0, ox, oy, oz, dx, dy, dz, tnear, tfar)
    _rtcOccluded1(_addr(scene), _ptr(buf, 0), _addr(0))
    return buf[TFAR] == -np.inf


# -- packets ------------------------------------------------------------------------------------------------------
@numba.njit(nogil=True, cache=True, forceinline=True)
def packet_set_ray(p, lane, ox, oy, oz, dx, dy, dz, tnear, tfar):
    """Set lane ``lane``'s ray (arguments as :func:`intersect1`), reset its hit ids and activate the lane."""
    w = packet_width(p)
    _set_ray(p, w, lane, ox, oy, oz, dx, dy, dz, tnear, tfar)
    _set_i32(p, LANE_WORDS * w + lane, -1)


# -- packets filled field by field (the render kernel's stage loops) ----------------------------------------------
# These take the buffer ``p`` (a :func:`packet_alloc` array or its :func:`pyrt.core.unmanaged.pointer`) and its
# width ``w`` explicitly: with a pointer, the per-lane code binds no array (no reference counting at all).
@numba.njit(nogil=True, cache=True, forceinline=True)
def packet_prepare(p, w, ox, oy, oz):
    """Write the fields a query never changes once for every lane: origin ``(ox, oy, oz)``, tnear 0, time 0, mask,
    id, flags; instID invalid; every lane inactive. A kernel that traces many packets through the same buffer then
    writes per packet only what changes (:func:`packet_set_dir`, :func:`packet_set_origin`, :func:`packet_activate`):
    Embree writes tfar and the hit fields and nothing else of a ray (see the module docstring; checked by
    tests/test_embree_jit.py)."""
    for lane in range(w):
        _set_ray(p, w, lane, ox, oy, oz, 0.0, 0.0, 1.0, 0.0, 0.0)
        _set_i32(p, LANE_WORDS * w + lane, 0)


@numba.njit(nogil=True, cache=True, forceinline=True)
def packet_activate(p, w, n):
    """Activate lanes ``[0, n)`` and deactivate the others."""
    for lane in range(w):
        _set_i32(p, LANE_WORDS * w + lane, -1 if lane < n else 0)


@numba.njit(nogil=True, cache=True, forceinline=True)
def packet_set_active(p, w, lane, active):
    """Switch lane ``lane`` on or off (``active`` a bool; branch-free)."""
    _set_i32(p, LANE_WORDS * w + lane, -np.int32(active))


@numba.njit(nogil=True, cache=True, forceinline=True)
def packet_set_dir(p, w, lane, dx, dy, dz, tfar):
    """Lane ``lane``'s direction and tfar, and its geomID reset (a miss until a query says otherwise); the other
    fields as :func:`packet_prepare` or an earlier :func:`packet_set_ray` left them. Does not activate the lane."""
    p[DIR_X * w + lane] = dx
    p[DIR_Y * w + lane] = dy
    p[DIR_Z * w + lane] = dz
    p[TFAR * w + lane] = tfar
    _set_i32(p, GEOM_ID * w + lane, _INVALID)


@numba.njit(nogil=True, cache=True, forceinline=True)
def packet_set_origin(p, w, lane, ox, oy, oz):
    """Lane ``lane``'s origin (with :func:`packet_set_dir`: a whole ray on a prepared buffer)."""
    p[ORG_X * w + lane] = ox
    p[ORG_Y * w + lane] = oy
    p[ORG_Z * w + lane] = oz


@numba.njit(nogil=True, cache=True, forceinline=True)
def packet_geom_prim(p, w, lane):
    """``(geomID, primID)`` of lane ``lane`` after :func:`intersect_packet` (geomID -1 on a miss; primID is then
    whatever the buffer held)."""
    return _get_i32(p, GEOM_ID * w + lane), _get_i32(p, PRIM_ID * w + lane)


@numba.njit(nogil=True, cache=True, forceinline=True)
def packet_uv(p, w, lane):
    """The barycentrics ``(u, v)`` (float32) of lane ``lane``'s hit."""
    return p[U * w + lane], p[V * w + lane]


@numba.njit(nogil=True, cache=True, forceinline=True)
def packet_tfar(p, w, lane):
    """Lane ``lane``'s tfar (float32) after a closest-hit query: the hit's distance along the ray's direction."""
    return p[TFAR * w + lane]


@numba.njit(nogil=True, cache=True, forceinline=True)
def packet_ray(p, w, lane):
    """Lane ``lane``'s ray as stored (float32): ``(origin, direction, tfar)`` (tfar before a query)."""
    return ((p[ORG_X * w + lane], p[ORG_Y * w + lane], p[ORG_Z * w + lane]),
            (p[DIR_X * w + lane], p[DIR_Y * w + lane], p[DIR_Z * w + lane]), p[TFAR * w + lane])


@numba.njit(nogil=True, cache=True, forceinline=True)
def lane_blocked(p, w, lane):
    """:func:`packet_blocked` with the width given."""
    return p[TFAR * w + lane] == -np.inf


@numba.njit(nogil=True, cache=True, forceinline=True)
def packet_query(scene, p, w, coherent, occluded):
    """:func:`intersect_packet` (``occluded`` False) or :func:`occluded_packet` with the width given."""
    args = LANE_WORDS * w + _VALID_WORDS
    _set_i32(p, args, RTC_RAY_QUERY_FLAG_COHERENT if coherent else RTC_RAY_QUERY_FLAG_INCOHERENT)
    s, v, r, a = _addr(scene), _ptr(p, LANE_WORDS * w), _ptr(p, 0), _ptr(p, args)
    if w == 16:
        if occluded:
            _rtcOccluded16(v, s, r, a)
        else:
            _rtcIntersect16(v, s, r, a)
    elif w == 8:
        if occluded:
            _rtcOccluded8(v, s, r, a)
        else:
            _rtcIntersect8(v, s, r, a)
    elif occluded:
        _rtcOccluded4(v, s, r, a)
    else:
        _rtcIntersect4(v, s, r, a)


@numba.njit(nogil=True, cache=True, forceinline=True)
def _packet_call(scene, p, coherent, occluded):
    packet_query(scene, p, packet_width(p), coherent, occluded)


@numba.njit(nogil=True, cache=True, forceinline=True)
def intersect_packet(scene, p, coherent):
    """Closest hits of the packet's active lanes (``rtcIntersect4/8/16`` by the packet's width).

    ``coherent`` selects ``RTC_RAY_QUERY_FLAG_COHERENT`` (camera-like rays) rather than ``INCOHERENT``. Read
    the hits with :func:`packet_hit`. They are those of :func:`intersect1`, bit for bit, except where a ray
    meets two triangles at an exact tie (through a shared vertex or edge): a coherent packet may report the
    other triangle (see tests/test_embree_jit.py).
    """
    _packet_call(scene, p, coherent, False)


@numba.njit(nogil=True, cache=True, forceinline=True)
def occluded_packet(scene, p, coherent):
    """Any-hit test of the packet's active lanes (``rtcOccluded4/8/16``); read with :func:`packet_blocked`."""
    _packet_call(scene, p, coherent, True)


@numba.njit(nogil=True, cache=True, forceinline=True)
def packet_hit(p, lane):
    """Lane ``lane``'s closest hit after :func:`intersect_packet`: the tuple :func:`intersect1` returns."""
    return _get_hit(p, packet_width(p), lane)


@numba.njit(nogil=True, cache=True, forceinline=True)
def packet_blocked(p, lane):
    """Whether lane ``lane`` was blocked by :func:`occluded_packet` (Embree set its tfar to -inf)."""
    return p[TFAR * packet_width(p) + lane] == -np.inf
