"""Stratified sample points in [0, 1)^2, shared by pixel sampling and light sampling.

Random numbers come from the caller's generator (one stream per image chunk), so results are
deterministic for a seed.
"""
from __future__ import annotations

import math

import numpy as np


def stratified_samples(rng, n_hits, n_samples):
    """Per-hit stratified points in [0, 1)^2, shape ``(n_samples, n_hits, 2)``.

    ``k x k`` jittered grid if ``n_samples == k^2``, else Latin hypercube (``n_samples`` strata in
    each dimension, randomly paired per hit). Every sample is uniformly distributed (unbiased).
    """
    k = math.isqrt(n_samples)
    xi = rng.random((n_samples, n_hits, 2))
    if n_samples == 1:
        return xi
    if k * k == n_samples:
        s = np.arange(n_samples)
        cell = np.stack([s % k, s // k], axis=1).astype(np.float64)
        return (cell[:, None, :] + xi) / k
    perm = rng.permuted(np.tile(np.arange(n_samples), (n_hits, 1)), axis=1).T   # (ns, n)
    u = np.empty_like(xi)
    u[..., 0] = (np.arange(n_samples)[:, None] + xi[..., 0]) / n_samples
    u[..., 1] = (perm + xi[..., 1]) / n_samples
    return u


def pixel_strata(rng, spp, s):
    """Points in [0, 1)^2 for the samples ``s`` (int array, each in ``[0, spp)``) of one pixel's set of ``spp``.

    The set is a jittered grid of ``spp`` equal-area cells that tile the square exactly once, for any
    ``spp``: ``k = isqrt(spp)`` rows, row ``j`` holding the samples ``[floor(j spp / k), floor((j+1) spp / k))``
    as ``n_j`` cells side by side, the row ``n_j / spp`` high (so every cell has area ``1 / spp``; when
    ``spp = k^2`` these are the ``k x k`` cells of :func:`stratified_samples`, sample ``s`` at column
    ``s % k``, row ``s // k``). Sample ``s`` is uniform in its cell, with the jitter drawn from ``rng`` in
    the order of ``s``: any subset of the samples can be drawn on its own, from its own stream, and the
    subsets of a partition of ``[0, spp)`` together form one stratified set (an unbiased estimate of the
    pixel). Memory is O(len(s)) whatever ``spp``.
    """
    s = np.asarray(s, dtype=np.int64)
    return strata_points(rng, np.full(s.shape[0], spp, dtype=np.int64), s)


def isqrt_array(n):
    """``floor(sqrt(n))`` of a non-negative int64 array, exact (corrects the float square root's rounding)."""
    n = np.asarray(n, dtype=np.int64)
    k = np.floor(np.sqrt(n.astype(np.float64))).astype(np.int64)
    k -= (k * k > n)
    k += ((k + 1) * (k + 1) <= n)
    return k


def strata_points(rng, n, s):
    """Points in [0, 1)^2 for the samples ``s`` of stratified sets of varying sizes ``n`` (int arrays, one
    entry per sample, ``0 <= s < n``): sample ``s`` of a set of ``n`` lies in cell ``s`` of the equal-area
    jittered grid of :func:`pixel_strata` for ``spp = n``, uniform in it.

    How adaptive passes draw a pixel's new samples: each pass gives a pixel one or more complete sets (of the
    size the pass allots it), each set an unbiased stratified estimate of the pixel on its own.
    """
    s = np.asarray(s, dtype=np.int64)
    n = np.asarray(n, dtype=np.int64)
    k = isqrt_array(n)
    row = ((s + 1) * k - 1) // n
    first = row * n // k
    n_row = (row + 1) * n // k - first
    xi = rng.random((s.shape[0], 2))
    u = np.empty_like(xi)
    u[:, 0] = (s - first + xi[:, 0]) / n_row
    u[:, 1] = (first + xi[:, 1] * n_row) / n
    return u


# --- progressive stratified points: Owen-scrambled Sobol' (0,2)-sequence ------------------------------------
# The first 2^m points of the 2-D Sobol' sequence (van der Corput in x, Sobol's second dimension in y) put
# exactly one point in every elementary interval of area 2^-m, and so does every aligned block of 2^m points;
# Owen scrambling keeps that and makes every point uniform on [0, 1)^2 (unbiased). Adaptive passes extend a
# pixel's sequence where the last pass stopped, so the samples stay one stratified set however they are split
# into passes. Hash-based nested uniform scrambling after Burley, "Practical Hash-based Owen Scrambling"
# (JCGT 2020): written here from the paper's description.

_M32 = np.uint64(0xFFFFFFFF)
#: direction numbers of Sobol's second dimension (the Pascal matrix mod 2): v_0 = 2^31, v_k+1 = v_k ^ (v_k >> 1)
_SOBOL1 = [1 << 31]
for _ in range(31):
    _SOBOL1.append(_SOBOL1[-1] ^ (_SOBOL1[-1] >> 1))


def _reverse_bits32(x):
    """Bit reversal of uint32 values held in a uint64 array."""
    x = ((x >> np.uint64(1)) & np.uint64(0x55555555)) | ((x & np.uint64(0x55555555)) << np.uint64(1))
    x = ((x >> np.uint64(2)) & np.uint64(0x33333333)) | ((x & np.uint64(0x33333333)) << np.uint64(2))
    x = ((x >> np.uint64(4)) & np.uint64(0x0F0F0F0F)) | ((x & np.uint64(0x0F0F0F0F)) << np.uint64(4))
    x = ((x >> np.uint64(8)) & np.uint64(0x00FF00FF)) | ((x & np.uint64(0x00FF00FF)) << np.uint64(8))
    return ((x >> np.uint64(16)) | (x << np.uint64(16))) & _M32


def hash32(*keys):
    """A 32-bit hash of integer arrays (broadcast; uint64 array of values < 2^32): combines the keys with a
    murmur3-style finaliser, for per-pixel scrambling seeds."""
    h = np.uint64(0x9E3779B9)
    for k in keys:
        h = (np.asarray(k).astype(np.uint64) & _M32) ^ ((h * np.uint64(0x85EBCA6B)) & _M32)
        h = h ^ (h >> np.uint64(16))
        h = (h * np.uint64(0x7FEB352D)) & _M32
        h = h ^ (h >> np.uint64(15))
        h = (h * np.uint64(0x846CA68B)) & _M32
        h = h ^ (h >> np.uint64(16))
    return h


def _owen(x, seed):
    """Nested uniform (Owen) scramble of 32-bit fixed-point values ``x`` with per-value ``seed`` (Burley's
    Laine-Karras-style hash applied to the bit-reversed value: each bit flipped by a hash of the bits above)."""
    x = _reverse_bits32(x)
    x = x ^ ((x * np.uint64(0x3D20ADEA)) & _M32)
    x = (x + seed) & _M32
    x = (x * ((seed >> np.uint64(16)) | np.uint64(1))) & _M32
    x = x ^ ((x * np.uint64(0x05526C56)) & _M32)
    x = x ^ ((x * np.uint64(0x53A22864)) & _M32)
    return _reverse_bits32(x)


def sobol_owen_2d(index, seed):
    """Points of Owen-scrambled 2-D Sobol' sequences: ``index`` (N,) (< 2^32) into the sequence whose
    scrambling seed is ``seed`` (N,) (one sequence per pixel and half-buffer). Returns (N, 2) in [0, 1).

    Each point is uniform on the square; the points ``0 .. 2^m - 1`` (and any aligned block of ``2^m``) of one
    sequence have exactly one point in each of the ``2^m`` elementary intervals ``2^-a x 2^-(m-a)``.
    """
    i = np.asarray(index).astype(np.uint64)
    seed = np.asarray(seed).astype(np.uint64) & _M32
    x = _reverse_bits32(i)
    y = np.zeros_like(i)
    b = 0
    rest = i.copy()
    while b < 32 and rest.any():
        y ^= np.where(rest & np.uint64(1), np.uint64(_SOBOL1[b]), np.uint64(0))
        rest >>= np.uint64(1)
        b += 1
    sx = _owen(x, hash32(seed, 0x68E31DA4))
    sy = _owen(y, hash32(seed, 0xB5297A4D))
    u = np.empty((i.shape[0], 2))
    u[:, 0] = sx.astype(np.float64) * 2.0 ** -32
    u[:, 1] = sy.astype(np.float64) * 2.0 ** -32
    return u
