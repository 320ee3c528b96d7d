"""Contracts every registered material keeps, parametrised over the registry (no hand-kept list).

A new material is one kernel in ``shaders/`` and one class registered in ``pyrt.MATERIALS``; these tests
pick it up through ``cls.example()``. Ground truth: deterministic quadrature of ``f_cos`` over the
hemisphere (tensor Gauss-Legendre in theta with a ``s^4`` substitution that resolves glossy peaks, midpoint
in phi); Monte Carlo tolerances from the estimator's standard error; a chi-square test of the sampled
directions against ``pdf``.
"""
import math

import numpy as np
import pytest

import pyrt
from material_helpers import LocalCtx, chi_square_cells_p, direction
from pyrt.materials import CosineQuery, IsotropicMaterial
from pyrt.shaders.vec import dot

NAMES = sorted(pyrt.MATERIALS)
#: materials with a non-delta lobe (the ones f_cos / sample / pdf describe)
GLOSSY = [n for n in NAMES if pyrt.MATERIALS[n].has_diffuse]
DELTA = [n for n in NAMES if pyrt.MATERIALS[n].has_delta]


def _hemisphere_quadrature(n_theta=160, n_phi=192):
    """Directions (M, 3) and solid-angle weights (M,) over the upper hemisphere; theta = pi/2 s^4 clusters
    nodes near the normal where glossy lobes peak. Error for the smooth lobes here: < 1e-3 relative."""
    gx, gw = np.polynomial.legendre.leggauss(n_theta)
    s, ws = 0.5 * (gx + 1), 0.5 * gw
    th = 0.5 * np.pi * s ** 4
    dth = 2 * np.pi * s ** 3 * ws
    ph = (np.arange(n_phi) + 0.5) / n_phi * 2 * np.pi
    T, P = np.meshgrid(th, ph, indexing="ij")
    w = np.stack([np.sin(T) * np.cos(P), np.sin(T) * np.sin(P), np.cos(T)], -1).reshape(-1, 3)
    dw = ((np.sin(th) * dth)[:, None] * np.full((1, n_phi), 2 * np.pi / n_phi)).reshape(-1)
    return w, dw


QUAD_W, QUAD_DW = _hemisphere_quadrature()


def _albedo(mat, wo):
    """Directional albedo (3,) of the non-delta lobes toward ``wo`` by quadrature: the upper hemisphere, plus
    for a material that ``transmits`` the lower one (the mirrored nodes) with the transmitted radiance's
    1/ior^2 compression undone (energy = reflected + transmitted power fraction)."""
    n = QUAD_W.shape[0]
    rho = np.sum(mat.f_cos(np.tile(wo, (n, 1)), QUAD_W, LocalCtx(n)) * QUAD_DW[:, None], axis=0)
    if mat.transmits:
        below = QUAD_W * [1.0, 1.0, -1.0]
        rho = rho + mat.ior ** 2 * np.sum(mat.f_cos(np.tile(wo, (n, 1)), below, LocalCtx(n)) * QUAD_DW[:, None], axis=0)
    return rho


@pytest.mark.parametrize("name", NAMES)
def test_registered_under_its_type_name_with_an_example(name):
    cls = pyrt.MATERIALS[name]
    assert cls.type_name == name and issubclass(cls, pyrt.Material)
    mat = cls.example()
    assert isinstance(mat, cls)
    assert isinstance(mat.emits, bool) and isinstance(mat.lambertian, bool)
    assert mat.is_dielectric == (mat.ior is not None)


@pytest.mark.parametrize("name", GLOSSY)
def test_f_cos_is_finite_non_negative_and_zero_below_the_horizon(name):
    mat = pyrt.MATERIALS[name].example()
    rng = np.random.default_rng(1)
    wo = rng.normal(size=(4000, 3))
    wi = rng.normal(size=(4000, 3))
    wo /= np.linalg.norm(wo, axis=1, keepdims=True)
    wi /= np.linalg.norm(wi, axis=1, keepdims=True)
    wo[:, 2] = np.abs(wo[:, 2])
    wo[:10, 2] = 0.0                                     # grazing viewer
    wo[:10] /= np.linalg.norm(wo[:10], axis=1, keepdims=True)
    f = mat.f_cos(wo, wi, LocalCtx(4000))
    assert f.shape == (4000, 3) and f.dtype == np.float64
    assert np.all(np.isfinite(f)) and np.all(f >= 0)
    if not mat.transmits:                                # a transmission lobe lives below the horizon
        assert np.all(f[wi[:, 2] <= 0] == 0)
    assert f.max() > 0


def _reciprocity_pair(mat):
    rng = np.random.default_rng(2)
    a = np.abs(rng.normal(size=(2000, 3)))
    b = rng.normal(size=(2000, 3))
    b[:, 2] = np.abs(b[:, 2]) + 0.05
    a /= np.linalg.norm(a, axis=1, keepdims=True)
    b /= np.linalg.norm(b, axis=1, keepdims=True)
    return mat.f_cos(a, b, LocalCtx(2000)) / b[:, 2:3], mat.f_cos(b, a, LocalCtx(2000)) / a[:, 2:3]


@pytest.mark.parametrize("name", [n for n in GLOSSY if pyrt.MATERIALS[n].reciprocal])
def test_reciprocity_where_declared(name):
    f_ab, f_ba = _reciprocity_pair(pyrt.MATERIALS[name].example())
    np.testing.assert_allclose(f_ab, f_ba, rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("name", [n for n in GLOSSY if not pyrt.MATERIALS[n].reciprocal
                                  and not pyrt.MATERIALS[n].transmits])
def test_declared_non_reciprocal_models_are_not_reciprocal(name):
    f_ab, f_ba = _reciprocity_pair(pyrt.MATERIALS[name].example())
    assert np.max(np.abs(f_ab - f_ba)) > 1e-3


@pytest.mark.parametrize("name", GLOSSY)
@pytest.mark.parametrize("theta_o", [0.0, 45.0, 80.0])
def test_energy_conservation_white_furnace(name, theta_o):
    """Directional albedo <= 1 per channel (quadrature error < 1e-3; the classic models are not energy
    conserving by construction and are checked only for finiteness)."""
    mat = pyrt.MATERIALS[name].example()
    rho = _albedo(mat, direction(theta_o))
    assert np.all(np.isfinite(rho)) and np.all(rho >= 0)
    if mat.reciprocal:
        assert np.all(rho <= 1.0 + 2e-3), rho


@pytest.mark.parametrize("name", GLOSSY)
@pytest.mark.parametrize("theta_o", [20.0, 70.0])
def test_sample_weight_and_pdf_are_consistent(name, theta_o):
    """sample() gives weight = f_cos / pdf with pdf = pdf(); E[weight] = albedo (5 standard errors)."""
    mat = pyrt.MATERIALS[name].example()
    n = 60_000
    wo = np.tile(direction(theta_o, 30.0), (n, 1))
    wi, weight, pdf = mat.sample(wo, np.random.default_rng(3).random((n, 2)), LocalCtx(n))
    up = (wi[:, 2] > 0) | (mat.transmits & (wi[:, 2] < 0))    # the lobes' support (full sphere: transmission)
    k = int(up.sum())
    np.testing.assert_allclose(pdf[up], mat.pdf(wo[up], wi[up], LocalCtx(k)), rtol=1e-9)
    ok = up & (pdf > 0)
    np.testing.assert_allclose(weight[ok] * pdf[ok][:, None], mat.f_cos(wo[ok], wi[ok], LocalCtx(int(ok.sum()))),
                               rtol=1e-9, atol=1e-300)
    assert np.all(np.isfinite(weight)) and np.all(weight[~up] == 0)
    rho = _albedo(mat, wo[0])
    if mat.transmits:                                    # E[weight] counts transmission with its 1/ior^2
        weight = np.where((wi[:, 2] < 0)[:, None], weight * mat.ior ** 2, weight)
    mean, se = weight.mean(0), weight.std(0) / math.sqrt(n)
    assert np.all(np.abs(mean - rho) <= 5 * se + 2e-3), (mean, rho, se)


def _chi_square_p(mat, theta_o):
    """p-value of the chi-square test of ``mat.sample`` against ``mat.pdf``: histogram of 200k sampled directions over
    12 x 24 (cos theta, phi) cells of the upper hemisphere against the pdf integrated over each cell
    (:func:`material_helpers.chi_square_cells_p`); cells with expectation < 5 are pooled with the samples below the
    horizon."""
    n, nt, nphi = 200_000, 12, 24
    wo_d = direction(theta_o, 10.0)
    wi, _, _ = mat.sample(np.tile(wo_d, (n, 1)), np.random.default_rng(4).random((n, 2)), LocalCtx(n))
    return chi_square_cells_p(lambda w: mat.pdf(np.tile(wo_d, (w.shape[0], 1)), w, LocalCtx(w.shape[0])), wi,
                              wi[:, 2] > 0, np.linspace(0.0, 1.0, nt + 1), np.linspace(-np.pi, np.pi, nphi + 1))


@pytest.mark.parametrize("name", GLOSSY)
@pytest.mark.parametrize("theta_o", [30.0, 75.0])
def test_sampled_directions_follow_pdf_chi_square(name, theta_o):
    """Sampled directions are distributed as pdf() says (rejected at p < 1e-4)."""
    assert _chi_square_p(pyrt.MATERIALS[name].example(), theta_o) > 1e-4


def test_chi_square_harness_rejects_a_wrong_pdf():
    """The harness can fail: a Cook-Torrance whose pdf() claims a 20 % wider lobe than it samples."""
    class Wrong(pyrt.CookTorrance):
        def _spec_pdf(self, wo, wi, alpha, aniso=None):
            return super()._spec_pdf(wo, wi, alpha * 1.2, aniso)

    assert _chi_square_p(Wrong(kd=0.0, ks=1.0, roughness=0.4), 30.0) < 1e-6


@pytest.mark.parametrize("name", [n for n in GLOSSY if issubclass(pyrt.MATERIALS[n], IsotropicMaterial)])
def test_isotropic_fast_path_equals_local_frame(name):
    """The world-space cosine query (the dispatcher's fast path) equals f_cos in the local frame."""
    mat = pyrt.MATERIALS[name].example()
    rng = np.random.default_rng(5)
    wo = rng.normal(size=(3000, 3))
    wo[:, 2] = np.abs(wo[:, 2])
    wo /= np.linalg.norm(wo, axis=1, keepdims=True)
    wi = rng.normal(size=(3000, 3))
    wi /= np.linalg.norm(wi, axis=1, keepdims=True)
    ctx = LocalCtx(3000, wo=wo)
    fast = mat.f_cos_cosines(CosineQuery(ctx, None, wi, dot(wi, ctx.ns), dot(wo, ctx.ns)))
    np.testing.assert_allclose(fast, mat.f_cos(wo, wi, ctx), rtol=1e-12, atol=1e-15)


@pytest.mark.parametrize("name", DELTA)
@pytest.mark.parametrize("theta_o", [0.0, 40.0, 85.0])
def test_delta_lobes_conserve_energy(name, theta_o):
    """Reflected weight + refracted weight * eta^2 (radiance compression undone) <= 1, both finite and >= 0;
    lobe directions with weight are unit length, reflection mirrors wo about the normal."""
    mat = pyrt.MATERIALS[name].example()
    wo = np.tile(direction(theta_o, 20.0), (8, 1))
    ctx = LocalCtx(8)
    ctx.front[4:] = False                                 # the inside of a dielectric too
    total = np.zeros((8, 3))
    for lobe in mat.delta_lobes(wo, ctx):
        assert np.all(np.isfinite(lobe.weight)) and np.all(lobe.weight >= 0)
        live = lobe.weight.max(axis=1) > 0                # (total internal reflection: no refracted ray)
        np.testing.assert_allclose(np.linalg.norm(lobe.wi[live], axis=1), 1.0, rtol=1e-12)
        if lobe.kind == "reflect":
            np.testing.assert_allclose(lobe.wi, wo * [-1, -1, 1], atol=1e-12)
            total += lobe.weight
        else:
            total += lobe.weight * (lobe.eta ** 2)[:, None]
    assert np.all(total <= 1.0 + 1e-12) and total.max() > 0


@pytest.mark.parametrize("name", [n for n in GLOSSY if pyrt.MATERIALS[n].transmits])
def test_transmission_obeys_generalised_reciprocity(name):
    """A BTDF in radiance mode: f(wo, wi) / eta_o^2 = f(wi, wo) / eta_i^2 (Veach 1997, sec. 5.2), eta of the
    medium on each direction's side (outside 1 above, ``ior`` below); reflection is plainly reciprocal."""
    mat = pyrt.MATERIALS[name].example()
    rng = np.random.default_rng(6)
    a = np.abs(rng.normal(size=(2000, 3)))
    b = rng.normal(size=(2000, 3))
    b[:, 2] = -np.abs(b[:, 2]) - 0.05
    a /= np.linalg.norm(a, axis=1, keepdims=True)
    b /= np.linalg.norm(b, axis=1, keepdims=True)
    f_ab = mat.f_cos(a, b, LocalCtx(2000)) / np.abs(b[:, 2:3])
    f_ba = mat.f_cos(b, a, LocalCtx(2000)) / np.abs(a[:, 2:3])
    assert np.count_nonzero(f_ab[:, 0]) > 200
    np.testing.assert_allclose(f_ab / 1.0 ** 2, f_ba / mat.ior ** 2, rtol=1e-9, atol=1e-12)
    f_aa, f_aa2 = mat.f_cos(a, a[::-1], LocalCtx(2000)) / a[::-1, 2:3], mat.f_cos(a[::-1], a, LocalCtx(2000)) / a[:, 2:3]
    np.testing.assert_allclose(f_aa, f_aa2, rtol=1e-9, atol=1e-12)
