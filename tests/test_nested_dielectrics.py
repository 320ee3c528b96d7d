"""Nested dielectrics (Schmidt & Budge 2002): interface stacks, relative indices, ignored surfaces,
Beer-Lambert absorption."""
import math

import numpy as np
import pytest

import pyrt
from pyrt.core.rays import RayBatch
from pyrt.integrators.media import NestedMedia, absorption_from_transmittance, beer_lambert
from pyrt.integrators import Integrator, PreparedScene


def _media(*glasses):
    return NestedMedia(list(glasses))


def test_stack_push_remove_top_with_priorities_and_ties():
    water, glass, ice = pyrt.Glass(1.33, priority=1), pyrt.Glass(1.5, priority=2), pyrt.Glass(1.31, priority=1)
    m = _media(water, glass, ice)                      # ids 0, 1, 2
    s = m.empty(3)
    s = m.push(s, np.array([0, 0, 2]))
    s = m.push(s, np.array([1, 2, 0]))
    s = m.push(s, np.array([2, 1, 1]))                 # forces a third column
    assert s.shape[1] == 3
    np.testing.assert_array_equal(m.top(s), [1, 1, 1])  # glass has the highest priority everywhere
    r = m.remove(s, np.array([1, 1, 1]))
    # water and ice tie (priority 1): the most recently entered one is current
    np.testing.assert_array_equal(r[:, :2], [[0, 2], [0, 2], [2, 0]])
    np.testing.assert_array_equal(m.top(r), [2, 2, 0])
    assert np.all(m.top(m.empty(2)) == -1)
    np.testing.assert_array_equal(m.remove(m.empty(1), np.array([1])), m.empty(1))


def test_classify_relative_indices():
    water, glass = pyrt.Glass(1.33, priority=1), pyrt.Glass(1.5, priority=2)
    m = _media(water, glass)
    empty = m.empty(1)
    in_water = m.push(empty, np.array([0]))
    in_both = m.push(in_water, np.array([1]))
    cases = [  # stack, material, front -> true hit, eta_t / eta_i
        (empty, 0, True, True, 1.33),           # air -> water
        (in_water, 1, True, True, 1.5 / 1.33),  # water -> glass
        (in_both, 1, False, True, 1.33 / 1.5),  # glass -> water
        (in_water, 0, False, True, 1 / 1.33),   # water -> air
        (m.push(empty, np.array([1])), 0, True, False, None),   # water surface inside glass: ignored
        (in_both, 0, False, False, None),       # leaving water while inside glass: ignored
    ]
    for stack, mat, front, true_hit, eta in cases:
        t, e = m.classify(stack, np.array([mat]), np.array([front]))
        assert t[0] == true_hit
        if eta is not None:
            assert e[0] == pytest.approx(eta, rel=1e-15)


def test_equal_priorities_give_glass_in_water_right():
    # default priorities (all 0): the most recently entered volume wins, which is right for nesting
    water, glass = pyrt.Glass(1.33), pyrt.Glass(1.5)
    m = _media(water, glass)
    in_water = m.push(m.empty(1), np.array([0]))
    t, e = m.classify(in_water, np.array([1]), np.array([True]))
    assert t[0] and e[0] == pytest.approx(1.5 / 1.33)


def test_media_only_when_needed():
    assert NestedMedia.for_scene([pyrt.Lambert(), pyrt.Glass(1.5)]) is None
    assert NestedMedia.for_scene([pyrt.Glass(1.5), pyrt.Glass(1.33)]) is not None
    assert NestedMedia.for_scene([pyrt.Glass(1.5, absorption=0.1)]) is not None


def _sphere_scene(specs, *, background=(1.0, 1.0, 1.0), subdivisions=3):
    scene = pyrt.Scene(pyrt.Camera(position=(0, 0, 6), target=(0, 0, 0), width=8, height=8),
                       background=background)
    for r, mat in specs:
        scene.add_sphere((0, 0, 0), r, mat, subdivisions=subdivisions, smooth=False)
    return scene


def _snell_ratio(ps, o_in, d_in, d_out):
    """sin(theta_in) / sin(theta_out) at the surface hit by the ray (o_in, d_in), with its facet normal."""
    h = ps.accel.intersect(o_in[None], d_in[None])
    n = h.ng[0] / np.linalg.norm(h.ng[0])
    s_in = np.linalg.norm(np.cross(d_in, n))
    s_out = np.linalg.norm(np.cross(d_out, n))
    # the refracted ray stays in the plane of incidence
    assert abs(np.dot(np.cross(d_in, n), d_out)) < 1e-5
    return s_in / s_out


@pytest.mark.parametrize("offset", [(0.35, 0.2), (-0.6, 0.1), (0.15, -0.45)])
def test_glass_sphere_inside_water_sphere_bends_by_relative_index(offset):
    n_w, n_g = 1.33, 1.5
    scene = _sphere_scene([(2.0, pyrt.Glass(n_w, priority=1)), (1.0, pyrt.Glass(n_g, priority=2))])
    ps = PreparedScene(scene)
    try:
        assert ps.media is not None
        integ = Integrator(ps, max_depth=3, throughput_cutoff=0.0, record_rays=True)
        o = np.array([[offset[0], offset[1], 6.0]])
        d = np.array([[0.0, 0.0, -1.0]])
        integ.render_samples(RayBatch(o, d))
        batches = [(r[1].astype(np.float64), r[2].astype(np.float64)) for r in integ.stats.recorded
                   if r[0] == "intersect"]

        def inward(batch, radius):
            oo, dd = batch
            k = np.flatnonzero((np.abs(np.linalg.norm(oo, axis=1) - radius) < 0.1)
                               & (np.einsum("ij,ij->i", oo, dd) < 0))
            assert k.size == 1
            return oo[k[0]], dd[k[0]] / np.linalg.norm(dd[k[0]])

        o1, d1 = inward(batches[1], 2.0)      # refracted into the water
        o2, d2 = inward(batches[2], 1.0)      # refracted into the glass
        assert _snell_ratio(ps, o[0], d[0], d1) == pytest.approx(n_w, rel=2e-5)
        assert _snell_ratio(ps, o1, d1, d2) == pytest.approx(n_g / n_w, rel=2e-5)
        # leaving the glass into the water (not into air): the ray inside the glass continues ...
        oo, dd = batches[3]
        k = np.flatnonzero((np.abs(np.linalg.norm(oo, axis=1) - 1.0) < 0.1) & (np.einsum("ij,ij->i", oo, dd) > 0)
                           & (np.linalg.norm(np.cross(dd / np.linalg.norm(dd, axis=1, keepdims=True), oo), axis=1)
                              > 0))
        ratios = [_snell_ratio(ps, o2, d2, dd[j] / np.linalg.norm(dd[j])) for j in k]
        # ... with the transmitted ray bent by n_g / n_w (the reflected one has ratio 1)
        assert any(r == pytest.approx(n_w / n_g, rel=2e-5) for r in ratios), ratios
    finally:
        ps.close()


def _checker_scene(specs, size=24):
    cam = pyrt.Camera(position=(0, 1.0, 4.0), target=(0, 0, 0), fov=40, width=size, height=size, spp=1,
                      jitter=False)
    scene = pyrt.Scene(cam, background=(0.2, 0.3, 0.5))
    scene.add_plane((0, -1.2, 0), 10.0, pyrt.Lambert(albedo=pyrt.CheckerTexture(0.1, 0.9, scale=12.0)))
    scene.add_light(pyrt.DirectionalLight((0.3, -1, -0.2), 3.0))
    for center, r, mat in specs:
        scene.add_sphere(center, r, mat, subdivisions=3, smooth=True)
    return scene


def test_surface_inside_higher_priority_volume_is_ignored():
    outer = pyrt.Glass(1.5, priority=2)
    ref = pyrt.render(_checker_scene([((0, 0, 0), 1.0, outer)]), max_depth=6)
    # a strongly refracting sphere wholly inside the glass, with lower priority: invisible
    hidden = pyrt.render(_checker_scene([((0, 0, 0), 1.0, outer), ((0.1, 0, 0), 0.5, pyrt.Glass(2.4, priority=1))]),
                         max_depth=6)
    np.testing.assert_allclose(hidden, ref, rtol=1e-4, atol=1e-5)
    # the same sphere with a higher priority does show (the test can tell the difference)
    shown = pyrt.render(_checker_scene([((0, 0, 0), 1.0, outer), ((0.1, 0, 0), 0.5, pyrt.Glass(2.4, priority=3))]),
                        max_depth=6)
    assert np.abs(shown - ref).max() > 0.05


def test_single_glass_renders_as_before_in_nested_mode():
    # a second (unused-elsewhere) dielectric far away switches the stack on; the sphere must not change
    g = pyrt.Glass(1.5)
    base = _checker_scene([((0, 0, 0), 1.0, g)])
    ps = PreparedScene(base)
    assert ps.media is None
    ps.close()
    ref = pyrt.render(base, max_depth=6)
    far = _checker_scene([((0, 0, 0), 1.0, g), ((0, 50, 0), 0.1, pyrt.Glass(1.2))])
    img = pyrt.render(far, max_depth=6)
    np.testing.assert_allclose(img, ref, rtol=1e-6, atol=1e-7)


def _slab_scene(ior, sigma, thickness, background):
    cam = pyrt.Camera(position=(0, 3, 0), target=(0, 0, 0), up=(0, 0, -1), fov=50, width=16, height=16, spp=1,
                      jitter=False)
    scene = pyrt.Scene(cam, background=background)
    scene.add_box((0, 0, 0), (4.0, thickness, 4.0), pyrt.Glass(ior, absorption=sigma))
    return scene


# Segment lengths are measured from the offset ray origins (pyrt.geometry.offsets: ~16 float32 ulps of the
# coordinates past the surface), so the absorbed length is short by ~1e-6 here: rtol 2e-5.
SLAB_RTOL = 2e-5


def test_beer_lambert_through_slab_index_matched():
    sigma = np.array([0.5, 1.0, 2.0])
    t = 0.4
    B = np.array([0.5, 1.0, 2.0])
    scene = _slab_scene(1.0, sigma, t, B)        # ior 1: no Fresnel reflection, no bending
    img = pyrt.render(scene, max_depth=4).astype(np.float64)
    cam = scene.camera
    ys, xs = np.mgrid[0:cam.height, 0:cam.width]
    d = cam.directions(xs.ravel() + 0.5, ys.ravel() + 0.5)
    path = t / np.abs(d[:, 1] / np.linalg.norm(d, axis=1))
    expected = B * np.exp(-sigma * path[:, None])
    np.testing.assert_allclose(img.reshape(-1, 3), expected, rtol=SLAB_RTOL)


def test_beer_lambert_slab_with_fresnel_series_at_normal_incidence():
    sigma = np.array([0.3, 1.2, 3.0])
    t, n = 0.5, 1.5
    B = np.array([1.0, 1.0, 1.0])
    scene = _slab_scene(n, sigma, t, B)
    ps = PreparedScene(scene)
    try:
        integ = Integrator(ps, max_depth=12, throughput_cutoff=0.0)
        L, _ = integ.render_samples(RayBatch(np.array([[0.0, 3.0, 0.0]]), np.array([[0.0, -1.0, 0.0]])))
    finally:
        ps.close()
    R = ((n - 1) / (n + 1)) ** 2
    a = np.exp(-sigma * t)
    # transmitted: (1-R)^2 a / (1 - R^2 a^2); reflected back to the camera: R + (1-R)^2 R a^2 / (1 - R^2 a^2)
    transmitted = (1 - R) ** 2 * a / (1 - R ** 2 * a ** 2)
    reflected = R + (1 - R) ** 2 * R * a ** 2 / (1 - R ** 2 * a ** 2)
    np.testing.assert_allclose(L[0], B * (transmitted + reflected), rtol=SLAB_RTOL)


def test_absorption_helpers():
    s = absorption_from_transmittance((0.5, 0.25, 1.0), 2.0)
    np.testing.assert_allclose(s, [math.log(2) / 2, math.log(4) / 2, 0.0])
    np.testing.assert_allclose(beer_lambert(np.array([s]), np.array([2.0]))[0], [0.5, 0.25, 1.0])
    np.testing.assert_array_equal(beer_lambert(np.array([[0.0, 1.0, 0.0]]), np.array([np.inf])), [[1.0, 0.0, 1.0]])
    with pytest.raises(ValueError):
        absorption_from_transmittance(0.0, 1.0)
    with pytest.raises(pyrt.MaterialError, match="absorption"):
        pyrt.Glass(1.5, absorption=-1.0)
