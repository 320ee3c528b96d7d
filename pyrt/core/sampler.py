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

_U32 = np.uint32
#: direction numbers of Sobol's second dimension (the Pascal matrix mod 2): v_0 = 2^31, v_k+1 = v_k ^ (v_k >> 1)
_SOBOL1 = [1 << 31]
for _ in range(31):
    _SOBOL1.append(_SOBOL1[-1] ^ (_SOBOL1[-1] >> 1))

# The hashes below are 32-bit arithmetic on uint32 arrays: NumPy's array operations wrap modulo 2^32 as the
# algorithms ask (products, sums), so no masking is needed and the arrays are half as wide as uint64 ones. Scalar
# operands are np.uint32 (a Python int would promote the array). Every caller passes arrays, never 0-d values:
# NumPy warns about wrapping scalar arithmetic.


_SOBOL1_BYTES = []     # per byte position p of the index: (256,) the XOR of _SOBOL1[8p + k] over its set bits k
for _p in range(4):
    _t = np.zeros(256, dtype=_U32)
    for _k in range(8):
        _t ^= np.where((np.arange(256) >> _k) & 1, _U32(_SOBOL1[8 * _p + _k]), _U32(0))
    _SOBOL1_BYTES.append(_t)


def _reverse_bits32(x):
    """Bit reversal of uint32 values: adjacent bits, pairs, nibbles, bytes and halves swapped (~1.5x faster than
    two lookups in a 16-bit table, which miss the cache)."""
    x = ((x >> _U32(1)) & _U32(0x55555555)) | ((x & _U32(0x55555555)) << _U32(1))
    x = ((x >> _U32(2)) & _U32(0x33333333)) | ((x & _U32(0x33333333)) << _U32(2))
    x = ((x >> _U32(4)) & _U32(0x0F0F0F0F)) | ((x & _U32(0x0F0F0F0F)) << _U32(4))
    x = ((x >> _U32(8)) & _U32(0x00FF00FF)) | ((x & _U32(0x00FF00FF)) << _U32(8))
    return (x >> _U32(16)) | (x << _U32(16))


def _u32(x):
    """Integers (any integer dtype, negative ones too) as uint32 arrays: their value modulo 2^32."""
    return np.asarray(x).astype(_U32)


def hash32(*keys):
    """A 32-bit hash of integer arrays (broadcast; a uint32 array of their broadcast shape): combines the keys (each
    taken modulo 2^32) with a murmur3-style finaliser, for per-pixel scrambling seeds."""
    shape = np.broadcast_shapes(*(np.shape(k) for k in keys))
    h = np.full(max(1, math.prod(shape)), (0x9E3779B9 * 0x85EBCA6B) & 0xFFFFFFFF, dtype=_U32)  # state x multiplier
    for j, k in enumerate(keys):
        if j:
            h = h * _U32(0x85EBCA6B)
        h = np.broadcast_to(_u32(k), shape).reshape(-1) ^ h
        h = h ^ (h >> _U32(16))
        h = h * _U32(0x7FEB352D)
        h = h ^ (h >> _U32(15))
        h = h * _U32(0x846CA68B)
        h = h ^ (h >> _U32(16))
    return h.reshape(shape)


def _owen(x, seed):
    """Nested uniform (Owen) scramble of 32-bit fixed-point values ``x`` with per-value ``seed`` (Burley's
    Laine-Karras-style hash applied to the bit-reversed value: each bit flipped by a hash of the bits above)."""
    return _reverse_bits32(_laine_karras(_reverse_bits32(x), seed))


def _laine_karras(x, seed):
    """Burley's Laine-Karras-style permutation of 32-bit values (each bit flipped by a hash of the bits below)."""
    x = x ^ (x * _U32(0x3D20ADEA))
    x = x + seed
    x = x * ((seed >> _U32(16)) | _U32(1))
    x = x ^ (x * _U32(0x05526C56))
    return x ^ (x * _U32(0x53A22864))


def sobol_owen_2d(index, seed):
    """Points of Owen-scrambled 2-D Sobol' sequences: ``index`` (N,) (< 2^32) into the sequence whose
    scrambling seed is ``seed`` (N,) (one sequence per pixel and half-buffer). Returns (N, 2) in [0, 1).

    Each point is uniform on the square; the points ``0 .. 2^m - 1`` (and any aligned block of ``2^m``) of one
    sequence have exactly one point in each of the ``2^m`` elementary intervals ``2^-a x 2^-(m-a)``.
    """
    i = _u32(index)
    seed = _u32(seed)
    m = _U32(0xFF)
    y = _SOBOL1_BYTES[0][i & m]       # the XOR of the direction numbers of the index's set bits, a byte at a time
    for p in (1, 2, 3):
        hi = i >> _U32(8 * p)
        if hi.any():
            y = y ^ _SOBOL1_BYTES[p][hi & m]
    sx = _reverse_bits32(_laine_karras(i, hash32(seed, 0x68E31DA4)))    # _owen(x): x is i bit-reversed
    sy = _owen(y, hash32(seed, 0xB5297A4D))
    u = np.empty((i.shape[0], 2))
    u[:, 0] = sx
    u[:, 1] = sy
    u *= 2.0 ** -32
    return u


# --- padded dimensions: a pixel's samples stratified in every dimension pair -----------------------------------
# The camera rays' pixel positions are one stratified set per pixel; the random numbers their hits draw for light
# and BSDF samples were independent, so a pixel's spp light samples were i.i.d. Padding (Kollig & Keller 2002;
# pbrt's padded samplers) gives every dimension pair its own stratified set over the pixel's samples, the sample
# index shuffled by a per-pixel, per-dimension permutation so that the pairs are not correlated with each other:
# sample j of the pixel reads point pi_d(j) of an Owen-scrambled Sobol' (0,2)-sequence of its own. Each point is
# uniform on the square (unbiased); the spp points of one pixel and dimension are one stratified set.


def permutation_element(i, n, seed):
    """Element ``i`` of a pseudo-random permutation of ``[0, n)`` chosen by ``seed`` (arrays broadcast; int64).

    Kensler's hash-based permutation ("Correlated Multi-Jittered Sampling", Pixar 2013): a bijection of the
    next power of two above ``n`` made of invertible 32-bit steps, walked until it lands below ``n``, then
    rotated by the seed. Computed per element, so a pixel's samples need not be drawn together.
    """
    i, n, p = np.broadcast_arrays(_u32(i), _u32(n), _u32(seed))
    w = n - _U32(1)
    for s in (1, 2, 4, 8, 16):
        w = w | (w >> _U32(s))
    out = np.empty(i.shape, dtype=np.int64)
    todo = np.arange(i.size)
    x, ww, pp, nn = i.ravel().copy(), w.ravel(), p.ravel(), n.ravel()
    res = out.ravel()
    while todo.size:
        v, wk, pk = x[todo], ww[todo], pp[todo]
        v = v ^ pk
        v = v * _U32(0xE170893D)
        v = v ^ (pk >> _U32(16))
        v = v ^ ((v & wk) >> _U32(4))
        v = v ^ (pk >> _U32(8))
        v = v * _U32(0x0929EB3F)
        v = v ^ (pk >> _U32(23))
        v = v ^ ((v & wk) >> _U32(1))
        v = v * (_U32(1) | (pk >> _U32(27)))
        v = v * _U32(0x6935FA69)
        v = v ^ ((v & wk) >> _U32(11))
        v = v * _U32(0x74DCB303)
        v = v ^ ((v & wk) >> _U32(2))
        v = v * _U32(0x9E501CC3)
        v = v ^ ((v & wk) >> _U32(2))
        v = v * _U32(0xC860A3DF)
        v = v & wk
        v = v ^ (v >> _U32(5))
        nk = nn[todo]
        done = v < nk
        dn = todo[done]
        # the rotation by the seed in 64 bits: v + p may pass 2^32
        res[dn] = (v[done].astype(np.int64) + pk[done].astype(np.int64)) % nk[done].astype(np.int64)
        x[todo[~done]] = v[~done]
        todo = todo[~done]
    return out


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
