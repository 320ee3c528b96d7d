"""Trilinear MIP textures with ray differentials, and normal maps, on the compiled path against the NumPy path.

Pixel centres and the full glass tree (``split_depth=None``), or adaptive passes (the same Sobol' camera rays, the
pixels' differentials scaled by their samples after the pass): both paths trace the same rays, so their images must
agree pixel by pixel (to float rounding: a footprint's MIP level is a log2 of sums made in another order). Jittered
fixed-spp renders draw other random numbers: they agree in distribution.
"""
import numpy as np
import pytest

import pyrt
from pyrt.integrators import compiled
from pyrt.integrators import compiled_layout as KL

from test_compiled_area_lights import assert_agree_in_distribution
from test_compiled_render import _scene


def _texels(rng, n=128):
    """High-frequency texels (white noise over a fine checker): minified, the MIP levels differ a lot."""
    img = rng.random((n, n, 3)).astype(np.float32) * 0.6
    img[(np.arange(n)[:, None] // 2 + np.arange(n)[None, :] // 2) % 2 == 0] += 0.4
    return img


def _mip_scene(width=48, height=36, spp=1, jitter=False, seed=0):
    """A trilinear-textured ground seen from low down (grazing far away), in a mirror sphere (smooth: dn/dx) and a flat
    mirror box, and through a glass sphere; a textured smooth sphere; a point light."""
    rng = np.random.default_rng(seed)
    cam = pyrt.Camera(position=(0, 0.45, 3.5), target=(0, 0.25, -3), fov=50, width=width, height=height, spp=spp,
                      jitter=jitter)
    s = pyrt.Scene(cam, background=(0.05, 0.06, 0.1))
    ground = pyrt.ImageTexture(_texels(rng), filter="trilinear", scale=(10.0, 10.0), rotation_deg=15.0)
    s.add_plane((0, 0, 0), 30.0, pyrt.Lambert(albedo=ground))
    s.add_sphere((-0.9, 0.45, -0.5), 0.45, pyrt.Mirror(0.9), subdivisions=3)
    s.add_box((1.3, 0.5, -1.2), (0.05, 1.0, 1.2), pyrt.Mirror(0.8))
    s.add_sphere((0.3, 0.4, 0.6), 0.4, pyrt.Glass(ior=1.5), subdivisions=3)
    ball = pyrt.ImageTexture(_texels(rng, 64), filter="trilinear", wrap="mirror")
    s.add_sphere((0.2, 0.35, -1.5), 0.35, pyrt.BlinnPhong(kd=ball, ks=0.2, exponent=30), subdivisions=3)
    s.add_light(pyrt.PointLight((2, 3, 2), intensity=20.0))
    return s


def _assert_same_pixels(c, n, frac=0.002):
    assert c.stats.backend == "compiled" and c.stats.fallback_reasons == [] and n.stats.backend == "numpy"
    diff = np.abs(c.image.astype(np.float64) - n.image)
    bad = diff > 1e-5 * (1.0 + np.abs(n.image))
    assert bad.any(axis=2).mean() < frac, f"{bad.any(axis=2).sum()} pixels differ, max {diff.max()}"


#: the render options of the pixel-by-pixel comparisons with AOVs
_AOV_KW = dict(progress=False, seed=0, split_depth=None, aovs=True)


def _same_image_and_aov(s, aov, rtol):
    """Both paths' renders of ``s`` (pixel centres, AOVs): the same pixels, AOV ``aov`` equal to ``rtol``; the
    compiled result."""
    c = pyrt.render_full(s, backend="compiled", **_AOV_KW)
    n = pyrt.render_full(s, backend="numpy", **_AOV_KW)
    _assert_same_pixels(c, n)
    np.testing.assert_allclose(c.aovs[aov], n.aovs[aov], rtol=rtol, atol=1e-6)
    return c


def _assert_changes_the_image(s, c, frac):
    """The compiled render of ``s`` (after a change the test made) differs from ``c`` by more than ``frac`` of its
    mean: what was compared was not invisible."""
    other = pyrt.render_full(s, backend="compiled", **_AOV_KW)
    assert np.abs(other.image.astype(np.float64) - c.image).mean() > frac * c.image.mean()


def test_trilinear_textures_match_the_numpy_path_pixel_by_pixel():
    """Seen directly (near to grazing), in mirrors (curved and flat) and through glass: the same footprints, the
    same MIP levels, the same image; and not the image of the textures' level 0 (the footprints matter here)."""
    s = _mip_scene()
    assert compiled.unsupported(pyrt.PreparedScene(s)) == []
    ground = s.materials[0].albedo_value
    assert ground.mip_levels_built == []              # deciding builds no pyramid; packing the tables builds it
    kw = dict(progress=False, seed=0, split_depth=None)
    c = pyrt.render_full(s, backend="compiled", **kw)
    n = pyrt.render_full(s, backend="numpy", **kw)
    _assert_same_pixels(c, n)
    for m in s.materials:                        # bilinear on level 0: another image
        for name in ("albedo_value", "kd"):
            tex = getattr(m, name, None)
            if isinstance(tex, pyrt.ImageTexture):
                tex.filter = "bilinear"
    b = pyrt.render_full(s, backend="compiled", **kw)
    assert np.abs(b.image.astype(np.float64) - c.image).mean() > 0.01 * c.image.mean()


def test_adaptive_passes_with_trilinear_textures_match_the_numpy_path():
    """Adaptive passes: each pixel's differentials scaled by its samples after the pass, as the NumPy path's."""
    s = _mip_scene(width=32, height=24)
    kw = dict(progress=False, seed=3, target_error=1e-5, split_depth=None, max_spp=32)
    c = pyrt.render_full(s, backend="compiled", **kw)
    n = pyrt.render_full(s, backend="numpy", **kw)
    assert c.stats.backend == "compiled" and c.stats.fallback_reasons == []
    assert c.passes == n.passes > 1
    np.testing.assert_array_equal(c.film.weight, n.film.weight)
    np.testing.assert_allclose(c.image, n.image, rtol=1e-5, atol=1e-6)


def test_jittered_trilinear_render_agrees_with_numpy_in_distribution():
    """4 jittered samples per pixel (differentials at half a pixel), the split-depth rule: the means agree."""
    assert_agree_in_distribution(_mip_scene(width=32, height=24, spp=4, jitter=True), K=6)


def _normal_map(rng, n=32):
    """Bumps: tangent-space normals tilted up to ~50 degrees, some flat texels."""
    xy = rng.uniform(-0.8, 0.8, (n, n, 2))
    z = np.sqrt(np.maximum(1.0 - (xy ** 2).sum(axis=2, keepdims=True), 0.05))
    nrm = np.concatenate([xy, z], axis=2)
    nrm /= np.linalg.norm(nrm, axis=2, keepdims=True)
    img = (0.5 * nrm + 0.5).astype(np.float32)
    img[::4, ::4] = (0.5, 0.5, 1.0)
    return img


def _normal_mapped_scene(width=48, height=36):
    """Normal maps (bilinear and trilinear, a DirectX one, one with reflections dropped) on a Lambert sphere, a
    Blinn-Phong ground with a trilinear albedo, a mirror and a glass sphere; seen directly, in the mirror and through
    the glass."""
    rng = np.random.default_rng(4)
    cam = pyrt.Camera(position=(0, 1.0, 3.8), target=(0, 0.35, 0), fov=45, width=width, height=height, jitter=False)
    s = pyrt.Scene(cam, background=(0.05, 0.06, 0.1))
    ground = pyrt.BlinnPhong(kd=pyrt.ImageTexture(_texels(rng, 64), filter="trilinear", scale=(6.0, 6.0)), ks=0.3,
                             exponent=40)
    ground.normal_map = pyrt.NormalMap(_normal_map(rng), filter="trilinear", scale=(6.0, 6.0), strength=0.8)
    s.add_plane((0, 0, 0), 12.0, ground)
    ball = pyrt.Lambert(albedo=(0.7, 0.5, 0.3))
    ball.normal_map = pyrt.NormalMap(_normal_map(rng), flip_green=True)
    s.add_sphere((0.9, 0.45, -0.2), 0.45, ball, subdivisions=3)
    mirror = pyrt.Mirror(0.9)
    mirror.normal_map = pyrt.NormalMap(_normal_map(rng), strength=0.3, reflection="drop")
    s.add_sphere((-0.9, 0.45, -0.3), 0.45, mirror, subdivisions=3)
    glass = pyrt.Glass(ior=1.5)
    glass.normal_map = pyrt.NormalMap(_normal_map(rng), strength=0.3)
    s.add_sphere((0.0, 0.4, 0.6), 0.4, glass, subdivisions=3)
    s.add_light(pyrt.PointLight((2, 3, 2), intensity=20.0))
    s.add_light(pyrt.DirectionalLight((0.3, -1, -0.4), irradiance=0.5))
    return s


def test_normal_maps_match_the_numpy_path_pixel_by_pixel():
    """The perturbed normals shade the diffuse and glossy lobes and turn the mirror's and the glass's rays: the same
    image as the NumPy path, and not the image without the maps. The normal AOV is the perturbed normal."""
    s = _normal_mapped_scene()
    assert compiled.unsupported(pyrt.PreparedScene(s)) == []
    c = _same_image_and_aov(s, "normal", 1e-6)
    for m in s.materials:
        m.normal_map = None
    _assert_changes_the_image(s, c, 0.02)


def test_scenes_without_footprints_or_normal_maps_do_not_carry_them():
    """The kernel's options: differentials only with a footprint-filtered texture, normal maps only with a map (the
    default and benchmark scenes pay for neither)."""
    for scene, want in ((_scene(), (0, 0)), (_mip_scene(), (1, 0)), (_normal_mapped_scene(), (1, 1))):
        cs = compiled.CompiledScene(pyrt.PreparedScene(scene))
        opts, _ = compiled.kernel_options(cs, 1, 0, 8, 1e-4, None, True)
        assert (opts[KL.O_DIFFS], opts[KL.O_NMAPS]) == want


def test_normal_maps_in_scenes_with_vertex_tangents_read_them():
    """A mesh with vertex tangents: the maps read them there (``O_NMAPS`` 2; tests/test_compiled_vertex_attrs.py)."""
    s = _normal_mapped_scene(width=8, height=6)
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0.0]])
    s.add_mesh((v, np.array([[0, 1, 2]])), pyrt.Lambert(albedo=0.5), normals=np.tile([0, 0, 1.0], (3, 1)),
               uv=v[:, :2], tangents=np.tile([1, 0, 0, 1.0], (3, 1)))
    cs = compiled.CompiledScene(pyrt.PreparedScene(s))
    assert compiled.kernel_options(cs, 1, 0, 8, 1e-4, None, True)[0][KL.O_NMAPS] == 2
    r = pyrt.render_full(s, progress=False)
    assert r.stats.backend == "compiled" and r.stats.fallback_reasons == []


@pytest.mark.parametrize("filt", ["anisotropic", "bicubic"])
def test_other_filters_fall_back(filt):
    s = _mip_scene(width=8, height=6)
    s.materials[0].albedo_value.filter = filt
    r = pyrt.render_full(s, progress=False)
    assert r.stats.backend == "numpy" and any("Lambert" in x for x in r.stats.fallback_reasons)
