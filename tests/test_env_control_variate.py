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
from pyrt.integrators import direct
from pyrt.lights import ENVIRONMENTS, ConstantEnvironment, LatLongEnvironment, procedural_sky, set_environment
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


def test_intensity_and_rotation_apply_per_query_and_a_new_image_is_refused():
    """E_world(n) = intensity E_env(R^T n): changing intensity or rotation later needs no rebuild; assigning a new
    image (whose tables would be stale) is an error naming the environment and the attribute."""
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
    with pytest.raises(pyrt.Error, match="LatLongEnvironment.*image cannot be changed after construction"):
        env.image = env.image * 2.0
    env.image = env.image                       # the same array: a no-op
    np.testing.assert_allclose(env.irradiance(n @ R.T), 2.5 * E, rtol=1e-12)


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


def test_distinct_rows():
    rng = np.random.default_rng(1)
    base = rng.normal(size=(7, 3))
    a = base[rng.integers(0, 7, 500)]
    rows, inv = direct.distinct_rows(a)
    assert rows.shape[0] == 7
    np.testing.assert_array_equal(rows[inv], a)
    rows, inv = direct.distinct_rows(np.tile([[0.0, 1.0, 0.0]], (9, 1)))
    assert rows.shape == (1, 3) and np.all(inv == 0)


# ----------------------------------------------------------------------------- renders


def _plane(size=16):
    cam = pyrt.Camera(position=(0, 3, 0), target=(0, 0, 0), up=(0, 0, -1), fov=30, width=size, height=size)
    sc = pyrt.Scene(cam)
    sc.add_plane((0, 0, 0), 4.0, pyrt.Lambert(albedo=(0.5, 0.25, 0.8)))
    return sc


@pytest.mark.parametrize("lighting,compensate", [("uniform", True), ("cosine", True), ("map", True),
                                                 ("bsdf", True), ("mis", False), ("mis", True)])
def test_white_furnace_is_exact_with_the_variate(lighting, compensate):
    """A constant environment L over an unoccluded flat Lambert plane: every pixel rho * L to float rounding
    with the variate, for every strategy; without it the strategies that do not sample the cosine are noisy."""
    rho, L = np.array([0.5, 0.25, 0.8]), 2.0
    out = {}
    for cv in (True, False):
        sc = _plane()
        set_environment(sc, ConstantEnvironment(L), lighting=lighting, compensate=compensate, control_variate=cv)
        out[cv] = pyrt.render(sc, spp=1, seed=1).reshape(-1, 3).astype(np.float64)
    np.testing.assert_allclose(out[True], np.broadcast_to(rho * L, out[True].shape), rtol=1.2e-7, atol=0)
    noisy = lighting in ("uniform", "map") or (lighting == "mis" and not compensate)
    assert (np.abs(out[False] - rho * L).max() > 0.05) == noisy


SKY = None


def _sky():
    global SKY
    if SKY is None:
        SKY = LatLongEnvironment(procedural_sky(128, 64, sun_direction=(0.5, 0.6, 0.4), sun_angle=4.0,
                                                sun_radiance=(300.0, 270.0, 230.0)))
    return SKY


def _occluded_scene(cv, ball=None, size=24, **light):
    """A Lambert ground (flat: the variate's) under a sphere (smooth: not the variate's) under the sky."""
    cam = pyrt.Camera(position=(0, 2.2, 2.2), target=(0, 0, 0), fov=50, width=size, height=size, jitter=False)
    sc = pyrt.Scene(cam)
    sc.add_plane((0, 0, 0), 8.0, pyrt.Lambert(albedo=0.6), name="ground")
    sc.add_sphere((0, 0.5, 0), 0.5, ball or pyrt.CookTorrance(metal="gold", roughness=0.4), name="ball")
    set_environment(sc, _sky(), control_variate=cv, **light)
    return sc


def _stack(sc, seeds, **kw):
    return np.stack([pyrt.render(sc, spp=1, seed=s, **kw).astype(np.float64) for s in seeds])


def _ground(size=24):
    sc = _occluded_scene(True, size=size)
    nrm = pyrt.render_full(sc, spp=1, seed=0, aovs=True, progress=False).aovs["normal"]
    return np.abs(nrm[..., 1] - 1.0) < 1e-6


def _z(a, b):
    """z of the difference of the pooled means of two independent stacks (seeds, pixels, 3) per channel."""
    da, db = a.mean(axis=0), b.mean(axis=0)
    va, vb = a.var(axis=0, ddof=1) / a.shape[0], b.var(axis=0, ddof=1) / b.shape[0]
    n_px = da.shape[0]
    return (da.mean(axis=0) - db.mean(axis=0)) / (np.sqrt((va + vb).sum(axis=0)) / n_px)


@pytest.mark.parametrize("lighting,kw,max_ratio,max_far", [("mis", {}, 0.8, 0.45),
                                                            ("mis", {"compensate": False, "n_samples": 1}, 0.3, 0.1),
                                                            ("map", {"n_samples": 2}, 0.3, 0.1),
                                                            ("cosine", {"n_samples": 2}, 0.3, 0.1)])
def test_unbiased_with_occlusion_and_less_noise_on_the_ground(lighting, kw, max_ratio, max_far):
    """Sphere over a plane under the sky with a sun, 16 seeds each (independent seeds for the two): the ground's
    mean with the variate agrees with the plain estimate's (|z| <= 4.5 per channel, the ground's 504 pixels
    pooled); so do the ground pixels far from the sphere (the image's top third) alone; the sphere's pixels are
    bit-identical for the same seed; the per-pixel variance over seeds is lower on the ground and far lower on
    its far part, where the sphere hides little of the sky. Measured, ground / far part, mean variance ratio: with
    the texel table's light samples 0.10 / 0.027 for the default mis, 0.014-0.092 / <= 0.011 for the others; since
    the bilinear map's light samples follow its bilinear luminance (pyrt.lights.latlong_sampling: the plain
    estimate itself far less noisy) 0.62 / 0.32 for the default mis (4 + 4 compensated), 0.065 / 0.011 (1 + 1
    uncompensated), 0.15 / 0.018 (map), 0.014 / 0 (cosine); 56-76 % of the far part's pixels noise-free."""
    ground = _ground()
    far = ground.copy()
    far[8:] = False
    a = _stack(_occluded_scene(True, lighting=lighting, **kw), range(100, 116))
    b = _stack(_occluded_scene(False, lighting=lighting, **kw), range(200, 216))
    for region in (ground, far):
        z = _z(a[:, region], b[:, region])
        assert np.all(np.abs(z) <= Z), z
    plain_100 = _stack(_occluded_scene(False, lighting=lighting, **kw), [100])[0]
    np.testing.assert_array_equal(a[0][~ground], plain_100[~ground])
    ratio = a[:, ground].var(axis=0).mean() / b[:, ground].var(axis=0).mean()
    assert ratio < max_ratio, ratio
    ratio_far = a[:, far].var(axis=0).mean() / b[:, far].var(axis=0).mean()
    assert ratio_far < max_far, ratio_far
    assert (a[:, far].var(axis=0).max(axis=-1) == 0).mean() > 0.3


def test_transparent_shadows_unbiased():
    """A glass sphere casting a coloured transparent shadow (V a transmittance (k, 3): (V - 1) per channel): the
    ground's means with and without the variate agree (|z| <= 4.5), and the variate still lowers the noise (variance
    ratio 0.53 measured with the bilinear light samples)."""
    glass = pyrt.Glass(ior=1.5, tint=(0.9, 0.6, 0.3))
    ground = _ground()
    a = _stack(_occluded_scene(True, ball=glass), range(300, 316), transparent_shadows=True)
    b = _stack(_occluded_scene(False, ball=glass), range(400, 416), transparent_shadows=True)
    z = _z(a[:, ground], b[:, ground])
    assert np.all(np.abs(z) <= Z), z
    assert a[:, ground].var(axis=0).mean() < 0.75 * b[:, ground].var(axis=0).mean()


def test_glossy_integrator_unbiased():
    """Under integrator="glossy" (a roughness-0.2 gold sphere traces glossy rays; the Lambert ground's hits take
    the light's own strategy, with the variate): the ground's means agree (|z| <= 4.5), the noise is lower
    (measured variance ratio 0.10 with the texel table's light samples, 0.65 with the bilinear ones)."""
    ground = _ground()
    ball = pyrt.CookTorrance(metal="gold", roughness=0.2)
    a = _stack(_occluded_scene(True, ball=ball), range(700, 716), integrator="glossy")
    b = _stack(_occluded_scene(False, ball=ball), range(800, 816), integrator="glossy")
    z = _z(a[:, ground], b[:, ground])
    assert np.all(np.abs(z) <= Z), z
    assert a[:, ground].var(axis=0).mean() < 0.85 * b[:, ground].var(axis=0).mean()


def test_other_materials_and_smooth_faces_are_bit_identical():
    """The switch changes nothing where the variate does not apply: non-Lambertian materials on flat faces, a
    smooth-shaded Lambert sphere, a normal-mapped flat Lambert plane (its shading normal is not the face's)."""
    cam = pyrt.Camera(position=(0, 2.0, 3.0), target=(0, 0.3, 0), fov=45, width=24, height=18)
    nmap = pyrt.NormalMap(np.dstack([0.5 + 0.3 * np.sin(np.arange(16) / 2.0)[None, :] * np.ones((16, 1)),
                                     np.full((16, 16), 0.5), np.full((16, 16), 0.9)]).astype(np.float32))
    bumpy = pyrt.Lambert(albedo=0.7)
    bumpy.normal_map = nmap
    imgs = []
    for cv in (True, False):
        sc = pyrt.Scene(cam)
        sc.add_plane((0, 0, 0), 6.0, pyrt.materials.OrenNayar(albedo=0.6, sigma_deg=20.0), name="ground")
        sc.add_box((-1.0, 0.3, 0), 0.6, pyrt.CookTorrance(roughness=0.5, kd=0.3, ks=0.5), name="box")
        sc.add_sphere((0.9, 0.4, 0), 0.4, pyrt.Lambert(albedo=0.8), name="smooth")
        sc.add_plane((0, 0.01, -1.5), 1.0, bumpy, name="bumpy")
        set_environment(sc, _sky(), control_variate=cv)
        # the NumPy path (the variate's home) both times: without the variate the compiled path would take the scene
        imgs.append(pyrt.render(sc, spp=2, seed=3, backend="numpy"))
    np.testing.assert_array_equal(imgs[0], imgs[1])


def test_faceted_sphere_bound_and_worker_independence(monkeypatch):
    """A flat-shaded Lambert sphere (each facet its own normal): with the per-batch bound forced down to 5 normals
    only the 5 most-hit facets of a batch get the variate; the image is the same on 1 thread, 2 threads and 2
    processes (the choice depends on the batch alone), and still agrees with the plain estimate (|z| <= 4.5)."""
    monkeypatch.setattr(direct, "CV_MAX_NORMALS", 5)
    seen = []
    distinct = direct.distinct_rows

    def counting(a):
        rows, inv = distinct(a)
        seen.append(rows.shape[0])
        return rows, inv
    monkeypatch.setattr(direct, "distinct_rows", counting)

    def scene(cv):
        cam = pyrt.Camera(position=(0, 0.6, 2.2), target=(0, 0.4, 0), fov=35, width=20, height=20, jitter=False)
        sc = pyrt.Scene(cam)
        sc.add_sphere((0, 0.4, 0), 0.5, pyrt.Lambert(albedo=0.7), subdivisions=1, smooth=False, name="facets")
        set_environment(sc, _sky(), control_variate=cv)
        return sc
    sc = scene(True)
    kw = dict(spp=4, seed=9, chunk_samples=256, progress=False)
    one = pyrt.render_full(sc, threads=1, **kw).image
    two = pyrt.render_full(sc, threads=2, parallel="threads", **kw).image
    procs = pyrt.render_full(sc, threads=2, parallel="processes", **kw).image
    np.testing.assert_array_equal(one, two)
    np.testing.assert_array_equal(one, procs)
    assert max(seen) > 5         # batches (in this process) brought more facets than the bound
    a = _stack(scene(True), range(500, 512)).reshape(12, -1, 3)     # every pixel pooled (the background's are
    b = _stack(scene(False), range(600, 612)).reshape(12, -1, 3)    # the same, noise-free, in both)
    z = _z(a, b)
    assert np.all(np.abs(z) <= Z), z


def test_before_fork_builds_the_grid_only_when_needed():
    """PreparedScene.before_fork builds the irradiance grid (forked workers then share it) for an environment light
    with the variate in a scene with a Lambertian material, and not without the variate."""
    for cv in (False, True):
        env = _sky_env()
        sc = pyrt.Scene(pyrt.Camera(position=(0, 2, 2), target=(0, 0, 0), fov=40, width=8, height=8))
        sc.add_plane((0, 0, 0), 4.0, pyrt.Lambert(albedo=0.5))
        set_environment(sc, env, control_variate=cv)
        ps = pyrt.PreparedScene(sc)
        ps.before_fork()
        assert (env in irr._TABLES) == cv and "irradiance" in ps.timings
        ps.close()
