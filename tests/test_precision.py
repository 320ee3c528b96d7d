"""The float32 range rule (pyrt.geometry.precision): warn where ray tracing distorts a mesh, refuse where it
loses everything; both sides of each measured threshold."""
import warnings

import numpy as np
import pytest

import pyrt
from pyrt.geometry.precision import PrecisionWarning


def _sphere_scene(center, radius, cam_offset):
    c = np.asarray(center, float)
    cam = pyrt.Camera(position=c + cam_offset, target=c, width=16, height=16, spp=1, jitter=False)
    s = pyrt.Scene(cam)
    s.add_sphere(center, radius, pyrt.Lambert(0.8), name="ball")
    s.add_light(pyrt.DirectionalLight((0, -1, -1), 1.0))
    return s


def _coverage(scene):
    return float(np.isfinite(pyrt.render_full(scene, aovs=True).aovs["depth"]).mean())


def test_unit_sphere_near_origin_renders_without_warning():
    with warnings.catch_warnings():
        warnings.simplefilter("error", PrecisionWarning)
        assert _coverage(_sphere_scene((1e5, 0, 0), 1.0, (0, 0, 5))) > 0.2


def test_unit_sphere_far_from_origin_is_warned_about():
    with pytest.warns(PrecisionWarning, match=r"mesh 'ball'.*float32 steps"):
        _coverage(_sphere_scene((1e7, 0, 0), 1.0, (0, 0, 5)))
    with pytest.warns(PrecisionWarning, match=r"mesh 'ball'.*size 0 along x"):    # flattened: nothing hit
        assert _coverage(_sphere_scene((1e8, 0, 0), 1.0, (0, 0, 5))) == 0.0


def test_scaled_scene_renders_at_1e12_and_is_refused_at_1e14():
    with warnings.catch_warnings():
        warnings.simplefilter("error", PrecisionWarning)
        assert _coverage(_sphere_scene((0, 0, 0), 1e12, (0, 0, 5e12))) > 0.2
    with pytest.warns(PrecisionWarning, match="overflows"), pytest.raises(pyrt.GeometryError,
                                                                          match="nothing can be rendered"):
        pyrt.render(_sphere_scene((0, 0, 0), 1e14, (0, 0, 5e14)))


def test_one_lost_mesh_among_visible_ones_is_a_warning_not_an_error():
    s = _sphere_scene((0, 0, 0), 1.0, (0, 0, 5))
    s.add_box((0, 0, -1e20), 1e15, pyrt.Lambert(), name="far")
    with pytest.warns(PrecisionWarning, match=r"mesh 'far'.*lost"):
        assert np.all(np.isfinite(pyrt.render(s)))


def test_coordinates_beyond_float32_are_refused():
    with pytest.raises(pyrt.GeometryError, match="float32 range"):
        pyrt.Scene().add_sphere((1e39, 0, 0), 1.0, pyrt.Lambert())
    s = _sphere_scene((0, 0, 0), 1.0, (0, 0, 5))
    s.camera.position = np.array([0.0, 0.0, 1e39])
    with pytest.raises(pyrt.GeometryError, match="camera"):
        pyrt.render(s)


def test_a_scene_smaller_than_the_measured_limit_is_warned_about():
    from pyrt.geometry.precision import PrecisionWarning, SMALLEST_EXTENT
    S = SMALLEST_EXTENT / 100
    cam = pyrt.Camera(position=(0, S, 4 * S), target=(0, 0.5 * S, 0), width=8, height=6)
    scene = pyrt.Scene(cam)
    scene.add_sphere((0, 0.5 * S, 0), 0.5 * S, pyrt.Lambert(0.5))
    scene.add_light(pyrt.PointLight((S, 3 * S, S), intensity=1e-20))
    with pytest.warns(PrecisionWarning, match="across"):
        pyrt.render(scene)
