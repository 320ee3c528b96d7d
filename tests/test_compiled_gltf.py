"""The glTF material family on the compiled path (:data:`pyrt.materials.compiled.GLTF`,
:mod:`pyrt.materials.gltf_record`).

- the reflection (:func:`pyrt.materials.compiled.gltf_f_cos_h` through the kernel's switches) equals the NumPy
  kernels it twins (:func:`pyrt.shaders.brdfs.gltf_pbr_f_cos`,
  :func:`~pyrt.shaders.brdfs.gltf_metallic_roughness_f_cos`)
  to 1e-6 relative in float64 on random per-hit parameters and directions, grazing ones included;
- the per-hit inputs (base colour, metallic, roughness, occlusion, emission slots) are the factors times the image
  lookups the NumPy textures make (ScaledTexture of a ChannelTexture: glTF's packed maps);
- renders of textured glTF materials (bilinear and trilinear maps, a packed occlusion-roughness-metallic map,
  emission, occlusion under ambient light, the albedo AOV) give the NumPy path's image pixel by pixel at pixel
  centres, and agree with it in distribution with jittered samples and an environment light (MIS: the family's
  BSDF sampling and pdf in the kernel); what the kernel cannot reproduce falls back, with its reason.
The sampling twins and the chi-square test are in tests/test_compiled_sampling.py, the contracts (furnace,
reciprocity, finite values) in tests/test_compiled_contracts.py: both cover ``gltf_pbr`` through the registries.
"""
import os
import types

import numba
import numpy as np
import pytest

import pyrt
from pyrt.integrators.compiled import _TexturePacker, unsupported
from pyrt.io.assets.materials import (FaceColorTexture, GltfMaterial, GltfPBRMaterial, ProductTexture, ScaledTexture,
                                      VertexColorTexture)
from pyrt.materials import compiled as MC
from pyrt.materials import compiled_sampling as CS
from pyrt.materials import gltf_record as GR
from pyrt.shaders import brdfs
from pyrt.textures import ChannelTexture, ImageTexture
from pyrt.textures import compiled as TC

KHRONOS = "/work/shared/khronos-gltf"


# ----------------------------------------------------------------------------------------- the reflection

@numba.njit
def _f_cos_many(rec, base, metal, rough, wo, wi, out, vector_form, spec=1.0, f0=(0.04, 0.04, 0.04)):
    for k in range(wo.shape[0]):
        a = (0.0, 0.0, 0.0, base[k, 0], base[k, 1], base[k, 2], metal[k], rough[k], 1.0, spec, f0[0], f0[1], f0[2],
             0.0, 0.0, 0.0, 0.0, 1.0)
        if vector_form:
            r = CS.f_cos_local(MC.GLTF, rec, 0, a, wo[k, 0], wo[k, 1], wo[k, 2], wi[k, 0], wi[k, 1], wi[k, 2])
        else:
            cos_io = wo[k, 0] * wi[k, 0] + wo[k, 1] * wi[k, 1] + wo[k, 2] * wi[k, 2]
            r = MC.f_cos(MC.GLTF, rec, 0, a, wo[k, 2], wi[k, 2], cos_io)
        out[k, 0], out[k, 1], out[k, 2] = r


def _unit(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _directions(rng, n):
    """Random upper-hemisphere pairs plus grazing ones (cos 1e-2 .. 1e-6, 0, just below the horizon)."""
    wo, wi = _unit(rng.normal(size=(n, 3))), _unit(rng.normal(size=(n, 3)))
    wo[:, 2], wi[:, 2] = np.abs(wo[:, 2]), np.abs(wi[:, 2])
    g = []
    for c in (1e-2, 1e-3, 1e-4, 1e-6, 0.0, -1e-6):
        for phi in (0.0, 1.1, 2.9):
            s = np.sqrt(1.0 - c * c)
            g.append([s * np.cos(phi), s * np.sin(phi), c])
    g = np.array(g)
    k = g.shape[0]
    other = _unit(rng.normal(size=(k, 3)))
    other[:, 2] = np.abs(other[:, 2])
    return np.concatenate([wo, g, other, g]), np.concatenate([wi, other, g, g[::-1]])


def _record(model, geometry):
    holder = types.SimpleNamespace(base_color=0.5, metallic=0.0, roughness=0.5)
    tag, rec = GR.gltf_record(holder, lambda t: None, model=model, geometry=geometry)
    assert tag == MC.GLTF
    return rec


@pytest.mark.parametrize("geometry", ["smith_separable", "smith_correlated"])
@pytest.mark.parametrize("model", [GR.MR, GR.GLTF_PBR])
def test_gltf_f_cos_equals_the_numpy_kernel_on_random_and_grazing_inputs(model, geometry, rng):
    wo, wi = _directions(rng, 4000)
    n = wo.shape[0]
    base = rng.uniform(0.0, 1.0, (n, 3))
    metal = rng.uniform(0.0, 1.0, n)
    metal[::7] = 0.0
    metal[1::7] = 1.0
    rough = rng.uniform(0.0, 1.0, n)
    rough[::11] = 0.02
    f0, spec = np.array([0.06, 0.05, 0.09]), 0.7           # the hit's inputs (tests/test_compiled_specular.py)
    rec = _record(model, geometry)
    if model == GR.MR:
        want = brdfs.gltf_metallic_roughness_f_cos(wo, wi, base, metal, rough, geometry=geometry)
    else:
        want = brdfs.gltf_pbr_f_cos(wo, wi, base, metal, rough, f0_dielectric=f0, specular=spec, geometry=geometry)
    got = np.zeros((n, 3))
    _f_cos_many(rec, base, metal, rough, wo, wi, got, True, spec, tuple(f0))
    np.testing.assert_allclose(got, want, rtol=1e-6, atol=1e-12)
    assert np.all(np.isfinite(got)) and np.all(got >= 0) and want.max() > 0
    # the kernel's cosine form (lights): the same away from the mirror-grazing pairs (docs/compiled.md)
    got_c = np.zeros((n, 3))
    _f_cos_many(rec, base, metal, rough, wo[:4000], wi[:4000], got_c[:4000], False, spec, tuple(f0))
    np.testing.assert_allclose(got_c[:4000], want[:4000], rtol=1e-6, atol=1e-9)


def test_gltf_pbr_with_the_core_parameters_is_the_metallic_roughness_model_at_metallic_0_and_1(rng):
    """KHR_materials_specular's defaults (F0 0.04, specular 1) give the core model where metallic is 0 or 1
    (brdfs.gltf_pbr_f_cos's docstring): the two records' f_cos agree there."""
    wo, wi = _directions(rng, 500)
    n = wo.shape[0]
    base, rough = rng.uniform(0, 1, (n, 3)), rng.uniform(0, 1, n)
    metal = np.where(rng.random(n) < 0.5, 0.0, 1.0)
    a, b = np.zeros((n, 3)), np.zeros((n, 3))
    _f_cos_many(_record(GR.MR, "smith_separable"), base, metal, rough, wo, wi, a, True)
    _f_cos_many(_record(GR.GLTF_PBR, "smith_separable"), base, metal, rough, wo, wi, b, True)
    np.testing.assert_allclose(a, b, rtol=1e-9, atol=1e-14)


# ----------------------------------------------------------------------------------------- the per-hit inputs

@numba.njit
def _inputs_many(rec, tex_tag, tex_par, uv, out, em):
    for k in range(uv.shape[0]):
        a = MC.albedo_at(MC.GLTF, rec, 0, tex_tag, tex_par, uv[k, 0], uv[k, 1], TC.NO_FOOTPRINT, MC.WHITE)
        e = MC.emission_at(MC.GLTF, rec, 0, False, tex_tag, tex_par, uv[k, 0], uv[k, 1], TC.NO_FOOTPRINT)
        for c in range(9):
            out[k, c] = a[c]
        em[k, 0], em[k, 1], em[k, 2] = e


def _maps(rng, filt="bilinear"):
    base = ImageTexture(rng.uniform(0, 1, (9, 7, 3)).astype(np.float32), srgb=False, filter=filt)
    orm = ImageTexture(rng.uniform(0, 1, (5, 6, 3)).astype(np.float32), srgb=False, filter=filt, wrap="clamp")
    emit = ImageTexture(rng.uniform(0, 1, (4, 4, 3)).astype(np.float32), srgb=False, filter=filt,
                        scale=(2.0, 1.5), rotation_deg=20.0)
    return base, orm, emit


def test_the_slots_are_the_factors_times_the_numpy_lookups(rng):
    base, orm, emit = _maps(rng)
    mat = GltfMaterial(base_color=ScaledTexture(base, (0.9, 0.8, 0.7)),
                       metallic=ScaledTexture(ChannelTexture(orm, 2), 0.6),
                       roughness=ScaledTexture(ChannelTexture(orm, 1), 0.9),
                       emission=ScaledTexture(emit, (2.0, 1.0, 0.5)), occlusion=ChannelTexture(orm, 0),
                       occlusion_strength=0.7)
    packer = _TexturePacker()
    tag, rec = mat.compiled_record(packer.add)
    assert tag == MC.GLTF and len(packer.tags) == 3           # the packed map is one row of the table
    tex_tag, tex_par = TC.pack_table(packer.tags, packer.records, packer.texels)
    uv = rng.uniform(-0.5, 1.5, (500, 2))
    got, em = np.zeros((500, 9)), np.zeros((500, 3))
    _inputs_many(np.ascontiguousarray(rec), tex_tag, tex_par.ravel(), uv, got, em)
    b = base.lookup(uv) * [0.9, 0.8, 0.7]
    o = orm.lookup(uv)
    occ = 1.0 + 0.7 * (o[:, 0] - 1.0)
    np.testing.assert_allclose(got[:, 3:6], b, rtol=1e-6)
    np.testing.assert_allclose(got[:, 0:3], b * occ[:, None], rtol=1e-6)
    np.testing.assert_allclose(got[:, 8], occ, rtol=1e-6)                  # what the environment preview multiplies
    np.testing.assert_allclose(got[:, 6], 0.6 * o[:, 2], rtol=1e-6)
    np.testing.assert_allclose(got[:, 7], 0.9 * o[:, 1], rtol=1e-6)
    np.testing.assert_allclose(em, emit.lookup(uv) * [2.0, 1.0, 0.5], rtol=1e-6)


def test_what_the_kernel_cannot_reproduce_has_no_record():
    img = ImageTexture(np.full((4, 4, 3), 0.5, dtype=np.float32), srgb=False, filter="bilinear")
    vc, fc = VertexColorTexture(), FaceColorTexture()
    none = lambda t: t.compiled_record() and 0          # noqa: E731  (a table that takes what the kernel reads)
    cases = {
        "transmission": pyrt.GltfPBR(transmission=0.5),
        "anisotropy": pyrt.GltfPBR(anisotropy=0.5),
        "per-face colours": GltfMaterial(base_color=ProductTexture(fc, ScaledTexture(img, 0.5)), metallic=0.0,
                                         roughness=0.5),
        "vertex colours twice": GltfMaterial(base_color=ProductTexture(vc, vc), metallic=0.0, roughness=0.5),
        "bicubic": pyrt.MetallicRoughness(base_color=ImageTexture(img, filter="bicubic")),
    }
    for what, m in cases.items():
        assert m.compiled_record(none) is None, what
    assert pyrt.GltfPBR(base_color=img).compiled_record(none)[0] == MC.GLTF
    assert pyrt.MetallicRoughness(base_color=0.5).compiled_record(none)[0] == MC.METALLIC_ROUGHNESS


# ----------------------------------------------------------------------------------------- renders

def _scene(rng, width=40, height=30, spp=1, jitter=False, filt="bilinear"):
    """A textured GltfMaterial ground (packed occlusion-roughness-metallic map, emission, occlusion), a textured
    GltfPBR sphere, a normal-mapped GltfPBRMaterial sphere and a mirror that shows them; a point and a directional
    light; ambient light."""
    base, orm, emit = _maps(rng, filt)
    cam = pyrt.Camera(position=(0, 1.4, 4.0), target=(0, 0.4, 0), fov=42, width=width, height=height, spp=spp,
                      jitter=jitter)
    s = pyrt.Scene(cam, background=(0.05, 0.06, 0.1), ambient=(0.05, 0.04, 0.03))
    ground = GltfMaterial(base_color=ScaledTexture(base, (0.9, 0.8, 0.7)),
                          metallic=ScaledTexture(ChannelTexture(orm, 2), 0.6),
                          roughness=ScaledTexture(ChannelTexture(orm, 1), 0.9),
                          emission=ScaledTexture(emit, (0.2, 0.1, 0.05)), occlusion=ChannelTexture(orm, 0),
                          occlusion_strength=0.8)
    s.add_plane((0, 0, 0), 6.0, ground)
    s.add_sphere((-0.7, 0.5, 0.0), 0.5, pyrt.GltfPBR(base_color=ScaledTexture(base, (1.0, 0.9, 0.8)),
                                                     metallic=ScaledTexture(ChannelTexture(orm, 2), 1.0),
                                                     roughness=0.45, specular=0.6, specular_color=(1.0, 0.9, 0.7),
                                                     ior=1.6), subdivisions=3)
    nmap = pyrt.NormalMap(np.dstack([np.full((8, 8), 0.6), np.full((8, 8), 0.45), np.ones((8, 8))])
                          .astype(np.float32), filter="bilinear")
    s.add_sphere((0.7, 0.45, -0.2), 0.45, GltfPBRMaterial(base_color=(0.3, 0.5, 0.8), metallic=0.2, roughness=0.3,
                                                          specular=0.8, emission=(0.02, 0.0, 0.0), normal_map=nmap),
                 subdivisions=3)
    s.add_sphere((0.0, 0.55, -1.3), 0.55, pyrt.Mirror(0.9), subdivisions=3)     # glTF hits of the specular tree
    s.add_light(pyrt.PointLight((2, 3, 2), intensity=20.0))
    s.add_light(pyrt.DirectionalLight((0.3, -1, -0.4), irradiance=0.8, color=(1.0, 0.9, 0.8)))
    return s


@pytest.mark.parametrize("filt", ["bilinear", "trilinear"])
def test_textured_gltf_materials_match_the_numpy_path_pixel_by_pixel(filt, rng):
    scene = _scene(rng, filt=filt)
    assert unsupported(None, scene=scene) == []
    c = pyrt.render_full(scene, backend="compiled", progress=False, seed=0, aovs=True)
    n = pyrt.render_full(scene, backend="numpy", progress=False, seed=0, aovs=True)
    assert c.stats.backend == "compiled" and n.stats.backend == "numpy" and c.stats.fallback_reasons == []
    diff = np.abs(c.image.astype(np.float64) - n.image)
    bad = diff > 1e-5 * (1.0 + np.abs(n.image))
    assert bad.any(axis=2).mean() < 0.002, f"{bad.any(axis=2).sum()} pixels differ, max {diff.max()}"
    assert n.image.max() > 0
    np.testing.assert_allclose(c.aovs["albedo"], n.aovs["albedo"], rtol=1e-5, atol=1e-6)


def test_jittered_gltf_render_with_an_environment_agrees_with_numpy_in_distribution(rng):
    """16 jittered samples, a constant environment lit by MIS (the family's BSDF sampling and pdf): the two paths'
    per-pixel means differ by their standard errors (z-scores), with a 256-spp NumPy render as the reference."""
    scene = _scene(rng, width=32, height=24, spp=16, jitter=True)
    pyrt.set_environment(scene, pyrt.ConstantEnvironment(0.4), n_samples=1, bsdf_samples=1)
    c = pyrt.render_full(scene, backend="compiled", progress=False, seed=1)
    n = pyrt.render_full(scene, backend="numpy", progress=False, seed=2)
    assert c.stats.backend == "compiled" and n.stats.backend == "numpy"
    ref = pyrt.render_full(scene, backend="numpy", progress=False, seed=3, spp=256).image.astype(np.float64)
    err_c = np.mean((c.image - ref) ** 2 / (ref ** 2 + 1e-2))
    err_n = np.mean((n.image - ref) ** 2 / (ref ** 2 + 1e-2))
    assert err_c < 2.0 * err_n + 1e-6, (err_c, err_n)
    assert abs(float(c.image.mean()) - float(ref.mean())) < 0.01 * float(ref.mean())


def test_glTF_materials_the_kernel_does_not_cover_fall_back_and_say_why(rng):
    scene = _scene(rng, width=8, height=6)
    scene.materials[1] = pyrt.GltfPBR(transmission=0.5, roughness=0.5)
    r = pyrt.render_full(scene, progress=False)
    assert r.stats.backend == "numpy" and any("GltfPBR" in x for x in r.stats.fallback_reasons)


@pytest.mark.parametrize("model", ["BoxTextured/BoxTextured.glb", "Duck/Duck.glb"])
def test_khronos_models_materials_are_compiled(model):
    """Shared Khronos models (skipped when absent): their glTF materials pack into the compiled table, and a render
    of the model under a point light (single-sided as the file says: back faces culled) takes the compiled path and
    matches the NumPy path at pixel centres."""
    path = os.path.join(KHRONOS, model)
    if not os.path.exists(path):
        pytest.skip(f"{path} not present")
    from pyrt.io.assets import load_asset
    asset = load_asset(path)
    cam = pyrt.Camera(position=(0, 0, 1), target=(0, 0, 0), fov=40, width=32, height=24, spp=1, jitter=False)
    s = pyrt.Scene(cam, background=(0.1, 0.1, 0.1), ambient=(0.02, 0.02, 0.02))
    asset.add_to_scene(s, lights=False)
    lo, hi = np.min([m.vertices.min(axis=0) for m in s.meshes], axis=0), np.max(
        [m.vertices.max(axis=0) for m in s.meshes], axis=0)
    centre, radius = 0.5 * (lo + hi), 0.5 * float(np.linalg.norm(hi - lo))
    s.camera = pyrt.Camera(position=centre + radius * np.array([1.2, 0.9, 2.2]), target=centre, fov=40, width=32,
                           height=24, spp=1, jitter=False)
    s.add_light(pyrt.PointLight(centre + radius * np.array([2.0, 3.0, 2.0]), intensity=20.0 * radius ** 2))
    for m in s.materials:
        assert m.compiled_record(_TexturePacker().add) is not None, m.label
    c = pyrt.render_full(s, backend="auto", progress=False, seed=0)
    n = pyrt.render_full(s, backend="numpy", progress=False, seed=0)
    assert c.stats.backend == "compiled", c.stats.fallback_reasons
    diff = np.abs(c.image.astype(np.float64) - n.image)
    bad = diff > 1e-5 * (1.0 + np.abs(n.image))
    assert bad.any(axis=2).mean() < 0.005 and n.image.max() > 0
