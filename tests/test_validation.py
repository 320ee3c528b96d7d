"""Parameters are checked when an object is built and again when a scene is prepared for rendering.

A value assigned after construction (``light.intensity = nan``) must be a :class:`pyrt.Error` naming the
object at render time, never a light that silently contributes nothing or a NaN image.
"""
import math

import numpy as np
import pytest

import pyrt
from pyrt.core.checks import Fixed
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
    with pytest.raises(pyrt.Error, match="position"):           # refused as it is assigned
        scene.camera.position = np.array([0.0, NAN, 0.0])
    scene.camera.position[1] = NAN                                # changed in place: found before the render
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
            if isinstance(getattr(cls, k, None), Fixed):      # refused as it is assigned (derived state)
                with pytest.raises(pyrt.Error, match=k):
                    setattr(bad, k, NAN)
                continue
            setattr(bad, k, NAN)
            with pytest.raises(pyrt.Error, match=k):
                bad.validate()


@pytest.mark.parametrize("call, words", [
    (lambda s, m: s.add_sphere((0, 0, 0), 0.0, m), r"sphere: radius must be a finite number > 0"),
    (lambda s, m: s.add_sphere((0, 0, 0), -0.5, m, name="ball"), r"sphere 'ball': radius"),
    (lambda s, m: s.add_sphere((0, 0, 0), NAN, m), "radius"),
    (lambda s, m: s.add_sphere((0, 0, 0), math.inf, m), "radius"),
    (lambda s, m: s.add_sphere((0, 0, 0), 1.0, m, subdivisions=-1), "subdivisions"),
    (lambda s, m: s.add_sphere((0, 0, 0), 1.0, m, subdivisions=2.5), "subdivisions"),
    (lambda s, m: s.add_sphere((0, 0, 0), 1.0, m, subdivisions=99), "subdivisions"),
    (lambda s, m: s.add_box((0, 0, 0), (1, 0, 1), m), "box: extents"),
    (lambda s, m: s.add_box((0, 0, 0), (1, NAN, 1), m), "box: extents"),
    (lambda s, m: s.add_box((0, 0, 0), -1, m), "box: extents"),
    (lambda s, m: s.add_plane((0, 0, 0), 0, m), "plane: size"),
    (lambda s, m: s.add_plane((0, 0, 0), (1, -2), m), "plane: size"),
    (lambda s, m: s.add_plane((0, 0, 0), math.inf, m), "plane: size"),
])
def test_primitive_sizes_are_checked(call, words):
    with pytest.raises(pyrt.Error, match=words):
        call(pyrt.Scene(), pyrt.Lambert())


def test_mesh_with_a_nan_vertex_names_the_non_finite_vertex():
    v = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, NAN]]
    with pytest.raises(pyrt.GeometryError, match=r"'quad'.*non-finite vertex.*index 3"):
        pyrt.Scene().add_mesh((v, [[0, 1, 2], [1, 3, 2]]), pyrt.Lambert(), name="quad")


def test_mesh_without_faces_says_it_has_no_triangles():
    with pytest.raises(pyrt.GeometryError, match=r"mesh 'dots' has no triangles"):
        pyrt.Scene().add_mesh(([[0, 0, 0], [1, 0, 0], [0, 1, 0]], np.zeros((0, 3), int)), pyrt.Lambert(),
                              name="dots")
    with pytest.raises(pyrt.GeometryError, match=r"mesh 'empty' has no triangles"):
        pyrt.Scene().add_mesh((np.zeros((0, 3)), np.zeros((0, 3), int)), pyrt.Lambert(), name="empty")


@pytest.mark.parametrize("option, value", [
    ("throughput_cutoff", -1.0), ("throughput_cutoff", NAN), ("throughput_cutoff", math.inf),
    ("threads", -1), ("threads", 0), ("threads", 1.5), ("max_depth", -1), ("max_depth", 2.5),
    ("spp", 0), ("spp", NAN), ("chunk_samples", 0),
])
def test_render_options_out_of_range_are_errors(option, value):
    scene, _, _ = _lit_scene()
    with pytest.raises(pyrt.RenderError, match=rf"(render|Whitted|Execution): {option} must be"):
        pyrt.render(scene, **{option: value})


def test_render_options_at_their_limits_are_accepted():
    scene, _, _ = _lit_scene()
    a = pyrt.render(scene, throughput_cutoff=0.0, threads=1, max_depth=0, spp=1.0, seed=1)
    assert np.all(np.isfinite(a))


@pytest.mark.parametrize("name, attr, bad", [("phong", "exponent", -1.0), ("phong_classic", "ka", 2.0),
                                             ("ward", "alpha_x", 0.0), ("cook_torrance", "rough", -0.5),
                                             ("metallic_roughness", "metallic", 1.5)])
def test_library_material_out_of_range_after_construction_is_an_error(name, attr, bad):
    """The library's declared ``ranges`` are re-checked before every render, not only in the constructor."""
    mat = pyrt.MATERIALS[name].example()
    mat.validate()
    setattr(mat, attr, bad)
    with pytest.raises(pyrt.MaterialError, match=attr):
        mat.validate()
