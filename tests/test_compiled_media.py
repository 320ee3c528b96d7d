"""Nested dielectrics and Beer-Lambert absorption on the compiled path (:mod:`pyrt.integrators.compiled_media`)
against the NumPy path's interface stacks (:class:`pyrt.integrators.media.NestedMedia`) and closed forms.

Delta paths at pixel centres (no jitter, no lobe choice) draw no random numbers: there the two paths' images agree
pixel by pixel (float32 hit distances against the kernel's float64 ones: 1e-5 relative)."""
import math

import numpy as np
import pytest

import pyrt
from pyrt.integrators import compiled
from pyrt.integrators import compiled_media as CMD
from pyrt.integrators.compiled_layout import MED_K, MED_ROW, STACK, STACK_MED, STACK_ROW
from pyrt.integrators.media import NestedMedia
from pyrt.io.assets import ProductTexture, VertexColorTexture
from pyrt.materials import compiled as MC

from test_nested_dielectrics import _slab_scene


def _tables(materials):
    """The media tables of ``materials`` as the kernel's records (``MEDIUM`` fields) and NestedMedia's."""
    recs = [(0, np.zeros(MC.RECORD)) for _ in materials]
    assert CMD.medium_fields(materials, recs)
    return np.concatenate([r for _, r in recs]), NestedMedia(materials)


def _put(stack, row, entries):
    stack[row * STACK_ROW + STACK_MED] = len(entries)
    stack[row * STACK_ROW + STACK_MED + 1:row * STACK_ROW + STACK_MED + 1 + len(entries)] = entries


def _get(stack, row):
    k = int(stack[row * STACK_ROW + STACK_MED])
    return [int(x) for x in stack[row * STACK_ROW + STACK_MED + 1:row * STACK_ROW + STACK_MED + 1 + k]]


def test_classify_and_cross_are_nested_medias_on_random_stacks():
    """Ties of priority, repeated entries, leaving a volume not on the stack: true hit, eta and the crossed stack are
    NestedMedia.classify's and .cross's, for 2,000 random stacks and hits."""
    mats = [pyrt.Glass(1.33, priority=1), pyrt.Glass(1.5, priority=2), pyrt.Glass(1.31, priority=1),
            pyrt.Glass(2.4, priority=0, absorption=(0.1, 0.2, 0.3)), pyrt.Glass(1.7, priority=2)]
    pars, media = _tables(mats)
    rng = np.random.default_rng(7)
    stack = np.zeros((STACK + 1) * STACK_ROW)
    for _ in range(2000):
        entries = list(rng.integers(0, len(mats), rng.integers(0, MED_K)))
        m, front = int(rng.integers(0, len(mats))), bool(rng.integers(0, 2))
        _put(stack, MED_ROW, entries)
        s = np.array([entries + [-1] * (MED_K - len(entries))], dtype=np.int32)
        true_hit, eta = CMD.classify(stack, MED_ROW, pars, m, front)
        t_ref, e_ref = media.classify(s, np.array([m]), np.array([front]))
        assert true_hit == bool(t_ref[0])
        assert eta == pytest.approx(e_ref[0], rel=1e-15)
        CMD.cross(stack, MED_ROW, 3, m, front)
        want = media.cross(s, np.array([m]), np.array([front]))[0]
        assert _get(stack, 3) == [int(x) for x in want if x >= 0]
        cur = media.top(s)[0]
        sig = media.sigma_a[cur] if cur >= 0 else np.zeros(3)
        np.testing.assert_allclose(CMD.attenuation(stack, MED_ROW, pars, 0.7), np.exp(-sig * 0.7), rtol=1e-15)


def test_a_full_stack_loses_the_ray_and_a_miss_keeps_unabsorbed_channels():
    pars, _ = _tables([pyrt.Glass(1.5, absorption=(0.0, 1.0, 0.0))])
    stack = np.zeros((STACK + 1) * STACK_ROW)
    _put(stack, MED_ROW, [0] * MED_K)
    CMD.cross(stack, MED_ROW, 0, 0, True)
    assert CMD.lost(stack, 0) and not CMD.lost(stack, MED_ROW)
    assert CMD.attenuation(stack, MED_ROW, pars, math.inf) == (1.0, 0.0, 1.0)


def _checker_scene(specs, size=24):
    """Spheres ``(centre, radius, material)`` over an unfiltered checker floor under a directional light
    (tests/test_nested_dielectrics.py's scene with the checker the kernel reads)."""
    cam = pyrt.Camera(position=(0, 1.0, 4.0), target=(0, 0, 0), fov=40, width=size, height=size, spp=1,
                      jitter=False)
    scene = pyrt.Scene(cam, background=(0.2, 0.3, 0.5))
    scene.add_plane((0, -1.2, 0), 10.0, pyrt.Lambert(albedo=pyrt.CheckerTexture(0.1, 0.9, scale=12.0,
                                                                               filtered=False)))
    scene.add_light(pyrt.DirectionalLight((0.3, -1, -0.2), 3.0))
    for center, r, mat in specs:
        scene.add_sphere(center, r, mat, subdivisions=3, smooth=True)
    return scene


def _both(scene, rtol=1e-5, **kw):
    """The scene on both paths (Whitted, pixel centres): the compiled image is the NumPy one's."""
    ex = lambda b: pyrt.Execution(backend=b, progress=False)     # noqa: E731
    rc = pyrt.render_full(scene, execution=ex("compiled"), **kw)
    rn = pyrt.render_full(scene, execution=ex("numpy"), **kw)
    assert rc.stats.backend == "compiled", rc.stats.fallback_reasons
    np.testing.assert_allclose(rc.image, rn.image, rtol=rtol, atol=1e-6)
    return rc.image.astype(np.float64)


def test_nested_spheres_match_the_numpy_path():
    """Water around glass (priorities), a hidden low-priority sphere inside the glass, an absorbing third volume
    overlapping both: every pixel the NumPy path's."""
    img = _both(_checker_scene([((0, 0, 0), 1.0, pyrt.Glass(1.33, priority=1)),
                                ((0.1, 0.1, 0), 0.5, pyrt.Glass(1.5, priority=2)),
                                ((0.2, -0.1, 0.1), 0.3, pyrt.Glass(2.4, priority=0)),
                                ((-0.5, 0.0, 0.3), 0.6, pyrt.Glass(1.2, priority=1, absorption=(0.2, 0.9, 2.0)))]),
                integrator=pyrt.Whitted(max_depth=8, split_depth=None))
    assert img.max() > 0.1


def test_absorbing_slab_is_beer_lambert_on_the_compiled_path():
    """An index-matched absorbing slab: the background through it is ``B exp(-sigma t / |cos|)`` (closed form)."""
    sigma, t, B = np.array([0.5, 1.0, 2.0]), 0.4, np.array([0.5, 1.0, 2.0])
    scene = _slab_scene(1.0, sigma, t, B)
    img = _both(scene, integrator=pyrt.Whitted(max_depth=4))
    cam = scene.camera
    ys, xs = np.mgrid[0:cam.height, 0:cam.width]
    d = cam.directions(xs.ravel() + 0.5, ys.ravel() + 0.5)
    path = t / np.abs(d[:, 1] / np.linalg.norm(d, axis=1))
    np.testing.assert_allclose(img.reshape(-1, 3), B * np.exp(-sigma * path[:, None]), rtol=2e-5)


def test_transparent_shadows_through_an_absorbing_slab_match_the_numpy_path():
    """A light straight down through an absorbing glass slab onto a floor: the shadow is ``tint^2 (1 - R)^2
    exp(-sigma t)`` of the lit floor, pixel by pixel the NumPy path's."""
    sigma, t = np.array([0.4, 1.5, 3.0]), 0.05
    cam = pyrt.Camera(position=(0, 0.9, 2.0), target=(0, 0, 0), fov=40, width=48, height=36, spp=1, jitter=False)
    s = pyrt.Scene(cam, background=(0.0, 0.0, 0.0))
    s.add_plane((0, 0, 0), 8.0, pyrt.Lambert(albedo=0.5))
    s.add_box((0.0, 1.0, 0.0), (1.2, t, 1.2), pyrt.Glass(ior=1.5, absorption=sigma))
    s.add_light(pyrt.DirectionalLight(direction=(0, -1, 0), irradiance=3.0))
    img = _both(s, integrator=pyrt.Whitted(transparent_shadows=True))
    rel = img.reshape(-1, 3) / img.reshape(-1, 3).max(axis=0)
    want = 0.96 ** 2 * np.exp(-sigma * t)
    assert np.count_nonzero(np.all(np.abs(rel - want) < 1e-4 * want, axis=1)) > 200


def test_gltf_volumes_with_vertex_coloured_and_textured_tints_match_the_numpy_path():
    """Smooth glTF transmission whose base colour (the transmission's tint) varies per hit: a texture on a thin wall,
    vertex colours on an absorbing volume (KHR_materials_volume: Beer-Lambert inside); transparent shadows read the
    tint at the shadow ray's hit. Every pixel the NumPy path's."""
    cam = pyrt.Camera(position=(0, 1.3, 4.0), target=(0, 0.5, 0), fov=40, width=40, height=30, spp=1, jitter=False)
    s = pyrt.Scene(cam, background=(0.5, 0.6, 0.8))
    s.add_plane((0, 0, 0), 6.0, pyrt.Lambert(albedo=pyrt.CheckerTexture(0.15, 0.8, scale=6, filtered=False)))
    texels = np.where((np.add.outer(np.arange(8), np.arange(8)) % 2)[..., None] == 1, (0.9, 0.3, 0.2),
                      (0.2, 0.8, 0.9))
    tex = pyrt.ImageTexture(texels, filter="nearest", srgb=False)
    thin = pyrt.GltfPBR(base_color=tex, roughness=0.0, transmission=0.9, thin=True, name="thin")
    vc = VertexColorTexture()
    vol = pyrt.GltfPBR(base_color=ProductTexture(vc, (0.95, 0.9, 0.85)), roughness=0.0, transmission=1.0, ior=1.45,
                       thin=False, absorption=(0.3, 0.8, 1.6), name="volume")
    s.add_box((0.9, 0.45, -0.2), (0.1, 0.9, 0.9), thin)
    s.add_sphere((-0.3, 0.5, 0.3), 0.5, vol, subdivisions=3)
    mid = len(s.meshes) - 1
    vc.bind(mid, s.meshes[mid].faces, np.random.default_rng(3).uniform(0.3, 1.0, (len(s.meshes[mid].vertices), 3)))
    s.add_light(pyrt.PointLight((2, 3, 2), intensity=20.0))
    ps = pyrt.PreparedScene(s)
    try:
        assert compiled.unsupported(ps, transparent_shadows=True) == []
    finally:
        ps.close()
    _both(s, integrator=pyrt.Whitted(transparent_shadows=True, split_depth=None))


def test_media_beside_alpha_masks_keep_the_numpy_path():
    """Interface stacks with mask or blend surfaces (whose re-traces the kernel's false-hit walk does not take) are
    named in the reasons."""
    s = _checker_scene([((0, 0, 0), 1.0, pyrt.Glass(1.33, priority=1)), ((0, 0, 0), 0.5, pyrt.Glass(1.5))])
    s.add_plane((0, 0.5, 2.0), 1.0, pyrt.Lambert(albedo=0.3).set_coverage(opacity=0.5, alpha_mode="mask"))
    ps = pyrt.PreparedScene(s)
    try:
        r = compiled.unsupported(ps)
    finally:
        ps.close()
    assert r == ["nested dielectrics or absorption (2 volume dielectrics: Glass(), Glass()) with alpha masks or blend "
                 "materials"]


def test_a_surface_inside_a_higher_priority_volume_is_invisible_on_the_compiled_path():
    """A strongly refracting sphere wholly inside glass of higher priority does not change the image; with the higher
    priority itself it does (the test can tell)."""
    outer = pyrt.Glass(1.5, priority=2)
    kw = dict(integrator=pyrt.Whitted(max_depth=6, split_depth=None))
    ex = pyrt.Execution(backend="compiled", progress=False)
    ref = pyrt.render_full(_checker_scene([((0, 0, 0), 1.0, outer)]), execution=ex, **kw).image
    hidden = pyrt.render_full(_checker_scene([((0, 0, 0), 1.0, outer), ((0.1, 0, 0), 0.5, pyrt.Glass(2.4, priority=1))]),
                              execution=ex, **kw).image
    np.testing.assert_allclose(hidden, ref, rtol=1e-4, atol=1e-5)
    shown = pyrt.render_full(_checker_scene([((0, 0, 0), 1.0, outer), ((0.1, 0, 0), 0.5, pyrt.Glass(2.4, priority=3))]),
                             execution=ex, **kw).image
    assert np.abs(shown - ref).max() > 0.05
