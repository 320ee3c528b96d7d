"""Projector (gobo) and goniometric lights: spot equivalence, image orientation, total power."""
import math

import numpy as np
import pytest

import pyrt
from pyrt.shaders import lights as K
from render_helpers import top_down_scene
from sphere_quadrature import sphere_integral


def _points(rng, n=2000):
    return rng.normal(size=(n, 3)) * 2.0 + np.array([0.0, -1.0, 0.0])


@pytest.mark.parametrize("kind", ["smoothstep", "gltf", "linear_angle"])
def test_projector_with_white_image_equals_spot(kind, rng):
    kw = dict(intensity=3.0, inner_angle=15.0, outer_angle=35.0, spot_falloff=kind, color=(1.0, 0.8, 0.5))
    spot = pyrt.SpotLight((0.1, 1.0, 0.2), (0.2, -1.0, 0.1), **kw)
    proj = pyrt.ProjectorLight((0.1, 1.0, 0.2), (0.2, -1.0, 0.1), image=np.ones((8, 8, 3), np.float32), **kw)
    p = _points(rng)
    for a, b in zip(proj.sample(p, None), spot.sample(p, None)):
        np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(proj.radiant_power(), spot.radiant_power(), rtol=1e-9)


def test_projector_image_orientation():
    # image: top-left quadrant bright; projector looking down -y with up = -z: image up -> world -z,
    # image right = cross(direction, up) = cross(-y, -z) = +x
    img = np.zeros((4, 4), np.float32)
    img[:2, :2] = 1.0
    proj = pyrt.ProjectorLight((0, 0, 0), (0, -1, 0), image=img, up=(0, 0, -1), intensity=1.0, outer_angle=40)
    t = math.tan(math.radians(20))
    w = np.array([[-t, -1, -t], [t, -1, -t], [-t, -1, t], [t, -1, t]])
    w /= np.linalg.norm(w, axis=1, keepdims=True)
    I = proj.radiant_intensity(w)[:, 0]
    assert I[0] > 0.99 and np.all(I[1:] < 1e-12)


def test_projector_half_black_image_halves_the_power():
    img = np.zeros((16, 16), np.float32)
    img[:, 8:] = 1.0
    kw = dict(intensity=2.0, inner_angle=10.0, outer_angle=30.0)
    proj = pyrt.ProjectorLight((0, 0, 0), (0, 0, 1), image=img, **kw)
    spot = pyrt.SpotLight((0, 0, 0), (0, 0, 1), **kw)
    # bilinear interpolation is antisymmetric about the centre column: exactly half
    np.testing.assert_allclose(proj.radiant_power(), 0.5 * spot.radiant_power(), rtol=1e-6)


def test_projector_power_matches_sphere_integral(rng):
    img = rng.random((12, 20, 3)).astype(np.float32)
    proj = pyrt.ProjectorLight((0, 0, 0), (1, 1, 0), image=img, intensity=1.5, inner_angle=5.0, outer_angle=25.0)
    num = sphere_integral(proj.radiant_intensity, proj.direction, breaks=(proj.cos_inner, proj.cos_outer),
                          n_per_piece=96, n_phi=512)
    np.testing.assert_allclose(proj.radiant_power(), num, rtol=2e-4)


def test_projector_rejects_wide_cones_and_bad_images():
    with pytest.raises(pyrt.LightError, match="outer_angle <= 89"):
        pyrt.ProjectorLight((0, 0, 0), (0, -1, 0), image=np.ones((2, 2)), intensity=1.0, outer_angle=95)
    with pytest.raises(pyrt.LightError, match="image"):
        pyrt.ProjectorLight((0, 0, 0), (0, -1, 0), image="/nonexistent.png", intensity=1.0)
    with pytest.raises(pyrt.LightError, match="parallel"):
        pyrt.ProjectorLight((0, 0, 0), (0, -1, 0), image=np.ones((2, 2)), up=(0, 1, 0), intensity=1.0)


def test_goniometric_constant_image_is_a_point_light(rng):
    g = pyrt.GoniometricLight((0, 1, 0), np.full((6, 12), 0.5, np.float32), intensity=4.0)
    pt = pyrt.PointLight((0, 1, 0), intensity=2.0)
    p = _points(rng)
    for a, b in zip(g.sample(p, None), pt.sample(p, None)):
        np.testing.assert_allclose(a, b, rtol=1e-7)   # image stored as float32
    np.testing.assert_allclose(g.radiant_power(), 4 * math.pi * 2.0, rtol=1e-12)


def test_goniometric_power_exact_for_interpolated_image(rng):
    img = rng.random((9, 16, 3)).astype(np.float32)
    g = pyrt.GoniometricLight((0, 0, 0), img, intensity=1.0, up=(0, 0, 1), reference=(1, 1, 0))
    # kinks at the row centres (theta) and the column centres (phi): split theta there, fine phi grid
    th = (np.arange(9) + 0.5) * math.pi / 9
    num = sphere_integral(g.radiant_intensity, g.up, breaks=np.cos(th), n_per_piece=24, n_phi=16 * 64)
    np.testing.assert_allclose(g.radiant_power(), num, rtol=1e-5)


def test_goniometric_orientation():
    img = np.zeros((4, 8), np.float32)
    img[0] = 1.0                   # top row: toward ``up``
    img[:, 2] = 2.0                # column 2: phi in [pi/2, 3pi/4) around up from the reference
    g = pyrt.GoniometricLight((0, 0, 0), img, intensity=1.0, up=(0, 0, 1), reference=(1, 0, 0), srgb=False)
    top = g.radiant_intensity(np.array([[0.0, 0.0, 1.0]]))[0, 0]
    assert top == pytest.approx(1.0)
    # column 2 centre: phi = 2.5 / 8 * 2 pi = 5 pi / 8, toward cross(up, reference) = +y side
    phi = 2.5 / 8 * 2 * math.pi
    w = np.array([[math.cos(phi), math.sin(phi), 0.0]])
    assert g.radiant_intensity(w)[0, 0] == pytest.approx(2.0)
    np.testing.assert_allclose(K.latlong_bilinear_solid_angle_weights(7).sum(), 4 * math.pi, rtol=1e-14)


def test_projector_render_equals_spot_render():
    imgs = []
    for cls in ("spot", "projector"):
        scene = top_down_scene(size=32, albedo=0.5)
        kw = dict(intensity=4.0, inner_angle=20.0, outer_angle=35.0)
        if cls == "spot":
            scene.add_light(pyrt.SpotLight((0, 1.0, 0), (0, -1, 0), **kw))
        else:
            scene.add_light(pyrt.ProjectorLight((0, 1.0, 0), (0, -1, 0), image=np.ones((4, 4, 3)), **kw))
        imgs.append(pyrt.render(scene))
    np.testing.assert_allclose(imgs[1], imgs[0], rtol=1e-6, atol=1e-9)
    assert imgs[0].max() > 0
