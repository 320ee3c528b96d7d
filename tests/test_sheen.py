"""Sheen (pyrt.materials.Sheen, KHR_materials_sheen): the Charlie distribution's normalisation, the albedo table
against direct quadrature, the white furnace of the specification's layering, sampling against evaluation, and the
glTF extension's parameters."""
import math

import numpy as np
import pytest

import pyrt
from material_helpers import LocalCtx, direction
from test_gltf_materials import _materials, _quad, write_gltf
from pyrt.shaders.sheen import charlie_d, sheen_albedo, sheen_f_cos


def _hemisphere(n_t, n_p):
    """Midpoint-rule directions in (cos theta, phi) over the upper hemisphere, each of solid angle 2 pi / count."""
    c = (np.arange(n_t) + 0.5) / n_t
    ph = (np.arange(n_p) + 0.5) / n_p * 2 * np.pi
    C, P = np.meshgrid(c, ph, indexing="ij")
    s = np.sqrt(1 - C * C)
    return np.stack([s * np.cos(P), s * np.sin(P), C], -1).reshape(-1, 3)


def _albedo(mat, theta_o, n_t=200, n_p=128):
    """Directional albedo (3,) by midpoint quadrature in (cos theta, phi)."""
    wi = _hemisphere(n_t, n_p)
    wo = np.tile(direction(theta_o), (wi.shape[0], 1))
    return mat.f_cos(wo, wi, LocalCtx(wi.shape[0])).sum(0) * (2 * np.pi / (n_t * n_p))


@pytest.mark.parametrize("alpha", [1e-4, 0.01, 0.25, 1.0])
def test_charlie_distribution_is_normalised(alpha):
    """int D(h) cos(theta_h) d omega_h = 1 (midpoint rule in cos theta_h, 20000 cells: error < 1e-5 here)."""
    n = 20000
    c = (np.arange(n) + 0.5) / n
    assert (charlie_d(c, alpha) * c).sum() / n * 2 * math.pi == pytest.approx(1.0, abs=1e-4)


@pytest.mark.parametrize("theta", [0.0, 45.0, 75.0])
@pytest.mark.parametrize("r", [0.2, 0.6, 1.0])
def test_albedo_table_matches_direct_quadrature(theta, r):
    """The bilinear table against a finer direct quadrature of the white lobe (within 1 %: interpolation)."""
    wi = _hemisphere(300, 200)
    wo = np.tile(direction(theta), (wi.shape[0], 1))
    direct = sheen_f_cos(wo, wi, r * r).sum() * (2 * np.pi / wi.shape[0])
    assert sheen_albedo(np.array([math.cos(math.radians(theta))]), r)[0] == pytest.approx(direct, rel=0.01, abs=2e-3)


@pytest.mark.parametrize("theta", [0.0, 30.0, 60.0, 80.0])
@pytest.mark.parametrize("r", [0.1, 0.5, 1.0])
def test_white_sheen_over_white_lambert_reflects_everything(theta, r):
    """E(v) + (1 - E(v)) x 1 = 1: the specification's albedo scaling over a white Lambertian base (within 1 %)."""
    m = pyrt.Sheen(pyrt.Lambert(1.0), color=1.0, roughness=r)
    np.testing.assert_allclose(_albedo(m, theta), 1.0, atol=0.01)


def test_sampling_weights_average_to_the_albedo():
    """E[f cos / pdf] over the material's own samples equals the quadrature albedo (within 4 standard errors)."""
    m = pyrt.Sheen(pyrt.MetallicRoughness(base_color=(0.4, 0.2, 0.1), roughness=0.6), color=(0.8, 0.5, 0.9),
                   roughness=0.5)
    n = 200000
    wo = np.tile(direction(40.0), (n, 1))
    u = np.random.default_rng(3).random((n, 2))
    wi, weight, pdf = m.sample(wo, u, LocalCtx(n))
    est, se = weight.mean(0), weight.std(0) / math.sqrt(n)
    ref = _albedo(m, 40.0, 400, 256)
    assert np.all(np.abs(est - ref) < 4 * se + 2e-3)
    k = pdf[:1000] > 0
    np.testing.assert_allclose(pdf[:1000][k], m.pdf(wo[:1000], wi[:1000], LocalCtx(1000))[k], rtol=1e-10)


def test_gltf_sheen_extension_wraps_the_material(tmp_path):
    img = np.zeros((2, 2, 4), np.uint8)
    img[...] = (255, 128, 0, 102)                                    # colour (sRGB), roughness in A: 0.4
    mats = [{"name": "velvet", "pbrMetallicRoughness": {"baseColorFactor": [0.2, 0.1, 0.1, 1], "metallicFactor": 0},
             "extensions": {"KHR_materials_sheen": {"sheenColorFactor": [1.0, 0.5, 0.25], "sheenColorTexture":
                                                    {"index": 0}, "sheenRoughnessFactor": 0.5,
                                                    "sheenRoughnessTexture": {"index": 0}}}}]
    path = write_gltf(tmp_path / "s.gltf", [_quad()], mats, images=[img], extensions_used=["KHR_materials_sheen"])
    asset, (m,) = _materials(path)
    assert isinstance(m, pyrt.Sheen) and not any("KHR_materials_sheen" in w for w in asset.warnings)
    ctx = LocalCtx(1)
    c = 128 / 255
    np.testing.assert_allclose(m.param(m.color, ctx)[0], [1.0, 0.5 * ((c + 0.055) / 1.055) ** 2.4, 0.0], rtol=1e-5)
    assert m.param(m.roughness, ctx, 1)[0] == pytest.approx(0.5 * 0.4, rel=1e-5)
    mats[0]["extensions"]["KHR_materials_clearcoat"] = {"clearcoatFactor": 1.0}
    path = write_gltf(tmp_path / "c.gltf", [_quad()], mats, images=[img])
    _, (m,) = _materials(path)
    assert isinstance(m, pyrt.Clearcoat) and isinstance(m.base, pyrt.Sheen)      # the coat over the sheen
