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
