"""The environment light's ``strategy="preview"`` on the compiled path, and the previewer's studio environment.

- the scalar twins (:mod:`pyrt.shaders.jit_preview`, :mod:`pyrt.lights.compiled_env_preview`) equal their NumPy
  twins to 1e-6 relative in float64 on random inputs, grazing ones included: the SH irradiance, the prefiltered
  stack's lookup, the DFG tables, the dominant direction and the materials' preview lobes;
- renders at pixel centres (the preview has no noise) give the NumPy path's image pixel by pixel under a
  ``StudioEnvironment`` and under a rotated lat-long sky, both preview methods: Lambert (SH), metallic-roughness and
  glTF PBR (split sum), Blinn-Phong and Cook-Torrance (Hammersley BSDF samples), mirror and glass (the specular
  tree's hits), without a shadow ray;
- :func:`pyrt.integrators.compiled.unsupported` no longer lists the studio or its light for the previewer's set-up.
"""
import os
import types

import numpy as np
import pytest

import pyrt
from pyrt.apps.preview.render import PreviewScene
from pyrt.apps.preview.studio import STUDIO_PREVIEW_SAMPLES, StudioEnvironment
from pyrt.integrators.compiled import unsupported
from pyrt.io.assets import load_asset
from pyrt.io.assets.materials import GltfMaterial
from pyrt.lights import compiled_env as CE
from pyrt.lights import compiled_env_preview as CP
from pyrt.lights.environment import LatLongEnvironment, procedural_sky
from pyrt.materials import preview as MP
from pyrt.shaders import dfg
from pyrt.shaders import jit_brdfs as JB
from pyrt.shaders import jit_preview as JP
from pyrt.textures import ChannelTexture, ImageTexture

from test_compiled_coverage import _leaves as coverage_leaves
from test_compiled_gltf import _scene as gltf_scene

RTOL = 1e-6
DUCK = "/work/shared/khronos-gltf/Duck/Duck.glb"


def _unit(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _directions(rng, n):
    """Random unit directions plus the poles, the seam of the lat-long map and near-horizontal ones."""
    d = _unit(rng.normal(size=(n, 3)))
    special = [(0, 1, 0), (0, -1, 0), (0, 0, -1), (0, 0, 1), (1, 0, 0), (1e-9, 0.3, -1.0), (0.5, 1e-7, 0.5)]
    return np.concatenate([d, _unit(np.array(special, dtype=np.float64))])


def _rotated(env):
    env.rotation = pyrt.lights.environment._rotation_matrix("test", [(35.0, (0.3, 1.0, 0.2))])
    return env


def _packed(env, k=4, method="split_sum", geometries=(0, 1, 4)):
    light = pyrt.EnvironmentLight(env, strategy="preview", preview_samples=k, preview_method=method)
    return CP.pack_preview(env, light, CE.pack_environment(env, light), geometries)


ENVS = {
    "studio": lambda: _rotated(StudioEnvironment(width=64, height=32, intensity=0.8)),
    "sky": lambda: _rotated(LatLongEnvironment(procedural_sky(64, 32, sun_angle=8.0), intensity=0.5)),
    "constant": lambda: pyrt.ConstantEnvironment((0.3, 0.5, 0.7), intensity=2.0),
}


# ----------------------------------------------------------------------------------------- the scalar twins

@pytest.mark.parametrize("name", sorted(ENVS))
def test_irradiance_sh_is_its_numpy_twin(name):
    env = ENVS[name]()
    tag, rec, data = _packed(env)
    n = _directions(np.random.default_rng(1), 200)
    got = np.array([CP.irradiance_sh(rec, data, *x) for x in n])
    np.testing.assert_allclose(got, env.irradiance_sh(n), rtol=RTOL, atol=1e-12)


@pytest.mark.parametrize("name", sorted(ENVS))
def test_prefiltered_is_its_numpy_twin(name):
    """Random directions and widths, the stack's levels exactly, 0, beyond the widest (clamped)."""
    env = ENVS[name]()
    tag, rec, data = _packed(env)
    rng = np.random.default_rng(2)
    d = _directions(rng, 300)
    alpha = np.concatenate([rng.uniform(0.0, 1.0, 300), [0.0, 0.05, 0.35, 1.0, 1.7, 1e-9, 0.999999]])
    got = np.array([CP.prefiltered(tag, rec, data, *x, a) for x, a in zip(d, alpha)])
    np.testing.assert_allclose(got, env.prefiltered(d, alpha), rtol=RTOL, atol=1e-12)


def test_the_studio_stack_is_its_own():
    """The studio's cheaper stack (its own ``_build_prefiltered``) is what the kernel reads, not the engine's."""
    env = StudioEnvironment(width=64, height=32)
    tag, rec, data = _packed(env)
    maps = env.prefiltered_maps()
    hdr, n = int(rec[CE.R_MAPS]), int(rec[CE.R_NLEVELS])
    assert n == len(maps)
    for k, mp in enumerate(maps):
        alpha, h, w, o = data[hdr + 4 * k:hdr + 4 * k + 4]
        assert (int(h), int(w)) == mp.shape[:2]
        np.testing.assert_array_equal(data[int(o):int(o) + mp.size], mp.ravel())


def test_dfg_lookups_are_their_numpy_twins():
    env = ENVS["sky"]()
    tag, rec, data = _packed(env)
    rng = np.random.default_rng(3)
    mu = np.concatenate([rng.uniform(0, 1, 200), [0.0, 1e-6, 1e-4, 1e-2, 0.5, 1.0]])
    alpha = np.concatenate([rng.uniform(0, 1, 200), [0.0, 1e-8, 1.0, 0.25, 1.2, 0.0]])
    for g in (0, 1, 4):
        A, B = MP.specular_tables(JB.GEOMETRY_TERMS[g])
        got = np.array([CP.specular_ab(rec, data, g, m, a) for m, a in zip(mu, alpha)])
        np.testing.assert_allclose(got[:, 0], dfg.lookup(A, mu, alpha), rtol=RTOL, atol=1e-15)
        np.testing.assert_allclose(got[:, 1], dfg.lookup(B, mu, alpha), rtol=RTOL, atol=1e-15)
    e5 = np.array([CP.diffuse_loss(rec, data, m) for m in mu])
    np.testing.assert_allclose(e5, dfg.lookup_1d(MP.diffuse_loss_table(), mu), rtol=RTOL, atol=1e-15)


def test_dominant_direction_and_lobe_width_are_their_numpy_twins():
    rng = np.random.default_rng(4)
    n = _unit(rng.normal(size=(300, 3)))
    wo = _unit(rng.normal(size=(300, 3)))
    wo = np.where((np.einsum("ij,ij->i", wo, n) < 0)[:, None], -wo, wo)
    t = _unit(np.cross(n[:20], rng.normal(size=(20, 3))))
    wo[:20] = _unit(t + 1e-5 * n[:20])                            # grazing views
    alpha = rng.uniform(0, 1, 300)
    alpha[:5] = [0.0, 1.0, 1e-6, 0.5, 1.3]
    got = np.array([JP.dominant_direction(tuple(w), tuple(m), a) for w, m, a in zip(wo, n, alpha)])
    np.testing.assert_allclose(got, dfg.dominant_direction(wo, n, alpha), rtol=RTOL, atol=1e-14)
    omega = np.concatenate([rng.uniform(0, 10, 50), [0.0, 1e-300, 4 * np.pi]])
    from pyrt.shaders.envmap import ggx_lobe_alpha_for_solid_angle
    np.testing.assert_allclose([JP.ggx_lobe_alpha_for_solid_angle(w) for w in omega],
                               ggx_lobe_alpha_for_solid_angle(omega), rtol=RTOL)


def _ctx(wo):
    n = np.zeros_like(wo)
    n[:, 2] = 1.0
    return types.SimpleNamespace(n_hits=wo.shape[0], wo=wo, ns=n)


def _views(rng, n):
    wo = _unit(rng.normal(size=(n, 3)))
    wo[:, 2] = np.abs(wo[:, 2])
    wo[:4] = _unit(np.array([[1.0, 0.0, 1e-2], [0.0, 1.0, 1e-4], [1.0, 1.0, 1e-7], [0.0, 0.0, 1.0]]))
    return wo


@pytest.mark.parametrize("kind", ["metallic_roughness", "learnopengl", "gltf_pbr"])
def test_material_lobes_are_their_numpy_twins(kind):
    """The split-sum lobes (diffuse, glossy weight) of random constant materials at random and grazing views, with the
    NumPy path's table values: :meth:`preview_lobes` of the material."""
    rng = np.random.default_rng(5)
    for trial in range(6):
        base, m, r = rng.uniform(0, 1, 3), float(rng.uniform()), float(rng.uniform(0.02, 1.0))
        if trial == 0:
            m, r = 1.0, 0.0
        if kind == "metallic_roughness":
            mat = pyrt.MetallicRoughness(base_color=base, metallic=m, roughness=r)
        elif kind == "learnopengl":
            mat = pyrt.LearnOpenGLPBR(albedo=base, metallic=m, roughness=r)
        else:
            tr = float(rng.uniform()) if trial % 2 else 0.0     # smooth transmission: its share of the lobes
            r = 0.0 if tr else r
            mat = pyrt.GltfPBR(base_color=base, metallic=m, roughness=r, specular=float(rng.uniform()),
                               specular_color=rng.uniform(0, 1, 3), ior=float(rng.uniform(1.2, 2.0)), transmission=tr)
        wo = _views(rng, 64)
        ctx = _ctx(wo)
        lobes = mat.preview_lobes(ctx)
        alpha = r * r
        mu = MP.view_cosine(ctx)
        A, B = MP.specular_tables(mat.geometry)
        e5 = dfg.lookup_1d(MP.diffuse_loss_table(), mu)
        a, b = dfg.lookup(A, mu, np.full(mu.size, alpha)), dfg.lookup(B, mu, np.full(mu.size, alpha))
        for k in range(wo.shape[0]):
            if kind == "gltf_pbr":
                f0 = mat._f0_dielectric(None)
                got = JP.gltf_pbr_lobes(*base, m, mat.specular, *f0, tr, 1.0 - tr, e5[k], a[k], b[k])
            else:
                got = JP.metallic_roughness_lobes(*base, m, e5[k], a[k], b[k])
            np.testing.assert_allclose(got[0], lobes.diffuse[k], rtol=RTOL, atol=1e-15)
            np.testing.assert_allclose(got[1], lobes.glossy[0].weight[k], rtol=RTOL, atol=1e-15)
        assert JP.view_cosine(tuple(wo[1]), (0.0, 0.0, 1.0)) == mu[1]
        np.testing.assert_allclose(lobes.glossy[0].alpha, alpha)


# ----------------------------------------------------------------------------------------- renders

def _scene(env, *, method="split_sum", samples=STUDIO_PREVIEW_SAMPLES, width=48, height=36):
    cam = pyrt.Camera(position=(0, 1.2, 4.2), target=(0, 0.45, 0), fov=42, width=width, height=height, jitter=False)
    s = pyrt.Scene(cam)
    s.add_plane((0, 0, 0), 8.0, pyrt.Lambert(albedo=(0.5, 0.45, 0.4)))
    s.add_sphere((-1.1, 0.45, 0), 0.45, pyrt.MetallicRoughness(base_color=(0.9, 0.6, 0.3), metallic=1.0,
                                                                 roughness=0.35), subdivisions=3)
    s.add_sphere((0.0, 0.45, -0.3), 0.45, pyrt.GltfPBR(base_color=(0.2, 0.4, 0.8), metallic=0.0, roughness=0.5,
                                                         specular=0.8, ior=1.6), subdivisions=3)
    s.add_sphere((1.1, 0.4, 0), 0.4, pyrt.BlinnPhong(kd=0.5, ks=0.3, exponent=40), subdivisions=3)
    s.add_sphere((0.6, 0.25, 1.0), 0.25, pyrt.CookTorrance(metal="gold", roughness=0.3), subdivisions=3)
    s.add_sphere((-0.5, 0.25, 1.1), 0.25, pyrt.Mirror(0.9), subdivisions=3)
    s.add_sphere((0.05, 0.22, 1.4), 0.22, pyrt.Glass(ior=1.5), subdivisions=3)
    pyrt.set_environment(s, env, lighting="preview", preview_samples=samples, preview_method=method)
    return s


def _assert_equal_images(scene, shadow_rays=0):
    """Pixel centres and the full glass tree (``split_depth=None``): the same rays on both paths."""
    c = pyrt.render_full(scene, backend="compiled", progress=False, split_depth=None)
    n = pyrt.render_full(scene, backend="numpy", progress=False, split_depth=None)
    assert c.stats.backend == "compiled" and c.stats.fallback_reasons == []
    assert n.stats.backend == "numpy"
    assert (c.stats.shadow_rays == 0) if shadow_rays == 0 else (c.stats.shadow_rays > 0)
    ci, ni = c.image.astype(np.float64), n.image.astype(np.float64)
    close = np.all(np.abs(ci - ni) <= 1e-5 * np.abs(ni) + 1e-6, axis=-1)
    # pixels whose ray meets an edge exactly may differ (Embree's packets break such ties differently)
    assert close.mean() > 0.998, (close.size - close.sum(), np.argwhere(~close)[:5])
    return ci, ni


def test_studio_environment_renders_as_on_the_numpy_path():
    """The previewer's set-up: the studio with ``lighting="preview"`` and its 4 samples."""
    _assert_equal_images(_scene(StudioEnvironment(width=128, height=64, intensity=0.9)))


@pytest.mark.parametrize("method", ["split_sum", "samples"])
def test_rotated_sky_renders_as_on_the_numpy_path(method):
    env = _rotated(LatLongEnvironment(procedural_sky(128, 64, sun_angle=6.0), intensity=0.4))
    _assert_equal_images(_scene(env, method=method, samples=8))


def test_textured_gltf_materials_under_the_studio(rng):
    """tests/test_compiled_gltf.py's scene (a textured GltfMaterial with a packed occlusion-roughness-metallic map and
    occlusion, a textured GltfPBR, a normal-mapped GltfPBRMaterial, a mirror, a point and a directional light, ambient
    light) lit by the studio too: the split sum with per-hit parameters and the occlusion; and a black glTF sphere
    with an occlusion map (its specular lobe alone carries the occlusion: one of the hit's inputs)."""
    s = gltf_scene(rng)
    occ = ImageTexture(rng.uniform(0.1, 1.0, (6, 6, 3)).astype(np.float32), srgb=False, filter="bilinear")
    s.add_sphere((0.0, 0.3, 1.2), 0.3, GltfMaterial(base_color=0.0, metallic=0.0, roughness=0.4,
                                                    occlusion=ChannelTexture(occ, 0), occlusion_strength=0.9),
                 subdivisions=3)
    pyrt.set_environment(s, StudioEnvironment(width=64, height=32, intensity=0.6), lighting="preview",
                         preview_samples=STUDIO_PREVIEW_SAMPLES)
    _assert_equal_images(s, shadow_rays=1)


def test_constant_environment_preview():
    ci, ni = _assert_equal_images(_scene(pyrt.ConstantEnvironment((0.6, 0.7, 0.9)), width=24, height=18))
    assert ci.max() > 0.1


def test_adaptive_passes_under_the_studio_match_the_numpy_path():
    """Jittered samples in adaptive passes: the preview draws no random numbers, so both paths place the same camera
    samples (tests/test_compiled_adaptive.py), estimate the same errors and give the same image."""
    scene = _scene(StudioEnvironment(width=64, height=32, intensity=0.9), width=32, height=24)
    kw = dict(progress=False, seed=3, target_error=5e-3, split_depth=None, max_spp=32)
    c = pyrt.render_full(scene, backend="compiled", **kw)
    n = pyrt.render_full(scene, backend="numpy", **kw)
    assert c.stats.backend == "compiled" and c.stats.fallback_reasons == [] and n.stats.backend == "numpy"
    assert c.passes == n.passes > 1
    np.testing.assert_array_equal(c.film.weight, n.film.weight)
    np.testing.assert_allclose(c.image, n.image, rtol=1e-5, atol=1e-7)


@pytest.mark.skipif(not os.path.exists(DUCK), reason="the shared Khronos models are not here")
def test_the_previewers_duck_renders_as_on_the_numpy_path():
    """The previewer's own scene (:class:`pyrt.apps.preview.render.PreviewScene`: the studio with the preview light,
    the key / fill / rim rig, the ground, the backdrop) of the Khronos Duck, rendered with the Whitted integrator at
    pixel centres: the compiled image is the NumPy path's."""
    ps = PreviewScene(load_asset(DUCK))
    ps._set_view(30.0)
    cam = ps.scene.camera
    ps.scene.camera = pyrt.Camera(position=cam.position, target=cam.target, up=cam.up, fov=cam.fov, width=64,
                                  height=48, jitter=False)
    assert ps.studio_environment and unsupported(None, scene=ps.scene) == []
    _assert_equal_images(ps.scene, shadow_rays=1)


def test_alpha_masks_under_the_preview():
    """The preview traces no shadow rays, so masked materials under it take the compiled path (camera and specular
    rays pass the cut-outs as without an environment light): tests/test_compiled_coverage.py's leaves, the same
    image."""
    s = coverage_leaves(width=40, height=30)
    pyrt.set_environment(s, StudioEnvironment(width=64, height=32, intensity=0.7), lighting="preview")
    assert unsupported(None, scene=s) == []
    _assert_equal_images(s, shadow_rays=1)


# ----------------------------------------------------------------------------------------- coverage

def _previewer_scene():
    cam = pyrt.Camera(position=(0, 0, 3), target=(0, 0, 0), fov=30, width=8, height=8)
    s = pyrt.Scene(cam)
    s.add_sphere((0, 0, 0), 1.0, pyrt.MetallicRoughness(base_color=0.8, metallic=0.5, roughness=0.4))
    env = StudioEnvironment(intensity=0.5)
    pyrt.set_environment(s, env, lighting="preview", preview_samples=STUDIO_PREVIEW_SAMPLES)
    return s


def test_the_previewers_studio_is_covered():
    s = _previewer_scene()
    assert unsupported(None, scene=s) == []
    # the previewer's integrator too (the glossy one with the light choice: tests/test_compiled_glossy.py)
    assert unsupported(None, scene=s, integrator="glossy", light_select_depth=1) == []


def test_a_subclass_that_does_not_declare_its_kind_falls_back():
    class Odd(LatLongEnvironment):
        def _radiance_local(self, d):
            return 2.0 * super()._radiance_local(d)

    class Declared(Odd):
        compiled_kind = "latlong"

    assert not CE.packable(Odd(procedural_sky(16, 8)))
    assert CE.packable(Declared(procedural_sky(16, 8)))
    assert CE.packable(StudioEnvironment(width=32, height=16))
    s = _previewer_scene()
    pyrt.set_environment(s, Odd(procedural_sky(16, 8)), lighting="preview")
    assert any("environment Odd" in r for r in unsupported(None, scene=s))
