"""Microfacet terms and samplers (shaders/microfacet.py).

Ground truth: closed forms and numerical integrals over the hemisphere. The quadrature is a
Gauss-Legendre rule in s with theta = (pi/2) s^4 (clusters nodes at the normal, where the lobes
peak) times a midpoint rule in phi. Error, measured by doubling the resolution: < 1e-13 for the
isotropic (1-D) integrals; < 3e-5 relative for the 2-D ones (the max(0, wo.h) kink limits the
phi rule), under the 2e-4 tolerances used with them.
"""
import functools
import math

import numpy as np
import pytest
from scipy import stats

from pyrt.shaders import microfacet as mf


@functools.lru_cache(maxsize=None)
def _theta_nodes(n=800):
    s, w = np.polynomial.legendre.leggauss(n)
    s = 0.5 * (s + 1.0)
    w = 0.5 * w
    theta = 0.5 * np.pi * s ** 4
    dtheta = 2.0 * np.pi * s ** 3 * w  # d theta / ds * weight
    return theta, dtheta


def hemisphere_integral(g, n_theta=800, n_phi=1, isotropic=True):
    """Integrate g(h) over the upper hemisphere (solid angle); g takes (N, 3) unit vectors."""
    theta, dtheta = _theta_nodes(n_theta)
    if isotropic:
        h = np.stack([np.sin(theta), np.zeros_like(theta), np.cos(theta)], axis=1)
        return float(np.sum(g(h) * np.sin(theta) * dtheta) * 2.0 * np.pi)
    phi = (np.arange(n_phi) + 0.5) / n_phi * 2.0 * np.pi
    T, P = np.meshgrid(theta, phi, indexing="ij")
    W = np.broadcast_to((np.sin(theta) * dtheta)[:, None], T.shape) * (2.0 * np.pi / n_phi)
    h = np.stack([np.sin(T) * np.cos(P), np.sin(T) * np.sin(P), np.cos(T)], axis=-1).reshape(-1, 3)
    return float(np.sum(g(h) * W.reshape(-1)))


ALPHAS = [0.01, 0.05, 0.2, 0.5, 1.0]


@pytest.mark.parametrize("alpha", ALPHAS)
@pytest.mark.parametrize("dist", ["ggx", "beckmann", "blinn"])
def test_ndf_projected_area_is_one(dist, alpha):
    val = hemisphere_integral(lambda h: mf.ndf(h[:, 2], alpha, dist) * h[:, 2])
    assert val == pytest.approx(1.0, abs=1e-4)


@pytest.mark.parametrize("exponent", [0.0, 1.0, 10.0, 1000.0])
def test_blinn_d_normalised_for_exponents(exponent):
    val = hemisphere_integral(lambda h: mf.blinn_d(h[:, 2], exponent) * h[:, 2])
    assert val == pytest.approx(1.0, abs=1e-4)


@pytest.mark.parametrize("alpha", [0.1, 0.4, 1.0])
@pytest.mark.parametrize("theta_o", [0.0, 45.0, 80.0, 89.0])
@pytest.mark.parametrize("dist", ["ggx", "beckmann"])
def test_smith_g1_satisfies_visible_area_identity(dist, alpha, theta_o):
    """Exact Smith masking: int G1(wo) max(0, wo.h) D(h) dw_h = cos(theta_o) (Heitz 2014, eq. 2)."""
    t = math.radians(theta_o)
    wo = np.array([math.sin(t), 0.0, math.cos(t)])
    g1 = mf.smith_g1(np.array([wo[2]]), alpha, dist)[0]
    val = hemisphere_integral(lambda h: np.maximum(h @ wo, 0.0) * mf.ndf(h[:, 2], alpha, dist),
                              n_theta=300, n_phi=192, isotropic=False)
    assert g1 * val == pytest.approx(wo[2], rel=2e-4, abs=1e-6)


def test_ggx_lambda_closed_form_value():
    # alpha 0.5, theta 60 deg: tan^2 = 3, Lambda = (sqrt(1 + 0.75) - 1) / 2
    lam = mf.ggx_lambda(np.array([0.5]), 0.5)[0]
    assert lam == pytest.approx((math.sqrt(1.75) - 1) / 2, rel=1e-12)


def test_beckmann_lambda_matches_erf_formula():
    cos = np.linspace(0.05, 0.99, 30)
    alpha = 0.3
    a = cos / (alpha * np.sqrt(1 - cos ** 2))
    ref = np.array([(math.erf(x) - 1) / 2 + math.exp(-x * x) / (2 * x * math.sqrt(math.pi)) for x in a])
    np.testing.assert_allclose(mf.beckmann_lambda(cos, alpha), ref, rtol=1e-5, atol=1e-9)


def test_erfc_accuracy():
    x = np.linspace(-4, 8, 2001)
    ref = np.array([math.erfc(v) for v in x])
    assert np.max(np.abs(mf.erfc(x) / ref - 1)) < 1.2e-7


@pytest.mark.parametrize("geometry", mf.GEOMETRY_TERMS)
@pytest.mark.parametrize("dist", mf.DISTRIBUTIONS)
def test_g_in_unit_interval_and_zero_at_horizon(dist, geometry):
    rng = np.random.default_rng(1)
    n = 4000
    co = np.concatenate([rng.random(n), [0.0, 1.0, 1e-9]])
    ci = np.concatenate([rng.random(n), [0.5, 1.0, 0.5]])
    wo = np.stack([np.sqrt(1 - co ** 2), np.zeros_like(co), co], 1)
    phi = rng.random(co.size) * 2 * np.pi
    wi = np.stack([np.sqrt(1 - ci ** 2) * np.cos(phi), np.sqrt(1 - ci ** 2) * np.sin(phi), ci], 1)
    h = wo + wi
    h /= np.linalg.norm(h, axis=1, keepdims=True)
    for alpha in (0.0, 0.05, 0.5, 1.0):
        g = mf.g2(co, ci, h[:, 2], np.sum(wo * h, 1), alpha, dist, geometry)
        assert np.all(np.isfinite(g)) and np.all((g >= 0) & (g <= 1))
        if geometry not in ("vgroove", "none"):
            assert g[n] == 0.0  # wo at the horizon


def test_correlated_smith_between_separable_and_min_g1():
    co = np.linspace(0.01, 1, 50)[:, None] * np.ones((1, 50))
    ci = co.T
    co, ci = co.ravel(), ci.ravel()
    for dist in ("ggx", "beckmann"):
        sep = mf.smith_g2_separable(co, ci, 0.6, dist)
        cor = mf.smith_g2_correlated(co, ci, 0.6, dist)
        gmin = np.minimum(mf.smith_g1(co, 0.6, dist), mf.smith_g1(ci, 0.6, dist))
        assert np.all(sep <= cor + 1e-15) and np.all(cor <= gmin + 1e-15)


def test_schlick_k_half_alpha_matches_smith_ggx_at_grazing_slope():
    # both go like 2 cos / alpha as cos -> 0
    alpha = 0.4
    c = np.array([1e-6])
    ratio = mf.schlick_g1(c, mf.schlick_k(alpha)) / mf.smith_g1(c, alpha, "ggx")
    assert ratio[0] == pytest.approx(1.0, rel=1e-4)


def test_schlick_ue4_k_value():
    assert mf.schlick_k_ue4_direct(0.5) == pytest.approx(1.5 ** 2 / 8)


def test_vgroove_value():
    # co = ci = 0.5, n.h = 1 (mirror configuration) -> o.h = 0.5: min(1, 2*1*0.5/0.5) = 1
    assert mf.vgroove_g(np.array([0.5]), np.array([0.5]), np.array([1.0]), np.array([0.5]))[0] == 1.0
    # grazing-ish: 2 * 0.9 * 0.1 / 0.6 = 0.3
    assert mf.vgroove_g(np.array([0.1]), np.array([0.8]), np.array([0.9]), np.array([0.6]))[0] == pytest.approx(0.3)


def test_roughness_mapping_and_blinn_equivalence():
    assert mf.roughness_to_alpha(0.5) == 0.25
    a = np.array([0.05, 0.3, 0.9])
    np.testing.assert_allclose(mf.alpha_from_blinn_exponent(mf.blinn_exponent_from_alpha(a)), a)


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_terms_keep_dtype_and_are_finite_at_extremes(dtype):
    c = np.array([0.0, 1e-7, 0.5, 1.0], dtype=dtype)
    for alpha in (0.0, 1e-4, 1.0):
        for f in (mf.ggx_d, mf.beckmann_d):
            d = f(c, alpha)
            assert d.dtype == dtype and np.all(np.isfinite(d))
        for dist in ("ggx", "beckmann"):
            g = mf.smith_g1(c, alpha, dist)
            assert g.dtype == dtype and np.all(np.isfinite(g))
    u = np.array([[0.0, 0.0], [0.999999, 0.5], [0.5, 0.999999]], dtype=dtype)
    wo = np.array([[0, 0, 1], [0.6, 0, 0.8], [1, 0, 0]], dtype=dtype)
    for h in (mf.sample_ggx_ndf(u, 0.3), mf.sample_beckmann_ndf(u, 0.3), mf.sample_ggx_vndf(wo, u, 0.3)):
        assert h.dtype == dtype and np.all(np.isfinite(h))
        np.testing.assert_allclose(np.linalg.norm(h.astype(np.float64), axis=1), 1.0, atol=1e-5)


# ----------------------------------------------------------------------------- sampling


@pytest.mark.parametrize("alpha", [0.1, 0.5, 1.0])
@pytest.mark.parametrize("theta_o", [0.0, 60.0, 85.0])
def test_ggx_vndf_pdf_integrates_to_one(alpha, theta_o):
    t = math.radians(theta_o)
    wo = np.array([[math.sin(t), 0.0, math.cos(t)]])
    val = hemisphere_integral(lambda h: mf.ggx_vndf_pdf(np.repeat(wo, h.shape[0], 0), h, alpha),
                              n_theta=300, n_phi=192, isotropic=False)
    assert val == pytest.approx(1.0, abs=2e-4)


def _chi2_pvalue(h, pdf_fn, alpha_bins, n_v=16, n_phi=12, sub=8):
    """Chi-square of half-vector samples against a solid-angle pdf.

    Bins: v = cos-based CDF of a GGX(alpha_bins) NDF (so bins follow the lobe) x uniform phi.
    Expected counts integrate the pdf over each bin (dw = d cos d phi) with a ``sub``-point
    Gauss-Legendre rule in cos theta and a 2 ``sub``-point midpoint rule in phi; bins with
    expectation < 5 are pooled.
    """
    a2 = alpha_bins ** 2
    n = h.shape[0]

    def cos_of_v(v):  # GGX NDF cdf in cos theta: v = 1 - (1 - c^2)... inverse of sample_ggx_ndf
        return np.sqrt((1.0 - v) / (1.0 - v + a2 * v))

    c = np.clip(h[:, 2], 0.0, 1.0)
    v = (1.0 - c * c) / (1.0 - c * c + a2 * c * c)  # inverse of cos_of_v
    phi = np.mod(np.arctan2(h[:, 1], h[:, 0]), 2 * np.pi)
    obs, _, _ = np.histogram2d(v, phi, bins=[n_v, n_phi], range=[[0, 1], [0, 2 * np.pi]])
    exp = np.zeros_like(obs)
    gx, gw = np.polynomial.legendre.leggauss(sub)
    for i in range(n_v):
        c_hi, c_lo = cos_of_v(i / n_v), cos_of_v((i + 1) / n_v)
        cs = c_lo + 0.5 * (gx + 1.0) * (c_hi - c_lo)
        wc = 0.5 * gw * (c_hi - c_lo)
        for j in range(n_phi):
            ps = (j + (np.arange(2 * sub) + 0.5) / (2 * sub)) * 2 * np.pi / n_phi
            C, P = np.meshgrid(cs, ps, indexing="ij")
            s = np.sqrt(1 - C ** 2)
            hh = np.stack([s * np.cos(P), s * np.sin(P), C], -1).reshape(-1, 3)
            vals = pdf_fn(hh).reshape(C.shape)
            exp[i, j] = np.sum(vals * wc[:, None]) / (2 * sub) * (2 * np.pi / n_phi) * n
    obs, exp = obs.ravel(), exp.ravel()
    big = exp >= 5
    o = np.append(obs[big], obs[~big].sum())
    e = np.append(exp[big], exp[~big].sum())
    keep = e > 0
    stat = np.sum((o[keep] - e[keep]) ** 2 / e[keep])
    return stats.chi2.sf(stat, keep.sum() - 1), exp.sum() / n


@pytest.mark.parametrize("alpha", [0.2, 0.7])
@pytest.mark.parametrize("theta_o", [0.0, 50.0, 85.0])
def test_ggx_vndf_samples_match_pdf_chi2(alpha, theta_o):
    rng = np.random.default_rng(12345)
    t = math.radians(theta_o)
    n = 100_000
    wo = np.tile([math.sin(t), 0.0, math.cos(t)], (n, 1))
    h = mf.sample_ggx_vndf(wo, rng.random((n, 2)), alpha)
    p, mass = _chi2_pvalue(h, lambda hh: mf.ggx_vndf_pdf(np.repeat(wo[:1], hh.shape[0], 0), hh, alpha), alpha)
    assert mass == pytest.approx(1.0, abs=2e-3)
    assert p > 1e-3


@pytest.mark.parametrize("alpha", [0.2, 0.7])
@pytest.mark.parametrize("dist,sampler", [("ggx", mf.sample_ggx_ndf), ("beckmann", mf.sample_beckmann_ndf)])
def test_ndf_samples_match_pdf_chi2(dist, sampler, alpha):
    rng = np.random.default_rng(7)
    h = sampler(rng.random((100_000, 2)), alpha)
    p, mass = _chi2_pvalue(h, lambda hh: mf.ndf_pdf(hh, alpha, dist), alpha)
    assert mass == pytest.approx(1.0, abs=2e-3)
    assert p > 1e-3


def test_chi2_detects_a_wrong_pdf():
    # the test has power: GGX samples against the Beckmann pdf of the same alpha fail
    rng = np.random.default_rng(7)
    h = mf.sample_ggx_ndf(rng.random((100_000, 2)), 0.5)
    p, _ = _chi2_pvalue(h, lambda hh: mf.ndf_pdf(hh, 0.5, "beckmann"), 0.5)
    assert p < 1e-6


def test_reflect_pdf_jacobian():
    wo = np.array([[0.0, 0.0, 1.0]])
    h = np.array([[0.0, 0.0, 1.0]])
    assert mf.reflect_pdf(np.array([2.0]), wo, h)[0] == pytest.approx(0.5)
