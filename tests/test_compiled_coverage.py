"""Back-face culling on the compiled path (:mod:`pyrt.integrators.compiled_coverage`) against the NumPy path
(:meth:`pyrt.integrators.coverage.CoverageTable.cull_hits`) and against renders without the culled surfaces.

Single-sided materials (``double_sided=False``) seen from behind: a quad whose winding normal faces away from the
camera, a single-sided sphere around the whole scene (the camera inside it: every face it sees is a back face),
mirror rays through both. At pixel centres with the full glass tree both paths trace the same rays (the culled hits
re-traced from the same pushed origins), so their images, AOVs and ray counts agree pixel by pixel, as in
tests/test_compiled_render.py.

Alpha masks (:data:`pyrt.materials.compiled.MASK`): a leaf quad whose opacity is a checker image (nearest) and a quad
of constant opacity below the cutoff, seen by camera, mirror and glass rays and crossed by shadow rays: the NumPy
path's image, AOVs and rays; the leaf's holes show what is behind it and its shadow has holes. What the kernel does
not cover (masks with an environment light) falls back, with its reason; blending and opacities read at a footprint:
tests/test_compiled_blend.py.
"""
import numpy as np
import pytest
import trimesh

import pyrt
from pyrt.integrators import compiled
from pyrt.integrators.coverage import MAX_LAYERS
from test_compiled_glossy import _add_sky, _renders, _z_agree
from test_compiled_render import assert_aovs_agree


def _quad(centre, half, flip):
    """A quad in the plane z = centre[2], winding normal +z (``flip``: -z)."""
    cx, cy, cz = centre
    v = np.array([[cx - half, cy - half, cz], [cx + half, cy - half, cz], [cx + half, cy + half, cz],
                  [cx - half, cy + half, cz]])
    f = np.array([[0, 2, 1], [0, 3, 2]]) if flip else np.array([[0, 1, 2], [0, 2, 3]])
    return trimesh.Trimesh(vertices=v, faces=f, process=False)


def _one_sided(albedo):
    return pyrt.Lambert(albedo=albedo).set_coverage(double_sided=False)


def _objects(width=48, height=36, spp=1, jitter=False, specular=True):
    """A checker floor (z in [-3, 3]), a Blinn-Phong sphere, a mirror and a single-sided glass sphere (dielectrics are
    never culled) with ``specular``, an emissive box; a point and a spot light above and behind them (at z = -1:
    their shadow rays never reach z > 3)."""
    cam = pyrt.Camera(position=(0, 1.3, 4.0), target=(0, 0.5, 0), fov=40, width=width, height=height, spp=spp,
                      jitter=jitter)
    s = pyrt.Scene(cam, background=(0.05, 0.06, 0.1), ambient=(0.01, 0.01, 0.01))
    s.add_plane((0, 0, 0), 6.0, pyrt.Lambert(albedo=pyrt.CheckerTexture(0.15, 0.8, scale=6, filtered=False)))
    if specular:
        s.add_sphere((-0.9, 0.45, -0.3), 0.45, pyrt.Mirror(0.9), subdivisions=3)
        s.add_sphere((0.0, 0.5, 0.4), 0.5, pyrt.Glass(ior=1.5).set_coverage(double_sided=False), subdivisions=3)
    s.add_sphere((0.95, 0.4, -0.2), 0.4, pyrt.BlinnPhong(kd=(0.5, 0.2, 0.1), ks=0.3, exponent=40), subdivisions=2)
    s.add_box((0.2, 0.15, -1.0), (0.6, 0.3, 0.4), pyrt.Lambert(albedo=(0.2, 0.5, 0.3), emission=0.05))
    s.add_light(pyrt.PointLight((2, 3, -1), intensity=20.0))
    s.add_light(pyrt.SpotLight((-2, 3, -1), target=(0, 0, 0), intensity=30.0, inner_angle=25, outer_angle=40))
    return s


def _culled_quad(s, near=False):
    """A single-sided quad between the camera and the objects, its back to the camera (it faces -z); ``near``: in
    front of everything else (z = 3.5), where no shadow ray of the objects reaches it."""
    quad = _quad((0.1, 1.22, 3.5), 0.1, flip=True) if near else _quad((0.3, 0.7, 2.2), 0.5, flip=True)
    s.add_mesh(quad, _one_sided((0.9, 0.1, 0.1)), smooth=False, name="culled")
    return s


def _enclosed(**kw):
    """The objects, the culled quad, a single-sided box seen from outside (its far faces culled), and a single-sided
    sphere around everything, camera and lights included (its faces point out: seen from inside, culled; the mirror
    and glass rays pass it too)."""
    s = _culled_quad(_objects(**kw))
    s.add_box((-0.3, 0.2, 1.2), (0.3, 0.4, 0.3), _one_sided((0.7, 0.7, 0.2)))
    s.add_sphere((0.0, 0.5, 0.0), 8.0, _one_sided((0.3, 0.9, 0.3)), subdivisions=3, smooth=False)
    return s


def _render(scene, backend="compiled", *, offset="robust", split_depth=None, aovs=False, **kw):
    """``pyrt.render_full`` with the Whitted integrator's ``offset`` and ``split_depth``, on ``backend``."""
    return pyrt.render_full(scene, integrator=pyrt.Whitted(offset=offset, split_depth=split_depth),
                            output=pyrt.Output(aovs=aovs), execution=pyrt.Execution(backend=backend, progress=False),
                            **kw)


def _both(scene, **kw):
    c = _render(scene, "compiled", **kw)
    n = _render(scene, "numpy", **kw)
    assert c.stats.backend == "compiled" and c.stats.fallback_reasons == []
    assert n.stats.backend == "numpy"
    return c, n


def _close(a, b, frac=0.002):
    """Pixel by pixel to 1e-5 relative but for at most ``frac`` of the pixels (a ray grazing an edge)."""
    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    with np.errstate(invalid="ignore"):           # inf - inf: both missed (depth)
        bad = (a != b) & ~(np.abs(a - b) <= 1e-5 * (1.0 + np.abs(b)))
    bad = bad.reshape(bad.shape[0], bad.shape[1], -1).any(axis=2)
    assert bad.mean() <= frac, f"{bad.sum()} pixels differ, max {np.abs(a - b).max()}"


def test_culling_alone_takes_the_compiled_path():
    ps = pyrt.PreparedScene(_enclosed(width=8, height=6))
    assert ps.coverage is not None and not ps.coverage.shadows
    assert compiled.unsupported(ps) == []


@pytest.mark.parametrize("offset", ["robust", "robust_no_terminator"])
def test_culled_surfaces_match_the_numpy_path_pixel_by_pixel(offset):
    """Camera rays through the culled quad and sphere, mirror and glass rays through them: the same image, the same
    camera and shadow rays, the same secondary rays (the re-traces included) as the NumPy path."""
    c, n = _both(_enclosed(), seed=0, offset=offset)
    _close(c.image, n.image)
    assert c.stats.primary_rays == n.stats.primary_rays
    assert abs(c.stats.secondary_rays - n.stats.secondary_rays) <= 0.002 * n.stats.secondary_rays
    assert abs(c.stats.shadow_rays - n.stats.shadow_rays) <= 0.002 * n.stats.shadow_rays
    # the re-traces are there: the camera rays that miss the objects re-trace through the enclosing sphere
    plain = _render(_objects(), seed=0, offset=offset)
    assert c.stats.secondary_rays > plain.stats.secondary_rays + 0.2 * c.stats.primary_rays


def test_culled_quad_is_invisible():
    """The quad seen from behind is not there for camera rays: the image and AOVs of the scene without it (no
    shadow ray and no mirror in this scene reaches the quad), while the same quad double-sided hides what is
    behind it."""
    with_quad = _render(_culled_quad(_objects(specular=False), near=True), seed=0, aovs=True)
    without = _render(_objects(specular=False), seed=0, aovs=True)
    assert with_quad.stats.backend == "compiled"
    _close(with_quad.image, without.image)
    _close(with_quad.aovs["depth"][..., None], without.aovs["depth"][..., None])
    for k in ("albedo", "normal"):
        _close(with_quad.aovs[k], without.aovs[k])
    s = _culled_quad(_objects(specular=False), near=True)
    s.materials[-1].set_coverage(double_sided=True)
    seen = _render(s, seed=0, aovs=True)
    hidden = np.abs(seen.aovs["albedo"] - np.array([0.9, 0.1, 0.1])).max(axis=2) < 1e-6
    assert hidden.sum() > 100
    assert np.all(np.abs(seen.image - without.image).max(axis=2)[hidden] > 1e-4)


def test_aovs_and_the_enclosing_sphere_match_the_numpy_path():
    """Depth (counted from the camera through the culled faces), normal and albedo of the nearest kept surface."""
    c, n = _both(_enclosed(), seed=0, aovs=True)
    assert_aovs_agree(c, n)
    assert np.isinf(c.aovs["depth"]).any()      # the enclosing sphere is culled: missed rays see the background


def test_jittered_samples_agree_with_numpy():
    """16 jittered samples per pixel with the split-depth rule (the two paths' random numbers differ): the image
    means agree to the noise."""
    c, n = _both(_enclosed(width=32, height=24, spp=16, jitter=True), seed=5, split_depth=2)
    ref = n.image.astype(np.float64)
    assert abs(float(c.image.mean()) - float(ref.mean())) < 0.02 * float(ref.mean())


def test_adaptive_passes_match_the_numpy_path():
    """Adaptive passes (:func:`pyrt.integrators.compiled.render_pixels`) through the culled surfaces: the same
    passes, samples and image as the NumPy path (as tests/test_compiled_adaptive.py, delta lights only)."""
    scene = _enclosed(width=32, height=24)
    c, n = _both(scene, seed=3, sampling=pyrt.Sampling(target_error=2e-3, max_spp=32))
    assert c.stats.backend == "compiled" and n.stats.backend == "numpy"
    assert c.passes == n.passes > 1
    np.testing.assert_array_equal(c.film.weight, n.film.weight)
    np.testing.assert_allclose(c.image, n.image, rtol=1e-5, atol=1e-7)


@pytest.mark.parametrize("layers", [MAX_LAYERS, MAX_LAYERS + 1])
def test_layer_bound(layers):
    """Up to MAX_LAYERS culled faces are skipped by a camera ray; a ray meeting one more is dropped (radiance 0), on
    both paths."""
    cam = pyrt.Camera(position=(0, 0, 3), target=(0, 0, 0), fov=10, width=4, height=4, spp=1, jitter=False)
    s = pyrt.Scene(cam, background=(0.1, 0.2, 0.9), ambient=0.2)
    for i in range(layers):
        s.add_mesh(_quad((0, 0, -0.01 * i), 0.5, flip=True), _one_sided(0.5), smooth=False)
    s.add_mesh(_quad((0, 0, -1.0), 20.0, flip=False), pyrt.Lambert(albedo=(0.6, 0.3, 0.2)), smooth=False)
    c, n = _both(s, seed=0)
    np.testing.assert_allclose(c.image, n.image, rtol=1e-6)
    if layers > MAX_LAYERS:
        assert np.all(c.image == 0.0)
    else:
        np.testing.assert_allclose(c.image.reshape(-1, 3), np.tile([0.12, 0.06, 0.04], (16, 1)), rtol=1e-6)


def test_a_lane_kept_early_is_not_dropped_by_another_lanes_layer_bound():
    """One camera packet: its left lanes keep a masked quad's opaque texels at once, its right lanes skip
    ``MAX_LAYERS`` culled faces first. A lane whose surface is kept is not looked at again (the NumPy path resolves
    it at its first layer): the left half shows the masked quad, not radiance 0, and both paths agree."""
    cam = pyrt.Camera(position=(0, 0, 3), target=(0, 0, 0), fov=10, width=4, height=4, spp=1, jitter=False)
    s = pyrt.Scene(cam, background=(0.1, 0.2, 0.9), ambient=0.2)
    for i in range(MAX_LAYERS):
        s.add_mesh(_quad((0.5, 0, -0.01 * i), 0.5, flip=True), _one_sided(0.5), smooth=False)
    masked = pyrt.Lambert(albedo=(0.2, 0.7, 0.3)).set_coverage(opacity=0.9, alpha_mode="mask")
    s.add_mesh(_quad((-0.5, 0, 0.1), 0.5, flip=False), masked, smooth=False)
    s.add_mesh(_quad((0, 0, -1.0), 20.0, flip=False), pyrt.Lambert(albedo=(0.6, 0.3, 0.2)), smooth=False)
    c, n = _both(s, seed=0)
    np.testing.assert_allclose(c.image, n.image, rtol=1e-6)
    np.testing.assert_allclose(c.image[:, :2].reshape(-1, 3), np.tile([0.04, 0.14, 0.06], (8, 1)), rtol=1e-6)
    np.testing.assert_allclose(c.image[:, 2:].reshape(-1, 3), np.tile([0.12, 0.06, 0.04], (8, 1)), rtol=1e-6)


# ----------------------------------------------------------------------------------------- alpha masks

N_TEX = 8
CHECKER = ((np.arange(N_TEX)[:, None] + np.arange(N_TEX)[None, :]) % 2 == 0).astype(np.float64)   # 1 = opaque


def _leaf(filter="nearest", mode="mask"):
    """A Lambert leaf whose opacity is a checker image (1 opaque, 0 a hole)."""
    tex = pyrt.ImageTexture(CHECKER, filter=filter, srgb=False, name="checker")
    return pyrt.Lambert(albedo=(0.3, 0.6, 0.2)).set_coverage(opacity=tex, alpha_mode=mode)


def _uv_quad(centre, half, flip=False):
    m = _quad(centre, half, flip)
    m.visual = trimesh.visual.TextureVisuals(uv=(m.vertices[:, :2] - m.vertices[:, :2].min(axis=0)) / (2 * half))
    return m


def _leaves(width=48, height=36, spp=1, jitter=False):
    """The objects with a masked leaf quad in front of them, lit from the side as well (its shadow falls on the floor
    left of the objects, with holes), a second masked quad (constant opacity below the cutoff: invisible) and a
    single-sided quad seen from behind."""
    s = _culled_quad(_objects(width=width, height=height, spp=spp, jitter=jitter))
    s.add_light(pyrt.PointLight((3, 3, 2.5), intensity=20.0))
    s.add_mesh(_uv_quad((0.2, 0.9, 1.2), 0.45), _leaf(), smooth=False, name="leaf")
    gone = pyrt.Lambert(albedo=0.9).set_coverage(opacity=0.2, alpha_mode="mask", alpha_cutoff=0.5)
    s.add_mesh(_quad((-0.6, 0.6, 1.5), 0.3, flip=False), gone, smooth=False, name="gone")
    return s


def test_masks_take_the_compiled_path():
    assert compiled.unsupported(pyrt.PreparedScene(_leaves(width=8, height=6))) == []


@pytest.mark.parametrize("offset", ["robust", "robust_no_terminator"])
def test_masks_match_the_numpy_path_pixel_by_pixel(offset):
    """Camera rays through the leaf's holes and the invisible quad, mirror and glass rays through them, shadow rays
    through the holes (point and spot light): the NumPy path's image and rays."""
    c, n = _both(_leaves(), seed=0, offset=offset)
    _close(c.image, n.image)
    assert c.stats.primary_rays == n.stats.primary_rays
    assert abs(c.stats.secondary_rays - n.stats.secondary_rays) <= 0.002 * n.stats.secondary_rays
    assert abs(c.stats.shadow_rays - n.stats.shadow_rays) <= 0.002 * n.stats.shadow_rays


def test_mask_aovs_and_adaptive_passes_match_the_numpy_path():
    c, n = _both(_leaves(width=32, height=24), seed=0, aovs=True)
    for k in ("depth", "normal", "albedo"):
        _close(c.aovs[k].reshape(24, 32, -1), n.aovs[k].reshape(24, 32, -1))
    c, n = _both(_leaves(width=32, height=24), seed=3, sampling=pyrt.Sampling(target_error=2e-3, max_spp=32))
    assert c.passes == n.passes > 1
    np.testing.assert_array_equal(c.film.weight, n.film.weight)
    np.testing.assert_allclose(c.image, n.image, rtol=1e-5, atol=1e-7)


def test_leaf_holes_show_what_is_behind_and_its_shadow_has_holes():
    """The leaf's opaque texels hide what is behind it, its holes show it (the image of the scene without the
    leaf there), and its shadow on the floor has holes: lit floor pixels that the leaf would shade when opaque."""
    kw = dict(seed=0, aovs=True)
    leaf = _render(_leaves(), **kw)
    s = _leaves()
    s.materials[-2].set_coverage(alpha_mode="opaque")
    solid = _render(s, **kw)
    assert leaf.stats.backend == "compiled"
    seen = np.abs(leaf.aovs["albedo"] - np.array([0.3, 0.6, 0.2])).max(axis=2) < 1e-6
    hidden = np.abs(solid.aovs["albedo"] - np.array([0.3, 0.6, 0.2])).max(axis=2) < 1e-6
    holes = hidden & ~seen
    assert seen.sum() > 30 and holes.sum() > 30 and not (seen & ~hidden).any()
    floor = (~hidden) & (np.abs(leaf.image - solid.image).max(axis=2) > 1e-3)     # light through the leaf's holes
    assert floor.sum() > 20


@pytest.mark.parametrize("integrator", [pyrt.Whitted(), pyrt.Glossy(samples=4, depth=2)])
def test_masks_under_a_sampled_environment_agree_with_numpy(integrator):
    """The sampled sky's shadow rays (the packet rounds, the specular tree's and glossy hits' single rays) walk
    through the leaf's cut-outs as the point lights' do: the image agrees with the NumPy path's in distribution."""
    s = _add_sky(_leaves(width=40, height=30, spp=16, jitter=True))
    assert compiled.unsupported(None, scene=s) == []
    mc, vc, pc = _renders(s, "compiled", range(100, 104), integrator=integrator)
    mn, vn, pn = _renders(s, "numpy", range(200, 204), integrator=integrator)
    assert pc == {"compiled"} and pn == {"numpy"}
    _z_agree(mc, vc, mn, vn)
