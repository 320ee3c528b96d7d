"""Blend surfaces and footprint-filtered opacity on the compiled path (:mod:`pyrt.integrators.compiled_coverage`)
against the NumPy path (:meth:`pyrt.integrators.coverage.CoverageTable.resolve`,
:func:`pyrt.integrators.shadows.transmittance`) and against closed forms.

A blend surface of coverage ``a`` splits a ray into the hit, weighted ``a``, and its continuation past the surface,
weighted ``1 - a``, at the same bounce; a shadow ray crossing it is multiplied by ``1 - a``. With delta lights, pixel
centres and the full glass tree there is no noise on either path: both trace the same rays and their images agree
pixel by pixel, as in tests/test_compiled_coverage.py. With area lights, jittered samples and the glossy integrator
their random numbers differ: the images agree in distribution (per-pixel z-scores of the means of a few renders, as
tests/test_compiled_glossy.py). An opacity texture read trilinearly is filtered at the ray's footprint on camera and
secondary rays and read at full resolution by shadow rays, as on the NumPy path.
"""
import numpy as np
import pytest
import trimesh

import pyrt
from pyrt.apps.preview.studio import StudioEnvironment
from pyrt.integrators import compiled
from pyrt.integrators.coverage import MAX_LAYERS
from test_compiled_coverage import _both, _close, _objects, _one_sided, _quad, _render, _uv_quad
from test_compiled_glossy import _add_sky, _renders, _z_agree
from test_compiled_preview_env import _assert_equal_images


def _veil(opacity=0.4, mode="blend", filter="nearest", width=48, height=36, spp=1, jitter=False, specular=True):
    """The objects (floor, Blinn-Phong, emissive box, with ``specular`` mirror and glass; point and spot light)
    behind a blend quad of
    ``opacity`` (a number, or a 4 x 4 image of coverage levels 0, 0.3, 0.7 and 1 read with ``filter``), a second,
    smaller blend quad overlapping it (two splits on one ray) and a light at the side, so that the quads' shadows
    fall on the floor and their reflections show in the mirror."""
    s = _objects(width=width, height=height, spp=spp, jitter=jitter, specular=specular)
    s.add_light(pyrt.PointLight((3, 3, 2.5), intensity=20.0))
    if isinstance(opacity, str):
        levels = np.array([[0.0, 0.3, 0.7, 1.0], [0.3, 0.7, 1.0, 0.0], [0.7, 1.0, 0.0, 0.3], [1.0, 0.0, 0.3, 0.7]])
        opacity = pyrt.ImageTexture(levels, filter=filter, srgb=False, name="levels")
    veil = pyrt.Lambert(albedo=(0.8, 0.3, 0.2)).set_coverage(opacity=opacity, alpha_mode=mode)
    s.add_mesh(_uv_quad((0.1, 0.8, 1.4), 0.6), veil, smooth=False, name="veil")
    film = pyrt.Lambert(albedo=(0.2, 0.3, 0.9)).set_coverage(opacity=0.55, alpha_mode="blend")
    s.add_mesh(_quad((-0.3, 0.5, 1.9), 0.3, flip=False), film, smooth=False, name="film")
    return s


def test_blend_takes_the_compiled_path():
    assert compiled.unsupported(pyrt.PreparedScene(_veil(width=8, height=6))) == []
    assert compiled.unsupported(pyrt.PreparedScene(_veil("levels", filter="trilinear", width=8, height=6))) == []
    assert compiled.unsupported(pyrt.PreparedScene(_receding("mask", width=8, height=6))) == []


@pytest.mark.parametrize("opacity,filter", [(0.4, None), ("levels", "nearest"), ("levels", "bilinear"),
                                            ("levels", "trilinear")])
def test_blend_matches_the_numpy_path_pixel_by_pixel(opacity, filter):
    """Camera rays split at the quads (constant and textured coverage, two on one ray), mirror and glass rays split
    there too, shadow rays through them multiplied by ``1 - a``: the NumPy path's image and rays."""
    c, n = _both(_veil(opacity, filter=filter), seed=0)
    _close(c.image, n.image)
    assert c.stats.primary_rays == n.stats.primary_rays
    assert abs(c.stats.secondary_rays - n.stats.secondary_rays) <= 0.002 * n.stats.secondary_rays
    assert abs(c.stats.shadow_rays - n.stats.shadow_rays) <= 0.002 * n.stats.shadow_rays


def test_blend_aovs_and_adaptive_passes_match_the_numpy_path():
    """The AOVs are the nearest kept surface's (the blend quad itself); adaptive passes take the same passes and
    give the same image (the same camera rays on both paths, delta lights only)."""
    c, n = _both(_veil("levels", width=32, height=24), seed=0, aovs=True)
    for k in ("depth", "normal", "albedo"):
        _close(c.aovs[k].reshape(24, 32, -1), n.aovs[k].reshape(24, 32, -1))
    c, n = _both(_veil("levels", width=32, height=24), seed=3, sampling=pyrt.Sampling(target_error=2e-3, max_spp=32))
    assert c.passes == n.passes > 1
    np.testing.assert_array_equal(c.film.weight, n.film.weight)
    np.testing.assert_allclose(c.image, n.image, rtol=1e-5, atol=1e-7)


def _layers(n_culled, a=0.4):
    """``n_culled`` single-sided quads seen from behind (culled), then a blend quad of coverage ``a`` (emission 0.5,
    black) in front of an emissive plane (emission 0.2): no lights."""
    cam = pyrt.Camera(position=(0, 0, 3), target=(0, 0, 0), fov=10, width=4, height=4, spp=1, jitter=False)
    s = pyrt.Scene(cam, background=(0.0, 0.0, 0.0))
    for i in range(n_culled):
        s.add_mesh(_quad((0, 0, -0.01 * i), 0.5, flip=True), _one_sided(0.5), smooth=False)
    blend = pyrt.Lambert(albedo=0.0, emission=0.5).set_coverage(opacity=a, alpha_mode="blend")
    s.add_mesh(_quad((0, 0, -0.5), 0.5, flip=False), blend, smooth=False)
    s.add_mesh(_quad((0, 0, -1.0), 20.0, flip=False), pyrt.Lambert(albedo=0.0, emission=0.2), smooth=False)
    return s


@pytest.mark.parametrize("n_culled", [0, MAX_LAYERS - 1, MAX_LAYERS])
def test_blend_radiance_is_the_coverage_mix_and_counts_layers(n_culled):
    """``a L_surface + (1 - a) L_behind`` exactly (constant radiances), on both paths. The blend quad's continuation
    counts the surfaces its ray skipped: behind ``MAX_LAYERS - 1`` culled quads the split is the last allowed and the
    continuation still reaches the plane (a plain surface); behind ``MAX_LAYERS`` the ray is dropped (radiance 0)."""
    a = 0.4
    c, n = _both(_layers(n_culled, a), seed=0)
    np.testing.assert_allclose(c.image, n.image, rtol=1e-6)
    want = 0.0 if n_culled == MAX_LAYERS else a * 0.5 + (1 - a) * 0.2
    np.testing.assert_allclose(c.image, want, rtol=1e-6)


def test_blend_over_the_background_and_a_second_layer():
    """Two blend quads in front of an emitter: ``a1 L1 + (1 - a1)(a2 L2 + (1 - a2) L_b)``; beside the emitter the
    background shows through with the weight ``(1 - a1)(1 - a2)``."""
    cam = pyrt.Camera(position=(0, 0, 3), target=(0, 0, 0), fov=30, width=16, height=8, spp=1, jitter=False)
    bg = 0.05
    s = pyrt.Scene(cam, background=(bg, bg, bg))
    for z, a, e in ((0.5, 0.3, 0.7), (0.0, 0.6, 0.4)):
        m = pyrt.Lambert(albedo=0.0, emission=e).set_coverage(opacity=a, alpha_mode="blend")
        s.add_mesh(_quad((0, 0, z), 5.0, flip=False), m, smooth=False)
    s.add_mesh(_quad((-1.0, 0, -1.0), 1.0, flip=False), pyrt.Lambert(albedo=0.0, emission=0.2), smooth=False)
    r = _render(s, seed=0)
    assert r.stats.backend == "compiled"
    behind = 0.6 * 0.4 + 0.4 * np.array([0.2, bg])
    want = 0.3 * 0.7 + 0.7 * behind
    img = r.image[..., 0].astype(np.float64)
    assert np.isclose(img, want[0], rtol=1e-6).sum() > 10 and np.isclose(img, want[1], rtol=1e-6).sum() > 10
    assert np.all(np.isclose(img, want[0], rtol=1e-6) | np.isclose(img, want[1], rtol=1e-6))


def _shadow_scene(opacity):
    """A floor lit by a point light straight above; a horizontal quad halfway up (coverage ``opacity``, or absent
    for None); the camera below the quad, so that its rays to the floor never cross it."""
    cam = pyrt.Camera(position=(0, 1.0, 4.0), target=(0, 0, 0), fov=50, width=32, height=24, spp=1, jitter=False)
    s = pyrt.Scene(cam, background=(0.0, 0.0, 0.0))
    s.add_plane((0, 0, 0), 8.0, pyrt.Lambert(albedo=0.5))
    s.add_light(pyrt.PointLight((0, 4, 0), intensity=30.0))
    if opacity is not None:
        v = np.array([[-0.5, 2.0, -0.5], [0.5, 2.0, -0.5], [0.5, 2.0, 0.5], [-0.5, 2.0, 0.5]])
        quad = trimesh.Trimesh(vertices=v, faces=np.array([[0, 1, 2], [0, 2, 3]]), process=False)
        m = pyrt.Lambert(albedo=0.9).set_coverage(opacity=opacity, alpha_mode="blend")
        s.add_mesh(quad, m, smooth=False, name="blend")
    return s


def test_blend_shadow_is_the_light_times_one_minus_coverage():
    """The floor in the blend quad's shadow gets ``1 - a`` of its light, elsewhere all of it, on both paths."""
    a = 0.35
    c, n = _both(_shadow_scene(a), seed=0)
    free = _render(_shadow_scene(None), seed=0).image.astype(np.float64)
    _close(c.image, n.image)
    ratio = c.image[..., 0].astype(np.float64) / np.maximum(free[..., 0], 1e-12)
    lit = free[..., 0] > 0
    shadow = lit & np.isclose(ratio, 1 - a, rtol=1e-5)
    assert shadow.sum() > 20
    assert np.all(shadow | np.isclose(ratio, 1.0, rtol=1e-6) | ~lit)


def _receding(mode, filter="trilinear", width=48, height=36, spp=1, jitter=False):
    """A fine checker opacity (64 x 64 texels of 0.2 and 1) on a long horizontal quad receding from the camera above
    a lit floor: near the camera the holes are texels, far away the footprint covers many of them (a trilinear
    lookup averages to 0.6: a mask's far end is solid, a blend's is 0.6 opaque)."""
    cam = pyrt.Camera(position=(0, 1.2, 4.0), target=(0, 0.3, -2), fov=45, width=width, height=height, spp=spp,
                      jitter=jitter)
    s = pyrt.Scene(cam, background=(0.1, 0.15, 0.3), ambient=(0.02, 0.02, 0.02))
    s.add_plane((0, 0, 0), 40.0, pyrt.Lambert(albedo=pyrt.CheckerTexture(0.2, 0.7, scale=10, filtered=False)))
    n_tex = 64
    ij = np.arange(n_tex)
    texels = np.where((ij[:, None] + ij[None, :]) % 2 == 0, 1.0, 0.2)
    tex = pyrt.ImageTexture(texels, filter=filter, srgb=False, name="fine")
    v = np.array([[-1.0, 0.4, 3.0], [1.0, 0.4, 3.0], [1.0, 0.4, -30.0], [-1.0, 0.4, -30.0]])
    uv = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], dtype=np.float64)
    quad = trimesh.Trimesh(vertices=v, faces=np.array([[0, 1, 2], [0, 2, 3]]), process=False)
    quad.visual = trimesh.visual.TextureVisuals(uv=uv)
    m = pyrt.Lambert(albedo=(0.9, 0.8, 0.3)).set_coverage(opacity=tex, alpha_mode=mode)
    s.add_mesh(quad, m, smooth=False, name="receding")
    s.add_light(pyrt.PointLight((1.5, 4, 0), intensity=40.0))
    return s


@pytest.mark.parametrize("mode", ["mask", "blend"])
def test_trilinear_opacity_matches_the_numpy_path(mode):
    """The opacity read at each ray's footprint (camera rays, pixel centres; shadow rays at full resolution): the
    NumPy path's image, which differs from the one read without a footprint (bilinear) where the quad recedes."""
    c, n = _both(_receding(mode), seed=0)
    _close(c.image, n.image)
    assert abs(c.stats.shadow_rays - n.stats.shadow_rays) <= 0.002 * n.stats.shadow_rays
    flat = _render(_receding(mode, filter="bilinear"), seed=0)
    assert (np.abs(flat.image - c.image).max(axis=2) > 1e-3).mean() > 0.05


@pytest.mark.parametrize("integrator", [pyrt.Glossy(samples=4, depth=2), pyrt.Whitted(light_select_depth=0)],
                         ids=["glossy", "select"])
def test_blend_agrees_with_numpy_in_distribution(integrator):
    """Jittered samples, a rectangle light (its light samples crossing the quads, its visible mesh reached by glossy
    rays), glossy rays split at the quads (their continuations MIS-weighted from the rays' first origins), camera
    continuations lit by one chosen light: per-pixel z-scores of 8 renders each look standard normal and the mean
    brightness agrees to half a percent. (No mirror and glass here: their view of the light's mesh is a heavy tail
    that needs hundreds of renders; with 256 renders each the glossy means agreed to 0.01 %, z 0.57, measured.)"""
    s = _veil("levels", filter="trilinear", width=32, height=24, spp=16, jitter=True, specular=False)
    s.add_sphere((-1.3, 0.35, 0.9), 0.35, pyrt.CookTorrance(kd=0.1, ks=0.8, roughness=0.3), subdivisions=3)
    pyrt.RectLight(center=(0, 2.5, 0), normal=(0, -1, 0), size=(1.0, 0.6), radiance=6.0).add_to(s)
    mc, vc, pc = _renders(s, "compiled", range(100, 108), integrator=integrator)
    mn, vn, pn = _renders(s, "numpy", range(200, 208), integrator=integrator)
    assert pc == {"compiled"} and pn == {"numpy"}
    z = (mc - mn) / np.sqrt(vc + vn + 1e-12)
    assert abs(z.mean()) < 0.1, z.mean()
    assert 0.75 < z.std() < 1.25, z.std()
    assert (np.abs(z) > 5).mean() < 0.005
    assert abs(mc.mean() - mn.mean()) / mn.mean() < 0.005


def test_blend_under_the_preview_matches_the_numpy_path():
    """The preview traces no shadow rays to the environment, so blend materials under it take the compiled path: the
    camera continuations see the background as camera rays do, their hits are lit by the preview as camera hits are;
    the same image pixel by pixel (pixel centres, the full glass tree)."""
    s = _veil("levels", filter="trilinear", width=40, height=30)
    pyrt.set_environment(s, StudioEnvironment(width=64, height=32, intensity=0.7), lighting="preview")
    assert compiled.unsupported(None, scene=s) == []
    _assert_equal_images(s, shadow_rays=1)


class _Ramp(pyrt.Texture):
    """A 1-channel texture the kernel cannot read (no compiled form): u."""

    channels = 1

    def evaluate(self, ctx):
        return ctx.uv[:, :1].copy()


def test_blending_under_a_sampled_environment_agrees_with_numpy():
    """The sampled sky's shadow rays are multiplied by ``1 - a`` through the veils, as the point lights' are: the
    image agrees with the NumPy path's in distribution (the glossy integrator's rays: tests/test_compiled_coverage.py's
    masks)."""
    s = _add_sky(_veil(width=40, height=30, spp=16, jitter=True))
    mc, vc, pc = _renders(s, "compiled", range(100, 104))
    mn, vn, pn = _renders(s, "numpy", range(200, 204))
    assert pc == {"compiled"} and pn == {"numpy"}
    _z_agree(mc, vc, mn, vn)


def test_an_opacity_the_kernel_cannot_read_falls_back_and_says_why():
    s = _veil(width=8, height=6)
    s.materials[-2].set_coverage(opacity=_Ramp())
    reason = "alpha blend of material"
    r = pyrt.render_full(s, execution=pyrt.Execution(progress=False))
    assert r.stats.backend == "numpy"
    assert any(reason in x for x in r.stats.fallback_reasons), r.stats.fallback_reasons
