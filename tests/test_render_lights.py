"""Analytic radiance of a Lambertian plane under point, directional and spot lights."""
import math

import numpy as np
import pytest

import pyrt
from render_helpers import pixel_centre_hits_on_plane_y0, top_down_scene

RHO = 0.6
# float32 output and float32 Embree rays; the hit point is rebuilt in float64: 1e-5 relative is ample
RTOL = 1e-5


def test_point_light_matches_inverse_square_law():
    scene = top_down_scene(albedo=RHO)
    lp = np.array([0.4, 1.2, -0.3])
    I = 7.0
    scene.add_light(pyrt.PointLight(lp, intensity=I))
    img = pyrt.render(scene)
    p = pixel_centre_hits_on_plane_y0(scene.camera)
    d = lp - p
    r2 = (d ** 2).sum(-1)
    cos = d[..., 1] / np.sqrt(r2)
    expected = RHO / math.pi * I * cos / r2
    inside = (np.abs(p[..., 0]) < 1.99) & (np.abs(p[..., 2]) < 1.99)
    assert inside.sum() > 0.9 * inside.size
    for c in range(3):
        np.testing.assert_allclose(img[..., c][inside], expected[inside], rtol=RTOL)


def test_point_light_power_is_4pi_intensity():
    a = pyrt.PointLight((0, 1, 0), power=4 * math.pi * 3.0)
    assert a.intensity == pytest.approx(3.0)
    assert a.power == pytest.approx(4 * math.pi * 3.0)


def test_directional_light_is_rho_over_pi_E_cos():
    scene = top_down_scene(albedo=RHO)
    direction = np.array([0.3, -1.0, 0.5])
    E = 2.5
    color = np.array([1.0, 0.5, 0.25])
    scene.add_light(pyrt.DirectionalLight(direction, E, color=color))
    img = pyrt.render(scene)
    cos = 1.0 / np.linalg.norm(direction)
    p = pixel_centre_hits_on_plane_y0(scene.camera)
    inside = (np.abs(p[..., 0]) < 1.99) & (np.abs(p[..., 2]) < 1.99)
    for c in range(3):
        np.testing.assert_allclose(img[..., c][inside], RHO / math.pi * E * color[c] * cos, rtol=RTOL)


def test_spot_light_cone():
    scene = top_down_scene(size=96, albedo=RHO, fov=70)
    lp = np.array([0.0, 1.0, 0.0])
    I = 5.0
    spot = pyrt.SpotLight(lp, (0, -1, 0), intensity=I, inner_angle=20.0, outer_angle=40.0)
    scene.add_light(spot)
    img = pyrt.render(scene)[..., 0]
    p = pixel_centre_hits_on_plane_y0(scene.camera)
    d = lp - p
    r = np.linalg.norm(d, axis=-1)
    cos_axis = d[..., 1] / r  # angle between the axis (down) and the light -> point direction
    theta = np.degrees(np.arccos(np.clip(cos_axis, -1, 1)))
    unlit = RHO / math.pi * I * cos_axis / r ** 2  # what the plane would receive from a point light
    inner = theta < 19.9
    outer = theta > 40.1
    np.testing.assert_allclose(img[inner], unlit[inner], rtol=RTOL)
    assert np.all(img[outer] == 0.0)
    # between the cones: the falloff factor is monotone in the angle and in [0, 1]
    mid = ~inner & ~outer
    factor = img[mid] / unlit[mid]
    order = np.argsort(theta[mid])
    assert np.all(np.diff(factor[order]) <= 1e-5)  # float32 image: relative noise ~1e-6
    assert factor.min() >= 0 and factor.max() <= 1 + 1e-6
    # and it equals the documented smoothstep in cos(theta)
    t = np.clip((cos_axis[mid] - math.cos(math.radians(40))) / (math.cos(math.radians(20)) - math.cos(math.radians(40))), 0, 1)
    np.testing.assert_allclose(factor, t * t * (3 - 2 * t), rtol=1e-4, atol=1e-6)


def test_lights_add_linearly():
    lights = [pyrt.PointLight((0.5, 1.0, 0.0), intensity=3.0),
              pyrt.DirectionalLight((0, -1, 0.2), 1.0, color=(0.2, 0.4, 1.0)),
              pyrt.SpotLight((0, 2, 0), (0, -1, 0), intensity=4.0)]
    parts = []
    for light in lights:
        s = top_down_scene(size=32)
        s.add_light(light)
        parts.append(pyrt.render(s).astype(np.float64))
    s = top_down_scene(size=32)
    for light in lights:
        s.add_light(light)
    np.testing.assert_allclose(pyrt.render(s), sum(parts), rtol=1e-5, atol=1e-7)


def test_light_behind_surface_costs_no_shadow_ray():
    scene = top_down_scene(size=16)
    scene.add_light(pyrt.PointLight((0, -1, 0), intensity=10.0))  # below the floor
    res = pyrt.render_full(scene)
    # the camera sees the top side; the light is below it: nothing to trace
    assert res.stats.shadow_rays == 0
    assert np.all(res.image == 0)
    # a spot pointing away likewise
    scene = top_down_scene(size=16)
    scene.add_light(pyrt.SpotLight((0, 1, 0), (0, 1, 0), intensity=10.0))
    assert pyrt.render_full(scene).stats.shadow_rays == 0
