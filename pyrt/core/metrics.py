"""Image error metrics shared by adaptive sampling, the tests and the benchmarks.

relMSE (relative mean squared error, Rousselle et al. 2011) is the metric pyrt's adaptive renderer targets
and its benchmarks report::

    relMSE(I, R) = mean over pixels and channels of (I - R)^2 / (R^2 + eps),  eps = 1e-2

``eps`` keeps black pixels from dominating; it is in the image's units (radiance), so compare images at the
same exposure. The adaptive renderer's *estimate* replaces ``(I - R)^2`` by the estimated variance of each
pixel's mean and ``R`` by the pixel mean (:func:`estimated_relmse`).
"""
from __future__ import annotations

import numpy as np

#: the denominator's offset in relMSE (radiance units)
RELMSE_EPS = 1e-2


def relmse(image, reference, eps=RELMSE_EPS):
    """relMSE of ``image`` against ``reference`` (same shape, (..., 3) linear radiance): a float.

    ``mean((image - reference)^2 / (reference^2 + eps))`` over every pixel and channel, in float64.
    """
    a = np.asarray(image, dtype=np.float64)
    r = np.asarray(reference, dtype=np.float64)
    if a.shape != r.shape:
        raise ValueError(f"relmse: image shape {a.shape} differs from the reference's {r.shape}")
    return float(np.mean((a - r) ** 2 / (r * r + eps)))


def relmse_per_pixel(variance, mean, eps=RELMSE_EPS):
    """Per-pixel relative error ``mean over channels of variance / (mean^2 + eps)`` ((N, 3) -> (N,))."""
    v = np.asarray(variance, dtype=np.float64)
    m = np.asarray(mean, dtype=np.float64)
    acc, r = np.zeros(v.shape[:-1]), np.empty(v.shape[:-1])
    for c in range(v.shape[-1]):                    # channel by channel in two buffers: the sums np.mean makes,
        np.multiply(m[..., c], m[..., c], out=r)    # without its strided reduction or an (N, 3) temporary (the
        r += eps                                    # adaptive renderer calls it per pass)
        np.divide(v[..., c], r, out=r)
        acc += r
    acc /= v.shape[-1]
    return acc


def estimated_relmse(variance, mean, eps=RELMSE_EPS):
    """The relMSE an image would have against the converged one, estimated from the variance of its pixel
    means: ``mean(variance / (mean^2 + eps))`` (bias: uses the noisy mean in the denominator)."""
    return float(np.mean(relmse_per_pixel(variance, mean, eps)))
