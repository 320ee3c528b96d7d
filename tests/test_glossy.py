"""The glossy integrator (pyrt.integrators.glossy): BSDF-sampled rays at glossy hits, MIS with light sampling.

Ground truths: the directional albedo of the lobe by quadrature (furnace), the lobe integrated over an
emitter's solid angle by quadrature (rough mirror), the Mirror image (roughness -> 0), and the power heuristic's
partition of unity. Monte Carlo tolerances are 4 standard errors of the pixel mean plus the quadrature's error.
"""
from __future__ import annotations

from copy import copy
import pathlib

import numpy as np
import pytest
import trimesh

import pyrt
from pyrt.apps import cli
from pyrt.core.errors import RenderError
from pyrt.integrators.glossy import GlossyIntegrator, mis_weights
from pyrt.integrators.prepared import PreparedScene
from pyrt.lights import ConstantEnvironment, set_environment


class Ctx:
    """A surface batch in its own local frame (shading normal +z), enough for the kernels."""

    def __init__(self, n):
        self.n_hits = n
        self.dpdu = np.tile([1.0, 0.0, 0.0], (n, 1))
        self.ns = self.ng = np.tile([0.0, 0.0, 1.0], (n, 1))
        self.front = np.ones(n, dtype=bool)
        self.uv = np.full((n, 2), 0.5)
        self.p = np.zeros((n, 3))


def _frame(n):
    """Orthonormal (t, b) around unit ``n`` (3,)."""
    a = np.array([1.0, 0.0, 0.0]) if abs(n[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    t = np.cross(n, a)
    t /= np.linalg.norm(t)
    return t, np.cross(n, t)


def directional_albedo(mat, wo, n_theta=1200, n_phi=64):
    """``int f_cos(wo, wi) dwi`` (3,) by a midpoint rule on the sphere in a frame around the mirror direction.

    ``theta = pi s^2`` (s uniform) packs the nodes into the lobe; the rule's error is below 1e-4 for
    alpha >= 0.05 (doubling both resolutions changes the value by less than that).
    """
    r = np.array([-wo[0], -wo[1], wo[2]])
    t, b = _frame(r)
    s = (np.arange(n_theta) + 0.5) / n_theta
    theta, dtheta = np.pi * s * s, 2 * np.pi * s / n_theta
    phi = (np.arange(n_phi) + 0.5) / n_phi * 2 * np.pi
    TH, PH = np.meshgrid(theta, phi, indexing="ij")
    wi = (np.sin(TH)[..., None] * (np.cos(PH)[..., None] * t + np.sin(PH)[..., None] * b)
          + np.cos(TH)[..., None] * r).reshape(-1, 3)
    dw = (np.sin(TH) * dtheta[:, None] * (2 * np.pi / n_phi)).reshape(-1)
    f = mat.f_cos(np.tile(wo, (wi.shape[0], 1)), wi, Ctx(wi.shape[0]))
    return np.sum(f * dw[:, None], axis=0)


def _render(sc, spp, integrator, **kw):
    """Both integrators on the NumPy path (the glossy one has only that; Whitted's compiled path draws other random
    numbers for area lights, so the two could not be compared sample by sample)."""
    return pyrt.render_full(sc, spp=spp, integrator=integrator, seed=1, progress=False, backend="numpy", **kw)


# -- (a) furnace ---------------------------------------------------------------------------------
GOLD_KS = (1.0, 0.78, 0.34)


def _furnace_scene(lighting, L):
    cam = pyrt.Camera(position=(0, 0, 4), target=(0, 0, 0), fov=6, width=12, height=12, jitter=False)
    sc = pyrt.Scene(cam)
    mat = pyrt.CookTorrance(ks=GOLD_KS, roughness=0.3, fresnel="none")
    sc.add_mesh(trimesh.creation.icosphere(subdivisions=5), mat)
    set_environment(sc, ConstantEnvironment(L), lighting=lighting, n_samples=2)
    return sc, mat


def _furnace_expected(sc, mat, res, L):
    """Per pixel ``L * albedo(wo)``: wo from the camera ray and the pixel's shading normal (AOV)."""
    cam = copy(sc.camera)
    cam.spp = 1
    rays = cam.generate_rays(0, cam.width * cam.height, np.random.default_rng(0))
    n = res.aovs["normal"].reshape(-1, 3).astype(np.float64)
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    cos_o = np.clip(-np.einsum("ij,ij->i", rays.directions, n), 0.0, 1.0)
    grid = np.linspace(cos_o.min(), 1.0, 8)
    alb = np.array([directional_albedo(mat, np.array([np.sqrt(1 - c * c), 0.0, c])) for c in grid])
    return L * np.stack([np.interp(cos_o, grid, alb[:, c]) for c in range(3)], axis=1)


@pytest.mark.parametrize("lighting", [None, "mis", pytest.param("map", marks=pytest.mark.slow),
                                      pytest.param("uniform", marks=pytest.mark.slow),
                                      pytest.param("bsdf", marks=pytest.mark.slow)])
def test_glossy_furnace_returns_directional_albedo_times_L(lighting):
    """A glossy sphere alone under a uniform environment of radiance L: every pixel is L * albedo(wo),
    whether the environment is only seen (no light) or also a light with any strategy (MIS: nothing twice)."""
    L = 1.5
    sc, mat = _furnace_scene(lighting, L)
    res = _render(sc, 16, "glossy", aovs=True, glossy_samples=4)
    exp = _furnace_expected(sc, mat, res, L)
    got = res.image.reshape(-1, 3).astype(np.float64)
    ratio = got / exp
    se = ratio.std(axis=0, ddof=1) / np.sqrt(ratio.shape[0])
    print(f"furnace {lighting}: expected {exp.mean(axis=0)}, got/expected {ratio.mean(axis=0)} +- {se} (1 SE)")
    np.testing.assert_array_less(np.abs(ratio.mean(axis=0) - 1.0), 4 * se + 2e-3)


def test_whitted_furnace_sees_only_what_the_environment_light_gives():
    """Whitted traces no glossy ray: with the environment only as a background the glossy sphere is black;
    with an EnvironmentLight (strategy mis) its estimator already integrates the lobe (same answer as glossy)."""
    L = 1.5
    sc, _ = _furnace_scene(None, L)
    assert np.all(_render(sc, 4, "whitted").image == 0.0)
    sc, mat = _furnace_scene("mis", L)
    res = _render(sc, 16, "whitted", aovs=True)
    ratio = res.image.reshape(-1, 3) / _furnace_expected(sc, mat, res, L)
    se = ratio.std(axis=0, ddof=1) / np.sqrt(ratio.shape[0])
    np.testing.assert_array_less(np.abs(ratio.mean(axis=0) - 1.0), 4 * se + 2e-3)


# -- (b) rough mirror in front of a large emitter ------------------------------------------------
EMIT_C = np.array([0.0, 3.0, 3.0])
EMIT_N = np.array([0.0, -1.0, -1.0]) / np.sqrt(2)


def _mirror_scene(mat, *, light_samples=4, width=4):
    """A 4 x 4 quad in z = 0 (normal +z) seen at 45 degrees; a 3 x 3 RectLight (visible) in its reflection."""
    cam = pyrt.Camera(position=(0, -3, 3), target=(0, 0, 0), fov=3, width=width, height=width, jitter=False)
    sc = pyrt.Scene(cam)
    v = np.array([[-2, -2, 0], [2, -2, 0], [2, 2, 0], [-2, 2, 0]], dtype=float)
    sc.add_mesh((v, [[0, 1, 2], [0, 2, 3]]), mat, smooth=False)
    pyrt.RectLight(EMIT_C, normal=EMIT_N, size=3.0, tangent=(1, 0, 0), radiance=2.0, n_samples=light_samples,
                   name="panel").add_to(sc)
    return sc


def _emitter_quadrature(mat, p, wo, L, n=240):
    """``L int_A f_cos(wo, wi) cos theta_l / r^2 dA`` over the 3 x 3 rectangle (midpoint rule, n x n)."""
    t = np.array([1.0, 0.0, 0.0])
    b = np.cross(EMIT_N, t)
    s = ((np.arange(n) + 0.5) / n - 0.5) * 3.0
    X = (EMIT_C + s[:, None, None] * t + s[None, :, None] * b).reshape(-1, 3)
    d = X - p
    r2 = np.einsum("ij,ij->i", d, d)
    wi = d / np.sqrt(r2)[:, None]
    cos_l = np.clip(-wi @ EMIT_N, 0, None)
    f = mat.f_cos(np.tile(wo, (wi.shape[0], 1)), wi, Ctx(wi.shape[0]))
    return L * np.sum(f * (cos_l / r2 * (3.0 / n) ** 2)[:, None], axis=0)


@pytest.mark.parametrize("light_samples", [pytest.param(1, marks=pytest.mark.slow), 4])
def test_rough_mirror_matches_quadrature_over_the_emitter(light_samples):
    """Rough mirror (GGX, ks = 1, no Fresnel, roughness 0.3) facing an emissive panel: each pixel is the lobe
    integrated over the panel's solid angle; light samples and glossy rays combined by MIS."""
    mat = pyrt.CookTorrance(ks=1.0, roughness=0.3, fresnel="none")
    sc = _mirror_scene(mat, light_samples=light_samples)
    res = _render(sc, 32, "glossy", glossy_samples=4)
    cam = copy(sc.camera)
    cam.spp = 1
    rays = cam.generate_rays(0, cam.width * cam.height, np.random.default_rng(0))
    tt = -rays.origins[:, 2] / rays.directions[:, 2]
    P = rays.origins + tt[:, None] * rays.directions
    exp = np.array([_emitter_quadrature(mat, P[i], -rays.directions[i], 2.0) for i in range(P.shape[0])])
    got = res.image.reshape(-1, 3).astype(np.float64)
    ratio = got[:, 0] / exp[:, 0]
    se = ratio.std(ddof=1) / np.sqrt(ratio.size)
    print(f"rough mirror: got/expected = {ratio.mean():.5f} +- {se:.5f} (1 SE)")
    assert abs(ratio.mean() - 1.0) < 4 * se + 2e-3, (ratio.mean(), se)
    # Whitted: only the light samples (no MIS weights), the same expectation with more noise
    ratio_w = _render(sc, 32, "whitted").image.reshape(-1, 3)[:, 0] / exp[:, 0]
    assert abs(ratio_w.mean() - 1.0) < 4 * ratio_w.std(ddof=1) / np.sqrt(ratio_w.size) + 2e-3


# -- (c) roughness -> 0 converges to the mirror --------------------------------------------------
def _checker_scene(mat):
    """The mirror quad reflecting a lit, checkered wall (a Lambert plane textured by a checker)."""
    cam = pyrt.Camera(position=(0, -3, 3), target=(0, 0, 0), fov=30, width=24, height=24, jitter=False)
    sc = pyrt.Scene(cam)
    v = np.array([[-2, -2, 0], [2, -2, 0], [2, 2, 0], [-2, 2, 0]], dtype=float)
    sc.add_mesh((v, [[0, 1, 2], [0, 2, 3]]), mat, smooth=False)
    wall = trimesh.Trimesh(vertices=[[-6, 3, -1], [6, 3, -1], [6, 3, 8], [-6, 3, 8]], faces=[[0, 2, 1], [0, 3, 2]],
                           process=False)
    wall.visual = trimesh.visual.TextureVisuals(uv=[[0, 0], [1, 0], [1, 1], [0, 1]])
    sc.add_mesh(wall, pyrt.Lambert(pyrt.CheckerTexture(0.1, 0.9, scale=6)), smooth=False)
    sc.add_light(pyrt.PointLight((0, -1, 4), intensity=30.0))
    return sc


def test_roughness_to_zero_converges_to_the_mirror_image():
    ref = _render(_checker_scene(pyrt.Mirror(1.0)), 8, "whitted").image
    errs = []
    for r in (0.3, 0.15, 0.07, 0.03):
        img = _render(_checker_scene(pyrt.CookTorrance(ks=1.0, roughness=r, fresnel="none")), 8, "glossy").image
        errs.append(float(np.sqrt(np.mean((img - ref) ** 2))))
    print("RMS error vs Mirror by roughness 0.3, 0.15, 0.07, 0.03:", errs)
    assert all(b < a for a, b in zip(errs, errs[1:])), errs
    assert errs[-1] < 0.25 * errs[0], errs


def test_small_roughness_is_close_to_the_mirror_image():
    ref = _render(_checker_scene(pyrt.Mirror(1.0)), 4, "whitted").image
    img = _render(_checker_scene(pyrt.CookTorrance(ks=1.0, roughness=0.03, fresnel="none")), 4, "glossy").image
    far = _render(_checker_scene(pyrt.CookTorrance(ks=1.0, roughness=0.3, fresnel="none")), 4, "glossy").image
    assert np.sqrt(np.mean((img - ref) ** 2)) < 0.3 * np.sqrt(np.mean((far - ref) ** 2))


# -- (d) MIS weights ------------------------------------------------------------------------------
def test_mis_weights_sum_to_one(rng):
    p_l, p_b = rng.exponential(size=1000), rng.exponential(size=1000)
    w_l, w_b = mis_weights(4, p_l, 3, p_b)
    np.testing.assert_allclose(w_l + w_b, 1.0, rtol=1e-12)
    assert np.all(mis_weights(1, np.zeros(3), 1, np.zeros(3))[0] == 0)


def test_integrator_weights_of_one_direction_sum_to_one(rng):
    """For directions toward the panel: the light-sampling weight the estimator uses at a glossy hit plus the
    emission weight a glossy ray gets on the emitter (the integrator's own function) is 1; an emitter of no
    light and the environment without a light get weight 1."""
    mat = pyrt.CookTorrance(ks=1.0, roughness=0.3, fresnel="none")
    sc = _mirror_scene(mat, light_samples=4)
    light = sc.lights[0]
    with PreparedScene(sc) as ps:
        integ = GlossyIntegrator(ps, glossy_samples=4)
        k = next(iter(integ.emitter_lights))
        assert integ.emitter_lights[k] == [light]
        n = 500
        X = light.sample_li(np.zeros((n, 3)), rng.random((n, 2))).wi
        o = np.zeros((n, 3))
        p_l = light.pdf_li(o, X)
        p_b = mat.pdf(np.tile([0, -1, 1] / np.sqrt(2), (n, 1)), X, Ctx(n))
        assert np.all(p_l > 0)
        w_l = mis_weights(light.n_samples, p_l, 4, p_b)[0]
        w_b = integ._emission_weight(k, o, X, 4 * p_b)
        np.testing.assert_allclose(w_l + w_b, 1.0, rtol=1e-12)
        np.testing.assert_array_equal(integ._emission_weight(k, o, X, np.zeros(n)), 1.0)   # delta-lobe rays
        np.testing.assert_array_equal(integ._escape_weight(X, 4 * p_b), 1.0)               # no environment light


def test_environment_weights_sum_to_one(rng):
    sc, mat = _furnace_scene("mis", 1.0)
    with PreparedScene(sc) as ps:
        integ = GlossyIntegrator(ps)
        env = integ.env_light
        d = rng.normal(size=(300, 3))
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        p_b = rng.exponential(size=300)
        w_l = mis_weights(env.n_samples, env.pdf_li(None, d), 1, p_b)[0]
        np.testing.assert_allclose(w_l + integ._escape_weight(d, p_b), 1.0, rtol=1e-12)


# -- options, declarations ----------------------------------------------------------------------
def test_glossy_alpha_declared_by_the_glossy_materials():
    c = Ctx(3)
    np.testing.assert_allclose(pyrt.CookTorrance(roughness=0.2).glossy_alpha(c), 0.04)
    np.testing.assert_allclose(pyrt.MetallicRoughness(roughness=0.5).glossy_alpha(c), 0.25)
    np.testing.assert_allclose(pyrt.Ward(alpha_x=0.1, alpha_y=0.4).glossy_alpha(c), 0.2)
    np.testing.assert_allclose(pyrt.BlinnPhong(exponent=98.0).glossy_alpha(c), np.sqrt(2 / 100))
    np.testing.assert_allclose(pyrt.Phong(exponent=24.5).glossy_alpha(c), np.sqrt(2 / 100))
    assert pyrt.Lambert(0.5).glossy_alpha(c) is None
    assert pyrt.Mirror(1.0).glossy_alpha(c) is None


def test_rough_lobe_above_threshold_is_direct_light_only():
    """Above ``glossy_threshold`` the lobe counts as diffuse: the glossy integrator gives Whitted's pixels."""
    mat = pyrt.CookTorrance(ks=1.0, roughness=0.3, fresnel="none")     # alpha 0.09
    sc = _mirror_scene(mat)
    a = _render(sc, 2, "whitted").image
    b = _render(sc, 2, "glossy", glossy_threshold=0.05).image
    np.testing.assert_array_equal(a, b)
    c = _render(sc, 2, "glossy", glossy_depth=0).image
    np.testing.assert_array_equal(a, c)


def test_integrator_option_is_checked():
    sc = _mirror_scene(pyrt.Lambert(0.5))
    with pytest.raises(RenderError, match="integrator"):
        pyrt.render(sc, integrator="path")
    with pytest.raises(RenderError, match="glossy_samples"):
        pyrt.render(sc, integrator="glossy", glossy_samples=0)


def test_glossy_render_is_deterministic():
    sc = _mirror_scene(pyrt.CookTorrance(ks=1.0, roughness=0.3, fresnel="none"))
    a = _render(sc, 2, "glossy").image
    b = pyrt.render_full(sc, spp=2, integrator="glossy", seed=1, progress=False, threads=1, backend="numpy").image
    np.testing.assert_array_equal(a, b)


# -- scene files and the command line ------------------------------------------------------------
ROOT = pathlib.Path(__file__).resolve().parents[1]
_SPEC = {"camera": {"position": [0, 0, 4], "width": 8, "height": 8},
         "materials": {"gold": {"type": "cook_torrance", "ks": [1.0, 0.78, 0.34], "roughness": 0.2}},
         "meshes": [{"primitive": "sphere", "material": "gold"}],
         "environment": {"type": "constant", "color": 1.0}}


def test_scene_file_render_table_names_the_integrator():
    spec = dict(_SPEC, render={"integrator": {"type": "glossy", "samples": 2, "depth": 1, "threshold": 0.3}})
    scene, options = pyrt.load_dict(spec)
    assert options == {"integrator": {"type": "glossy", "samples": 2, "depth": 1, "threshold": 0.3}}
    assert pyrt.render(scene, spp=1, **options).shape == (8, 8, 3)
    with pytest.raises(pyrt.Error, match="integrator"):
        pyrt.load_dict(dict(_SPEC, render={"integrator": "path"}))


def test_cli_integrator_option(tmp_path, capsys):
    scene = str(ROOT / "assets/default_scene.toml")
    out = tmp_path / "x.png"
    assert cli.main(["render", scene, "-o", str(out), "--width", "16", "--height", "12", "--spp", "1",
                     "--integrator", "glossy"]) == 0
    assert out.stat().st_size > 0
    with pytest.raises(SystemExit):
        cli.main(["render", scene, "-o", str(out), "--integrator", "path"])


def test_glossy_integrator_traces_rough_glass_transmission_and_converges_to_glass():
    """Rough glass in front of an emissive checker (no lights: only what refraction shows): with the glossy
    integrator its transmission rays see the backdrop, and the mean over the sphere approaches the smooth
    Glass image as roughness -> 0 (the per-pixel noise of the stochastic reflect/refract choice stays); the
    Whitted integrator gives rough glass no refraction rays at all."""
    def scene(mat):
        cam = pyrt.Camera(position=(0, 0.5, 3.0), target=(0, 0.5, 0), fov=30, width=48, height=36, spp=16)
        s = pyrt.Scene(cam, background=(0.2, 0.2, 0.25))
        s.add_plane((0, 0, -1.5), 6, pyrt.Lambert(0.0, emission=pyrt.CheckerTexture(0.1, 0.9, scale=12)),
                    normal=(0, 0, 1))
        s.add_sphere((0, 0.5, 0), 0.5, mat)
        return s
    sph = np.s_[8:28, 14:34]
    ref = pyrt.render(scene(pyrt.Glass(ior=1.5)), seed=0)[sph].mean()
    errs = [abs(pyrt.render(scene(pyrt.RoughDielectric(ior=1.5, roughness=r)), integrator="glossy", seed=0,
                            glossy_depth=3)[sph].mean() - ref) for r in (0.3, 0.15, 0.07, 0.03)]
    assert all(a >= b - 5e-4 for a, b in zip(errs, errs[1:])), errs
    assert errs[-1] < 0.01 * ref and errs[0] > 0.05 * ref, errs
    whitted = pyrt.render(scene(pyrt.RoughDielectric(ior=1.5, roughness=0.03)), seed=0)[sph].mean()
    assert whitted < 0.5 * ref
