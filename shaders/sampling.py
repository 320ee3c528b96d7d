"""Warping functions ``square_to_<dist>(u)`` from ``[0,1)^2`` and their solid-angle pdfs.

``u`` is ``(N, 2)``; directions are in a local frame with z up. Random numbers are passed in,
never drawn here.
"""
import numpy as np


def square_to_uniform_disk_concentric(u):
    """Shirley-Chiu concentric map to the unit disk, ``(N, 2)``."""
    a = 2.0 * u - 1.0
    x, y = a[:, 0], a[:, 1]
    zero = (x == 0) & (y == 0)
    use_x = np.abs(x) > np.abs(y)
    r = np.where(use_x, x, y)
    safe_x = np.where(x == 0, 1.0, x)
    safe_y = np.where(y == 0, 1.0, y)
    theta = np.where(use_x, (np.pi / 4) * (y / safe_x), np.pi / 2 - (np.pi / 4) * (x / safe_y))
    out = np.stack([r * np.cos(theta), r * np.sin(theta)], axis=1)
    out[zero] = 0.0
    return out


def square_to_cosine_hemisphere(u):
    """Cosine-weighted hemisphere (Malley's method), pdf = cos(theta) / pi. The height is ``sqrt((1 - r)(1 + r))`` of
    the concentric map's radius ``r = max(|2 u0 - 1|, |2 u1 - 1|)`` (well conditioned at the rim, where ``1 - |d|^2``
    of the rounded disk point loses every digit)."""
    d = square_to_uniform_disk_concentric(u)
    r = np.maximum(np.abs(2.0 * u[:, 0] - 1.0), np.abs(2.0 * u[:, 1] - 1.0))
    z = np.sqrt(np.maximum(0.0, (1.0 - r) * (1.0 + r)))
    return np.concatenate([d, z[:, None]], axis=1)


def cosine_hemisphere_pdf(w):
    """pdf of :func:`square_to_cosine_hemisphere` (solid angle)."""
    return np.where(w[:, 2] > 0, w[:, 2] / np.pi, 0.0)


def square_to_uniform_sphere(u):
    """Uniform direction on the unit sphere, pdf = 1 / (4 pi)."""
    z = 1.0 - 2.0 * u[:, 0]
    r = np.sqrt(np.maximum(0.0, 1.0 - z * z))
    phi = 2.0 * np.pi * u[:, 1]
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=1)


def uniform_sphere_pdf(w):
    """pdf of :func:`square_to_uniform_sphere`."""
    return np.full(w.shape[0], 1.0 / (4.0 * np.pi))


def square_to_uniform_cone(u, cos_max):
    """Uniform direction inside the cone ``theta <= theta_max`` around +z, pdf = 1 / (2 pi (1 - cos_max)).

    Parameters
    ----------
    u : (N, 2) float ndarray in [0, 1)^2
    cos_max : float or (N,) ndarray
        Cosine of the cone half-angle, in [-1, 1].

    Returns
    -------
    (N, 3) ndarray, unit directions (z = cone axis), dtype of ``u``.
    """
    cos_max = np.asarray(cos_max, dtype=u.dtype)
    z = 1.0 - u[:, 0] * (1.0 - cos_max)
    r = np.sqrt(np.maximum(0.0, 1.0 - z * z))
    phi = 2.0 * np.pi * u[:, 1]
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=1).astype(u.dtype, copy=False)


def uniform_cone_pdf(cos_max):
    """pdf of :func:`square_to_uniform_cone` inside the cone (the caller zeroes directions outside)."""
    one_minus = 1.0 - np.asarray(cos_max, dtype=np.float64)
    return np.divide(1.0, 2.0 * np.pi * one_minus, out=np.zeros_like(one_minus), where=one_minus > 0)


def radical_inverse_base2(i):
    """Van der Corput radical inverse in base 2 of non-negative integers ``i`` -> float64 in [0, 1)."""
    i = np.asarray(i, dtype=np.uint64)
    out = np.zeros(i.shape, dtype=np.float64)
    scale = 0.5
    for _ in range(32):  # enough for i < 2^32
        out += (i & np.uint64(1)) * scale
        i = i >> np.uint64(1)
        scale *= 0.5
    return out


def hammersley(n):
    """The ``n``-point Hammersley set ``((i + 1/2) / n, radical_inverse_2(i))``, (n, 2) float64.

    A deterministic, well-stratified point set for quadratures that must be noise-free (prefiltered
    environment maps, the preview estimator).
    """
    i = np.arange(n)
    return np.stack([(i + 0.5) / n, radical_inverse_base2(i)], axis=1)


def power_heuristic(pdf_f, pdf_g, beta=2.0, n_f=1, n_g=1):
    """Veach's power heuristic weight of strategy f: ``(n_f p_f)^beta / ((n_f p_f)^beta + (n_g p_g)^beta)``.

    ``beta = 1`` is the balance heuristic. Lanes where both densities are zero get weight 0 (no NaN).
    Densities may be ``inf`` for nothing here: callers pass finite solid-angle pdfs.
    """
    a = (n_f * np.asarray(pdf_f, dtype=np.float64)) ** beta
    b = (n_g * np.asarray(pdf_g, dtype=np.float64)) ** beta
    s = a + b
    return np.divide(a, s, out=np.zeros_like(s), where=s > 0)


def balance_heuristic(pdf_f, pdf_g, n_f=1, n_g=1):
    """Veach's balance heuristic ``n_f p_f / (n_f p_f + n_g p_g)`` (:func:`power_heuristic` with beta = 1)."""
    return power_heuristic(pdf_f, pdf_g, 1.0, n_f, n_g)
