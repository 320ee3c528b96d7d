"""Photometric units, total power of every light by numerical integration, distance falloffs and range."""
import math

import numpy as np
import pytest

import pyrt
from pyrt.integrators import PreparedScene
from pyrt.shaders import lights as K
from pyrt.shaders.color import LUMINANCE_WEIGHTS
from render_helpers import pixel_centre_hits_on_plane_y0, top_down_scene
from sphere_quadrature import sphere_integral

# 683 lm/W: luminous efficacy of 540 THz (~555 nm) radiation, SI definition of the candela.
KM = 683.0


def test_constants_documented_values():
    assert pyrt.lights.LUMINOUS_EFFICACY == KM
    np.testing.assert_array_equal(LUMINANCE_WEIGHTS, [0.2126, 0.7152, 0.0722])


def test_point_candela_and_lumens():
    a = pyrt.PointLight((0, 0, 0), candela=800.0)
    np.testing.assert_allclose(a.I, 800.0 / KM)
    assert a.candela == pytest.approx(800.0)
    assert a.luminous_power() == pytest.approx(4 * math.pi * 800.0)
    b = pyrt.PointLight((0, 0, 0), power_lm=1000.0)
    assert b.candela == pytest.approx(1000.0 / (4 * math.pi))
    assert b.luminous_power() == pytest.approx(1000.0)


def test_coloured_light_candela_is_filtered_by_colour_luminance():
    # glTF reading: colour filters a light of the given photometric value
    c = np.array([1.0, 0.0, 0.0])
    a = pyrt.PointLight((0, 0, 0), candela=100.0, color=c)
    assert a.candela == pytest.approx(100.0 * 0.2126)


def test_directional_lux():
    d = pyrt.DirectionalLight((0, -1, 0), lux=KM * 2.0)
    np.testing.assert_allclose(d.E, 2.0)
    assert d.lux == pytest.approx(2 * KM)
    with pytest.raises(pyrt.LightError, match="exactly one of irradiance"):
        pyrt.DirectionalLight((0, -1, 0), 1.0, lux=3.0)


def test_exactly_one_quantity_is_required():
    with pytest.raises(pyrt.LightError, match="exactly one of"):
        pyrt.PointLight((0, 0, 0), 1.0, candela=3.0)
    with pytest.raises(pyrt.LightError, match="exactly one of"):
        pyrt.SpotLight((0, 0, 0), (0, -1, 0))


def test_point_power_is_4pi_I_by_integration():
    a = pyrt.PointLight((0, 0, 0), intensity=3.0, color=(1.0, 0.5, 0.25))
    num = sphere_integral(a.radiant_intensity, (0, 1, 0))
    np.testing.assert_allclose(num, 4 * math.pi * a.I, rtol=1e-12)
    np.testing.assert_allclose(a.radiant_power(), num, rtol=1e-12)


@pytest.mark.parametrize("kind", ["smoothstep", "gltf", "linear_angle"])
@pytest.mark.parametrize("inner, outer", [(15.0, 35.0), (30.0, 30.0), (0.0, 120.0)])
def test_spot_power_closed_form_matches_integral(kind, inner, outer):
    s = pyrt.SpotLight((0, 0, 0), (0.3, -1.0, 0.2), intensity=2.0, inner_angle=inner, outer_angle=outer,
                       spot_falloff=kind)
    num = sphere_integral(s.radiant_intensity, s.direction, breaks=(s.cos_inner, s.cos_outer))
    # Gauss-Legendre on each smooth piece: the residual is the quadrature's, far below 1e-8
    np.testing.assert_allclose(s.radiant_power(), num, rtol=1e-8)


@pytest.mark.parametrize("kind", ["smoothstep", "gltf", "linear_angle"])
def test_spot_power_lm_round_trip(kind):
    s = pyrt.SpotLight((0, 0, 0), (0, -1, 0), power_lm=1200.0, inner_angle=10, outer_angle=40, spot_falloff=kind)
    assert s.luminous_power() == pytest.approx(1200.0)
    s2 = pyrt.SpotLight((0, 0, 0), (0, -1, 0), power=5.0, inner_angle=10, outer_angle=40, spot_falloff=kind)
    np.testing.assert_allclose(s2.radiant_power(), 5.0)


def test_spot_falloff_shapes():
    ci, co = math.cos(math.radians(20)), math.cos(math.radians(40))
    mid_angle = math.radians(30)
    c = np.array([1.0, ci, math.cos(mid_angle), co, -1.0])
    t = (math.cos(mid_angle) - co) / (ci - co)
    np.testing.assert_allclose(K.spot_falloff_smoothstep(c, ci, co), [1, 1, 3 * t * t - 2 * t ** 3, 0, 0], atol=1e-12)
    np.testing.assert_allclose(K.spot_falloff_gltf(c, ci, co), [1, 1, t * t, 0, 0], atol=1e-12)
    np.testing.assert_allclose(K.spot_falloff_linear_angle(c, ci, co), [1, 1, 0.5, 0, 0], atol=1e-12)


def test_distance_falloff_variants():
    r = np.array([0.0, 0.5, 1.0, 2.0, 3.999, 4.0, 5.0])
    np.testing.assert_allclose(K.distance_falloff(r), np.r_[0.0, 1 / r[1:] ** 2])
    eps = 0.1
    np.testing.assert_allclose(K.distance_falloff(r, "inverse_square_eps", eps=eps), 1 / (r + eps) ** 2)
    R = 4.0
    w = np.clip(1 - (r / R) ** 4, 0, 1)
    inv = np.r_[0.0, 1 / r[1:] ** 2]
    np.testing.assert_allclose(K.distance_falloff(r, "smooth_range", light_range=R), w * w * inv)
    np.testing.assert_allclose(K.distance_falloff(r, "gltf_range", light_range=R), w * inv)
    # exactly zero at and beyond the range, for every kind
    for kind in K.DISTANCE_FALLOFFS:
        f = K.distance_falloff(np.array([4.0, 4.5]), kind, eps=eps, light_range=R)
        assert np.all(f == 0.0), kind
    # smooth_range is C1 at the range: one-sided slope -> 0 (the glTF window's is -4/R^3 / R^2)
    h = 1e-6
    slope = (K.distance_falloff(np.array([R - h]), "smooth_range", light_range=R)[0]) / h
    assert abs(slope) < 1e-4
    slope_gltf = K.distance_falloff(np.array([R - h]), "gltf_range", light_range=R)[0] / h
    assert slope_gltf == pytest.approx(4 / R / R ** 2, rel=1e-4)
    assert K.distance_falloff(np.array([1.0], dtype=np.float32)).dtype == np.float32


def test_falloff_parameters_are_validated():
    with pytest.raises(pyrt.LightError, match="needs a range"):
        pyrt.PointLight((0, 0, 0), 1.0, falloff="smooth_range")
    with pytest.raises(pyrt.LightError, match="needs epsilon"):
        pyrt.PointLight((0, 0, 0), 1.0, falloff="inverse_square_eps")
    with pytest.raises(pyrt.LightError, match="falloff must be one of"):
        pyrt.PointLight((0, 0, 0), 1.0, falloff="linear")
    with pytest.raises(pyrt.LightError, match="spot_falloff must be one of"):
        pyrt.SpotLight((0, 0, 0), (0, -1, 0), intensity=1.0, spot_falloff="cosine")


def test_eps_falloff_is_finite_at_the_light():
    a = pyrt.PointLight((0, 0, 0), 2.0, falloff="inverse_square_eps", epsilon=0.5)
    wi, dist, E = a.sample(np.zeros((1, 3)), np.zeros((1, 2)))
    np.testing.assert_allclose(E, 2.0 / 0.25)
    assert np.all(np.isfinite(wi))


def test_range_render_zero_beyond_range_and_no_shadow_rays_there():
    scene = top_down_scene(size=48, albedo=0.5)
    lp = np.array([0.0, 0.5, 0.0])
    R = 1.2
    scene.add_light(pyrt.PointLight(lp, 4.0, falloff="smooth_range", range=R))
    ps = PreparedScene(scene)
    try:
        res = pyrt.render_full(scene, prepared=ps)
    finally:
        ps.close()
    img = res.image[..., 0]
    p = pixel_centre_hits_on_plane_y0(scene.camera)
    d = lp - p
    r = np.linalg.norm(d, axis=-1)
    w = np.clip(1 - (r / R) ** 4, 0, 1) ** 2
    expected = 0.5 / math.pi * 4.0 * (d[..., 1] / r) / r ** 2 * w
    inside = (np.abs(p[..., 0]) < 1.99) & (np.abs(p[..., 2]) < 1.99)
    np.testing.assert_allclose(img[inside], expected[inside], rtol=1e-5, atol=1e-7)
    beyond = inside & (r >= R)
    assert beyond.sum() > 0.3 * inside.sum()
    assert np.all(img[beyond] == 0)
    # one shadow ray per pixel within range, none beyond it
    assert res.stats.shadow_rays == int(((r < R) & (np.abs(p[..., 0]) < 2) & (np.abs(p[..., 2]) < 2)).sum())


def test_default_falloff_path_is_unchanged():
    # the physical default keeps the original kernels: bit-identical to shaders.lights.point_light
    p = np.random.default_rng(1).normal(size=(100, 3))
    a = pyrt.PointLight((0.2, 1, 0), 3.0)
    np.testing.assert_array_equal(a.sample(p, None)[2], K.point_light(p, a.position, a.I)[2])
    # and the generic path agrees with it to rounding
    b = pyrt.PointLight((0.2, 1, 0), 3.0, range=1e9)
    np.testing.assert_allclose(b.sample(p, None)[2], a.sample(p, None)[2], rtol=1e-14)


@pytest.mark.parametrize("kind", sorted(K.SPOT_FALLOFFS))
def test_spot_falloff_kernels_keep_dtype(kind, dtype):
    c = np.linspace(-1, 1, 7).astype(dtype)
    g = K.SPOT_FALLOFFS[kind](c, 0.9, 0.7)
    assert g.dtype == dtype and np.all(np.isfinite(g)) and g.min() >= 0 and g.max() <= 1
