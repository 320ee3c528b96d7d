"""Material classes of the library (pyrt/materials/): API, validation, scene files, sampling."""
import math
import textwrap

import numpy as np
import pytest

import pyrt
from pyrt import materials as M
from pyrt.shaders import brdfs
from pyrt.shaders import fresnel
from pyrt.shaders import metals
from pyrt.shaders.vec import normalize


class Ctx:
    """Minimal stand-in for SurfaceBatch: identity local frame (world = local), given dpdu."""

    def __init__(self, n, dpdu=None):
        self.n_hits = n
        self.dpdu = np.tile([1.0, 0.0, 0.0], (n, 1)) if dpdu is None else dpdu

    def to_local(self, w):
        return np.asarray(w, dtype=np.float64)


def _dirs(rng, n):
    c = rng.uniform(0.02, 1.0, n)
    phi = rng.uniform(0, 2 * np.pi, n)
    s = np.sqrt(1 - c * c)
    return np.stack([s * np.cos(phi), s * np.sin(phi), c], 1)


LIBRARY = {
    "phong": dict(kd=0.4, ks=0.5, exponent=30.0),
    "phong_classic": dict(kd=0.4, ks=2.0, exponent=30.0, ka=0.1),
    "blinn_phong_classic": dict(kd=0.4, ks=2.0, exponent=30.0),
    "ward": dict(kd=0.2, ks=0.7, alpha_x=0.1, alpha_y=0.3, variant="ward"),
    "cook_torrance": dict(metal="gold", roughness=0.4),
    "metallic_roughness": dict(base_color=[0.9, 0.5, 0.2], metallic=0.5, roughness=0.5),
}


@pytest.mark.parametrize("type_name", sorted(LIBRARY))
def test_every_model_is_registered_and_evaluates(type_name):
    cls = pyrt.MATERIALS[type_name]
    mat = cls(**LIBRARY[type_name])
    rng = np.random.default_rng(0)
    wo, wi = _dirs(rng, 64), _dirs(rng, 64)
    f = mat.f_cos(wo, wi, Ctx(64))
    assert f.shape == (64, 3) and np.all(np.isfinite(f)) and np.all(f >= 0) and f.max() > 0
    assert mat.albedo(Ctx(64)).shape == (64, 3)


@pytest.mark.parametrize("type_name", sorted(pyrt.MATERIALS))
def test_unknown_parameters_are_rejected(type_name):
    with pytest.raises(TypeError):
        pyrt.MATERIALS[type_name](roughnes=0.3)  # typo


@pytest.mark.parametrize("type_name", sorted(LIBRARY))
def test_new_models_take_keyword_only_parameters(type_name):
    with pytest.raises(TypeError):
        pyrt.MATERIALS[type_name](0.5)


@pytest.mark.parametrize("cls,kwargs,match", [
    (M.Phong, dict(kd=0.6, ks=0.5), "kd \\+ ks"),
    (M.Phong, dict(exponent=-1.0), "exponent"),
    (M.PhongClassic, dict(kd=1.5), "kd"),
    (M.Ward, dict(alpha=0.0), "alpha"),
    (M.Ward, dict(alpha_x=0.1), "alpha_x and alpha_y"),
    (M.Ward, dict(alpha=0.1, alpha_x=0.2, alpha_y=0.2), "not both"),
    (M.Ward, dict(variant="new"), "variant"),
    (M.Ward, dict(tangent=(0, 0, 0)), "tangent"),
    (M.CookTorrance, dict(roughness=0.3, alpha=0.1), "not both"),
    (M.CookTorrance, dict(roughness=1.5), "roughness"),
    (M.CookTorrance, dict(distribution="phong"), "distribution"),
    (M.CookTorrance, dict(geometry="smith"), "geometry"),
    (M.CookTorrance, dict(metal="unobtainium"), "gold"),
    (M.CookTorrance, dict(metal="gold", f0=0.5), "does not use"),
    (M.CookTorrance, dict(fresnel="conductor", eta=[0.2, 0.3, 0.4]), "both eta and k"),
    (M.CookTorrance, dict(ior=0.0), "ior"),
    (M.CookTorrance, dict(kd=0.5, ks=0.6), "kd \\+ ks"),
    (M.MetallicRoughness, dict(metallic=1.2), "metallic"),
    (M.MetallicRoughness, dict(base_color=[1, 2, 0]), "base_color"),
    (M.MetallicRoughness, dict(geometry="vgroove"), "geometry"),
])
def test_invalid_parameters_name_the_parameter(cls, kwargs, match):
    with pytest.raises(M.MaterialError, match=match):
        cls(**kwargs)


def test_cook_torrance_fresnel_inference():
    assert M.CookTorrance(metal="copper").fresnel == "conductor"
    assert M.CookTorrance(ior=1.5).fresnel == "dielectric"
    assert M.CookTorrance().fresnel == "schlick"
    assert M.CookTorrance(distribution="blinn").geometry == "vgroove"
    assert M.CookTorrance(distribution="beckmann").geometry == "smith_correlated"


def test_materials_match_their_kernels():
    rng = np.random.default_rng(1)
    wo, wi = _dirs(rng, 100), _dirs(rng, 100)
    ctx = Ctx(100)
    eta, k = metals.METALS["gold"]
    ct = M.CookTorrance(metal="gold", roughness=0.4, distribution="beckmann", geometry="smith_separable")
    np.testing.assert_allclose(ct.f_cos(wo, wi, ctx), brdfs.cook_torrance_f_cos(
        wo, wi, 0.0, 1.0, 0.16, distribution="beckmann", geometry="smith_separable", fresnel="conductor",
        eta=eta, k=k))
    mr = M.MetallicRoughness(base_color=0.7, metallic=0.2, roughness=0.3, geometry="smith_correlated")
    np.testing.assert_allclose(mr.f_cos(wo, wi, ctx), brdfs.gltf_metallic_roughness_f_cos(
        wo, wi, np.full(3, 0.7), 0.2, 0.3, geometry="smith_correlated"))
    # alpha given directly is not squared
    a = M.CookTorrance(alpha=0.16, metal="gold", distribution="beckmann", geometry="smith_separable")
    np.testing.assert_allclose(a.f_cos(wo, wi, ctx), ct.f_cos(wo, wi, ctx))


def test_ambient_coefficients():
    ctx = Ctx(2)
    np.testing.assert_allclose(M.PhongClassic(kd=0.5, ka=0.1).albedo(ctx), 0.1)
    np.testing.assert_allclose(M.BlinnPhongClassic(kd=0.5).albedo(ctx), 0.5)  # ka defaults to kd
    F0 = fresnel.fr_conductor(np.ones(1), *metals.METALS["silver"])[0]
    np.testing.assert_allclose(M.CookTorrance(metal="silver").albedo(ctx), np.tile(F0, (2, 1)))
    np.testing.assert_allclose(M.MetallicRoughness(base_color=[0.3, 0.2, 0.1]).albedo(ctx)[0], [0.3, 0.2, 0.1])


def test_ward_tangent_defaults_to_dpdu_and_accepts_a_direction():
    rng = np.random.default_rng(2)
    wo, wi = _dirs(rng, 200), _dirs(rng, 200)
    t = normalize(np.array([[1.0, 2.0, 0.3]]))
    ctx = Ctx(200, dpdu=np.repeat(t, 200, 0))
    w_uv = M.Ward(ks=1.0, alpha_x=0.05, alpha_y=0.4)
    w_dir = M.Ward(ks=1.0, alpha_x=0.05, alpha_y=0.4, tangent=t[0])
    np.testing.assert_allclose(w_uv.f_cos(wo, wi, ctx), w_dir.f_cos(wo, wi, Ctx(200)))
    assert np.max(np.abs(w_uv.f_cos(wo, wi, ctx) - w_uv.f_cos(wo, wi, Ctx(200)))) > 1e-3


SAMPLED = {
    "ggx": lambda: M.CookTorrance(metal="gold", roughness=0.5),
    "ggx_rough_with_diffuse": lambda: M.CookTorrance(kd=0.4, ks=0.6, roughness=0.9, f0=0.04),
    "beckmann": lambda: M.CookTorrance(kd=0.2, ks=0.8, distribution="beckmann", roughness=0.4, ior=1.5),
    "blinn": lambda: M.CookTorrance(distribution="blinn", roughness=0.6, metal="aluminium"),
    "metallic_roughness": lambda: M.MetallicRoughness(base_color=[0.8, 0.5, 0.3], metallic=0.3, roughness=0.45),
}


@pytest.mark.parametrize("name", sorted(SAMPLED))
@pytest.mark.parametrize("theta_o", [10.0, 60.0, 85.0])
def test_sampling_is_consistent_with_pdf_and_f(name, theta_o):
    """sample() returns weight = f_cos / pdf with pdf = pdf(); E[weight] equals the albedo by
    quadrature (within 5 standard errors); the pdf's integral over the upper hemisphere equals
    1 - (fraction of samples below the horizon)."""
    mat = SAMPLED[name]()
    n = 100_000
    t = math.radians(theta_o)
    wo = np.tile([math.sin(t), 0.0, math.cos(t)], (n, 1))
    ctx = Ctx(n)
    u = np.random.default_rng(99).random((n, 2))
    wi, weight, pdf = mat.sample(wo, u, ctx)
    up = wi[:, 2] > 0
    np.testing.assert_allclose(pdf[up], mat.pdf(wo[up], wi[up], Ctx(int(up.sum()))), rtol=1e-10)
    f = mat.f_cos(wo[up], wi[up], Ctx(int(up.sum())))
    np.testing.assert_allclose(weight[up] * pdf[up][:, None], f, rtol=1e-9, atol=1e-300)
    assert np.all(weight[~up] == 0) and np.all(np.isfinite(weight))
    # unbiasedness against a deterministic quadrature of f_cos over the hemisphere (theta, phi)
    gx, gw = np.polynomial.legendre.leggauss(200)
    s, ws = 0.5 * (gx + 1), 0.5 * gw
    th = 0.5 * np.pi * s ** 4
    dth = 2 * np.pi * s ** 3 * ws
    nphi = 192
    ph = (np.arange(nphi) + 0.5) / nphi * 2 * np.pi
    T, P = np.meshgrid(th, ph, indexing="ij")
    wq = np.stack([np.sin(T) * np.cos(P), np.sin(T) * np.sin(P), np.cos(T)], -1).reshape(-1, 3)
    dw = ((np.sin(th) * dth)[:, None] * np.full((1, nphi), 2 * np.pi / nphi)).reshape(-1)
    woq = np.tile(wo[:1], (wq.shape[0], 1))
    cq = Ctx(wq.shape[0])
    rho = np.sum(mat.f_cos(woq, wq, cq) * dw[:, None], axis=0)
    mean, se = weight.mean(0), weight.std(0) / math.sqrt(n)
    assert np.all(np.abs(mean - rho) <= 5 * se + 2e-3), (mean, rho, se)
    pdf_int = np.sum(mat.pdf(woq, wq, cq) * dw)
    leak = 1.0 - up.mean()
    assert pdf_int == pytest.approx(1.0 - leak, abs=5 * math.sqrt(leak * (1 - leak) / n) + 2e-3)


SCENE = textwrap.dedent("""
    [camera]
    position = [0.0, 0.0, 4.0]
    target = [0.0, 0.0, 0.0]
    width = 16
    height = 8

    [materials.a]
    type = "phong"
    kd = 0.4
    ks = 0.4
    exponent = 20.0

    [materials.b]
    type = "phong_classic"
    kd = [0.5, 0.2, 0.2]
    ks = 1.0
    ka = 0.1

    [materials.c]
    type = "blinn_phong_classic"
    kd = 0.5

    [materials.d]
    type = "ward"
    alpha_x = 0.1
    alpha_y = 0.3
    tangent = [1.0, 0.0, 0.0]

    [materials.e]
    type = "cook_torrance"
    metal = "copper"
    roughness = 0.3
    distribution = "beckmann"
    geometry = "vgroove"

    [materials.f]
    type = "metallic_roughness"
    base_color = [0.9, 0.8, 0.1]
    metallic = 1.0
    roughness = 0.2


    [[meshes]]
    primitive = "sphere"
    radius = 0.3
    subdivisions = 2
    material = "a"
    translate = [-1.5, 0.0, 0.0]

    [[meshes]]
    primitive = "sphere"
    radius = 0.3
    subdivisions = 2
    material = "b"
    translate = [-0.9, 0.0, 0.0]

    [[meshes]]
    primitive = "sphere"
    radius = 0.3
    subdivisions = 2
    material = "c"
    translate = [-0.3, 0.0, 0.0]

    [[meshes]]
    primitive = "sphere"
    radius = 0.3
    subdivisions = 2
    material = "d"
    translate = [0.3, 0.0, 0.0]

    [[meshes]]
    primitive = "sphere"
    radius = 0.3
    subdivisions = 2
    material = "e"
    translate = [0.9, 0.0, 0.0]

    [[meshes]]
    primitive = "sphere"
    radius = 0.3
    subdivisions = 2
    material = "f"
    translate = [1.5, 0.0, 0.0]

    [[lights]]
    type = "point"
    position = [2.0, 2.0, 3.0]
    intensity = 10.0
""")


def test_scene_file_selects_every_model(tmp_path):
    path = tmp_path / "scene.toml"
    path.write_text(SCENE)
    scene, options = pyrt.load_scene(str(path))
    types = sorted(type(m).__name__ for m in scene.materials)
    assert {"Phong", "PhongClassic", "BlinnPhongClassic", "Ward", "CookTorrance", "MetallicRoughness"} <= set(types)
    img = pyrt.render(scene, **options)  # every model shades through the integrator
    assert img.shape == (8, 16, 3) and np.all(np.isfinite(img)) and img.max() > 0


def test_scene_file_reports_bad_material_parameters(tmp_path):
    path = tmp_path / "scene.toml"
    path.write_text(SCENE.replace('roughness = 0.3\n', 'roughnes = 0.3\n'))
    with pytest.raises(pyrt.SceneFileError, match="roughnes"):
        pyrt.load_scene(str(path))
    path.write_text(SCENE.replace('metal = "copper"', 'metal = "brass"'))
    with pytest.raises(pyrt.SceneFileError, match="brass"):
        pyrt.load_scene(str(path))
