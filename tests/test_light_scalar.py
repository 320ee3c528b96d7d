"""Lights' scalar fast path (Light.sample_scalar: E = s * rgb) agrees with Light.sample."""
import numpy as np
import pytest

import pyrt

LIGHTS = {
    "point": pyrt.PointLight((1, 2, 3), intensity=5.0, color=(1.0, 0.5, 0.25)),
    "point_kelvin": pyrt.PointLight((-1, 2, 0), power=40.0, temperature=3000),
    "spot": pyrt.SpotLight((0, 3, 0), target=(0, 0, 0), intensity=7.0, inner_angle=10, outer_angle=40),
    "spot_gltf": pyrt.SpotLight((0, 3, 0), target=(1, 0, 0), intensity=7.0, inner_angle=5, outer_angle=60,
                                spot_falloff="gltf"),
    "directional": pyrt.DirectionalLight((-0.3, -1, -0.4), 1.5, color=(0.2, 0.4, 1.0)),
}


@pytest.mark.parametrize("name", sorted(LIGHTS))
def test_sample_scalar_equals_sample(name):
    light = LIGHTS[name]
    rng = np.random.default_rng(1)
    p = rng.uniform(-3, 3, size=(5000, 3))
    wi, dist, E = light.sample(p, None)
    wi_s, dist_s, s, rgb = light.sample_scalar(p, None)
    np.testing.assert_array_equal(wi_s, wi)
    np.testing.assert_array_equal(dist_s, dist)
    E_s = np.broadcast_to(rgb, E.shape) if s is None else s[:, None] * rgb
    np.testing.assert_allclose(E_s, E, rtol=1e-15, atol=0)
    if name.startswith("spot"):
        assert np.count_nonzero(s == 0) > 100 and np.count_nonzero(s > 0) > 100   # both sides of the cone


def test_lights_with_textures_ranges_or_subclasses_use_the_general_path():
    class Dimmed(pyrt.PointLight):
        def sample(self, p, u):
            wi, dist, E = super().sample(p, u)
            return wi, dist, 0.5 * E

    assert Dimmed((0, 1, 0), intensity=1.0).sample_scalar(np.zeros((2, 3)), None) is None
    assert pyrt.PointLight((0, 1, 0), intensity=1.0, falloff="smooth_range", range=2.0).sample_scalar(
        np.zeros((2, 3)), None) is None
    assert pyrt.ProjectorLight((0, 1, 0), target=(0, 0, 0), intensity=1.0,
                               image=np.ones((4, 4, 3))).sample_scalar(np.zeros((2, 3)), None) is None


def test_subclass_overriding_sample_is_rendered_with_its_own_sample():
    cam = pyrt.Camera(position=(0, 3, 0.01), target=(0, 0, 0), fov=40, width=16, height=16, spp=1, jitter=False)

    class Dimmed(pyrt.PointLight):
        def sample(self, p, u):
            wi, dist, E = super().sample(p, u)
            return wi, dist, 0.5 * E

    images = []
    for cls in (pyrt.PointLight, Dimmed):
        scene = pyrt.Scene(cam)
        scene.add_plane((0, 0, 0), 4.0, pyrt.Lambert(albedo=0.5))
        scene.add_light(cls((0, 2, 0), intensity=3.0))
        images.append(pyrt.render(scene))
    assert images[0].min() > 0
    np.testing.assert_allclose(images[1], 0.5 * images[0], rtol=1e-6)
