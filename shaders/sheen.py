"""Sheen kernels (``KHR_materials_sheen``): the Charlie distribution (Estevez & Kulla 2017), Neubelt & Pettineo's
visibility, the white sheen lobe ``D V cos`` and its directional albedo ``E(mu, r)``, tabulated by quadrature on first
use (the layering over a base: :class:`pyrt.materials.Sheen`)."""
from __future__ import annotations

import functools
import math

import numpy as np

from .vec import half_vector

#: the sheen roughness's floor (``a = r^2`` >= 1e-4 keeps ``sin^(1/a)`` finite)
MIN_ROUGHNESS = 0.01
#: the (mu, r) grid of the directional-albedo table and its quadrature (midpoint in cos theta_i and phi)
TABLE_MU, TABLE_R, QUAD_T, QUAD_P = 32, 32, 96, 96


def charlie_d(cos_h, alpha):
    """The Charlie sheen distribution ``(2 + 1/a) sin(theta_h)^(1/a) / (2 pi)`` (Estevez & Kulla 2017) at ``cos_h``
    (N,), ``alpha`` (N,) or a number; normalised: ``int D cos_h d omega_h = 1`` (tested)."""
    inv = 1.0 / np.asarray(alpha, dtype=np.float64)
    sin2 = np.clip(1.0 - np.asarray(cos_h, dtype=np.float64) ** 2, 0.0, 1.0)
    return (2.0 + inv) * np.power(sin2, 0.5 * inv) / (2.0 * math.pi)


def neubelt_v(cos_o, cos_i):
    """Neubelt & Pettineo's sheen visibility ``1 / (4 (cos_i + cos_o - cos_i cos_o))`` (both > 0)."""
    return 1.0 / (4.0 * (cos_i + cos_o - cos_i * cos_o))


def sheen_f_cos(wo, wi, alpha):
    """``D_charlie V cos_i`` (N,) for local directions (white sheen); 0 where either is below the surface."""
    co, ci = wo[:, 2], wi[:, 2]
    ok = (co > 0) & (ci > 0)
    h, _ = half_vector(wo, wi)
    f = charlie_d(h[:, 2], alpha) * neubelt_v(np.where(ok, co, 1.0), np.where(ok, ci, 1.0)) * ci
    return np.where(ok, f, 0.0)


@functools.lru_cache(maxsize=1)
def albedo_table():
    """(TABLE_MU, TABLE_R) directional albedo of the white sheen lobe on a grid of ``mu`` in [0.001, 1] and ``r`` in
    [MIN_ROUGHNESS, 1], endpoints included (``mu = 1``, normal view, is a common query)."""
    c = (np.arange(QUAD_T) + 0.5) / QUAD_T
    ph = (np.arange(QUAD_P) + 0.5) / QUAD_P * 2 * math.pi
    C, P = np.meshgrid(c, ph, indexing="ij")
    s = np.sqrt(1 - C * C)
    wi = np.stack([s * np.cos(P), s * np.sin(P), C], -1).reshape(-1, 3)
    table = np.empty((TABLE_MU, TABLE_R))
    mus = np.linspace(1e-3, 1.0, TABLE_MU)
    rs = np.linspace(MIN_ROUGHNESS, 1.0, TABLE_R)
    for i, mu in enumerate(mus):
        wo = np.tile([math.sqrt(1 - mu * mu), 0.0, mu], (wi.shape[0], 1))
        for j, r in enumerate(rs):
            table[i, j] = sheen_f_cos(wo, wi, r * r).sum() * (2 * math.pi / wi.shape[0])
    return mus, rs, table


def sheen_albedo(mu, r):
    """Directional albedo ``E(mu, r)`` (N,) of the white sheen lobe at ``mu = n.v`` and roughness ``r``: bilinear in
    the table of :func:`albedo_table` (midpoint quadrature, 96 x 96 directions per grid point)."""
    mus, rs, table = albedo_table()
    mu = np.clip(np.asarray(mu, dtype=np.float64), mus[0], mus[-1])
    r = np.clip(np.broadcast_to(np.asarray(r, dtype=np.float64), mu.shape), rs[0], rs[-1])
    x = (mu - mus[0]) / (mus[1] - mus[0])
    y = (r - rs[0]) / (rs[1] - rs[0])
    i0 = np.minimum(np.floor(x).astype(np.int64), TABLE_MU - 2)
    j0 = np.minimum(np.floor(y).astype(np.int64), TABLE_R - 2)
    fx, fy = x - i0, y - j0
    return ((1 - fx) * (1 - fy) * table[i0, j0] + fx * (1 - fy) * table[i0 + 1, j0]
            + (1 - fx) * fy * table[i0, j0 + 1] + fx * fy * table[i0 + 1, j0 + 1])
