"""Rectangle, disk and sphere lights on the compiled path: the sampling twin, closed forms, and agreement with the
NumPy path in distribution (the two paths draw different random numbers for the light samples)."""
import numba
import numpy as np
import pytest

import pyrt
from pyrt.lights import compiled as LC
from pyrt.lights.area import AreaEmitter, DiskLight, RectLight, SphereLight


@numba.njit(cache=False)
def _sample_all(tag, rec, P, U):
    out = np.zeros((P.shape[0], 5))
    for i in range(P.shape[0]):
        r = LC.area_sample(tag, rec, 0, P[i, 0], P[i, 1], P[i, 2], U[i, 0], U[i, 1])
        for k in range(5):
            out[i, k] = r[k]
    return out


LIGHTS = [RectLight((0.2, 2.0, -0.1), normal=(0.1, -1, 0.2), size=(1.0, 0.6), tangent=(1, 0, 0.3), power=30.0),
          DiskLight((-1.5, 1.5, 1.0), normal=(0.6, -0.6, -0.3), radius=0.3, power=20.0, color=(1, 0.7, 0.5)),
          SphereLight((0.3, 0.2, 0.1), radius=0.5, power=15.0)]


@pytest.mark.parametrize("light", LIGHTS, ids=lambda x: type(x).__name__)
def test_area_sample_is_the_lights_sample(light, rng):
    """The compiled sampler gives the NumPy light's direction, distance and irradiance for the same random numbers
    (points all around the light, the sphere's inside included, u up to the edges of the square)."""
    P = rng.normal(size=(2000, 3)) * 1.5
    U = rng.random((2000, 2))
    U[:8] = [[0, 0], [0, 1 - 1e-16], [0.5, 0.5], [1 - 1e-16, 0], [0.5, 0], [0, 0.5], [1e-300, 0.5], [0.5, 1e-300]]
    tag, rec = light.compiled_record()
    got = _sample_all(tag, rec, P, U)
    wi, dist, E = light.sample(P, U)
    np.testing.assert_allclose(got[:, :3], wi, rtol=0, atol=1e-13)
    np.testing.assert_allclose(got[:, 3], dist, rtol=1e-12, atol=1e-13)
    np.testing.assert_allclose(got[:, 4:5] * light.L, E, rtol=1e-12, atol=1e-13)


@numba.njit(cache=False)
def _pdf_dist_all(tag, rec, P, W):
    out = np.zeros((P.shape[0], 2))
    for i in range(P.shape[0]):
        out[i, 0], out[i, 1] = LC.area_pdf_dist(tag, rec, 0, P[i, 0], P[i, 1], P[i, 2], W[i, 0], W[i, 1], W[i, 2])
    return out


@pytest.mark.parametrize("light", LIGHTS, ids=lambda x: type(x).__name__)
def test_area_pdf_and_distance_are_the_lights(light, rng):
    """Toward the light's own samples (inside its cone / on its face) and toward random directions (mostly
    missing it): the NumPy light's ``pdf_li`` and ``ray_distance``."""
    P = rng.normal(size=(3000, 3)) * 1.5
    wi, _, _ = light.sample(P, rng.random((3000, 2)))
    W = rng.normal(size=(3000, 3))
    W /= np.linalg.norm(W, axis=1)[:, None]
    W[:1500] = wi[:1500]
    tag, rec = light.compiled_record()
    got = _pdf_dist_all(tag, rec, P, W)
    np.testing.assert_allclose(got[:, 0], light.pdf_li(P, W), rtol=1e-9, atol=0)
    np.testing.assert_allclose(got[:, 1], light.ray_distance(P, W), rtol=1e-9, atol=0)
    assert (got[:1500, 0] > 0).mean() > 0.3


def test_stratum_is_the_stratified_grid_and_latin_hypercube():
    """``k x k`` cells for a square count (sample ``s`` in column ``s % k``, row ``s // k``), Latin-hypercube strata
    otherwise: every stratum of each axis holds exactly one sample."""
    for ns in (4, 9):
        k = int(np.sqrt(ns))
        pts = np.array([LC.stratum(s, ns, k, 0.5, 0.5, 0) for s in range(ns)])
        cells = np.floor(pts * k).astype(int)
        assert sorted(map(tuple, cells)) == sorted((s % k, s // k) for s in range(ns))
    ns, perm = 5, [3, 0, 4, 1, 2]
    pts = np.array([LC.stratum(s, ns, 2, 0.3, 0.7, perm[s]) for s in range(ns)])
    assert sorted(np.floor(pts[:, 0] * ns).astype(int)) == list(range(ns))
    assert sorted(np.floor(pts[:, 1] * ns).astype(int)) == list(range(ns))


def test_sphere_light_over_a_lambert_plane_matches_the_closed_form():
    """A sphere light fully above a Lambert plane: ``L_o = rho / pi * pi L_e (r / d)^2 cos(theta)`` at each pixel
    centre's point (the sphere's irradiance), unbiased to the Monte Carlo error: the error of the mean within 4
    standard errors, every pixel within 6 (the per-pixel noise measured from a second seed's render)."""
    cam = pyrt.Camera(position=(0, 2, 0.001), target=(0, 0, 0), up=(0, 0, -1), fov=60, width=24, height=24,
                      jitter=False, spp=4)
    s = pyrt.Scene(cam)
    s.add_plane((0, 0, 0), 10.0, pyrt.Lambert(albedo=0.6))
    c, r, Le = np.array([0.4, 1.2, -0.3]), 0.3, 3.0
    SphereLight(c, radius=r, radiance=Le, n_samples=4).add_to(s, visible=False)
    a = pyrt.render_full(s, backend="compiled", progress=False, seed=0)
    b = pyrt.render_full(s, backend="compiled", progress=False, seed=1).image[..., 0].astype(np.float64)
    assert a.stats.backend == "compiled"
    ys, xs = np.mgrid[0:24, 0:24]
    d = cam.directions((xs + 0.5).ravel(), (ys + 0.5).ravel())
    p = cam.position + (-cam.position[1] / d[:, 1])[:, None] * d
    to_c = c - p
    dist = np.linalg.norm(to_c, axis=1)
    want = (0.6 / np.pi * np.pi * Le * (r / dist) ** 2 * to_c[:, 1] / dist).reshape(24, 24)
    rel = a.image[..., 0] / want - 1.0
    sigma = np.std(b / want - 1.0 - rel) / np.sqrt(2.0)     # the relative noise of one render's pixel
    assert sigma > 0
    assert abs(rel.mean()) < 4 * sigma / np.sqrt(rel.size), (rel.mean(), sigma)
    assert np.abs(rel).max() < 6 * sigma, (np.abs(rel).max(), sigma)


def _scene(spp=16):
    cam = pyrt.Camera(position=(0, 1.3, 4.0), target=(0, 0.5, 0), fov=45, width=40, height=30, spp=spp)
    s = pyrt.Scene(cam, background=(0.02, 0.02, 0.03), ambient=0.005)
    s.add_plane((0, 0, 0), 6.0, pyrt.Lambert(albedo=pyrt.CheckerTexture(0.2, 0.7, scale=6, filtered=False)))
    s.add_sphere((-0.7, 0.45, -0.3), 0.45, pyrt.Mirror(0.9), subdivisions=3)
    s.add_sphere((0.7, 0.4, 0.0), 0.4, pyrt.BlinnPhong(kd=(0.5, 0.2, 0.1), ks=0.3, exponent=40), subdivisions=2)
    s.add_sphere((0.0, 0.3, 0.7), 0.3, pyrt.CookTorrance(metal="gold", roughness=0.4), subdivisions=2)
    RectLight((0, 2.2, 0), size=(1.0, 0.6), power=60.0, n_samples=4).add_to(s)
    DiskLight((-1.5, 1.5, 1.0), normal=(0.6, -0.6, -0.3), radius=0.3, power=20.0, n_samples=3,
              color=(1, 0.7, 0.5)).add_to(s)
    SphereLight((1.5, 1.2, 1.0), radius=0.2, power=15.0, n_samples=1).add_to(s)
    s.add_light(pyrt.PointLight((2, 3, 2), intensity=5.0))
    return s


def assert_agree_in_distribution(scene, K=6):
    """Per pixel, the mean of ``K`` compiled renders against the mean of ``K`` NumPy renders (other seeds), z-scores
    from their per-pixel standard errors: no pixel beyond 6, the pooled mean of z within noise (t-distributed with
    2K - 2 degrees of freedom: std ~1.1), equal where both are noiseless, the same number of shadow rays to 1 %."""
    c = [pyrt.render_full(scene, backend="compiled", progress=False, seed=k) for k in range(K)]
    n = [pyrt.render_full(scene, backend="numpy", progress=False, seed=100 + k) for k in range(K)]
    assert all(r.stats.backend == "compiled" and r.stats.fallback_reasons == [] for r in c)
    ci = np.array([r.image for r in c], dtype=np.float64)
    ni = np.array([r.image for r in n], dtype=np.float64)
    se = np.sqrt(ci.var(axis=0, ddof=1) / K + ni.var(axis=0, ddof=1) / K)
    diff = ci.mean(axis=0) - ni.mean(axis=0)
    noisy = se > 1e-6 * (1.0 + np.abs(ni.mean(axis=0)))
    z = diff[noisy] / se[noisy]
    assert np.abs(z).max() < 6.0, np.abs(z).max()
    assert abs(z.mean()) < 4.0 * z.std() / np.sqrt(z.size), (z.mean(), z.std())
    np.testing.assert_allclose(ci.mean(axis=0)[~noisy], ni.mean(axis=0)[~noisy], rtol=1e-5, atol=1e-6)
    rays_c = np.mean([r.stats.shadow_rays for r in c])
    rays_n = np.mean([r.stats.shadow_rays for r in n])
    assert abs(rays_c - rays_n) < 0.01 * rays_n, (rays_c, rays_n)


def test_area_lights_agree_with_the_numpy_path_in_distribution():
    """Rectangle (4 samples: a grid), disk (3: Latin hypercube) and sphere (1) lights with their visible meshes, a
    point light, mirror reflections (measured: pooled mean of z -0.05 on 2040 pixels)."""
    assert_agree_in_distribution(_scene())


def test_the_emitter_is_seen_from_its_front_only():
    """A rectangle light's visible mesh: its radiance from the front, nothing from the back (pixel centres)."""
    for normal, want in (((0, 0, 1), 2.5), ((0, 0, -1), 0.0)):
        cam = pyrt.Camera(position=(0, 0, 3), target=(0, 0, 0), fov=20, width=8, height=8, jitter=False)
        s = pyrt.Scene(cam)
        RectLight((0, 0, 0), normal=normal, size=3.0, radiance=2.5).add_to(s)
        img = pyrt.render_full(s, backend="compiled", progress=False)
        assert img.stats.backend == "compiled"
        np.testing.assert_array_equal(img.image, np.full((8, 8, 3), want, dtype=np.float32))
    assert AreaEmitter(1.0, two_sided=True).compiled_record(None)[1][7] == 1.0


def test_area_lights_with_bsdf_samples_agree_with_the_numpy_path():
    """Light and BSDF samples combined by the power heuristic (the rectangle 4 + 4: grids; the disk 3 + 2; a glossy
    Blinn-Phong and gold near the lights)."""
    scene = _scene()
    scene.lights[0].bsdf_samples = 4
    scene.lights[1].bsdf_samples = 2
    assert_agree_in_distribution(scene)


def test_an_area_light_subclass_that_samples_differently_is_not_compiled():
    class Half(RectLight):
        def sample(self, p, u):
            wi, dist, E = super().sample(p, u)
            return wi, dist, 0.5 * E

    assert Half((0, 2, 0), power=10.0).compiled_record() is None
    assert RectLight((0, 2, 0), power=10.0).compiled_record() is not None
