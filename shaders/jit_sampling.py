"""Scalar twins of the progressive sample sequences of :mod:`pyrt.core.sampler`, for the compiled kernel.

``register_jitable`` functions (nopython and plain Python): the 32-bit key hash :func:`hash32_2` / :func:`hash32_3`
(:func:`pyrt.core.sampler.hash32` of two or three keys) and the Owen-scrambled 2-D Sobol' points
:func:`sobol_owen_2d` (:func:`pyrt.core.sampler.sobol_owen_2d`): the same bits as the NumPy functions
(tests/test_jit_sampling.py), so a compiled adaptive pass puts its camera samples exactly where the NumPy path's
would; :func:`padded_sobol_2d` (:func:`pyrt.core.sampler.padded_sobol_2d`), the padded light samples of camera hits. 32-bit arithmetic is written as masked 64-bit (Numba widens small integers).
"""
from __future__ import annotations

import numpy as np
from numba.extending import register_jitable

from .jit import permute

_M32 = 0xFFFFFFFF
#: the hash's initial state, (0x9E3779B9 * 0x85EBCA6B) mod 2^32
_H0 = (0x9E3779B9 * 0x85EBCA6B) & _M32


@register_jitable(forceinline=True)
def _mix(h, k):
    """One key's round of :func:`pyrt.core.sampler.hash32` (``k`` taken modulo 2^32)."""
    m = np.uint64(_M32)
    h = (np.uint64(k) & m) ^ h
    h ^= h >> np.uint64(16)
    h = (h * np.uint64(0x7FEB352D)) & m
    h ^= h >> np.uint64(15)
    h = (h * np.uint64(0x846CA68B)) & m
    return h ^ (h >> np.uint64(16))


@register_jitable(forceinline=True)
def _next(h):
    return (h * np.uint64(0x85EBCA6B)) & np.uint64(_M32)


@register_jitable(forceinline=True)
def hash32_2(a, b):
    """:func:`pyrt.core.sampler.hash32` of the keys ``a, b`` (non-negative integers): a uint64 below 2^32."""
    h = _mix(np.uint64(_H0), a)
    return _mix(_next(h), b)


@register_jitable(forceinline=True)
def hash32_3(a, b, c):
    """:func:`pyrt.core.sampler.hash32` of the keys ``a, b, c`` (non-negative integers)."""
    h = _mix(np.uint64(_H0), a)
    h = _mix(_next(h), b)
    return _mix(_next(h), c)


@register_jitable(forceinline=True)
def hash32_4(a, b, c, d):
    """:func:`pyrt.core.sampler.hash32` of the keys ``a, b, c, d`` (non-negative integers)."""
    h = _mix(np.uint64(_H0), a)
    h = _mix(_next(h), b)
    h = _mix(_next(h), c)
    return _mix(_next(h), d)


@register_jitable(forceinline=True)
def reverse_bits32(x):
    """Bit reversal of a 32-bit value (held in a uint64)."""
    m = np.uint64(_M32)
    x = ((x >> np.uint64(1)) & np.uint64(0x55555555)) | ((x & np.uint64(0x55555555)) << np.uint64(1))
    x = ((x >> np.uint64(2)) & np.uint64(0x33333333)) | ((x & np.uint64(0x33333333)) << np.uint64(2))
    x = ((x >> np.uint64(4)) & np.uint64(0x0F0F0F0F)) | ((x & np.uint64(0x0F0F0F0F)) << np.uint64(4))
    x = ((x >> np.uint64(8)) & np.uint64(0x00FF00FF)) | ((x & np.uint64(0x00FF00FF)) << np.uint64(8))
    return ((x >> np.uint64(16)) | (x << np.uint64(16))) & m


@register_jitable(forceinline=True)
def laine_karras(x, seed):
    """Burley's Laine-Karras-style permutation of a 32-bit value (``pyrt.core.sampler._laine_karras``)."""
    m = np.uint64(_M32)
    x = x ^ ((x * np.uint64(0x3D20ADEA)) & m)
    x = (x + seed) & m
    x = (x * ((seed >> np.uint64(16)) | np.uint64(1))) & m
    x = x ^ ((x * np.uint64(0x05526C56)) & m)
    return x ^ ((x * np.uint64(0x53A22864)) & m)


@register_jitable(forceinline=True)
def sobol_owen_2d(index, seed):
    """Point ``index`` (< 2^32) of the Owen-scrambled 2-D Sobol' sequence with scrambling seed ``seed`` (a 32-bit
    value): ``(x, y)`` in [0, 1), bit for bit :func:`pyrt.core.sampler.sobol_owen_2d`."""
    kx, ky = sobol_owen_keys(seed)
    return sobol_owen_2d_keyed(index, kx, ky)


@register_jitable(forceinline=True)
def sobol_owen_keys(seed):
    """The two per-dimension scrambling keys :func:`sobol_owen_2d` derives from ``seed``: computed once for the
    points of one sequence (:func:`sobol_owen_2d_keyed`)."""
    s = np.uint64(seed) & np.uint64(_M32)
    return hash32_2(s, 0x68E31DA4), hash32_2(s, 0xB5297A4D)


@register_jitable(forceinline=True)
def sobol_owen_2d_keyed(index, kx, ky):
    """:func:`sobol_owen_2d` with its scrambling keys ``(kx, ky)`` given (:func:`sobol_owen_keys` of its seed)."""
    i = np.uint64(index) & np.uint64(_M32)
    y = np.uint64(0)
    v = np.uint64(1 << 31)
    k = i
    while k != np.uint64(0):                 # the XOR of Sobol's second dimension's direction numbers
        if k & np.uint64(1):
            y ^= v
        v ^= v >> np.uint64(1)
        k >>= np.uint64(1)
    sx = reverse_bits32(laine_karras(i, kx))
    sy = reverse_bits32(laine_karras(reverse_bits32(y), ky))
    return float(sx) * 2.0 ** -32, float(sy) * 2.0 ** -32


@register_jitable(forceinline=True)
def padded_sobol_2d(index, n, key, dim):
    """Point of dimension pair ``dim`` for sample ``index`` of a pixel whose set has ``n`` samples and whose seed is
    ``key``: :func:`pyrt.core.sampler.padded_sobol_2d` for one sample, bit for bit: point ``pi(index)`` of the
    Owen-scrambled Sobol' sequence of ``hash32(key, dim)``, ``pi`` Kensler's permutation
    (:func:`pyrt.shaders.jit.permute`) of that seed's shuffle, or for ``n`` <= 0 (the NumPy function's ``n=None``:
    a progressive set) the nested uniform scramble of the index bits."""
    return padded_sobol_2d_keyed(index, n, padded_keys(key, dim))


@register_jitable(forceinline=True)
def padded_keys(key, dim):
    """What :func:`padded_sobol_2d` derives from the pixel's seed ``key`` and the dimension pair ``dim`` alone,
    ``(shuffle, kx, ky)``: the same for all the pixel's samples (a packet of one pixel's samples hashes them once,
    :func:`padded_sobol_2d_keyed`)."""
    k = hash32_2(key, dim)
    kx, ky = sobol_owen_keys(k)
    return hash32_2(k, 0x2545F491), kx, ky


@register_jitable(forceinline=True)
def padded_sobol_2d_keyed(index, n, keys):
    """:func:`padded_sobol_2d` of sample ``index`` of ``n`` with the pixel's and dimension pair's
    :func:`padded_keys` ``keys`` given."""
    shuffle, kx, ky = keys
    if n <= 0:      # a progressive set: Burley's nested uniform shuffle of the index
        i = np.uint64(index) & np.uint64(_M32)
        return sobol_owen_2d_keyed(reverse_bits32(laine_karras(reverse_bits32(i), shuffle)), kx, ky)
    return sobol_owen_2d_keyed(permute(index, n, shuffle), kx, ky)
