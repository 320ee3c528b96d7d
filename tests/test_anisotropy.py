"""Anisotropic GGX (shaders/microfacet.py) and ``KHR_materials_anisotropy`` (pyrt.GltfPBR's ``anisotropy``).

Ground truth: the normalisation of D by a midpoint rule whose error is estimated by halving the cell size (Richardson
extrapolation); the isotropic kernels for strength 0 and for equal widths; the chi-square test of the visible-normal
sampler against its pdf (test_microfacet's harness) and of the material's sampling against its pdf
(test_material_contracts' harness); the exact bound ``f cos / pdf = F G2 / G1 <= 1`` of visible-normal sampling of a
white metal; the symmetry of the lobe under a quarter turn of its direction; the glTF extension's parameters.
"""
import math

import numpy as np
import pytest

import pyrt
from material_helpers import LocalCtx, direction
from test_gltf_materials import _materials, _quad, write_gltf
from test_material_contracts import QUAD_DW, QUAD_W, _chi_square_p
from test_microfacet import _chi2_pvalue, hemisphere_integral
from pyrt.shaders import brdfs
from pyrt.shaders import microfacet as mf
from pyrt.shaders.vec import from_azimuth_frame, to_azimuth_frame
from pyrt.textures import ImageTexture

WIDTHS = [(0.05, 0.5), (1.0, 0.1), (0.7, 0.4), (0.3, 0.3)]


def _unit_upper(rng, n):
    w = rng.normal(size=(n, 3))
    w[:, 2] = np.abs(w[:, 2])
    return w / np.linalg.norm(w, axis=1, keepdims=True)


def _d_integral(ax, ay, n):
    """``int D(h) (n.h) dw_h`` with the substitution of isotropic GGX NDF sampling of width ``sqrt(ax ay)`` (cos^2 =
    (1 - v) / (1 - v + a^2 v), so the integrand is the smooth ratio D / D_iso) and a midpoint rule, n x 2n cells in
    (v, phi)."""
    ar = math.sqrt(ax * ay)
    v = (np.arange(n) + 0.5) / n
    ph = (np.arange(2 * n) + 0.5) / (2 * n) * 2 * np.pi
    V, P = np.meshgrid(v, ph, indexing="ij")
    c = np.sqrt((1 - V) / (1 - V + ar * ar * V))
    s = np.sqrt(1 - c * c)
    h = np.stack([s * np.cos(P), s * np.sin(P), c], -1).reshape(-1, 3)
    return float(np.mean(mf.ggx_d_aniso(h, ax, ay) / mf.ggx_d(h[:, 2], ar)))


@pytest.mark.parametrize("ax,ay", WIDTHS)
def test_ggx_d_aniso_normalised(ax, ay):
    """int D(h) (n.h) dw_h = 1. The midpoint rule's error is O(n^-2) (3.1e-4, 7.7e-5, 1.9e-5 at n = 100, 200, 400
    for a 10:1 ratio): the Richardson extrapolation of n = 200 and 400, whose error bound is the next order (< 1e-7
    here), is 1 within 1e-6, and the n = 400 rule itself within 1e-4."""
    i1, i2 = _d_integral(ax, ay, 200), _d_integral(ax, ay, 400)
    assert (4 * i2 - i1) / 3 == pytest.approx(1.0, abs=1e-6)
    assert i2 == pytest.approx(1.0, abs=1e-4)


def test_equal_widths_are_the_isotropic_kernels():
    """alpha_x = alpha_y: D and Lambda agree with the isotropic ones to rounding (1e-12 relative), the sampler and
    its pdf bit for bit."""
    rng = np.random.default_rng(1)
    w, h = _unit_upper(rng, 2000), _unit_upper(rng, 2000)
    u = rng.random((2000, 2))
    for a in (1e-3, 0.3, 1.0):
        np.testing.assert_allclose(mf.ggx_d_aniso(h, a, a), mf.ggx_d(h[:, 2], a), rtol=1e-12)
        np.testing.assert_allclose(mf.ggx_lambda_aniso(w, a, a), mf.ggx_lambda(w[:, 2], a), rtol=1e-12)
        assert np.array_equal(mf.sample_ggx_vndf(w, u, a, a), mf.sample_ggx_vndf(w, u, a))
        np.testing.assert_allclose(mf.ggx_vndf_pdf(w, h, a, a), mf.ggx_vndf_pdf(w, h, a), rtol=1e-12)


def test_strength_zero_is_the_isotropic_brdf():
    """gltf_pbr_f_cos with strength 0 (the default: bit for bit; an array of zeros through the anisotropic kernels:
    within 1e-12), and a material with a texture of strength 0 at a rotation (its directions turned into the lobe's
    frame) against the isotropic material: within 1e-12 relative, for f_cos and pdf."""
    rng = np.random.default_rng(2)
    n = 3000
    wo, wi = _unit_upper(rng, n), _unit_upper(rng, n)
    kw = dict(f0_dielectric=np.array([0.04, 0.05, 0.06]), specular=0.8, geometry="smith_correlated")
    base, m, r = (0.8, 0.5, 0.3), rng.random(n), rng.random(n)
    iso = brdfs.gltf_pbr_f_cos(wo, wi, base, m, r, **kw)
    assert np.array_equal(iso, brdfs.gltf_pbr_f_cos(wo, wi, base, m, r, anisotropy=0.0, **kw))
    np.testing.assert_allclose(brdfs.gltf_pbr_f_cos(wo, wi, base, m, r, anisotropy=np.zeros(n), **kw), iso,
                               rtol=1e-12, atol=1e-12 * iso.max())
    tex = ImageTexture(np.full((2, 2, 3), (1.0, 0.5, 0.0)), srgb=False, filter="nearest")      # B = 0
    a = pyrt.GltfPBR(base_color=base, metallic=0.3, roughness=0.4)
    b = pyrt.GltfPBR(base_color=base, metallic=0.3, roughness=0.4, anisotropy=1.0, anisotropy_rotation=0.9,
                     anisotropy_texture=tex)
    fa, fb = a.f_cos(wo, wi, LocalCtx(n)), b.f_cos(wo, wi, LocalCtx(n))
    np.testing.assert_allclose(fb, fa, rtol=1e-12, atol=1e-12 * fa.max())
    pa, pb = a.pdf(wo, wi, LocalCtx(n)), b.pdf(wo, wi, LocalCtx(n))
    np.testing.assert_allclose(pb, pa, rtol=1e-12, atol=1e-12 * pa.max())


@pytest.mark.parametrize("ax,ay", [(0.6, 0.15), (0.1, 0.5)])
@pytest.mark.parametrize("theta_o", [0.0, 50.0, 80.0])
def test_aniso_vndf_pdf_integrates_to_one(ax, ay, theta_o):
    """The pdf of the anisotropic sampler integrates to 1 (test_microfacet's quadrature: < 3e-5 relative)."""
    wo = direction(theta_o, 30.0)[None]
    val = hemisphere_integral(lambda h: mf.ggx_vndf_pdf(np.repeat(wo, h.shape[0], 0), h, ax, ay),
                              n_theta=300, n_phi=192, isotropic=False)
    assert val == pytest.approx(1.0, abs=2e-4)


@pytest.mark.parametrize("ax,ay", [(0.6, 0.15), (0.1, 0.5)])
@pytest.mark.parametrize("theta_o", [0.0, 50.0, 80.0])
def test_aniso_vndf_samples_match_pdf_chi2(ax, ay, theta_o):
    """Anisotropic visible normals (wo at azimuth 30 degrees, off both axes) against their pdf: chi-square over
    16 x 12 cells, 100k samples, rejected at p < 1e-3."""
    n = 100_000
    wo = np.tile(direction(theta_o, 30.0), (n, 1))
    h = mf.sample_ggx_vndf(wo, np.random.default_rng(12345).random((n, 2)), ax, ay)
    p, mass = _chi2_pvalue(h, lambda hh: mf.ggx_vndf_pdf(np.repeat(wo[:1], hh.shape[0], 0), hh, ax, ay),
                           math.sqrt(ax * ay))
    assert mass == pytest.approx(1.0, abs=2e-3)
    assert p > 1e-3


def test_aniso_chi2_detects_swapped_widths():
    """The test has power: samples of (0.6, 0.15) against the pdf of (0.15, 0.6) fail."""
    n = 100_000
    wo = np.tile(direction(50.0, 30.0), (n, 1))
    h = mf.sample_ggx_vndf(wo, np.random.default_rng(7).random((n, 2)), 0.6, 0.15)
    p, _ = _chi2_pvalue(h, lambda hh: mf.ggx_vndf_pdf(np.repeat(wo[:1], hh.shape[0], 0), hh, 0.15, 0.6), 0.3)
    assert p < 1e-6


def _white_metal(**kw):
    return pyrt.GltfPBR(base_color=1.0, metallic=1.0, roughness=kw.pop("roughness", 0.3), **kw)


@pytest.mark.parametrize("geometry", ["smith_correlated", "smith_separable"])
@pytest.mark.parametrize("theta_o", [0.0, 45.0, 80.0])
def test_white_furnace_reflects_at_most_everything(geometry, theta_o):
    """A white anisotropic metal (F = 1): every visible-normal sample's weight is ``G2 / G1(wo) <= 1`` (exact, to
    rounding), so its mean, the albedo, is <= 1; the quadrature albedo agrees with the mean within 5 standard errors
    plus the quadrature's error (2e-3)."""
    m = _white_metal(anisotropy=0.8, anisotropy_rotation=0.6, geometry=geometry)
    n = 100_000
    wo = np.tile(direction(theta_o, 20.0), (n, 1))
    wi, weight, pdf = m.sample(wo, np.random.default_rng(5).random((n, 2)), LocalCtx(n))
    assert np.all(weight <= 1.0 + 1e-9) and np.all(weight >= 0)
    mean, se = weight.mean(0), weight.std(0) / math.sqrt(n)
    rho = (m.f_cos(np.tile(wo[0], (QUAD_W.shape[0], 1)), QUAD_W, LocalCtx(QUAD_W.shape[0])) * QUAD_DW[:, None]).sum(0)
    assert np.all(rho <= 1.0 + 2e-3) and np.all(mean <= 1.0)
    assert np.all(np.abs(mean - rho) <= 5 * se + 2e-3), (mean, rho, se)


@pytest.mark.parametrize("theta_o,coat", [(30.0, False), (75.0, False), (30.0, True)])
def test_material_samples_follow_its_pdf(theta_o, coat):
    """GltfPBR's anisotropic sampling (diffuse + anisotropic visible normals), alone and as the base of a clear coat
    (which mixes in the base's sample_direction), against its pdf (the contract tests' chi-square harness, 200k
    samples, rejected at p < 1e-4)."""
    m = pyrt.GltfPBR(base_color=(0.7, 0.4, 0.2), metallic=0.6, roughness=0.35, anisotropy=0.7,
                     anisotropy_rotation=0.4)
    assert _chi_square_p(pyrt.Clearcoat(m, clearcoat=0.8, roughness=0.35) if coat else m, theta_o) > 1e-4


def _quarter_turn(w):
    return np.stack([-w[:, 1], w[:, 0], w[:, 2]], axis=1)


def test_rotation_turns_the_lobe():
    """A quarter turn of anisotropyRotation turns the lobe with it: f_r+pi/2(R wo, R wi) = f_r(wo, wi), R the quarter
    turn about the normal (t and b exchange roles, within 1e-12); and the highlight is stretched along t: light
    tilted 25 degrees off the mirror direction along t is reflected more than the same tilt along b."""
    rng = np.random.default_rng(3)
    n = 2000
    wo, wi = _unit_upper(rng, n), _unit_upper(rng, n)
    for r in (0.0, 0.3):
        a = _white_metal(anisotropy=0.9, anisotropy_rotation=r)
        b = _white_metal(anisotropy=0.9, anisotropy_rotation=r + math.pi / 2)
        fa = a.f_cos(wo, wi, LocalCtx(n))
        np.testing.assert_allclose(b.f_cos(_quarter_turn(wo), _quarter_turn(wi), LocalCtx(n)), fa,
                                   rtol=1e-12, atol=1e-12 * fa.max())
        assert not np.allclose(b.f_cos(wo, wi, LocalCtx(n)), fa, rtol=1e-3)      # and the lobe did turn
    for r, t_deg in ((0.0, 0.0), (math.pi / 2, 90.0), (0.5, math.degrees(0.5))):
        m = _white_metal(roughness=0.2, anisotropy=0.8, anisotropy_rotation=r)
        wo = direction(0.0)[None]
        along = m.f_cos(wo, direction(25.0, t_deg)[None], LocalCtx(1))[0, 0]
        across = m.f_cos(wo, direction(25.0, t_deg + 90.0)[None], LocalCtx(1))[0, 0]
        assert along > 3 * across


def test_texture_direction_and_strength():
    """anisotropyTexture: RG = (0.5, 1) is the direction (0, 1), i.e. B, the same lobe as a rotation of pi/2; its B
    scales the strength (B = 0.5 x strength 0.8 = strength 0.4); the rotation turns the texture's direction too;
    the tangent frame is the surface's dpdu, dpdv (here the local x, y)."""
    rng = np.random.default_rng(4)
    n = 500
    wo, wi = _unit_upper(rng, n), _unit_upper(rng, n)

    def tex(rgb):
        return ImageTexture(np.full((2, 2, 3), rgb), srgb=False, filter="nearest")

    def f(**kw):
        return _white_metal(**kw).f_cos(wo, wi, LocalCtx(n))

    np.testing.assert_allclose(f(anisotropy=0.8, anisotropy_texture=tex((0.5, 1.0, 1.0))),
                               f(anisotropy=0.8, anisotropy_rotation=math.pi / 2), rtol=1e-12)
    np.testing.assert_allclose(f(anisotropy=0.8, anisotropy_texture=tex((1.0, 0.5, 0.5))), f(anisotropy=0.4),
                               rtol=1e-12)
    np.testing.assert_allclose(f(anisotropy=0.8, anisotropy_rotation=0.3, anisotropy_texture=tex((0.5, 1.0, 1.0))),
                               f(anisotropy=0.8, anisotropy_rotation=0.3 + math.pi / 2), rtol=1e-12)
    t, s = _white_metal(anisotropy=0.8, anisotropy_rotation=0.3)._anisotropy(LocalCtx(3))
    np.testing.assert_allclose(t, np.tile([math.cos(0.3), math.sin(0.3)], (3, 1)), rtol=1e-15)
    ctx = LocalCtx(3)
    ctx.dpdu, ctx.dpdv = ctx.dpdv.copy(), -ctx.dpdu          # the UV frame turned a quarter: t follows dpdu
    t, _ = _white_metal(anisotropy=0.8)._anisotropy(ctx)
    np.testing.assert_allclose(t, np.tile([0.0, 1.0], (3, 1)), atol=1e-15)


def test_azimuth_frame_round_trip():
    rng = np.random.default_rng(6)
    w = rng.normal(size=(100, 3))
    ang = rng.random(100) * 2 * np.pi
    t = np.stack([np.cos(ang), np.sin(ang)], 1)
    np.testing.assert_allclose(from_azimuth_frame(to_azimuth_frame(w, t), t), w, atol=1e-14)
    np.testing.assert_allclose(to_azimuth_frame(np.c_[t, np.zeros(100)], t), np.tile([1.0, 0, 0], (100, 1)),
                               atol=1e-15)


def test_preview_and_glossy_alpha_stand_ins():
    """The documented isotropic stand-ins: glossy_alpha is the smaller width alpha_b = alpha; the preview's lobe
    has the geometric mean sqrt(alpha_t alpha_b)."""
    m = _white_metal(roughness=0.4, anisotropy=0.5)
    ctx = LocalCtx(2)
    ctx.wo = np.tile(direction(30.0), (2, 1))
    a = 0.4 ** 2
    np.testing.assert_allclose(m.glossy_alpha(ctx), a)
    lobes = m.preview_lobes(ctx)
    np.testing.assert_allclose(lobes.glossy[0].alpha, math.sqrt((a + (1 - a) * 0.25) * a))


def test_gltf_anisotropy_extension(tmp_path):
    """The reader: anisotropyStrength, anisotropyRotation and anisotropyTexture (linear RGB) reach GltfPBR; no
    'ignored' warning; a strength above 1 is clamped with a warning; under a clear coat the base is anisotropic."""
    img = np.zeros((2, 2, 3), np.uint8)
    img[...] = (255, 128, 204)
    ext = {"anisotropyStrength": 0.6, "anisotropyRotation": 0.5, "anisotropyTexture": {"index": 0}}
    mats = [{"name": "brushed", "pbrMetallicRoughness": {"metallicFactor": 1.0, "roughnessFactor": 0.3},
             "extensions": {"KHR_materials_anisotropy": ext}},
            {"name": "plain", "extensions": {"KHR_materials_anisotropy": {}}},
            {"name": "strong", "extensions": {"KHR_materials_anisotropy": {"anisotropyStrength": 2.0}}}]
    path = write_gltf(tmp_path / "a.gltf", [_quad(material=i) for i in range(3)], mats, images=[img],
                      extensions_used=["KHR_materials_anisotropy"])
    asset, (m, plain, strong) = _materials(path)
    assert isinstance(m, pyrt.GltfPBR) and m.anisotropic
    assert not any("ignored" in w or "not supported" in w for w in asset.warnings), asset.warnings
    assert m.anisotropy == 0.6 and m.anisotropy_rotation == 0.5
    rgb = m.param(m.anisotropy_texture, LocalCtx(1))[0]
    np.testing.assert_allclose(rgb, [1.0, 128 / 255, 204 / 255], atol=1e-6)        # linear: no sRGB decoding
    t, s = m._anisotropy(LocalCtx(1))
    x, y = 1.0, 2 * 128 / 255 - 1
    d = np.array([math.cos(0.5) * x - math.sin(0.5) * y, math.sin(0.5) * x + math.cos(0.5) * y])
    np.testing.assert_allclose(t[0], d / np.linalg.norm(d), atol=1e-6)
    assert s[0] == pytest.approx(0.6 * 204 / 255, abs=1e-6)
    assert not getattr(plain, "anisotropic", False)                         # default strength 0: isotropic
    assert strong.anisotropy == 1.0 and any("anisotropyStrength 2.0 > 1" in w for w in asset.warnings)
    mats[0]["extensions"]["KHR_materials_clearcoat"] = {"clearcoatFactor": 1.0}
    _, (c, _, _) = _materials(write_gltf(tmp_path / "c.gltf", [_quad(material=i) for i in range(3)], mats,
                                         images=[img]))
    assert isinstance(c, pyrt.Clearcoat) and c.base.anisotropic
