"""Lights' factored samples (LightSample with E = scale * rgb, from Light.sample_li) agree with Light.sample."""
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
def test_factored_sample_li_equals_sample(name):
    light = LIGHTS[name]
    rng = np.random.default_rng(1)
    p = rng.uniform(-3, 3, size=(5000, 3))
    wi, dist, E = light.sample(p, None)
    ls = light.sample_li(p, None)
    assert ls.factored
    s = ls.scale
    np.testing.assert_array_equal(ls.wi, wi)
    np.testing.assert_array_equal(ls.dist, dist)
    np.testing.assert_allclose(ls.irradiance(), E, rtol=1e-15, atol=0)
    np.testing.assert_array_equal(ls.active(), E.max(axis=1) > 0)
    if name.startswith("spot"):
        assert np.count_nonzero(s == 0) > 100 and np.count_nonzero(s > 0) > 100   # both sides of the cone


def test_lights_with_textures_ranges_or_subclasses_use_the_general_path():
    """The factored form is derived by construction: a subclass overriding sample() (or radiant_intensity)
    gets the general sample_li built from its own sample()."""
    class Dimmed(pyrt.PointLight):
        def sample(self, p, u):
            wi, dist, E = super().sample(p, u)
            return wi, dist, 0.5 * E

    class Reddish(pyrt.DirectionalLight):
        def sample(self, p, u):
            wi, dist, E = super().sample(p, u)
            return wi, dist, E * np.array([1.0, 0.5, 0.5])

    p = np.array([[0.0, 0.0, 0.0], [0.5, 0.0, 0.2]])
    for light in (Dimmed((0, 1, 0), intensity=1.0),
                  pyrt.PointLight((0, 1, 0), intensity=1.0, falloff="smooth_range", range=2.0),
                  pyrt.ProjectorLight((0, 1, 0), target=(0, 0, 0), intensity=1.0, image=np.ones((4, 4, 3))),
                  Reddish((0, -1, 0), 2.0)):
        ls = light.sample_li(p, None)
        assert not ls.factored
        np.testing.assert_array_equal(ls.irradiance(), light.sample(p, None)[2])


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
