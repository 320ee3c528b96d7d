"""Textured ``KHR_materials_specular`` on the compiled path: :class:`pyrt.GltfPBR`'s ``specular`` (a scalar slot) and
``specular_color`` (a colour slot) read per hit (:func:`pyrt.materials.compiled.gltf_specular`,
:data:`pyrt.materials.compiled.SPECULAR`).

- the slots are the factors times the NumPy lookups, the dielectric F0 ``min(f0(ior) specular_color, 1)`` clamped as
  ``GltfPBR._f0_dielectric``; the reflection with per-hit specular weight and F0 equals its NumPy kernel to 1e-6
  relative in float64 on random inputs;
- renders with textured specular and specular colour (a grey specular image as the glTF loader builds it from an
  alpha channel, an HDR colour factor that clamps F0 at 1) give the NumPy path's image pixel by pixel at pixel
  centres, under delta lights and under the studio preview (the split sum's lobes read the per-hit inputs), and agree
  with it in distribution with the glossy integrator under the studio preview and under a sampled sky;
- smooth transmission with a textured specular keeps the NumPy path, with its reason; the Khronos SpecularTest model
  has no fallback reason.
"""
import glob
import os

import numba
import numpy as np
import pytest

import pyrt
from pyrt.apps.preview.studio import StudioEnvironment
from pyrt.integrators import compiled
from pyrt.integrators.compiled import _TexturePacker, unsupported
from pyrt.io.assets.materials import GltfPBRMaterial, ScaledTexture
from pyrt.materials import compiled as MC
from pyrt.shaders import brdfs, fresnel
from pyrt.textures import ChannelTexture, ImageTexture
from pyrt.textures.base import is_texture
from pyrt.textures import compiled as TC

from test_compiled_glossy import _add_sky, _assert_agree  # noqa: E402

KHRONOS = "/work/shared/khronos-gltf"
IOR = 1.6


def _maps(rng, filt="bilinear"):
    """A grey specular image (the loader's alpha channel), an RGB map whose channel 1 is read as specular, and a
    specular colour map."""
    grey = ImageTexture(rng.uniform(0, 1, (7, 5)).astype(np.float32), srgb=False, filter=filt)
    rgb = ImageTexture(rng.uniform(0, 1, (6, 6, 3)).astype(np.float32), srgb=False, filter=filt, wrap="clamp")
    col = ImageTexture(rng.uniform(0, 1, (5, 8, 3)).astype(np.float32), srgb=False, filter=filt,
                       scale=(2.0, 1.5), rotation_deg=20.0)
    return grey, rgb, col


# ----------------------------------------------------------------------------------------- slots and formulas

@numba.njit
def _inputs_many(rec, tex_tag, tex_par, uv, out):
    for k in range(uv.shape[0]):
        a = MC.albedo_at(MC.GLTF, rec, 0, tex_tag, tex_par, uv[k, 0], uv[k, 1], TC.NO_FOOTPRINT, MC.WHITE)
        for c in range(13):
            out[k, c] = a[c]


@pytest.mark.parametrize("which", ["grey", "channel"])
def test_the_specular_slots_are_the_factors_times_the_numpy_lookups(which, rng):
    grey, rgb, col = _maps(rng)
    spec = ScaledTexture(grey, 0.7) if which == "grey" else ScaledTexture(ChannelTexture(rgb, 1), 0.7)
    factor = np.array([40.0, 4.0, 0.5])                  # F0 = min(f0(ior) factor col, 1): clamps in red
    mat = pyrt.GltfPBR(base_color=0.5, metallic=0.1, roughness=0.4, specular=spec,
                       specular_color=ScaledTexture(col, factor), ior=IOR)
    packer = _TexturePacker()
    tag, rec = mat.compiled_record(packer.add)
    assert tag == MC.GLTF and len(packer.tags) == 2
    tex_tag, tex_par = TC.pack_table(packer.tags, packer.records, packer.texels)
    uv = rng.uniform(-0.5, 1.5, (500, 2))
    got = np.zeros((500, 13))
    _inputs_many(np.ascontiguousarray(rec), tex_tag, tex_par.ravel(), uv, got)
    s = 0.7 * (grey.lookup(uv)[:, 0] if which == "grey" else rgb.lookup(uv)[:, 1])
    f0 = np.minimum(fresnel.f0_from_ior(IOR) * (col.lookup(uv) * factor), 1.0)
    np.testing.assert_allclose(got[:, 9], s, rtol=1e-6)
    np.testing.assert_allclose(got[:, 10:13], f0, rtol=1e-6)
    assert (f0 == 1.0).any() and (f0 < 1.0).any()
    np.testing.assert_allclose(got[:, 3:6], 0.5, rtol=1e-12)           # the other inputs as before
    np.testing.assert_allclose(got[:, 6:9], np.broadcast_to([0.1, 0.4, 1.0], (500, 3)), rtol=1e-12)


def test_constant_specular_inputs_are_the_materials_constants():
    mat = pyrt.GltfPBR(base_color=0.5, specular=0.3, specular_color=(1.0, 0.5, 30.0), ior=1.45)
    tag, rec = mat.compiled_record(_TexturePacker().add)
    got = np.zeros((1, 13))
    _inputs_many(np.ascontiguousarray(rec), np.zeros(1, np.int64), np.zeros(1), np.zeros((1, 2)), got)
    assert got[0, 9] == 0.3
    np.testing.assert_array_equal(got[0, 10:13], mat._f0_dielectric(None))


@numba.njit
def _f_cos_many(rec, base, metal, rough, spec, f0, wo, wi, out):
    for k in range(wo.shape[0]):
        a = (0.0, 0.0, 0.0, base[k, 0], base[k, 1], base[k, 2], metal[k], rough[k], 1.0, spec[k], f0[k, 0],
             f0[k, 1], f0[k, 2])
        cos_io = wo[k, 0] * wi[k, 0] + wo[k, 1] * wi[k, 1] + wo[k, 2] * wi[k, 2]
        out[k, 0], out[k, 1], out[k, 2] = MC.f_cos(MC.GLTF, rec, 0, a, wo[k, 2], wi[k, 2], cos_io)


def _unit(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


@pytest.mark.parametrize("geometry", ["smith_separable", "smith_correlated"])
def test_the_reflection_with_per_hit_specular_is_the_numpy_kernel(geometry, rng):
    n = 3000
    wo, wi = _unit(rng.normal(size=(n, 3))), _unit(rng.normal(size=(n, 3)))
    wo[:, 2], wi[:, 2] = np.abs(wo[:, 2]) + 1e-3, np.abs(wi[:, 2]) + 1e-3
    wo, wi = _unit(wo), _unit(wi)
    base, metal, rough = rng.uniform(0, 1, (n, 3)), rng.uniform(0, 1, n), rng.uniform(0.02, 1, n)
    metal[::5] = 0.0
    spec, f0 = rng.uniform(0, 1, n), rng.uniform(0, 1, (n, 3))
    f0[::7] = 1.0
    tag, rec = pyrt.GltfPBR(geometry=geometry).compiled_record(_TexturePacker().add)
    got = np.zeros((n, 3))
    _f_cos_many(np.ascontiguousarray(rec), base, metal, rough, spec, f0, wo, wi, got)
    want = brdfs.gltf_pbr_f_cos(wo, wi, base, metal, rough, f0_dielectric=f0, specular=spec, geometry=geometry)
    np.testing.assert_allclose(got, want, rtol=1e-6, atol=1e-12)
    assert want.max() > 0


# ----------------------------------------------------------------------------------------- renders

def _scene(rng, width=40, height=30, spp=1, jitter=False):
    """Three black-based dielectric spheres whose reflection is their specular alone (a grey specular map, a specular
    colour map with an HDR factor, both with a texture each), a textured base-colour one, a mirror that shows them, a
    grey floor; a point and a directional light."""
    grey, rgb, col = _maps(rng)
    cam = pyrt.Camera(position=(0, 1.3, 4.0), target=(0, 0.45, 0), fov=42, width=width, height=height, spp=spp,
                      jitter=jitter)
    s = pyrt.Scene(cam, background=(0.05, 0.06, 0.1), ambient=(0.03, 0.03, 0.03))
    s.add_plane((0, 0, 0), 6.0, pyrt.Lambert(albedo=0.4))
    s.add_sphere((-1.0, 0.4, 0.0), 0.4, pyrt.GltfPBR(base_color=0.0, roughness=0.3, specular=ScaledTexture(grey, 0.9),
                                                      ior=IOR), subdivisions=3)
    s.add_sphere((0.0, 0.45, 0.1), 0.45, pyrt.GltfPBR(base_color=0.0, roughness=0.25,
                                                       specular_color=ScaledTexture(col, (25.0, 25.0, 0.5)),
                                                       ior=1.5), subdivisions=3)
    s.add_sphere((1.0, 0.4, 0.0), 0.4, GltfPBRMaterial(base_color=ScaledTexture(col, (0.8, 0.7, 0.6)), metallic=0.3,
                                                       roughness=0.45, specular=ScaledTexture(ChannelTexture(rgb, 2),
                                                                                              0.8),
                                                       specular_color=ScaledTexture(rgb, (1.0, 0.9, 3.0)), ior=1.7,
                                                       emission=(0.02, 0.0, 0.0)), subdivisions=3)
    s.add_sphere((0.0, 0.55, -1.3), 0.55, pyrt.Mirror(0.9), subdivisions=3)     # glTF hits of the specular tree
    s.add_light(pyrt.PointLight((2, 3, 2), intensity=20.0))
    s.add_light(pyrt.DirectionalLight((0.3, -1, -0.4), irradiance=0.8, color=(1.0, 0.9, 0.8)))
    return s


def _studio(s):
    pyrt.set_environment(s, StudioEnvironment(width=64, height=32, intensity=0.6), lighting="preview",
                         preview_method="split_sum")
    return s


@pytest.mark.parametrize("studio", [False, True])
def test_textured_specular_matches_the_numpy_path_pixel_by_pixel(studio, rng):
    s = _scene(rng)
    if studio:
        _studio(s)
    assert unsupported(None, scene=s) == []
    kw = dict(integrator=pyrt.Whitted(split_depth=None))
    c = pyrt.render_full(s, execution=pyrt.Execution(backend="compiled", progress=False), seed=0, **kw)
    n = pyrt.render_full(s, execution=pyrt.Execution(backend="numpy", progress=False), seed=0, **kw)
    assert c.stats.backend == "compiled" and n.stats.backend == "numpy" and c.stats.fallback_reasons == []
    close = np.isclose(c.image.astype(np.float64), n.image, rtol=1e-5, atol=1e-6).all(axis=2)
    # a pixel whose ray meets an edge exactly may differ (Embree's packets break such ties differently)
    assert (~close).mean() < 0.002, np.argwhere(~close)[:5]
    assert n.image.mean() > 0.02


def test_textured_specular_with_the_glossy_integrator_under_the_studio_agrees_with_numpy(rng):
    """The previewer's set-up: the studio's split sum at camera hits, glossy rays at glossy hits, one delta light
    chosen per glossy-ray hit."""
    s = _studio(_scene(rng, spp=16, jitter=True))
    assert compiled.glossy_reasons(s) == []
    _assert_agree(s, integrator=pyrt.Glossy(samples=4, depth=2, light_select_depth=1))


def test_textured_specular_under_a_sampled_sky_agrees_with_numpy(rng):
    """Light and BSDF samples of a sampled sky (MIS) and glossy rays at the textured-specular hits."""
    s = _add_sky(_scene(rng, spp=16, jitter=True))
    _assert_agree(s, integrator=pyrt.Glossy(samples=4, depth=2))


# ----------------------------------------------------------------------------------------- what falls back

def test_smooth_transmission_with_a_textured_specular_falls_back_and_says_why(rng):
    grey, rgb, col = _maps(rng)
    for kw in (dict(specular=ScaledTexture(grey, 0.5)), dict(specular_color=col)):
        m = pyrt.GltfPBR(roughness=0.0, transmission=0.8, name="glass", **kw)
        assert m.compiled_record(_TexturePacker().add) is None
        s = _scene(rng, width=8, height=6)
        s.materials[1] = m
        reasons = unsupported(None, scene=s)
        assert any("glass" in r and "specular" in r for r in reasons), reasons
    opaque = pyrt.GltfPBR(specular=ScaledTexture(grey, 0.5), specular_color=col)
    assert opaque.compiled_record(_TexturePacker().add)[0] == MC.GLTF


def test_specular_test_model_has_no_fallback_reason():
    """The shared Khronos SpecularTest (skipped when absent): textured specular and specular colour, HDR factors."""
    files = glob.glob(os.path.join(KHRONOS, "SpecularTest", "**", "*.gl*"), recursive=True)
    if not files:
        pytest.skip("SpecularTest not present")
    from pyrt.io.assets import load_asset
    asset = load_asset(files[0])
    cam = pyrt.Camera(position=(0, 0, 1), target=(0, 0, 0), fov=40, width=8, height=6)
    s = pyrt.Scene(cam)
    asset.add_to_scene(s, lights=False)
    assert any(isinstance(m, pyrt.GltfPBR) and is_texture(m.specular_color) for m in s.materials)
    assert any(isinstance(m, pyrt.GltfPBR) and is_texture(m.specular) for m in s.materials)
    for m in s.materials:
        assert m.compiled_record(_TexturePacker().add) is not None, m.label
