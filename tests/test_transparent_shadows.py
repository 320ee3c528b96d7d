"""Transparent shadows (pyrt.integrators.shadows): a glass slab's shadow is exactly the product of its
interface transmittances (exact Fresnel at each pixel's own angle), times Beer-Lambert absorption over the
straight path inside; opaque objects still cast 0; switched off, glass casts 0 as before."""
import numpy as np
import pytest

import pyrt
from pyrt.shaders.fresnel import fr_dielectric

from pyrt.integrators import Integrator, PreparedScene

from render_helpers import pixel_centre_hits_on_plane_y0

LIGHT = np.array([0.3, 1.3, -0.2])
Y0, H = 0.9, 0.1          # slab between y = Y0 and y = Y0 + H


def _scene(blocker=None):
    """A Lambert floor at y = 0 seen from below the blocker (camera at y = 0.5, 1 spp, pixel centres), lit by
    a point light above the blocker: camera rays never meet the blocker, only shadow rays do."""
    cam = pyrt.Camera(position=(0, 0.5, 0), target=(0, 0, 0), up=(0, 0, -1), fov=120.0, width=24, height=24,
                      spp=1, jitter=False)
    scene = pyrt.Scene(cam)
    scene.add_plane((0, 0, 0), 4.0, pyrt.Lambert(albedo=0.8), name="floor")
    scene.add_light(pyrt.PointLight(LIGHT, intensity=5.0))
    if blocker is not None:
        blocker(scene)
    return scene


def _slab(glass):
    def add(scene):
        scene.add_plane((0, Y0, 0), 20.0, glass, normal=(0, -1, 0), name="slab bottom")   # outward normals
        scene.add_plane((0, Y0 + H, 0), 20.0, glass, normal=(0, 1, 0), name="slab top")
    return add


def _expected(cam, ior, sigma_a=0.0):
    p = pixel_centre_hits_on_plane_y0(cam)
    w = LIGHT - p
    w /= np.linalg.norm(w, axis=-1, keepdims=True)
    cos = w[..., 1].ravel()
    t_one = 1.0 - fr_dielectric(cos, ior)
    d = H / cos                                    # straight path inside the slab
    return ((t_one * t_one) * np.exp(-sigma_a * d)).reshape(cam.height, cam.width), cos


def test_glass_slab_shadow_is_the_product_of_its_interface_transmittances():
    bare = pyrt.render(_scene(), transparent_shadows=True)
    scene = _scene(_slab(pyrt.Glass(ior=1.5)))
    img = pyrt.render(scene, transparent_shadows=True)
    expect, cos = _expected(scene.camera, 1.5)
    ratio = img[..., 0] / bare[..., 0]
    np.testing.assert_allclose(ratio, expect, rtol=2e-6)
    # normal incidence: (1 - 0.04)^2 = 0.9216 for ior 1.5 (the pixel under the light); the image spans oblique
    # angles to ~50 degrees off the normal, where the exact Fresnel product is well below it
    i = np.argmax(cos)
    assert cos[i] > 0.999 and abs(ratio.ravel()[i] - (1 - 0.04) ** 2) < 1e-3
    assert cos.min() < 0.7 and expect.min() < (1 - 0.04) ** 2 - 0.02


def test_absorbing_tinted_slab_adds_beer_lambert_over_the_straight_path_and_the_tint_per_interface():
    sigma = np.array([0.5, 2.0, 8.0])
    tint = np.array([1.0, 0.9, 0.7])
    bare = pyrt.render(_scene(), transparent_shadows=True)
    scene = _scene(_slab(pyrt.Glass(ior=1.5, absorption=sigma, tint=tint)))
    img = pyrt.render(scene, transparent_shadows=True)
    for c in range(3):
        expect, _ = _expected(scene.camera, 1.5, sigma[c])
        np.testing.assert_allclose(img[..., c] / bare[..., c], expect * tint[c] ** 2, rtol=2e-6)


def test_two_slabs_of_different_glasses_multiply_whichever_path_each_material_takes():
    """Constant-parameter dielectrics are crossed together, the others (a textured tint) one material at a time
    (shadows._cross): two stacked absorbing slabs of different ior, tint and absorption, one of them with a
    constant texture as its tint, give the product of the two closed forms."""
    g1 = pyrt.Glass(ior=1.5, absorption=np.array([0.5, 2.0, 8.0]), tint=np.array([1.0, 0.9, 0.7]))
    tint2 = np.array([0.8, 1.0, 0.6])
    g2 = pyrt.Glass(ior=1.33, absorption=np.array([3.0, 1.0, 0.2]),
                    tint=pyrt.ImageTexture(np.broadcast_to(tint2, (2, 2, 3)).copy(), srgb=False, filter="nearest"))
    lo = 0.5

    def add(scene):
        _slab(g1)(scene)
        scene.add_plane((0, lo, 0), 20.0, g2, normal=(0, -1, 0), name="low slab bottom")
        scene.add_plane((0, lo + H, 0), 20.0, g2, normal=(0, 1, 0), name="low slab top")
    cam = pyrt.Camera(position=(0, 0.3, 0), target=(0, 0, 0), up=(0, 0, -1), fov=120.0, width=24, height=24,
                      spp=1, jitter=False)
    scene = _scene(add)
    scene.camera = cam
    bare_scene = _scene()
    bare_scene.camera = cam
    bare = pyrt.render(bare_scene, transparent_shadows=True)
    img = pyrt.render(scene, transparent_shadows=True)
    for c in range(3):
        e1, _ = _expected(cam, 1.5, g1.absorption[c])
        e2, _ = _expected(cam, 1.33, g2.absorption[c])
        np.testing.assert_allclose(img[..., c] / bare[..., c], e1 * g1.tint[c] ** 2 * e2 * tint2[c] ** 2,
                                   rtol=2e-6)


def test_opaque_box_still_casts_zero_and_glass_with_the_switch_off_too():
    box = _scene(lambda s: s.add_box((0.3, 1.0, -0.2), (0.15, 0.1, 0.15), pyrt.Lambert(albedo=0.5)))
    img = pyrt.render(box, transparent_shadows=True)
    assert img.max() > 0                       # the floor outside the box's shadow
    p = pixel_centre_hits_on_plane_y0(box.camera)
    under = (np.abs(p[..., 0] - 0.3) < 0.2) & (np.abs(p[..., 2] + 0.2) < 0.2)   # inside the umbra (half-width 0.33)
    assert under.sum() > 4 and np.all(img[under] == 0.0)
    glass = _scene(_slab(pyrt.Glass(ior=1.5)))
    assert pyrt.render(glass).max() == 0.0     # default: strict Whitted, glass blocks
    # a glass slab above an opaque box: still black
    both = _scene(lambda s: (_slab(pyrt.Glass(ior=1.5))(s), s.add_box((0, 0.7, 0), (20, 0.05, 20), pyrt.Lambert())))
    assert pyrt.render(both, transparent_shadows=True).max() == 0.0


def test_box_shadow_region_is_exactly_zero():
    """The floor point right under the light behind an opaque box gets 0 with the switch on."""
    scene = _scene(lambda s: s.add_box((0, 1.1, 0), (20, 0.1, 20), pyrt.Lambert(albedo=0.5)))
    assert pyrt.render(scene, transparent_shadows=True).max() == 0.0


def test_switch_changes_nothing_in_a_scene_without_dielectrics():
    scene = _scene(lambda s: s.add_sphere((0.1, 1.0, 0), 0.2, pyrt.Lambert()))
    a = pyrt.render_full(scene)
    b = pyrt.render_full(scene, transparent_shadows=True)
    np.testing.assert_array_equal(a.image, b.image)
    assert a.stats.shadow_rays == b.stats.shadow_rays


def test_switch_is_a_bool_and_a_scene_file_key():
    with pytest.raises(pyrt.RenderError):
        pyrt.render(_scene(), transparent_shadows="yes")
    with pytest.raises(pyrt.RenderError, match="transparent_shadows must be True or False"):
        pyrt.Whitted(transparent_shadows="yes")
    _, opts = pyrt.load_dict({"render": {"integrator": {"transparent_shadows": True}}})
    assert opts["integrator"]["transparent_shadows"] is True



class _Counting(Integrator):
    """Counts the shadow rays that enter the closest-hit walk."""

    walked = 0

    def _shadow_hits(self, o, d, tmax):
        self.walked += o.shape[0]
        return super()._shadow_hits(o, d, tmax)


class _WalkEveryRay(_Counting):
    """The walk without the any-hit pre-test: every shadow ray starts the closest-hit loop (the method before)."""

    def _occluded(self, o, d, tmax):
        return np.ones(o.shape[0], dtype=bool)


def test_any_hit_pretest_keeps_the_transmittance_exactly_and_walks_only_blocked_rays():
    """Slab shadows, a half-covering opaque box and open floor: the image with the pre-test is bit-identical to
    walking every shadow ray, and the closest-hit loop sees only the rays the occlusion query found blocked."""
    def blockers(s):
        _slab(pyrt.Glass(ior=1.5, absorption=(0.5, 1.0, 2.0)))(s)
        s.add_box((0.4, 1.2, -0.2), (0.1, 0.05, 0.1), pyrt.Lambert(albedo=0.5))
    glass = _scene(lambda s: s.add_box((0.3, 1.0, -0.2), (0.15, 0.05, 0.15), pyrt.Glass(ior=1.4)))
    for scene, open_floor in ((_scene(blockers), False), (glass, True)):
        cam = scene.camera
        rays = cam.generate_rays(0, cam.width * cam.height, np.random.default_rng(0))
        ps = PreparedScene(scene)
        try:
            a = _Counting(ps, transparent_shadows=True)
            b = _WalkEveryRay(ps, transparent_shadows=True)
            La, _ = a.render_samples(rays)
            Lb, _ = b.render_samples(rays)
        finally:
            ps.close()
        np.testing.assert_array_equal(La, Lb)
        assert 0 < La.max() and np.any((La > 0) & (La < La.max() * 0.99))   # lit, and partly shadowed
        # every pixel's one shadow ray walks without the pre-test; with it only those through the blockers
        assert b.walked >= cam.width * cam.height and a.walked > 0
        assert (a.walked < b.walked) if open_floor else (a.walked <= b.walked)
