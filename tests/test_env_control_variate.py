"""The unshadowed-irradiance control variate of the environment estimator (integrators/direct.py) and the
quadrature of E(n) it rests on (shaders/irradiance.py, pyrt/lights/irradiance.py).

Ground truths: closed forms (a constant environment gives E = pi L; the cosine moments of the lat-long cells),
the quadrature against itself on finer grids and against a brute-force sum, and renders with and without the
variate, which are two unbiased estimators of the same image: their means over independent seeds must agree
within 4.5 standard errors of the difference (|z| <= 4.5: a false failure has probability ~7e-6 per comparison),
region by region (all pixels of a region pooled: pixels are independent samples). The variate adds no random
numbers, so with the same seed hits it does not touch render bit for bit as without it.
"""
import math

import numpy as np
import pytest

import pyrt
from pyrt.lights import ENVIRONMENTS, ConstantEnvironment, LatLongEnvironment, procedural_sky
from pyrt.lights import irradiance as irr
from pyrt.shaders import irradiance as Q
from pyrt.shaders.envmap import latlong_texel_directions, latlong_texel_solid_angle

Z = 4.5


def _normals(n=200, seed=7):
    rng = np.random.default_rng(seed)
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1)[:, None]
    return np.vstack([[0, 1, 0], [0, -1, 0], [1, 0, 0], [0, 0, 1], d])


def _sky_env(w=128, h=64, **kw):
    return LatLongEnvironment(procedural_sky(w, h, sun_direction=(0.5, 0.6, 0.4), sun_angle=3.0,
                                             sun_radiance=(300.0, 270.0, 230.0)), **kw)


# ----------------------------------------------------------------------------- the quadrature


def test_cell_moments_are_exact():
    """The vector solid angles int_cell w dw of the cells in closed form: equal to a 128 x 128-point midpoint sum
    per cell (to its own error, 1e-5 of the cell's solid angle), cancelling over the sphere, shorter than the
    cells' solid angles (shaders.envmap.latlong_texel_solid_angle), and the upper hemisphere's n.Omega for
    n = +y sums to pi (int cos over the hemisphere)."""
    h, w = 8, 16
    row_y, row_s, col_x, col_z = Q.latlong_cell_moments(h, w)
    om = np.stack([col_x[None, :] * row_s[:, None], np.broadcast_to(row_y[:, None], (h, w)),
                   col_z[None, :] * row_s[:, None]], axis=-1)
    k = 128
    fine = Q.latlong_cell_centres(h * k, w * k) * np.repeat(latlong_texel_solid_angle(h * k, w * k), w * k
                                                             ).reshape(h * k, w * k)[..., None]
    numeric = fine.reshape(h, k, w, k, 3).sum(axis=(1, 3))
    dw = np.broadcast_to(latlong_texel_solid_angle(h, w)[:, None], (h, w))
    np.testing.assert_allclose(om, numeric, rtol=0, atol=1e-5 * dw.min())
    np.testing.assert_allclose(om.sum(axis=(0, 1)), 0.0, atol=1e-14)
    assert np.all(np.linalg.norm(om, axis=-1) < dw)
    assert abs(row_y[: h // 2].sum() * w - math.pi) < 1e-14


@pytest.mark.parametrize("rows,bound", [(32, 1.2e-3), (256, 2e-5)])
def test_constant_radiance_gives_pi_L(rows, bound):
    """Constant radiance L: E = pi L exactly (to rounding) for n = +-y (the equator is a row boundary) and within
    the horizon-straddling cells' error for other normals, second order in the cell size: measured 1.08e-3 at
    32 x 64 cells, 1.36e-5 at 256 x 512 (200 random normals)."""
    L = np.full((rows, 2 * rows, 1), 1.0)
    m = Q.latlong_cell_moments(rows, 2 * rows)
    E = Q.irradiance_quadrature(L, m, Q.row_moments(L, m[2], m[3]), _normals())[:, 0]
    np.testing.assert_allclose(E[:2], math.pi, rtol=4e-16)
    rel = np.abs(E / math.pi - 1)
    assert rel.max() < bound and rel.max() > bound / 4, rel.max()


def test_constant_environment_is_the_closed_form():
    """ConstantEnvironment (radiance_resolution None): E = pi L for every normal, intensity included."""
    env = ConstantEnvironment((0.5, 1.0, 2.0), intensity=3.0)
    np.testing.assert_array_equal(env.irradiance(_normals()), np.pi * env.radiance(_normals()))


def test_sky_with_a_sun_refined():
    """A 128 x 64 sky with a 3 degree sun: the default grid (256 x 512 cells) against one 2x finer differs by
    <= 2.5e-4 relative (measured 1.1e-4; 6.3e-5 for normals above the horizon), and halving the grid
    (128 x 256) changes E several times more (the error falls with the cell size)."""
    env = _sky_env()
    n = _normals()
    table = irr.irradiance_table(env)
    assert table.cells == (256, 512) and table.sub == 1
    E = env.irradiance(n)
    fine = irr.IrradianceTable(env._radiance_local, None, cells=(512, 1024)).irradiance(n)
    coarse = irr.IrradianceTable(env._radiance_local, None, cells=(128, 256)).irradiance(n)
    d_fine, d_coarse = np.abs(E / fine - 1).max(), np.abs(coarse / E - 1).max()
    assert d_fine < 2.5e-4, d_fine
    assert d_coarse > 3 * d_fine, (d_coarse, d_fine)


@pytest.mark.parametrize("name", ["latlong", "cube", "angular", "mirror_ball"])
def test_every_environment_against_brute_force(name):
    """Each registered environment's example against the midpoint sum of L(d) max(0, n.d) dw over 512 x 1024
    texels: within 1e-3 relative (measured 1.2e-4 to 3.7e-4 over 54 normals; against 1024 x 2048 texels
    6.8e-5 to 4.5e-4; the largest for a normal whose horizon cuts the sun)."""
    env = ENVIRONMENTS[name].example()
    n = _normals(50, seed=3)
    d = latlong_texel_directions(512, 1024).reshape(-1, 3)
    Ldw = env.radiance(d) * np.repeat(latlong_texel_solid_angle(512, 1024), 1024)[:, None]
    ref = np.stack([np.maximum(d @ m, 0.0) @ Ldw for m in n])
    rel = np.abs(env.irradiance(n) / ref - 1)
    assert rel.max() < 1e-3, rel.max()


def test_intensity_and_rotation_apply_per_query_and_a_new_image_rebuilds():
    """E_world(n) = intensity E_env(R^T n): changing intensity or rotation later needs no rebuild; assigning a new
    image (another array) rebuilds the grid."""
    env = _sky_env()
    n = _normals(20)
    E = env.irradiance(n)
    table = irr.irradiance_table(env)
    env.intensity = 2.5
    np.testing.assert_allclose(env.irradiance(n), 2.5 * E, rtol=1e-14)
    R = pyrt.core.transforms.transform_matrix(rotate=(40.0, (0.3, 1.0, 0.2)))[:3, :3]
    env.rotation = R
    np.testing.assert_allclose(env.irradiance(n @ R.T), 2.5 * E, rtol=1e-12)
    assert irr.irradiance_table(env) is table
    env.image = env.image * 2.0
    assert irr.irradiance_table(env) is not table
    np.testing.assert_allclose(env.irradiance(n @ R.T), 5.0 * E, rtol=1e-12)


def test_values_do_not_depend_on_the_query():
    """E of a normal is the same alone, among others, cached or not (images must not depend on the workers)."""
    env = _sky_env()
    n = _normals(30)
    together = irr.IrradianceTable(env._radiance_local, env.radiance_resolution).irradiance(n)
    alone = np.vstack([irr.IrradianceTable(env._radiance_local, env.radiance_resolution).irradiance(n[i:i + 1])
                       for i in range(len(n))])
    np.testing.assert_array_equal(together, alone)
    t = irr.IrradianceTable(env._radiance_local, env.radiance_resolution)
    t.irradiance(n[::2])
    np.testing.assert_array_equal(t.irradiance(n), together)
