"""Directional-albedo tables of microfacet lobes: the "DFG" half of the split-sum approximation.

The split sum (Karis 2013, "Real Shading in Unreal Engine 4"; Lagarde & de Rousiers 2014, "Moving Frostbite to
PBR", section 4.9) approximates the light a glossy lobe reflects from an environment by the product of two
integrals: the environment prefiltered with the lobe (:func:`shaders.envmap.prefilter_latlong_ggx`) and the
lobe's directional albedo. With Schlick's Fresnel ``F = F0 + (1 - F0)(1 - v.h)^5`` the albedo is linear in
``F0``::

    int F(v.h) S(v, l) dl = F0 A(mu, alpha) + B(mu, alpha)
    A = int (1 - (1 - v.h)^5) S dl,   B = int (1 - v.h)^5 S dl,   S = D G / (4 |n.v|)   (f_spec cos_l, Fresnel-free)

with ``mu = n.v``. ``A + B`` is the Fresnel-free albedo (<= 1 with a Smith G). The diffuse lobe of glTF's
``fresnel_mix`` loses ``(1 - v.h)^5`` weighted by the cosine lobe, a function of ``mu`` alone::

    E5(mu) = int (1 - v.h)^5 cos(l) / pi dl,   h = normalize(v + l)

The tables are computed here by quadrature with the renderer's own lobe (:func:`shaders.brdfs.microfacet_spec_cos`,
so they agree with the BRDF for every geometry term): ``A``, ``B`` by visible-normal importance sampling (Heitz 2018)
with a Hammersley set per cell, whose weight ``S / pdf = G2 / G1(v)`` lies in [0, 1] (error below 2e-3 with 256
points: ``tests/test_split_sum.py`` compares against 4096), ``E5`` by a cosine-weighted Hammersley set.

Grid: ``mu`` at cell centres ``(i + 1/2) / n`` (the table is never needed at ``mu = 0``: callers clamp), and
``sqrt(alpha)`` (perceptual roughness) at ``j / (n - 1)``, which resolves the sharp lobes better than a grid in
``alpha``. :func:`lookup` interpolates bilinearly and clamps to the grid.
"""
from __future__ import annotations

import numpy as np

from . import brdfs as _brdfs
from . import microfacet as _mf
from . import sampling as _sampling
from .vec import reflect

#: smallest alpha the tables are built with (alpha = 0, a mirror, is the limit: A + B -> 1)
ALPHA_MIN = 1e-4


def _view_dirs(mu):
    """Unit views in the local frame (z = normal) with ``n.v = mu``, in the xz plane."""
    mu = np.asarray(mu, dtype=np.float64)
    return np.stack([np.sqrt(np.maximum(1.0 - mu * mu, 0.0)), np.zeros_like(mu), mu], axis=-1)


def grid(n_mu, n_r):
    """The table's nodes: ``mu`` (n_mu,) at cell centres in (0, 1), ``r = sqrt(alpha)`` (n_r,) in [0, 1]."""
    return (np.arange(n_mu) + 0.5) / n_mu, np.linspace(0.0, 1.0, n_r)


def specular_albedo_tables(n_mu=32, n_r=32, n_samples=256, geometry="smith_separable"):
    """``(A, B)`` (n_mu, n_r) each: the Schlick-Fresnel directional albedo ``F0 A + B`` of the GGX lobe.

    Parameters
    ----------
    n_mu, n_r : int
        Grid size in ``mu = n.v`` and ``r = sqrt(alpha)`` (:func:`grid`).
    n_samples : int
        Hammersley points per cell (visible-normal sampling).
    geometry : str
        The lobe's Smith term, as :func:`shaders.brdfs.microfacet_spec_cos` takes it.
    """
    mus, rs = grid(n_mu, n_r)
    alphas = np.maximum(rs * rs, ALPHA_MIN)
    u = _sampling.hammersley(n_samples)
    M, R = np.meshgrid(mus, alphas, indexing="ij")                 # (n_mu, n_r)
    mu_l = np.repeat(M.ravel(), n_samples)
    a_l = np.repeat(R.ravel(), n_samples)
    wo = _view_dirs(mu_l)
    uu = np.tile(u, (M.size, 1))
    h = _mf.sample_ggx_vndf(wo, uu, a_l)
    wi = reflect(wo, h)
    pdf = _mf.reflect_pdf(_mf.ggx_vndf_pdf(wo, h, a_l), wo, h)
    spec, cos_oh = _brdfs.microfacet_spec_cos(wo, wi, a_l, distribution="ggx", geometry=geometry)
    ok = (pdf > 0) & (wi[:, 2] > 0)
    w = np.divide(spec, pdf, out=np.zeros_like(spec), where=ok)
    x5 = (1.0 - cos_oh) ** 5
    A = (w * (1.0 - x5)).reshape(M.size, n_samples).mean(axis=1).reshape(M.shape)
    B = (w * x5).reshape(M.size, n_samples).mean(axis=1).reshape(M.shape)
    return A, B


def schlick_diffuse_loss_table(n_mu=32, n_samples=1024):
    """``E5(mu)`` (n_mu,): the cosine-weighted mean of ``(1 - v.h)^5`` over the hemisphere (see the module)."""
    mus, _ = grid(n_mu, 2)
    l = _sampling.square_to_cosine_hemisphere(_sampling.hammersley(n_samples))    # (K, 3)
    out = np.empty(n_mu)
    for i, mu in enumerate(mus):
        v = _view_dirs(mu)
        h = l + v
        h /= np.linalg.norm(h, axis=1, keepdims=True)
        out[i] = np.mean((1.0 - np.clip(h @ v, 0.0, 1.0)) ** 5)
    return out


def lookup(table, mu, alpha):
    """Bilinear lookup of an ``(n_mu, n_r)`` table at ``mu`` (N,) and ``alpha`` (N,) (clamped to the grid)."""
    n_mu, n_r = table.shape
    x = np.clip(np.asarray(mu, dtype=np.float64) * n_mu - 0.5, 0.0, n_mu - 1.0)
    y = np.clip(np.sqrt(np.maximum(np.asarray(alpha, dtype=np.float64), 0.0)) * (n_r - 1), 0.0, n_r - 1.0)
    i0 = np.minimum(x.astype(np.intp), n_mu - 2)
    j0 = np.minimum(y.astype(np.intp), n_r - 2)
    fx, fy = x - i0, y - j0
    return ((1 - fx) * (1 - fy) * table[i0, j0] + fx * (1 - fy) * table[i0 + 1, j0]
            + (1 - fx) * fy * table[i0, j0 + 1] + fx * fy * table[i0 + 1, j0 + 1])


def lookup_1d(table, mu):
    """Linear lookup of an ``(n_mu,)`` table (:func:`schlick_diffuse_loss_table`) at ``mu`` (N,), clamped."""
    n = table.shape[0]
    x = np.clip(np.asarray(mu, dtype=np.float64) * n - 0.5, 0.0, n - 1.0)
    i0 = np.minimum(x.astype(np.intp), n - 2)
    f = x - i0
    return (1 - f) * table[i0] + f * table[i0 + 1]


def dominant_direction(wo, n, alpha):
    """Frostbite's dominant direction of a GGX reflection lobe (Lagarde & de Rousiers 2014, listing 22):
    ``normalize(lerp(n, r, s (sqrt(s) + alpha)))``, ``s = 1 - alpha``, ``r`` the mirror direction of ``wo``
    about ``n`` (world (N, 3) arrays; ``alpha`` (N,)). The lobe's peak leans toward the normal as it widens."""
    r = reflect(wo, n)
    s = 1.0 - np.clip(alpha, 0.0, 1.0)
    f = (s * (np.sqrt(s) + alpha))[:, None]
    d = n + f * (r - n)
    return d / np.maximum(np.linalg.norm(d, axis=1, keepdims=True), 1e-300)
