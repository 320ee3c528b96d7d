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
    """Cosine-weighted hemisphere (Malley's method), pdf = cos(theta) / pi."""
    d = square_to_uniform_disk_concentric(u)
    z = np.sqrt(np.maximum(0.0, 1.0 - np.einsum("ij,ij->i", d, d)))
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
