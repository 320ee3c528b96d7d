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
    k = math.isqrt(spp)
    row = ((s + 1) * k - 1) // spp                  # the j with floor(j spp / k) <= s < floor((j+1) spp / k)
    first = row * spp // k
    n_row = (row + 1) * spp // k - first
    xi = rng.random((s.shape[0], 2))
    u = np.empty_like(xi)
    u[:, 0] = (s - first + xi[:, 0]) / n_row
    u[:, 1] = (first + xi[:, 1] * n_row) / spp
    return u
