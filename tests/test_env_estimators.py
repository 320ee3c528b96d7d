"""Light-sample splitting and MIS compensation of the environment estimator (integrators/direct.py).

Ground truths: the white furnace (rho * L), the exact irradiance of a nearest-filtered lat-long map on an
upward-facing plane (rings of texels integrate cos theta in closed form), and for a glossy plane a
high-sample light-sampling reference (full table, 256 samples per hit: its own standard error enters the
tolerance). Every pixel of the test scenes is an independent estimate; tolerances are 4.5 standard errors of
the pixel mean (of the pixel differences where each pixel has its own expectation).
"""
import math

import numpy as np
import pytest

import pyrt
from pyrt.integrators import direct
from pyrt.lights import ConstantEnvironment, EnvironmentLight, EnvironmentMapError, LatLongEnvironment
from pyrt.lights import procedural_sky, set_environment

SPLITS = [(1, 1), (1, 4), (4, 1), (2, 3)]


def _sky(**kw):
    return procedural_sky(64, 32, sun_angle=6.0, sun_radiance=(200.0, 180.0, 150.0), **kw)


def _exact_up_irradiance(img):
    """E(+y) of a nearest-filtered lat-long map (texel rows are rings: int cos dw in closed form)."""
    h, w = img.shape[:2]
    th = np.pi * np.arange(h + 1) / h
    ring = (2 * np.pi / w) * (np.sin(th[1:]) ** 2 - np.sin(th[:-1]) ** 2) / 2
    return (img[: h // 2].astype(np.float64).sum(1) * ring[: h // 2, None]).sum(0)


def _plane_scene(material, size=32):
    """Camera above an upward-facing plane that fills the image (every pixel sees the unoccluded sky)."""
    cam = pyrt.Camera(position=(0, 3, 0), target=(0, 0, 0), up=(0, 0, -1), fov=30, width=size, height=size)
    sc = pyrt.Scene(cam)
    sc.add_plane((0, 0, 0), 4.0, material)
    return sc


def _pixels(sc, seed):
    """The NumPy path's estimators (some tests monkeypatch them; the compiled path has its own twins)."""
    return pyrt.render(sc, spp=1, seed=seed, backend="numpy").reshape(-1, 3).astype(np.float64)


def _mean_se(x):
    return x.mean(axis=0), x.std(axis=0, ddof=1) / math.sqrt(x.shape[0])


# ----------------------------------------------------------------------------- the weights


@pytest.mark.parametrize("compensate", [False, True])
@pytest.mark.parametrize("heuristic", ["power", "balance"])
@pytest.mark.parametrize("nl,nb", SPLITS)
def test_mis_weights_sum_to_one(nl, nb, heuristic, compensate, rng):
    """w_light + w_bsdf = 1 wherever either density is positive, 0 and 0 where both are; with unequal counts
    the heuristic is Veach's with the counts (checked against the formula)."""
    light = EnvironmentLight(ConstantEnvironment(1.0), n_samples=nl, bsdf_samples=nb, heuristic=heuristic,
                             compensate=compensate)
    p_l = rng.exponential(1.0, 1000) * (rng.random(1000) > 0.3)
    p_b = rng.exponential(1.0, 1000) * (rng.random(1000) > 0.3)
    w_l, w_b = light.mis_weights(p_l, p_b)
    some = (p_l + p_b) > 0
    np.testing.assert_allclose(w_l[some] + w_b[some], 1.0, rtol=1e-14)
    assert np.all(w_l[~some] == 0) and np.all(w_b[~some] == 0)
    assert np.all(w_l[(p_b == 0) & some] == 1) and np.all(w_b[(p_l == 0) & some] == 1)
    beta = 2.0 if heuristic == "power" else 1.0
    a, b = (nl * p_l[some]) ** beta, (nb * p_b[some]) ** beta
    np.testing.assert_allclose(w_l[some], a / (a + b), rtol=1e-12)


# ----------------------------------------------------------------------------- white furnace


@pytest.mark.parametrize("nl,nb", SPLITS)
def test_white_furnace_compensated_is_pure_bsdf_sampling(nl, nb):
    """Constant environment L: the compensated table is empty (L - mean L = 0), so compensated MIS is cosine
    sampling of the Lambertian BRDF with weight 1 -- exactly rho * L at every pixel, for any split."""
    rho, L = 0.5, 2.0
    sc = _plane_scene(pyrt.Lambert(albedo=rho), size=16)
    set_environment(sc, ConstantEnvironment(L), n_samples=nl, bsdf_samples=nb, compensate=True)
    np.testing.assert_allclose(_pixels(sc, 1), rho * L, rtol=1e-5)


@pytest.mark.parametrize("nl,nb", SPLITS)
def test_white_furnace_split_uncompensated(nl, nb):
    """Without compensation the light samples are uniform; rho * L within 4.5 standard errors (the samples'
    estimate: without the control variate, which makes it exact, tests/test_env_control_variate.py)."""
    rho, L = 0.5, 2.0
    sc = _plane_scene(pyrt.Lambert(albedo=rho))
    set_environment(sc, ConstantEnvironment(L), n_samples=nl, bsdf_samples=nb, compensate=False,
                    control_variate=False)
    m, se = _mean_se(_pixels(sc, 2))
    assert np.all(np.abs(m - rho * L) <= 4.5 * se + 1e-9), (m, se)


# ----------------------------------------------------------------------------- unbiased under a map


@pytest.mark.parametrize("cv", [False, True])
@pytest.mark.parametrize("compensate", [False, True])
@pytest.mark.parametrize("nl,nb", SPLITS)
def test_lambert_plane_matches_closed_form(nl, nb, compensate, cv):
    """Lambert plane under the sky with a sun: E[estimate] = rho / pi * E(+y) in closed form. With the control
    variate the unoccluded plane gets rho / pi * E(+y) of the quadrature, which is exact for a nearest-filtered
    map and the normal +y (cells nest in texel rings, the horizon is a row boundary): every pixel equals the
    closed form to the float32 rounding of the image (se = 0)."""
    env = LatLongEnvironment(_sky(), filter="nearest")
    rho = 0.5
    ref = rho / np.pi * _exact_up_irradiance(env.image)
    sc = _plane_scene(pyrt.Lambert(albedo=rho))
    set_environment(sc, env, n_samples=nl, bsdf_samples=nb, compensate=compensate, control_variate=cv)
    m, se = _mean_se(_pixels(sc, 3))
    assert np.all(np.abs(m - ref) <= 4.5 * se + (1.2e-7 * ref if cv else 0.0)), (m, ref, se)


def _glossy_plane(env, **light):
    mat = pyrt.materials.CookTorrance(kd=0.2, ks=0.8, roughness=0.45)
    sc = _plane_scene(mat)
    set_environment(sc, env, **light)
    return sc


@pytest.fixture(scope="module")
def glossy_reference():
    """Per-pixel reference of the glossy plane: full-table light sampling, 256 samples per hit."""
    env = LatLongEnvironment(_sky(sun_direction=(0.0, 0.6, -0.8)), filter="bilinear")
    return env, _pixels(_glossy_plane(env, lighting="map", n_samples=256), 99)


def _check_against(vals, ref):
    """|mean(vals - ref)| <= 4.5 standard errors of the pixel differences (each pixel its own expectation)."""
    m, se = _mean_se(vals - ref)
    return np.abs(m) <= 4.5 * se, m, se


@pytest.mark.parametrize("compensate", [False, True])
@pytest.mark.parametrize("nl,nb", [(1, 1), (1, 4), (4, 1)])
def test_glossy_plane_matches_high_sample_reference(glossy_reference, nl, nb, compensate):
    env, ref = glossy_reference
    vals = _pixels(_glossy_plane(env, n_samples=nl, bsdf_samples=nb, compensate=compensate), 4)
    ok, m, se = _check_against(vals, ref)
    assert ok.all(), (m, se)


def test_compensated_needs_the_bsdf_samples(glossy_reference, monkeypatch):
    """The test above can fail: without the BSDF half, the compensated light samples alone miss the sky below
    the map's mean (the compensated pdf is 0 there) and the estimate is far below the reference."""
    env, ref = glossy_reference
    monkeypatch.setattr(direct, "_add_bsdf_sample", lambda *a, **k: None)
    vals = _pixels(_glossy_plane(env, n_samples=4, bsdf_samples=4, compensate=True), 4)
    ok, m, se = _check_against(vals, ref)
    assert not ok.any() and np.all(m < -20 * se), (m, se)


def test_equal_counts_take_the_one_sum_path():
    """bsdf_samples = n_samples renders exactly what bsdf_samples=None (the default) renders, with or without
    compensation; the defaults are 2 + 2 samples, compensated (padded camera-hit samples, 2026-12-02)."""
    env = LatLongEnvironment(_sky(), filter="bilinear")
    for comp in (False, True):
        a = _pixels(_glossy_plane(env, n_samples=2, compensate=comp), 7)
        b = _pixels(_glossy_plane(env, n_samples=2, bsdf_samples=2, compensate=comp), 7)
        np.testing.assert_array_equal(a, b)
    lt = EnvironmentLight(env)
    assert (lt.n_samples, lt.bsdf_samples, lt.compensate, lt.heuristic) == (2, 2, True, "power")


# ----------------------------------------------------------------------------- parameters


def test_parameters_are_checked_and_named():
    env = ConstantEnvironment(1.0)
    with pytest.raises(EnvironmentMapError, match="bsdf_samples"):
        EnvironmentLight(env, bsdf_samples=0)
    with pytest.raises(EnvironmentMapError, match="compensate"):
        EnvironmentLight(env, compensate="yes")
    with pytest.raises(EnvironmentMapError, match="control_variate"):
        EnvironmentLight(env, control_variate=1)
    lt = EnvironmentLight(env, n_samples=3)
    assert lt.bsdf_samples == 3 and lt.control_variate is False
    lt.control_variate = "no"                     # assigned later: PreparedScene's validate() names it
    with pytest.raises(EnvironmentMapError, match="control_variate"):
        lt.validate()


def test_scene_file_keys(tmp_path):
    p = tmp_path / "s.toml"
    p.write_text('[camera]\nposition = [0, 3, 0]\ntarget = [0, 0, 0]\nup = [0, 0, -1]\nwidth = 8\nheight = 8\n'
                 '[environment]\ntype = "sky"\nsamples = 2\nbsdf_samples = 5\ncompensate = true\n'
                 'control_variate = true\n')
    sc, _ = pyrt.load_scene(str(p))
    lt = [x for x in sc.lights if x.environment is not None][0]
    assert (lt.n_samples, lt.bsdf_samples, lt.compensate, lt.control_variate) == (2, 5, True, True)
    p.write_text(p.read_text().replace("compensate = true", 'compensate = "maybe"'))
    with pytest.raises(pyrt.Error, match="compensate"):
        pyrt.load_scene(str(p))


# ----------------------------------------------------------------------------- area lights: light + BSDF samples


def _area_lights():
    return {"rect": pyrt.RectLight(center=(0.3, 1.0, 0.1), normal=(0, -1, 0), size=(1.5, 1.0), power=30.0),
            "disk": pyrt.DiskLight((0.3, 1.0, 0.1), (0.2, -1, 0), radius=0.6, power=30.0),
            "sphere": pyrt.SphereLight((0.3, 1.2, 0.1), 0.5, power=60.0)}


@pytest.mark.parametrize("kind", ["rect", "disk", "sphere"])
def test_ray_distance_agrees_with_pdf_li(kind, rng):
    """A direction reaches the light (finite ray_distance) exactly where its light-sampling pdf is positive, and
    the light's own samples lie at the distance ray_distance gives."""
    light = _area_lights()[kind]
    n = 20000
    p = np.column_stack([rng.uniform(-2, 2, n), rng.uniform(-1, 0.2, n), rng.uniform(-2, 2, n)])
    wi = rng.normal(size=(n, 3))
    wi /= np.linalg.norm(wi, axis=1, keepdims=True)
    dist = light.ray_distance(p, wi)
    pdf = light.pdf_li(p, wi)
    assert np.isfinite(dist).sum() > 200
    np.testing.assert_array_equal(np.isfinite(dist), pdf > 0)
    ls = light.sample_li(p, rng.random((n, 2)))
    np.testing.assert_allclose(light.ray_distance(p, ls.wi), ls.dist, rtol=1e-9)


@pytest.fixture(scope="module")
def area_references():
    """Per-pixel references: light sampling only, 256 samples per hit, for each light and material."""
    out = {}
    for kind in ("rect", "disk", "sphere"):
        for mat in ("lambert", "glossy"):
            out[kind, mat] = _pixels(_area_plane(kind, mat, n_samples=256, bsdf_samples=0), 98)
    return out


def _area_plane(kind, mat, **kw):
    m = pyrt.Lambert(albedo=0.6) if mat == "lambert" else pyrt.materials.CookTorrance(kd=0.1, ks=0.9, roughness=0.3)
    sc = _plane_scene(m)
    light = _area_lights()[kind]
    light.n_samples, light.bsdf_samples = kw["n_samples"], kw["bsdf_samples"]
    light.add_to(sc, visible=False)
    return sc


@pytest.mark.parametrize("nl,nb", [(1, 1), (4, 1), (1, 4)])
@pytest.mark.parametrize("mat", ["lambert", "glossy"])
@pytest.mark.parametrize("kind", ["rect", "disk", "sphere"])
def test_area_light_mis_matches_light_sampling(area_references, kind, mat, nl, nb):
    """Light + BSDF samples (MIS with the counts) have the expectation of light sampling alone."""
    vals = _pixels(_area_plane(kind, mat, n_samples=nl, bsdf_samples=nb), 5)
    ok, m, se = _check_against(vals, area_references[kind, mat])
    assert ok.all(), (m, se)
    assert np.all(np.abs(m) < 0.05 * area_references[kind, mat].mean(0))


def test_area_light_bsdf_samples_checked():
    with pytest.raises(pyrt.LightError, match="bsdf_samples"):
        pyrt.RectLight(center=(0, 1, 0), size=1.0, power=1.0, bsdf_samples=-1)
    lt = pyrt.RectLight(center=(0, 1, 0), size=1.0, power=1.0)
    assert lt.bsdf_samples == 0
    lt.bsdf_samples = 1.5
    with pytest.raises(pyrt.LightError, match="bsdf_samples"):
        lt.validate()
