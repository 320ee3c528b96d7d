"""Punctual light kernels (radiometric units).

Each kernel returns, for shading points ``p`` (N, 3):
``wi`` unit direction toward the light, ``dist`` distance to the light (``inf`` for directional)
and ``E`` (N, 3): the irradiance the light delivers on a surface *perpendicular* to ``wi``
(W/m^2). The caller multiplies by ``f * cos(theta_i)``; a Lambertian surface of albedo rho
then has outgoing radiance ``rho / pi * E * cos(theta_i)``.

Units
-----
- point light: radiant intensity ``I`` (W/sr) per RGB channel; E = I / r^2.
- spot light: intensity ``I`` on the axis; E = I * falloff(cos theta) / r^2, where theta is
  the angle between the spot axis and the direction from the light to ``p``.
- directional light: irradiance ``E`` (W/m^2) on a surface perpendicular to the light.
"""
import numpy as np


def smoothstep(x, edge0, edge1):
    """Hermite smoothstep: 0 below ``edge0``, 1 above ``edge1``, ``3t^2 - 2t^3`` between."""
    denom = edge1 - edge0
    t = np.clip(np.divide(x - edge0, denom, out=np.where(x >= edge1, 1.0, 0.0).astype(np.result_type(x, 1.0)),
                          where=denom != 0), 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


def spot_falloff_smoothstep(cos_theta, cos_inner, cos_outer):
    """pbrt-v4 spot falloff: ``smoothstep(cos_theta; cos_outer, cos_inner)``.

    1 inside the inner cone, 0 outside the outer cone, monotone in between (in cos theta).
    """
    return smoothstep(cos_theta, cos_outer, cos_inner)


def point_light(p, light_pos, I):
    """Point light of intensity ``I`` (3,) W/sr at ``light_pos`` (3,).

    Returns ``wi, dist, E`` as described in the module docstring.
    """
    d = np.asarray(light_pos, dtype=np.float64) - p
    dist2 = np.einsum("ij,ij->i", d, d)
    dist = np.sqrt(dist2)
    inv = np.divide(1.0, dist, out=np.zeros_like(dist), where=dist > 0)
    wi = d * inv[:, None]
    E = np.asarray(I, dtype=np.float64)[None, :] * (inv * inv)[:, None]
    return wi, dist, E


def spot_light(p, light_pos, axis, I, cos_inner, cos_outer, falloff=spot_falloff_smoothstep):
    """Spot light at ``light_pos`` pointing along unit ``axis``, on-axis intensity ``I`` (W/sr).

    ``falloff(cos_theta, cos_inner, cos_outer)`` shapes the cone (default: pbrt smoothstep).
    """
    wi, dist, E = point_light(p, light_pos, I)
    cos_theta = -(wi @ np.asarray(axis, dtype=np.float64))
    return wi, dist, E * falloff(cos_theta, cos_inner, cos_outer)[:, None]


def directional_light(p, direction, E):
    """Directional light travelling along unit ``direction`` with perpendicular irradiance ``E``."""
    n = p.shape[0]
    wi = np.broadcast_to(-np.asarray(direction, dtype=np.float64), (n, 3)).copy()
    return wi, np.full(n, np.inf), np.broadcast_to(np.asarray(E, dtype=np.float64), (n, 3)).copy()
