"""Contracts every registered light and environment keeps, parametrised over the registries.

A new light is one kernel in ``shaders/lights.py`` and one class registered in ``pyrt.lights.LIGHTS`` (a new
environment: ``pyrt.lights.ENVIRONMENTS``) with an ``example()``; these tests pick it up. Ground truth: the
light's own closed-form power against a deterministic sphere quadrature of its intensity, the pdf integrated
over the sphere (midpoint rule in lat-long coordinates, exact for piecewise-constant tables), a chi-square
test of sampled directions against the pdf, Monte Carlo means within 5 standard errors.
"""
import math
import os
import sys

import numpy as np
import pytest
from scipy import stats

import pyrt
from pyrt.lights import ENVIRONMENTS, LIGHTS, LightSample

sys.path.insert(0, os.path.dirname(__file__))
from sphere_quadrature import sphere_integral  # noqa: E402

NAMES = sorted(LIGHTS)
PUNCTUAL = [n for n in NAMES if LIGHTS[n].fixed_position]
SAMPLED = [n for n in NAMES if not LIGHTS[n].delta]
ENVS = sorted(ENVIRONMENTS)


def _points(n=3000, seed=0):
    """Shading points around the examples (all at height 2): below them, off to the sides."""
    rng = np.random.default_rng(seed)
    return np.column_stack([rng.uniform(-3, 3, n), rng.uniform(-1.5, 1.0, n), rng.uniform(-3, 3, n)])


@pytest.mark.parametrize("name", NAMES)
def test_registered_under_its_type_name_with_an_example(name):
    cls = LIGHTS[name]
    assert cls.type_name == name and issubclass(cls, pyrt.Light)
    light = cls.example()
    assert isinstance(light, cls)
    assert (light.position is not None) == light.fixed_position
    assert light.environment is None


@pytest.mark.parametrize("name", NAMES)
def test_sample_li_is_well_formed_and_equals_sample(name):
    light = LIGHTS[name].example()
    p = _points()
    u = np.random.default_rng(1).random((p.shape[0], 2))
    ls = light.sample_li(p, u)
    assert isinstance(ls, LightSample)
    np.testing.assert_allclose(np.linalg.norm(ls.wi, axis=1), 1.0, rtol=1e-12)
    assert np.all(ls.dist > 0)
    E = ls.irradiance()
    assert E.shape == (p.shape[0], 3) and np.all(np.isfinite(E)) and np.all(E >= 0) and E.max() > 0
    np.testing.assert_array_equal(ls.active(), E.max(axis=1) > 0)
    wi, dist, E2 = light.sample(p, u)
    np.testing.assert_array_equal(wi, ls.wi)
    np.testing.assert_array_equal(dist, ls.dist)
    np.testing.assert_allclose(E2, E, rtol=1e-15, atol=0)
    if light.fixed_position:   # shadow rays end at the light: the distance is to its position
        np.testing.assert_allclose(ls.dist, np.linalg.norm(light.position - p, axis=1), rtol=1e-12)


@pytest.mark.parametrize("name", [n for n in NAMES if LIGHTS[n].delta])
def test_delta_lights_ignore_u_and_have_zero_pdf(name):
    light = LIGHTS[name].example()
    p = _points(500)
    rng = np.random.default_rng(2)
    a = light.sample_li(p, rng.random((500, 2))).irradiance()
    b = light.sample_li(p, rng.random((500, 2))).irradiance()
    np.testing.assert_array_equal(a, b)
    assert np.all(light.pdf_li(p, light.sample_li(p, None).wi) == 0)


@pytest.mark.parametrize("name", PUNCTUAL)
def test_radiant_power_is_the_integral_of_the_intensity(name):
    """``radiant_power()`` (closed form or the light's own table integral) equals the sphere integral of
    ``E r^2`` sampled at radius r around the light (inverse-square falloff): 1e-3 relative (the quadrature
    has no breaks at cone edges or table cells)."""
    light = LIGHTS[name].example()
    r = 2.0

    def er2(w):
        return light.sample_li(light.position + r * w, None).irradiance() * r * r

    axis = light.direction if light.direction is not None else np.array([0.0, 1.0, 0.0])
    P = sphere_integral(er2, axis, n_per_piece=800, n_phi=512)
    np.testing.assert_allclose(P, light.radiant_power(), rtol=1e-3)


@pytest.mark.parametrize("name", SAMPLED)
def test_sampled_light_E_is_radiance_over_pdf_and_pdf_integrates_to_one(name):
    """For emitters of uniform radiance L: every sample's E = L / pdf_li(wi) (pdf in solid angle), and
    pdf_li integrates to 1 over the sphere of directions (quadrature, 2e-3) at points outside the light."""
    light = LIGHTS[name].example()
    p = _points(2000, seed=3)
    ls = light.sample_li(p, np.random.default_rng(4).random((2000, 2)))
    pdf = light.pdf_li(p, ls.wi)
    E = ls.irradiance()
    lit = E.max(axis=1) > 0
    assert lit.sum() > 500
    np.testing.assert_allclose(E[lit] * pdf[lit, None], np.broadcast_to(light.L, (int(lit.sum()), 3)), rtol=1e-9)
    assert np.all(pdf[~lit] == 0) or np.all(E[~lit] == 0)
    for q in ([0.2, 0.0, 0.1], [1.5, -1.0, 0.5]):
        q = np.asarray(q, dtype=np.float64)
        total = sphere_integral(lambda w: light.pdf_li(np.broadcast_to(q, w.shape), w)[:, None],
                                light.position if light.position is not None else
                                np.array([0.0, 1.0, 0.0]), n_per_piece=1500, n_phi=1024)
        # a one-sided emitter seen from its back would integrate to 0: the points are below the examples
        np.testing.assert_allclose(total, 1.0, rtol=2e-3)


# ------------------------------------------------------------------------------------------ environments

def _latlong_grid(nv=256, nu=512):
    """Midpoints (M, 3) of a lat-long grid (pyrt's mapping: v = acos(y)/pi, u = atan2(x, -z)/2pi) and their
    solid angles (M,)."""
    v = (np.arange(nv) + 0.5) / nv
    u = (np.arange(nu) + 0.5) / nu
    V, U = np.meshgrid(v, u, indexing="ij")
    th, ph = np.pi * V, 2 * np.pi * U
    d = np.stack([np.sin(th) * np.sin(ph), np.cos(th), -np.sin(th) * np.cos(ph)], -1).reshape(-1, 3)
    dw = (np.sin(th) * (np.pi / nv) * (2 * np.pi / nu)).reshape(-1)
    return d, dw


@pytest.mark.parametrize("name", ENVS)
def test_environment_pdf_integrates_to_one_and_radiance_is_finite(name):
    env = ENVIRONMENTS[name].example()
    assert ENVIRONMENTS[name].type_name == name
    d, dw = _latlong_grid()
    pdf = env.pdf(d)
    L = env.radiance(d)
    assert np.all(np.isfinite(L)) and np.all(L >= 0) and L.max() > 0
    assert np.all(pdf >= 0)
    np.testing.assert_allclose(np.sum(pdf * dw), 1.0, rtol=2e-3)


@pytest.mark.parametrize("name", ENVS)
def test_environment_compensated_pdf_integrates_to_one_where_positive(name):
    """The MIS-compensated density (Environment.pdf_compensated) integrates to 1 over the sphere, or is 0
    everywhere (a constant map: L - mean L = 0); it is 0 somewhere (the part of the map below its mean is left
    to BSDF sampling) and positive where the full density is largest (the sun of the examples)."""
    env = ENVIRONMENTS[name].example()
    d, dw = _latlong_grid()
    pc = env.pdf_compensated(d)
    assert np.all(pc >= 0) and np.all(np.isfinite(pc))
    if name == "constant":
        assert np.all(pc == 0)
        return
    np.testing.assert_allclose(np.sum(pc * dw), 1.0, rtol=2e-3)
    assert np.mean(pc == 0) > 0.5
    p = env.pdf(d)
    assert np.all(pc[p >= 0.5 * p.max()] > 0)


@pytest.mark.parametrize("compensated", [False, True])
@pytest.mark.parametrize("name", ENVS)
def test_environment_samples_follow_pdf_chi_square(name, compensated):
    """200k samples histogrammed over 16 x 32 lat-long cells against the pdf integrated per cell (16 x 16
    midpoints: the cube map's texels and the sun cut through cells, 4 x 4 is not enough); cells with
    expectation < 5 pooled. Rejected at p < 1e-4. The same for the MIS-compensated table (``sample_compensated``
    against ``pdf_compensated``; none for the constant map, whose compensated samples all have pdf 0)."""
    env = ENVIRONMENTS[name].example()
    n, nv, nu, k = 200_000, 16, 32, 16
    sample, pdf_fn = (env.sample_compensated, env.pdf_compensated) if compensated else (env.sample, env.pdf)
    d, pdf_s = sample(np.random.default_rng(5).random((n, 2)))
    if compensated and name == "constant":
        assert np.all(pdf_s == 0) and np.all(pdf_fn(d) == 0)
        return
    assert np.all(pdf_s > 0)
    np.testing.assert_allclose(pdf_s, pdf_fn(d), rtol=1e-9)
    v = np.arccos(np.clip(d[:, 1], -1, 1)) / np.pi
    u = (np.arctan2(d[:, 0], -d[:, 2]) / (2 * np.pi)) % 1.0
    obs, _, _ = np.histogram2d(v, u, bins=[np.linspace(0, 1, nv + 1), np.linspace(0, 1, nu + 1)])
    g, dw = _latlong_grid(nv * k, nu * k)
    exp = (pdf_fn(g) * dw).reshape(nv, k, nu, k).sum(axis=(1, 3)) * n
    obs, exp = obs.ravel(), exp.ravel()
    small = exp < 5
    o = np.concatenate([obs[~small], [obs[small].sum()]])
    e = np.concatenate([exp[~small], [exp[small].sum()]])
    e = e * (o.sum() / e.sum())          # the per-cell quadrature's own error (< 2e-3) must not decide
    keep = e > 0
    chi2 = np.sum((o[keep] - e[keep]) ** 2 / e[keep])
    assert stats.chi2.sf(chi2, keep.sum() - 1) > 1e-4, chi2


@pytest.mark.parametrize("name", ENVS)
def test_environment_light_samples_are_radiance_over_pdf(name):
    """EnvironmentLight.sample_li: E = L / pdf, dist = inf, pdf_li = the environment's pdf; the mean of E over
    samples is the integral of L over the sphere (5 standard errors)."""
    env = ENVIRONMENTS[name].example()
    light = pyrt.EnvironmentLight(env)
    n = 100_000
    p = np.zeros((n, 3))
    ls = light.sample_li(p, np.random.default_rng(6).random((n, 2)))
    assert np.all(np.isinf(ls.dist))
    pdf = light.pdf_li(p, ls.wi)
    np.testing.assert_allclose(ls.irradiance() * pdf[:, None], env.radiance(ls.wi), rtol=1e-9)
    d, dw = _latlong_grid(512, 1024)
    ref = np.sum(env.radiance(d) * dw[:, None], axis=0)
    E = ls.irradiance()
    mean, se = E.mean(0), E.std(0) / math.sqrt(n)
    assert np.all(np.abs(mean - ref) <= 5 * se + 2e-3 * ref), (mean, ref, se)
