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


def _byte_tables():
    """(256,) uint64: each byte bit-reversed."""
    b = np.arange(256, dtype=np.uint64)
    rev = np.zeros(256, dtype=np.uint64)
    for k in range(8):
        rev |= ((b >> np.uint64(k)) & np.uint64(1)) << np.uint64(7 - k)
    return rev


_REV8 = _byte_tables()
_REV16 = (_REV8[np.arange(65536) & 0xFF] << np.uint64(8)) | _REV8[np.arange(65536) >> 8]
_SOBOL1_BYTES = []     # per byte position p of the index: (256,) the XOR of _SOBOL1[8p + k] over its set bits k
for _p in range(4):
    _t = np.zeros(256, dtype=np.uint64)
    for _k in range(8):
        _t ^= np.where((np.arange(256) >> _k) & 1, np.uint64(_SOBOL1[8 * _p + _k]), np.uint64(0))
    _SOBOL1_BYTES.append(_t)


def _reverse_bits32(x):
    """Bit reversal of uint32 values held in a uint64 array (two lookups in a 16-bit table)."""
    return (_REV16[x & np.uint64(0xFFFF)] << np.uint64(16)) | _REV16[(x >> np.uint64(16)) & np.uint64(0xFFFF)]


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
    return _reverse_bits32(_laine_karras(_reverse_bits32(x), seed))


def _laine_karras(x, seed):
    """Burley's Laine-Karras-style permutation of 32-bit values (each bit flipped by a hash of the bits below)."""
    x = x ^ ((x * np.uint64(0x3D20ADEA)) & _M32)
    x = (x + seed) & _M32
    x = (x * ((seed >> np.uint64(16)) | np.uint64(1))) & _M32
    x = x ^ ((x * np.uint64(0x05526C56)) & _M32)
    return x ^ ((x * np.uint64(0x53A22864)) & _M32)


def sobol_owen_2d(index, seed):
    """Points of Owen-scrambled 2-D Sobol' sequences: ``index`` (N,) (< 2^32) into the sequence whose
    scrambling seed is ``seed`` (N,) (one sequence per pixel and half-buffer). Returns (N, 2) in [0, 1).

    Each point is uniform on the square; the points ``0 .. 2^m - 1`` (and any aligned block of ``2^m``) of one
    sequence have exactly one point in each of the ``2^m`` elementary intervals ``2^-a x 2^-(m-a)``.
    """
    i = np.asarray(index).astype(np.uint64)
    seed = np.asarray(seed).astype(np.uint64) & _M32
    m = np.uint64(0xFF)
    y = _SOBOL1_BYTES[0][i & m]       # the XOR of the direction numbers of the index's set bits, a byte at a time
    for p in (1, 2, 3):
        hi = i >> np.uint64(8 * p)
        if hi.any():
            y = y ^ _SOBOL1_BYTES[p][hi & m]
    sx = _reverse_bits32(_laine_karras(i, hash32(seed, 0x68E31DA4)))    # _owen(x): x is i bit-reversed
    sy = _owen(y, hash32(seed, 0xB5297A4D))
    u = np.empty((i.shape[0], 2))
    u[:, 0] = sx.astype(np.float64) * 2.0 ** -32
    u[:, 1] = sy.astype(np.float64) * 2.0 ** -32
    return u


# --- padded dimensions: a pixel's samples stratified in every dimension pair -----------------------------------
# The camera rays' pixel positions are one stratified set per pixel; the random numbers their hits draw for light
# and BSDF samples were independent, so a pixel's spp light samples were i.i.d. Padding (Kollig & Keller 2002;
# pbrt's padded samplers) gives every dimension pair its own stratified set over the pixel's samples, the sample
# index shuffled by a per-pixel, per-dimension permutation so that the pairs are not correlated with each other:
# sample j of the pixel reads point pi_d(j) of an Owen-scrambled Sobol' (0,2)-sequence of its own. Each point is
# uniform on the square (unbiased); the spp points of one pixel and dimension are one stratified set.

def _u32(x):
    return np.asarray(x).astype(np.uint64) & _M32


def permutation_element(i, n, seed):
    """Element ``i`` of a pseudo-random permutation of ``[0, n)`` chosen by ``seed`` (arrays broadcast; int64).

    Kensler's hash-based permutation ("Correlated Multi-Jittered Sampling", Pixar 2013): a bijection of the
    next power of two above ``n`` made of invertible 32-bit steps, walked until it lands below ``n``, then
    rotated by the seed. Computed per element, so a pixel's samples need not be drawn together.
    """
    i, n, p = np.broadcast_arrays(_u32(i), _u32(n), _u32(seed))
    i, n, p = i.copy(), n, p
    w = n - np.uint64(1)
    for s in (1, 2, 4, 8, 16):
        w |= w >> np.uint64(s)
    out = np.empty_like(i)
    todo = np.arange(i.size)
    x, ww, pp, nn = i.ravel(), w.ravel(), p.ravel(), n.ravel()
    res = out.ravel()
    while todo.size:
        v, wk, pk = x[todo], ww[todo], pp[todo]

        def mul(a, c):
            return (a * np.uint64(c)) & _M32
        v = v ^ pk
        v = mul(v, 0xE170893D)
        v = v ^ (pk >> np.uint64(16))
        v = v ^ ((v & wk) >> np.uint64(4))
        v = v ^ (pk >> np.uint64(8))
        v = mul(v, 0x0929EB3F)
        v = v ^ (pk >> np.uint64(23))
        v = v ^ ((v & wk) >> np.uint64(1))
        v = (v * (np.uint64(1) | (pk >> np.uint64(27)))) & _M32
        v = mul(v, 0x6935FA69)
        v = v ^ ((v & wk) >> np.uint64(11))
        v = mul(v, 0x74DCB303)
        v = v ^ ((v & wk) >> np.uint64(2))
        v = mul(v, 0x9E501CC3)
        v = v ^ ((v & wk) >> np.uint64(2))
        v = mul(v, 0xC860A3DF)
        v = v & wk
        v = v ^ (v >> np.uint64(5))
        done = v < nn[todo]
        res[todo[done]] = (v[done] + pk[done]) % nn[todo[done]]
        x[todo[~done]] = v[~done]
        todo = todo[~done]
    return out.reshape(i.shape).astype(np.int64)


def padded_sobol_2d(index, n, key, dim):
    """The points of dimension pair ``dim`` (an int) for samples ``index`` (N,) of pixels whose sets have ``n``
    samples (N,) or a number, ``key`` (N,) a per-pixel seed: (N, 2) in [0, 1).

    Sample ``j`` reads point ``pi(j)`` of the Owen-scrambled Sobol' sequence of ``hash(key, dim)``, ``pi`` the
    permutation :func:`permutation_element` of ``[0, n)`` of that seed: the ``n`` samples of a pixel are one
    stratified set in every pair (exactly one point per elementary interval when ``n`` is a power of two), each
    pair shuffled independently of the others and of the pixel position.

    ``n = None``: a progressive set (adaptive passes, whose final count is not known): ``pi`` is a nested uniform
    scramble of the index bits (Burley 2020, "shuffling"), which maps every aligned block of ``2^m`` indices onto
    an aligned block of the sequence, itself an elementary net: the first ``2^m`` samples of a pixel, and every
    aligned block of ``2^m`` after them, are stratified, however the passes split them.
    """
    k = hash32(key, dim)
    shuffle = hash32(k, 0x2545F491)
    if n is None:
        return sobol_owen_2d(_owen(_u32(index), shuffle), k)
    return sobol_owen_2d(permutation_element(index, n, shuffle), k)


class PaddedStream:
    """Stands in for the ``numpy.random.Generator`` of a chunk at the hits of camera rays: ``random((..., N, 2))``
    (N = the hits) returns :func:`padded_sobol_2d` points, a new dimension pair for each call and for each
    leading index, in call order; the other draws the integrators make (``random`` of other shapes, ``permuted``) go
    to the generator. ``index``, ``n``, ``key`` (N,) are each hit's sample index in its pixel's set, the set's size
    (None: progressive sets) and the pixel's seed."""

    def __init__(self, rng, index, n, key, _dims=None):
        self._rng = rng
        self.index, self.n, self.key = index, n, key
        self._dims = [0] if _dims is None else _dims     # shared with the streams of its rows (:meth:`rows`)

    def rows(self, idx):
        """The stream of the hits ``idx`` (an index array): the same pixels' sets, and the dimension pairs counted
        on from this stream's (draws for a subset never reuse a pair another draw of the bounce used)."""
        return PaddedStream(self._rng, np.take(self.index, idx), None if self.n is None else np.take(self.n, idx),
                            np.take(self.key, idx), self._dims)

    def random(self, size=None, *args, **kwargs):
        shape = (size,) if isinstance(size, (int, np.integer)) else tuple(size) if size is not None else ()
        m = self.index.shape[0]
        if args or kwargs or len(shape) < 2 or shape[-2:] != (m, 2):
            return self._rng.random(size, *args, **kwargs)
        lead = int(np.prod(shape[:-2], dtype=np.int64))
        out = np.empty((lead, m, 2))
        for r in range(lead):
            out[r] = padded_sobol_2d(self.index, self.n, self.key, self._dims[0])
            self._dims[0] += 1
        return out.reshape(shape)

    def permuted(self, *args, **kwargs):
        """The generator's :meth:`numpy.random.Generator.permuted` (the Latin-hypercube pairing of
        :func:`stratified_samples`): not padded."""
        return self._rng.permuted(*args, **kwargs)


def stream_rows(rng, idx):
    """The random numbers for the hits ``idx`` of a batch whose draws come from ``rng``: a :class:`PaddedStream`'s
    :meth:`~PaddedStream.rows`, a ``numpy.random.Generator`` itself (its draws are not tied to rows)."""
    return rng.rows(idx) if isinstance(rng, PaddedStream) else rng
