"""Area lights (pyrt/area_lights.py): irradiance against closed forms, the far-field limit against point
lights, umbra/penumbra against an exact quadrature of the visible part of the light, and the visible
emitter mesh (seen by the camera, never shadowing its own light)."""
import math

import numpy as np
import pytest
from scipy import stats

import pyrt
from pyrt.core.rays import RayBatch
from pyrt.core.sampler import stratified_samples
from pyrt.lights.area import AreaEmitter, DiskLight, RectLight, SphereLight
from pyrt.integrators import Integrator, PreparedScene


def _mc_irradiance(light, p, n_recv, n=200000, seed=0):
    """E at point p on a surface with normal n_recv: mean of E_sample * cos(theta_r) over uniform u."""
    rng = np.random.default_rng(seed)
    P = np.broadcast_to(np.asarray(p, dtype=np.float64), (n, 3)).copy()
    wi, dist, E = light.sample(P, rng.random((n, 2)))
    x = E[:, 0] * np.maximum(wi @ np.asarray(n_recv, dtype=np.float64), 0.0)
    return x.mean(), x.std() / math.sqrt(n)


# ----------------------------------------------------------------------------- closed forms


def test_rect_on_axis_irradiance_closed_form():
    """Square of half-side s at height h, receiver parallel and centred:
    E = 4 L s / sqrt(s^2 + h^2) * atan(s / sqrt(s^2 + h^2))."""
    L, s, h = 3.0, 0.5, 1.2
    light = RectLight((0, h, 0), (0, -1, 0), 2 * s, radiance=L)
    m, se = _mc_irradiance(light, (0, 0, 0), (0, 1, 0))
    q = math.sqrt(s * s + h * h)
    assert abs(m - 4 * L * s / q * math.atan(s / q)) < 4 * se


def test_disk_on_axis_irradiance_closed_form():
    """E = pi L r^2 / (r^2 + h^2)."""
    L, r, h = 2.0, 0.7, 1.5
    m, se = _mc_irradiance(DiskLight((0, h, 0), (0, -1, 0), r, radiance=L), (0, 0, 0), (0, 1, 0))
    assert abs(m - math.pi * L * r * r / (r * r + h * h)) < 4 * se


def test_sphere_irradiance_closed_form_is_exact():
    """Cone sampling of a sphere fully above the horizon: E = pi L (r / d)^2 cos(theta_r), zero variance
    when the receiver faces the centre."""
    L, r, d = 5.0, 0.3, 2.0
    m, se = _mc_irradiance(SphereLight((0, d, 0), r, radiance=L), (0, 0, 0), (0, 1, 0))
    assert m == pytest.approx(math.pi * L * (r / d) ** 2, rel=2e-3) and abs(m - math.pi * L * (r / d) ** 2) < 4 * se + 1e-12


def test_power_radiance_conversions():
    assert RectLight((0, 1, 0), size=(2, 3), power=10.0).radiance == pytest.approx(10 / (math.pi * 6))
    assert DiskLight((0, 1, 0), radius=0.5, power=10.0).radiance == pytest.approx(10 / (math.pi * math.pi * 0.25))
    sl = SphereLight((0, 1, 0), 0.5, power=10.0)
    assert sl.radiance == pytest.approx(10 / (4 * math.pi ** 2 * 0.25)) and sl.power == pytest.approx(10.0)


def test_parameter_errors_name_the_parameter():
    with pytest.raises(pyrt.LightError, match="exactly one of radiance"):
        RectLight((0, 1, 0))
    with pytest.raises(pyrt.LightError, match="size"):
        RectLight((0, 1, 0), size=0.0, radiance=1.0)
    with pytest.raises(pyrt.LightError, match="radius"):
        SphereLight((0, 1, 0), -1.0, radiance=1.0)
    with pytest.raises(pyrt.LightError, match="n_samples"):
        DiskLight((0, 1, 0), radiance=1.0, n_samples=0)
    with pytest.raises(pyrt.LightError, match="tangent"):
        RectLight((0, 1, 0), (0, -1, 0), tangent=(0, 2, 0), radiance=1.0)


# ----------------------------------------------------------------------------- stratification


@pytest.mark.parametrize("ns", [16, 6])
def test_stratified_samples_are_uniform_and_stratified(rng, ns):
    u = stratified_samples(rng, 5000, ns)          # (ns, n, 2)
    assert u.shape == (ns, 5000, 2) and np.all((u >= 0) & (u < 1))
    flat = u.reshape(-1, 2)
    for c in range(2):
        assert stats.kstest(flat[:, c], "uniform").pvalue > 1e-3
    k = math.isqrt(ns)
    if k * k == ns:   # jittered grid: one sample per cell per hit
        cells = np.floor(u[..., 0] * k) + k * np.floor(u[..., 1] * k)
        assert np.all(np.sort(cells, axis=0) == np.arange(ns)[:, None])
    else:             # Latin hypercube: one sample per stratum per dimension per hit
        for c in range(2):
            assert np.all(np.sort(np.floor(u[..., c] * ns), axis=0) == np.arange(ns)[:, None])


# ----------------------------------------------------------------------------- renderer plumbing


def _shade_points(scene, pts, *, rays_per_point=1, seed=0, above=0.1):
    """Radiance of the floor (y = 0) at ``pts`` (k, 3), traced from just above it straight down."""
    ps = PreparedScene(scene)
    try:
        integ = Integrator(ps, max_depth=0)
        o = np.repeat(np.asarray(pts, dtype=np.float64) + [0, above, 0], rays_per_point, axis=0)
        d = np.tile([0.0, -1.0, 0.0], (o.shape[0], 1))
        L, _ = integ.render_samples(RayBatch(o, d), rng=np.random.default_rng(seed))
    finally:
        ps.close()
    return L.reshape(len(pts), rays_per_point, 3)


def _floor_scene(albedo=1.0):
    sc = pyrt.Scene(pyrt.Camera(width=4, height=4))
    sc.add_plane((0, 0, 0), 40.0, pyrt.Lambert(albedo=albedo))
    return sc


def test_small_far_sphere_light_matches_point_light_of_same_power():
    phi, h = 100.0, 20.0
    pts = np.stack([np.linspace(-15, 15, 13), np.zeros(13), np.linspace(-5, 5, 13)], 1)
    a = _floor_scene()
    SphereLight((0, h, 0), 0.05, power=phi, n_samples=16).add_to(a, visible=True)
    b = _floor_scene()
    b.add_light(pyrt.PointLight((0, h, 0), power=phi))
    La = _shade_points(a, pts, rays_per_point=16)[..., 0].mean(1)
    Lb = _shade_points(b, pts)[:, 0, 0]
    # E = pi L (r/d)^2 cos(theta_r) = phi / (4 pi d^2) cos(theta_r) exactly for a sphere above the horizon;
    # the estimate's noise comes from cos(theta_i) varying by < r/d = 2.5e-3 across the cone (256 samples)
    np.testing.assert_allclose(La, Lb, rtol=2e-4)


def test_small_far_rect_light_matches_lambertian_point_emitter():
    """A small one-sided rectangle of power phi is a point source of intensity I(theta) = (phi / pi) cos theta
    (Lambert): on its axis that is a point light of intensity phi / pi (not phi / 4 pi: the power of an
    isotropic point light of the same axial intensity is 4x larger); off axis E = I(theta) cos(theta_r) / d^2."""
    phi, h, s = 50.0, 20.0, 0.1
    pts = np.stack([np.linspace(-15, 15, 13), np.zeros(13), np.zeros(13)], 1)
    a = _floor_scene()
    RectLight((0, h, 0), (0, -1, 0), s, power=phi, n_samples=16).add_to(a)
    La = _shade_points(a, pts, rays_per_point=16)[..., 0].mean(1)
    d = np.array([0, h, 0]) - pts
    dist = np.linalg.norm(d, axis=1)
    cos = d[:, 1] / dist          # = cos theta at the light = cos theta_r at the floor
    E = phi / math.pi * cos * cos / dist ** 2
    np.testing.assert_allclose(La, E / math.pi, rtol=5e-4)   # rho = 1: L = E / pi; 256 samples of a 0.5 % wide light
    b = _floor_scene()
    b.add_light(pyrt.PointLight((0, h, 0), intensity=phi / math.pi))
    Lb = _shade_points(b, pts[6:7])[0, 0, 0]
    assert La[6] == pytest.approx(Lb, rel=5e-4)


def test_penumbra_matches_geometry():
    """Rect light of width w = 1 at height h = 2, an opaque half-plane x < 0 at height h_o = 1.

    Similar triangles: umbra for x < -w h_o / (2 (h - h_o)) = -0.5, full light for x > 0.5, penumbra width
    w h_o / (h - h_o) = 1. The rendered profile must be exactly 0 in the umbra, equal the unoccluded value
    in the lit region and match a quadrature of the visible part of the light in between.
    """
    w, h, h_o, L_e = 1.0, 2.0, 1.0, 4.0
    sc = _floor_scene()
    sc.add_plane((-3.0, h_o, 0), 6.0, pyrt.Lambert(albedo=0.5), name="occluder")   # x in [-6, 0]
    light = RectLight((0, h, 0), (0, -1, 0), w, tangent=(1, 0, 0), radiance=L_e, n_samples=16)
    light.add_to(sc)
    xs = np.linspace(-1.0, 1.0, 41)
    pts = np.stack([xs, np.zeros_like(xs), np.zeros_like(xs)], 1)
    Lr = _shade_points(sc, pts, rays_per_point=64, seed=3)[..., 0]        # (41, 64) estimates, each of 16 rays
    m, se = Lr.mean(1), Lr.std(1) / 8.0

    # exact: L_o = rho / pi * int_visible L cos_l cos_r / r^2 dA, light point visible iff x + x_l > 0
    g = (np.arange(400) + 0.5) / 400 - 0.5
    XL, ZL = np.meshgrid(g * w, g * w, indexing="ij")
    ref = []
    for x in xs:
        dx, dy, dz = XL - x, h, ZL
        r2 = dx * dx + dy * dy + dz * dz
        integrand = L_e * (dy * dy) / (r2 * r2) * ((x + XL) > 0)
        ref.append(integrand.mean() * w * w / math.pi)
    ref = np.array(ref)
    umbra, lit = xs < -0.5 - 1e-9, xs > 0.5 + 1e-9
    assert np.all(m[umbra] == 0.0)
    assert np.all(m[~umbra & ~lit & (np.abs(np.abs(xs) - 0.5) > 1e-9)] > 0)
    assert np.all(np.abs(m - ref) <= 4.5 * se + 2e-3 * ref.max()), np.c_[xs, m, ref, se]
    # the lit side equals the unoccluded irradiance: nothing of the light is hidden there
    free = _floor_scene()
    RectLight((0, h, 0), (0, -1, 0), w, tangent=(1, 0, 0), radiance=L_e, n_samples=16).add_to(free)
    Lf = _shade_points(free, pts, rays_per_point=64, seed=3)[lit][..., 0]      # same points: same random numbers
    np.testing.assert_array_equal(Lr[lit], Lf)
    # and the measured penumbra: first x with L > 0 and first x with L = full, within one grid step
    step = xs[1] - xs[0]
    first_lit = xs[np.argmax(m > 0)]
    full = xs[np.argmax(np.isclose(m, Lf.mean(1).max(), rtol=0) | (xs > 0.5))]
    assert abs(first_lit - (-0.5)) <= step + 1e-9 and abs(full - 0.5) <= step + 1e-9


@pytest.mark.parametrize("make", [
    lambda: RectLight((0, 2, 0), (0, -1, 0), 1.0, radiance=3.0, n_samples=9),
    lambda: DiskLight((0, 2, 0), (0, -1, 0), 0.6, radiance=3.0, n_samples=9),
    lambda: SphereLight((0, 2, 0), 0.6, radiance=3.0, n_samples=9),
], ids=["rect", "disk", "sphere"])
def test_emitter_mesh_never_shadows_its_own_light(make):
    """The floor is lit identically (bit for bit, same seed) with and without the visible emitter mesh."""
    pts = np.stack([np.linspace(-3, 3, 25), np.zeros(25), np.linspace(-2, 2, 25)], 1)
    a, b = _floor_scene(), _floor_scene()
    make().add_to(a, visible=True)
    make().add_to(b, visible=False)
    assert len(a.meshes) == 2 and len(b.meshes) == 1
    np.testing.assert_array_equal(_shade_points(a, pts, rays_per_point=4), _shade_points(b, pts, rays_per_point=4))


def test_emitter_visible_to_camera_one_sided():
    L_e = 7.0
    for pos, expect in (((0, -2, 0), L_e), ((0, 2, 0), 0.0)):     # below = front side (normal -y), above = back
        cam = pyrt.Camera(position=pos, target=(0, 0, 0), up=(0, 0, -1), fov=10, width=8, height=8)
        sc = pyrt.Scene(cam)
        RectLight((0, 0, 0), (0, -1, 0), 2.0, radiance=L_e).add_to(sc)
        img = pyrt.render(sc, spp=1)
        np.testing.assert_allclose(img, expect, rtol=1e-6)
    # the sphere emitter is seen from everywhere, with radiance L_e
    cam = pyrt.Camera(position=(0, 0, 5), target=(0, 0, 0), fov=5, width=8, height=8)
    sc = pyrt.Scene(cam)
    SphereLight((0, 0, 0), 1.0, radiance=L_e).add_to(sc)
    np.testing.assert_allclose(pyrt.render(sc, spp=1), L_e, rtol=1e-6)


def test_area_emitter_material_receives_no_light():
    m = AreaEmitter(2.0)
    assert not m.has_diffuse and not m.has_delta


def test_scene_file_area_lights(tmp_path):
    p = tmp_path / "s.toml"
    p.write_text('''
[camera]
position = [0, 3, 6]
target = [0, 0, 0]
width = 8
height = 8
[materials.floor]
type = "lambert"
[[meshes]]
primitive = "plane"
size = 10
material = "floor"
[[lights]]
type = "rect"
center = [0, 2, 0]
normal = [0, -1, 0]
size = [1, 0.5]
power = 20.0
n_samples = 4
[[lights]]
type = "sphere"
center = [1, 1, 0]
radius = 0.2
radiance = 10.0
visible = false
[[lights]]
type = "disk"
center = [-1, 2, 0]
radius = 0.3
radiance = 5.0
''')
    sc, _ = pyrt.load_scene(p)
    assert [type(lt).__name__ for lt in sc.lights] == ["RectLight", "SphereLight", "DiskLight"]
    assert len(sc.meshes) == 3           # floor + rect + disk (the sphere is invisible)
    assert sc.lights[0].power == pytest.approx(20.0)
    assert np.all(np.isfinite(pyrt.render(sc, spp=1)))
    p.write_text('[camera]\nwidth = 4\nheight = 4\n[[lights]]\ntype = "rect"\ncenter = [0, 1, 0]\nradius = 2\n'
                 'radiance = 1\n')
    with pytest.raises(pyrt.SceneFileError, match="radius"):
        pyrt.load_scene(p)
