"""Parameters are checked when an object is built and again when a scene is prepared for rendering.

A value assigned after construction (``light.intensity = nan``) must be a :class:`pyrt.Error` naming the
object at render time, never a light that silently contributes nothing or a NaN image.
"""
import math

import numpy as np
import pytest

import pyrt
from pyrt.lights.base import LIGHTS
from pyrt.lights.environment import ENVIRONMENTS
from pyrt.materials.base import MATERIALS
from render_helpers import top_down_scene

NAN = float("nan")


def _lit_scene():
    scene = top_down_scene(size=8)
    key = pyrt.PointLight((0, 2, 0), intensity=5.0, name="key")
    scene.add_light(key)
    return scene, key, scene.materials[0]


def test_valid_scene_renders_unchanged_by_validation():
    scene, _, _ = _lit_scene()
    a = pyrt.render(scene, seed=3)
    scene.validate()
    b = pyrt.render(scene, seed=3)
    assert np.array_equal(a, b) and a.max() > 0


@pytest.mark.parametrize("attr, value, words", [
    ("intensity", NAN, "intensity"), ("intensity", -1.0, "intensity"), ("intensity", math.inf, "intensity"),
    ("position", np.array([0.0, NAN, 0.0]), "position"), ("color", np.array([1.0, NAN, 1.0]), "color"),
    ("color", np.array([1.0, -1.0, 1.0]), "color"),
])
def test_light_mutated_after_construction_is_an_error_at_render(attr, value, words):
    scene, key, _ = _lit_scene()
    setattr(key, attr, value)
    with pytest.raises(pyrt.Error, match=rf"PointLight\(key\).*{words}"):
        pyrt.render(scene)


@pytest.mark.parametrize("attr, value", [("albedo_value", NAN), ("albedo_value", np.array([0.5, NAN, 0.5])),
                                         ("albedo_value", 1.5), ("emission_value", -1.0)])
def test_material_mutated_after_construction_is_an_error_at_render(attr, value):
    scene, _, mat = _lit_scene()
    mat.name = "floor"
    setattr(mat, attr, value)
    with pytest.raises(pyrt.Error, match=r"Lambert\(floor\)"):
        pyrt.render(scene)


def test_camera_and_background_mutated_after_construction_are_errors():
    scene, _, _ = _lit_scene()
    scene.camera.fov = NAN
    with pytest.raises(pyrt.Error, match="fov"):
        pyrt.render(scene)
    scene, _, _ = _lit_scene()
    scene.camera.position = np.array([0.0, NAN, 0.0])
    with pytest.raises(pyrt.Error, match="position"):
        pyrt.render(scene)
    scene, _, _ = _lit_scene()
    scene.background = np.array([NAN, 0, 0])
    with pytest.raises(pyrt.Error, match="background"):
        pyrt.render(scene)


def test_environment_mutated_after_construction_is_an_error():
    scene, _, _ = _lit_scene()
    env = pyrt.ConstantEnvironment(0.5, name="sky")
    pyrt.set_environment(scene, env)
    env.intensity = NAN
    with pytest.raises(pyrt.Error, match=r"ConstantEnvironment\(sky\).*intensity"):
        pyrt.render(scene)


@pytest.mark.parametrize("registry", [MATERIALS, LIGHTS, ENVIRONMENTS], ids=lambda r: r.family)
def test_every_example_validates_and_rejects_a_nan_parameter(registry):
    """Over the whole registry: the example passes validate(); a NaN in any public float parameter fails it."""
    for name, cls in registry.items():
        obj = cls.example()
        obj.validate()
        floats = [k for k, v in vars(obj).items() if not k.startswith("_") and isinstance(v, float)]
        for k in floats:
            bad = cls.example()
            setattr(bad, k, NAN)
            with pytest.raises(pyrt.Error, match=k):
                bad.validate()
