"""Image-based lighting on the compiled path: constant and lat-long environments seen by missed rays and lighting
by ``strategy="mis"`` (the scalar twins: tests/test_compiled_env.py, tests/test_compiled_sampling.py)."""
import numpy as np
import pytest

import pyrt
from pyrt.core.errors import RenderError

from test_compiled_area_lights import assert_agree_in_distribution


def _sky_scene(spp=16, width=40, height=30):
    cam = pyrt.Camera(position=(0, 1.0, 4.0), target=(0, 0.4, 0), fov=40, width=width, height=height, spp=spp)
    s = pyrt.Scene(cam)
    s.add_plane((0, 0, 0), 8.0, pyrt.Lambert(albedo=(0.5, 0.45, 0.4)))
    s.add_sphere((-0.5, 0.5, 0), 0.5, pyrt.CookTorrance(metal="gold", roughness=0.3), subdivisions=3)
    s.add_sphere((0.6, 0.4, 0.3), 0.4, pyrt.BlinnPhong(kd=0.6, ks=0.2, exponent=30), subdivisions=3)
    s.add_sphere((0.1, 0.25, 0.9), 0.25, pyrt.Mirror(0.9), subdivisions=3)
    sky = pyrt.procedural_sky(128, 64, sun_direction=(0.5, 0.6, 0.4), sun_angle=3.0)
    pyrt.set_environment(s, pyrt.LatLongEnvironment(sky), n_samples=2, bsdf_samples=3)
    return s


def test_white_furnace_is_exact():
    """A Lambertian sphere in a constant environment: the compensated table is empty, so every sample is a BSDF
    sample of weight ``albedo`` carrying ``L`` with MIS weight 1 and an unblocked shadow ray (a convex object): each
    pixel is ``albedo L`` exactly; missed rays see ``L``."""
    cam = pyrt.Camera(position=(0, 0, 4), target=(0, 0, 0), fov=30, width=24, height=24, jitter=False)
    s = pyrt.Scene(cam)
    s.add_sphere((0, 0, 0), 1.0, pyrt.Lambert(albedo=(0.8, 0.5, 0.2)), subdivisions=4)
    L = np.array([1.5, 1.0, 0.5])
    pyrt.set_environment(s, pyrt.ConstantEnvironment(L))
    r = pyrt.render_full(s, backend="compiled", progress=False)
    assert r.stats.backend == "compiled" and r.stats.shadow_rays > 0
    img = r.image.astype(np.float64)
    on_sphere = img[..., 2] < 0.3                                 # 0.1 on the sphere (0.2 x 0.5), 0.5 off it
    assert 0.2 < on_sphere.mean() < 0.8
    np.testing.assert_allclose(img[on_sphere], np.broadcast_to(L * [0.8, 0.5, 0.2], img[on_sphere].shape),
                               rtol=1e-6)
    np.testing.assert_allclose(img[~on_sphere], np.broadcast_to(L, img[~on_sphere].shape), rtol=1e-6)


def test_sky_agrees_with_the_numpy_path_in_distribution():
    """A lat-long sky with a sun over a Lambert ground, gold, Blinn-Phong and a mirror (2 light + 3 BSDF samples per
    hit, the compensated table, the power heuristic): per pixel against the NumPy path."""
    assert_agree_in_distribution(_sky_scene())


def test_hidden_background_and_reflections():
    """``hide_background``: camera rays that miss see the background colour, mirror reflections the environment
    (pixel centres: the same on both paths)."""
    cam = pyrt.Camera(position=(0, 0, 4), target=(0, 0, 0), fov=30, width=24, height=24, jitter=False)
    s = pyrt.Scene(cam)
    s.add_sphere((0, 0, 0), 1.0, pyrt.Mirror(0.5), subdivisions=4)
    sky = pyrt.procedural_sky(64, 32, sun_direction=(0.5, 0.6, 0.4), sun_angle=5.0)
    env = pyrt.LatLongEnvironment(sky, hide_background=True, background=(0.1, 0.2, 0.3))
    pyrt.set_environment(s, env, lighting=None)
    c = pyrt.render_full(s, backend="compiled", progress=False)
    n = pyrt.render_full(s, backend="numpy", progress=False)
    assert c.stats.backend == "compiled"
    np.testing.assert_allclose(c.image, n.image, rtol=1e-5, atol=1e-7)
    assert np.allclose(c.image[0, 0], [0.1, 0.2, 0.3])
    assert not np.allclose(c.image[12, 12], [0.1, 0.2, 0.3])


@pytest.mark.parametrize("kw, reason", [(dict(lighting="map"), "EnvironmentLight"),
                                        (dict(control_variate=True), "EnvironmentLight")])
def test_other_strategies_fall_back(kw, reason):
    s = _sky_scene(spp=1, width=8, height=6)
    pyrt.set_environment(s, s.environment, **kw)
    r = pyrt.render_full(s, progress=False)
    assert r.stats.backend == "numpy" and any(reason in x for x in r.stats.fallback_reasons), r.stats
    with pytest.raises(RenderError, match="does not cover"):
        pyrt.render_full(s, progress=False, backend="compiled")


def test_adaptive_passes_with_an_environment():
    """The sky to a target error on the compiled path: it stops at the target, and is as close to a converged NumPy
    reference as the NumPy path's own adaptive render (within 2x in relMSE)."""
    scene = _sky_scene(width=32, height=24)
    ref = pyrt.render_full(scene, backend="numpy", progress=False, seed=9, spp=256).image.astype(np.float64)
    errs = {}
    for b in ("compiled", "numpy"):
        r = pyrt.render_full(scene, backend=b, progress=False, seed=1, target_error=5e-3, max_spp=256)
        assert r.stats.backend == b and r.stop_reason == "target_error"
        errs[b] = float(np.mean((r.image - ref) ** 2 / (ref ** 2 + 1e-2)))
    assert 0.5 < errs["compiled"] / errs["numpy"] < 2.0, errs
