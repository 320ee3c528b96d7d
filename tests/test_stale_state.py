"""Parameters assigned after construction are never half-used: the camera re-derives its frame from what is set;
a parameter other state was derived from at construction (a light's frame, an environment's tables, a texture's
decoding, a metal's optical constants) is refused with an error naming the object and the attribute."""
import numpy as np
import pytest

import pyrt
from pyrt.core.checks import FixedAttributeError


def _scene(camera):
    scene = pyrt.Scene(camera, background=(0.05, 0.05, 0.1))
    scene.add_plane((0, 0, 0), 6.0, pyrt.Lambert(albedo=(0.6, 0.6, 0.5)))
    scene.add_sphere((0.5, 0.5, -0.5), 0.5, pyrt.Lambert(albedo=(0.7, 0.2, 0.2)))
    scene.add_light(pyrt.PointLight((2, 3, 2), intensity=20.0))
    return scene


CAM = dict(position=(0, 1, 4), target=(0, 0.5, 0), up=(0, 1, 0), fov=40, width=24, height=18, spp=1)


@pytest.mark.parametrize("backend", ["numpy", "compiled"])
@pytest.mark.parametrize("attr, value", [("position", (3.0, 2.0, 1.0)), ("target", (1.0, 0.0, -1.0)),
                                         ("up", (0.3, 1.0, 0.0)), ("fov", 25.0)])
def test_a_camera_parameter_assigned_later_renders_as_if_given_to_the_constructor(backend, attr, value):
    cam = pyrt.Camera(**CAM)
    before = pyrt.render(_scene(cam), seed=1, backend=backend)
    setattr(cam, attr, value)
    after = pyrt.render(_scene(cam), seed=1, backend=backend)
    fresh = pyrt.render(_scene(pyrt.Camera(**dict(CAM, **{attr: value}))), seed=1, backend=backend)
    assert np.array_equal(after, fresh) and not np.array_equal(after, before)


def test_the_camera_frame_is_derived_and_read_only():
    cam = pyrt.Camera(**CAM)
    cam.target = (0.0, 1.0, 0.0)
    np.testing.assert_allclose(cam.forward, [0, 0, -1], atol=1e-15)
    with pytest.raises(AttributeError):
        cam.forward = np.array([1.0, 0.0, 0.0])
    with pytest.raises(pyrt.Error, match="target equals position"):
        cam.target = cam.position.copy()
        pyrt.render(_scene(cam))


CASES = [
    (lambda: pyrt.RectLight.example(), "normal", np.array([1.0, 0.0, 0.0])),
    (lambda: pyrt.DiskLight.example(), "normal", np.array([1.0, 0.0, 0.0])),
    (lambda: pyrt.ProjectorLight.example(), "direction", np.array([1.0, 0.0, 0.0])),
    (lambda: pyrt.ProjectorLight.example(), "outer_angle", 10.0),
    (lambda: pyrt.GoniometricLight.example(), "up", np.array([1.0, 0.0, 0.0])),
    (lambda: pyrt.IESLight.example(), "scale", 2.0),
    (lambda: pyrt.IESLight.example(), "direction", np.array([1.0, 0.0, 0.0])),
    (lambda: pyrt.ConstantEnvironment.example(), "color", np.array([1.0, 0.0, 0.0])),
    (lambda: pyrt.LatLongEnvironment.example(), "image", np.ones((8, 16, 3))),
    (lambda: pyrt.CubeMapEnvironment.example(), "faces", np.ones((6, 4, 4, 3))),
    (lambda: pyrt.ImageTexture.example(), "decode", "srgb"),
    (lambda: pyrt.ImageTexture.example(), "srgb", True),
    (lambda: pyrt.NoiseTexture.example(), "seed", 7),
    (lambda: pyrt.Conductor(metal="gold"), "metal", "copper"),
    (lambda: pyrt.CookTorrance(metal="gold"), "metal", "copper"),
    (lambda: pyrt.GltfPBR(transmission=1.0), "transmission", 0.0),
]


@pytest.mark.parametrize("make, attr, value", CASES, ids=[f"{i}-{c[1]}" for i, c in enumerate(CASES)])
def test_a_parameter_with_derived_state_is_refused_after_construction(make, attr, value):
    obj = make()
    old = getattr(obj, attr)
    with pytest.raises(FixedAttributeError, match=rf"{type(obj).__name__}.*{attr} cannot be changed after "
                                                  rf"construction \(.*\): make a new {type(obj).__name__}"):
        setattr(obj, attr, value)
    assert getattr(obj, attr) is old
    setattr(obj, attr, old)           # the object it holds: allowed
    assert isinstance(FixedAttributeError("x"), (pyrt.Error, AttributeError))


def test_a_procedural_texture_channel_count_follows_its_colours():
    tex = pyrt.CheckerTexture(0.2, 0.8)
    assert tex.channels == 1
    tex.color1 = np.array([0.9, 0.1, 0.1])      # grey -> RGB: a render reads 3 channels now (was: still 1)
    assert tex.channels == 3
    noise = pyrt.NoiseTexture.example()
    noise.high = np.array([1.0, 0.5, 0.0])
    assert noise.channels == 3


def _glass_shadow(material):
    """A Lambert floor under a slab of ``material`` lit by a point light above it (transparent shadows, pixel
    centres, NumPy path): the floor's colour is the light times the slab's tint at each interface."""
    cam = pyrt.Camera(position=(0, 0.5, 0), target=(0, 0, 0), up=(0, 0, -1), fov=100.0, width=12, height=12,
                      spp=1, jitter=False)
    scene = pyrt.Scene(cam)
    scene.add_plane((0, 0, 0), 4.0, pyrt.Lambert(albedo=0.8), name="floor")
    scene.add_light(pyrt.PointLight((0.3, 1.3, -0.2), intensity=5.0))
    scene.add_plane((0, 0.9, 0), 20.0, material, normal=(0, -1, 0), name="slab bottom")
    scene.add_plane((0, 1.0, 0), 20.0, material, normal=(0, 1, 0), name="slab top")
    return pyrt.render(scene, transparent_shadows=True, backend="numpy")


TINTED = [
    ("base_color", np.array([0.9, 0.5, 0.2]), lambda **kw: pyrt.GltfPBR(roughness=0.0, thin=False, **kw)),
    ("metallic", 0.5, lambda **kw: pyrt.GltfPBR(roughness=0.0, thin=False, **kw)),
    ("base_color", np.array([0.9, 0.5, 0.2]),
     lambda **kw: pyrt.GltfPBR(roughness=0.0, thin=False, transmission=pyrt.ImageTexture(np.full((2, 2), 0.75),
                                                                                            srgb=False), **kw)),
]


@pytest.mark.parametrize("coat", [False, True])
@pytest.mark.parametrize("attr, value, make", TINTED, ids=["base_color", "metallic", "textured-transmission"])
def test_a_transmitting_gltf_material_tints_by_its_parameters_as_they_are_at_render_time(attr, value, make, coat):
    """The tint transparent shadows multiply by derives from base_color, metallic and transmission whenever it is
    read (was: computed once in the constructor; a base_color or metallic assigned later left the old colour in the
    shadow), also through a clear coat on top (a layer passes its base's tint on)."""
    const = {} if make is TINTED[2][2] else {"transmission": 1.0}
    mat = make(**const)
    shown = pyrt.Clearcoat(mat, clearcoat=0.0) if coat else mat      # the layer built before the assignment
    before = _glass_shadow(shown)
    setattr(mat, attr, value)
    after = _glass_shadow(shown)
    fresh = make(**const, **{attr: value})
    np.testing.assert_array_equal(after, _glass_shadow(pyrt.Clearcoat(fresh, clearcoat=0.0) if coat else fresh))
    assert np.abs(after - before).max() > 0.01
