"""Reference switches (issue 16, item 8): the terminator lift and the back-facing-normal fallback can be
turned off, for comparisons with renderers that trace the true triangles (pbrt-v4, Mitsuba 3)."""
import numpy as np

import pyrt
from pyrt.geometry import offsets


def _lowpoly_scene(light_dir, *, fallback=True):
    """An 80-face smooth-shaded unit sphere (icosphere level 1) seen from +z, a directional light."""
    cam = pyrt.Camera(position=(0, 0, 4), target=(0, 0, 0), width=128, height=128, fov=35, jitter=False)
    scene = pyrt.Scene(cam, shading_normal_fallback=fallback)
    scene.add_sphere((0, 0, 0), 1.0, pyrt.Lambert(albedo=0.8), subdivisions=1, smooth=True)
    scene.add_light(pyrt.DirectionalLight(light_dir, irradiance=3.0))
    return scene


def test_defaults_are_unchanged():
    assert offsets.DEFAULT == "robust" and offsets.STRATEGIES["robust"].terminator
    st = offsets.STRATEGIES["robust_no_terminator"]
    assert not st.terminator and st.tmax == "robust" and st.origin is offsets.local_bound
    assert pyrt.Scene().shading_normal_fallback is True


def test_terminator_lift_off_leaves_the_band_black():
    # light from the side: the terminator runs down the middle of the visible disc
    scene = _lowpoly_scene((-1.0, -0.1, 0.05))
    lifted = pyrt.render(scene, spp=1)[..., 0]
    flat = pyrt.render(scene, spp=1, offset="robust_no_terminator")[..., 0]
    band = (lifted > 0) & (flat == 0)
    assert band.sum() >= 40                      # measured: 67 of the 128 x 128 pixels (3708 lit)
    assert np.all(flat <= lifted)                # the switch only removes light
    np.testing.assert_array_equal(flat[~band], lifted[~band])


def test_shading_normal_fallback_off_shades_black():
    # light from the camera: every visible pixel is lit; where the interpolated normal faces away
    # from the viewer (near the silhouette of the coarse sphere) the fallback shades with ng
    on = pyrt.render(_lowpoly_scene((0.0, 0.0, -1.0)), spp=1)[..., 0]
    off = pyrt.render(_lowpoly_scene((0.0, 0.0, -1.0), fallback=False), spp=1)[..., 0]
    changed = on != off
    assert changed.sum() >= 40                   # measured: 88 of 7940 visible pixels
    assert np.all(off[changed] == 0) and np.all(on[changed] > 0)
