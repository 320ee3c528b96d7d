"""Issue 16 materials: smooth Conductor, Oren-Nayar, LearnOpenGL's PBR model (pyrt.materials.extra).

The contract tests (tests/test_material_contracts.py) cover reciprocity, furnace, sampling for all three;
here: the closed forms they must reproduce.
"""
import math

import numpy as np
import pytest

import pyrt
from pyrt.shaders import brdfs, fresnel, metals

from material_helpers import LocalCtx, direction


def _f0_conductor(eta, k):
    """Normal-incidence reflectance of a conductor: ((eta - 1)^2 + k^2) / ((eta + 1)^2 + k^2)."""
    return ((eta - 1) ** 2 + k ** 2) / ((eta + 1) ** 2 + k ** 2)


# ------------------------------------------------------------------------------------------ Conductor
@pytest.mark.parametrize("metal", sorted(metals.METALS))
def test_conductor_normal_incidence_reflectance_closed_form(metal):
    mat = pyrt.Conductor(metal=metal)
    eta, k = metals.METALS[metal]
    (lobe,) = mat.delta_lobes(np.array([[0.0, 0.0, 1.0]]), LocalCtx(1))
    assert lobe.kind == "reflect"
    np.testing.assert_allclose(lobe.wi, [[0.0, 0.0, 1.0]], atol=1e-15)
    np.testing.assert_allclose(lobe.weight[0], _f0_conductor(eta, k), rtol=1e-12)


def test_conductor_eta_k_parameters_and_grazing_limit():
    eta, k = np.array([0.2, 0.9, 1.6]), np.array([3.0, 2.5, 1.7])
    mat = pyrt.Conductor(eta=eta, k=k)
    wo = np.stack([direction(t, 30.0) for t in (0.0, 60.0, 89.9, 89.999)])
    (lobe,) = mat.delta_lobes(wo, LocalCtx(4))
    np.testing.assert_allclose(lobe.weight[0], _f0_conductor(eta, k), rtol=1e-12)
    np.testing.assert_allclose(lobe.weight, fresnel.fr_conductor(wo[:, 2], eta, k), rtol=1e-15)
    np.testing.assert_allclose(lobe.wi, wo * [-1, -1, 1], atol=1e-15)
    # grazing -> 1, linearly in cos(theta) (measured 1 - F <= 6.9e-3 at 89.9 degrees, <= 6.9e-5 at 89.999)
    assert np.all(1.0 - lobe.weight[2] < 7e-3) and np.all(1.0 - lobe.weight[3] < 7e-5)
    assert np.all(np.diff(lobe.weight[1:], axis=0) > 0)


def test_conductor_parameter_errors():
    with pytest.raises(pyrt.MaterialError, match="not both"):
        pyrt.Conductor(metal="gold", eta=1.0)
    with pytest.raises(pyrt.MaterialError, match="both eta and k"):
        pyrt.Conductor(eta=[0.2, 0.3, 0.4])
    with pytest.raises(pyrt.MaterialError, match="gold"):
        pyrt.Conductor(metal="unobtainium")
    assert pyrt.load_dict  # scene files reach it by its registry name
    assert pyrt.MATERIALS["conductor"] is pyrt.Conductor


def _ggx_lobe_integral(mat, wo, alpha, n_s=256, n_phi=256):
    """Directional albedo (3,) of a GGX lobe by quadrature over half vectors.

    ``int f_cos(wo, reflect(wo, h)) 4 |wo.h| dw_h`` with ``tan(theta_h) = alpha tan(pi s / 2)``: the GGX
    NDF becomes a smooth function of s (Gauss-Legendre in s, midpoint in phi), so the quadrature is as
    accurate for alpha = 0.02 as for 0.2 (error < 1e-5 here, checked by doubling the nodes).
    """
    gx, gw = np.polynomial.legendre.leggauss(n_s)
    s, ws = 0.5 * (gx + 1), 0.5 * gw
    x = np.tan(0.5 * np.pi * s)
    th = np.arctan(alpha * x)
    dth = alpha / (1 + (alpha * x) ** 2) * 0.5 * np.pi / np.cos(0.5 * np.pi * s) ** 2 * ws
    ph = (np.arange(n_phi) + 0.5) / n_phi * 2 * np.pi
    T, P = np.meshgrid(th, ph, indexing="ij")
    h = np.stack([np.sin(T) * np.cos(P), np.sin(T) * np.sin(P), np.cos(T)], -1).reshape(-1, 3)
    dw = ((np.sin(th) * dth)[:, None] * np.full((1, n_phi), 2 * np.pi / n_phi)).reshape(-1)
    wo_n = np.tile(wo, (h.shape[0], 1))
    cos_oh = h @ wo
    wi = 2 * cos_oh[:, None] * h - wo_n
    f = mat.f_cos(wo_n, wi, LocalCtx(h.shape[0]))
    return np.sum(f * (4 * np.abs(cos_oh) * dw)[:, None], axis=0)


#: max |albedo(GGX, alpha) - F_conductor| over RGB, gold, CookTorrance's default smith_correlated G (measured by
#: this test): {theta_o: errors at alpha = 0.2, 0.1, 0.05, 0.02}. The error is the single-scattering energy lost
#: by the rough lobe (O(alpha)) plus F varying over the lobe's half vectors (O(alpha^2)).
GGX_TO_CONDUCTOR = {0.0: [0.05172, 0.01157, 0.00264, 0.00039],
                    45.0: [0.07472, 0.01815, 0.00418, 0.00063],
                    75.0: [0.13755, 0.07249, 0.02296, 0.00356]}
ALPHAS = [0.2, 0.1, 0.05, 0.02]


@pytest.mark.parametrize("theta_o", [0.0, 45.0, 75.0])
def test_ggx_conductor_converges_to_smooth_conductor_as_alpha_to_0(theta_o):
    wo = direction(theta_o, 10.0)
    F = pyrt.Conductor(metal="gold").delta_lobes(wo[None], LocalCtx(1))[0].weight[0]
    errors = []
    for alpha in ALPHAS:
        ct = pyrt.CookTorrance(metal="gold", fresnel="conductor", alpha=alpha)
        errors.append(np.abs(_ggx_lobe_integral(ct, wo, alpha) - F).max())
    assert np.all(np.diff(errors) < 0), errors          # strictly decreasing with alpha
    assert errors[-1] < 0.05 * errors[0] and errors[-1] < 4e-3, errors
    np.testing.assert_allclose(errors, GGX_TO_CONDUCTOR[theta_o], rtol=1e-3, atol=2e-5)


def test_ggx_lobe_quadrature_is_converged():
    wo = direction(45.0, 10.0)
    ct = pyrt.CookTorrance(metal="gold", fresnel="conductor", alpha=0.02)
    a = _ggx_lobe_integral(ct, wo, 0.02)
    b = _ggx_lobe_integral(ct, wo, 0.02, n_s=512, n_phi=512)
    np.testing.assert_allclose(a, b, atol=1e-5)


def _emitter_wall(scene, z, color, normal):
    scene.add_plane((0, 0, z), 100.0, pyrt.Lambert(albedo=0.0, emission=color), normal=normal, name=f"emitter{z}")


def test_conductor_plane_render_is_fresnel_times_radiance_per_pixel():
    """A Conductor plane seen through a 60-degree camera reflects a uniform emitter behind the camera:
    each pixel is exactly F(cos theta) L_e with theta the angle of that pixel's ray (F(0) L_e at the centre)."""
    w = 16
    cam = pyrt.Camera(position=(0, 0, 2), target=(0, 0, 0), fov=60, width=w, height=w, jitter=False)
    scene = pyrt.Scene(cam)
    mat = pyrt.Conductor(metal="copper")
    scene.add_plane((0, 0, 0), 10.0, mat, normal=(0, 0, 1))
    Le = np.array([1.0, 0.5, 0.25])
    _emitter_wall(scene, 5.0, Le, (0, 0, -1))
    img = pyrt.render(scene)
    d = cam.generate_rays(0, w * w, np.random.default_rng(0), differentials=False).directions
    cos_o = -d[:, 2] / np.linalg.norm(d, axis=1)
    expected = fresnel.fr_conductor(cos_o, mat.eta, mat.k) * Le
    np.testing.assert_allclose(img.reshape(-1, 3), expected, rtol=2e-6)
    assert cos_o.min() < 0.8                             # the angles really vary across the image


# ------------------------------------------------------------------------------------------ Oren-Nayar
def _random_pairs(rng, n):
    wo = rng.normal(size=(n, 3))
    wi = rng.normal(size=(n, 3))
    wo[:, 2] = np.abs(wo[:, 2])
    wo /= np.linalg.norm(wo, axis=1, keepdims=True)
    wi /= np.linalg.norm(wi, axis=1, keepdims=True)
    return wo, wi


def test_oren_nayar_sigma_0_is_lambert_exactly(rng):
    wo, wi = _random_pairs(rng, 5000)
    albedo = [0.9, 0.5, 0.2]
    on = pyrt.OrenNayar(albedo, sigma=0.0).f_cos(wo, wi, LocalCtx(5000))
    lam = pyrt.Lambert(albedo).f_cos(wo, wi, LocalCtx(5000))
    assert np.array_equal(on, lam)


def test_oren_nayar_matches_the_angular_form(rng):
    """The kernel's ``max(0, s) / max(cos)`` equals the paper's ``max(0, cos dphi) sin(alpha) tan(beta)``."""
    wo, wi = _random_pairs(rng, 3000)
    wi[:, 2] = np.abs(wi[:, 2])
    sigma = math.radians(30.0)
    got = pyrt.OrenNayar(1.0, sigma_deg=30.0).f_cos(wo, wi, LocalCtx(3000))[:, 0]
    th_o, th_i = np.arccos(wo[:, 2]), np.arccos(wi[:, 2])
    dphi = np.arctan2(wi[:, 1], wi[:, 0]) - np.arctan2(wo[:, 1], wo[:, 0])
    a_ = np.maximum(th_o, th_i)
    b_ = np.minimum(th_o, th_i)
    A = 1 - 0.5 * sigma ** 2 / (sigma ** 2 + 0.33)
    B = 0.45 * sigma ** 2 / (sigma ** 2 + 0.09)
    want = (A + B * np.maximum(0, np.cos(dphi)) * np.sin(a_) * np.tan(b_)) / np.pi * wi[:, 2]
    np.testing.assert_allclose(got, want, rtol=1e-10, atol=1e-14)


def _albedo_fine(mat, wo, n=400):
    """Directional albedo (channel 0) by Gauss-Legendre in theta_i (n nodes) x midpoint in phi (n): the
    Oren-Nayar integrand has a kink at theta_i = theta_o, so uniform theta nodes (not the s^4 ones)."""
    gx, gw = np.polynomial.legendre.leggauss(n)
    t, wt = (gx + 1) / 2 * np.pi / 2, gw * np.pi / 4
    ph = (np.arange(n) + 0.5) / n * 2 * np.pi
    T, P = np.meshgrid(t, ph, indexing="ij")
    w = np.stack([np.sin(T) * np.cos(P), np.sin(T) * np.sin(P), np.cos(T)], -1).reshape(-1, 3)
    dw = ((np.sin(t) * wt)[:, None] * np.full((1, n), 2 * np.pi / n)).reshape(-1)
    return float(np.sum(mat.f_cos(np.tile(wo, (len(w), 1)), w, LocalCtx(len(w)))[:, 0] * dw))


#: white-albedo directional albedo of the qualitative model at theta_o = 0 / 60 / 89.9 degrees (measured here)
ON_WHITE_ALBEDO = {2.0: (0.99816, 0.99995, 1.00116), 11.0: (0.94976, 0.98874, 1.01507),
                   30.0: (0.77311, 0.87411, 0.94231), 90.0: (0.55898, 0.68842, 0.77583)}


@pytest.mark.parametrize("sigma_deg", sorted(ON_WHITE_ALBEDO))
def test_oren_nayar_white_albedo_measured(sigma_deg):
    """The qualitative model is *not* exactly energy conserving: with albedo 1 and sigma ~ 11 degrees it
    reflects up to 1.5 % more than it receives at grazing view (the B term is not normalised against
    A); for sigma >= 20 degrees it stays below 1. Measured values pinned to catch a changed kernel."""
    mat = pyrt.OrenNayar(1.0, sigma_deg=sigma_deg)
    got = [_albedo_fine(mat, direction(t)) for t in (0.0, 60.0, 89.9)]
    np.testing.assert_allclose(got, ON_WHITE_ALBEDO[sigma_deg], atol=2e-5)
    assert max(got) <= 1.0152


def test_oren_nayar_parameters():
    assert pyrt.OrenNayar(sigma_deg=45.0).sigma == pytest.approx(math.pi / 4)
    with pytest.raises(pyrt.MaterialError, match="not both"):
        pyrt.OrenNayar(sigma=0.1, sigma_deg=5.0)
    with pytest.raises(pyrt.MaterialError, match="sigma"):
        pyrt.OrenNayar(sigma=2.0)
    assert brdfs.oren_nayar_ab(0.0) == (1.0, 0.0)


def test_oren_nayar_keeps_float32(rng):
    wo, wi = _random_pairs(rng, 100)
    out = brdfs.oren_nayar_f_cos_cosines(wo[:, 2].astype(np.float32), wi[:, 2].astype(np.float32),
                                         np.sum(wo * wi, axis=1).astype(np.float32), np.array([0.5, 0.5, 0.5]), 0.3)
    assert out.dtype == np.float32 and np.all(np.isfinite(out))


# ------------------------------------------------------------------------------------------ LearnOpenGL
# The tutorial's GLSL (learnopengl.com "PBR / Lighting", course notes seeds/003), transcribed literally.
PI = 3.14159265359


def _glsl_dot(a, b):
    return float(np.dot(a, b))


def _normalize(v):
    return np.asarray(v, dtype=np.float64) / np.linalg.norm(v)


def DistributionGGX(N, H, roughness):
    a = roughness * roughness
    a2 = a * a
    NdotH = max(_glsl_dot(N, H), 0.0)
    NdotH2 = NdotH * NdotH
    num = a2
    denom = (NdotH2 * (a2 - 1.0) + 1.0)
    denom = PI * denom * denom
    return num / denom


def GeometrySchlickGGX(NdotV, roughness):
    r = (roughness + 1.0)
    k = (r * r) / 8.0
    num = NdotV
    denom = NdotV * (1.0 - k) + k
    return num / denom


def GeometrySmith(N, V, L, roughness):
    NdotV = max(_glsl_dot(N, V), 0.0)
    NdotL = max(_glsl_dot(N, L), 0.0)
    ggx2 = GeometrySchlickGGX(NdotV, roughness)
    ggx1 = GeometrySchlickGGX(NdotL, roughness)
    return ggx1 * ggx2


def fresnelSchlick(cosTheta, F0):
    return F0 + (1.0 - F0) * pow(1.0 - cosTheta, 5.0)


def learnopengl_brdf_times_NdotL(N, V, L, albedo, metallic, roughness):
    """The loop body of the tutorial's fragment shader for one light, without ``radiance``."""
    H = _normalize(V + L)
    F0 = np.array([0.04, 0.04, 0.04])
    F0 = F0 * (1.0 - metallic) + albedo * metallic           # mix(F0, albedo, metallic)
    NDF = DistributionGGX(N, H, roughness)
    G = GeometrySmith(N, V, L, roughness)
    F = fresnelSchlick(max(_glsl_dot(H, V), 0.0), F0)
    kS = F
    kD = np.array([1.0, 1.0, 1.0]) - kS
    kD *= 1.0 - metallic
    numerator = NDF * G * F
    denominator = 4.0 * max(_glsl_dot(N, V), 0.0) * max(_glsl_dot(N, L), 0.0)
    specular = numerator / max(denominator, 0.001)
    NdotL = max(_glsl_dot(N, L), 0.0)
    return (kD * albedo / PI + specular) * NdotL


CASES = [  # (theta_v, phi_v, theta_l, phi_l) in degrees, albedo, metallic, roughness
    ((0.0, 0.0, 0.0, 0.0), [0.9, 0.6, 0.3], 0.0, 0.5),
    ((30.0, 0.0, 45.0, 180.0), [0.9, 0.6, 0.3], 0.0, 0.5),
    ((60.0, 20.0, 20.0, 250.0), [1.0, 0.766, 0.336], 1.0, 0.3),
    ((75.0, 90.0, 70.0, 300.0), [0.5, 0.5, 0.5], 0.4, 0.8),
    ((10.0, 45.0, 80.0, 200.0), [0.2, 0.7, 0.9], 0.7, 0.15),
    ((50.0, 0.0, 50.0, 180.0), [0.8, 0.8, 0.8], 0.0, 1.0),
]


@pytest.mark.parametrize("angles,albedo,metallic,roughness", CASES)
def test_learnopengl_reproduces_the_tutorial_shader(angles, albedo, metallic, roughness):
    tv, pv, tl, pl = angles
    N = np.array([0.0, 0.0, 1.0])
    V, L = direction(tv, pv), direction(tl, pl)
    want = learnopengl_brdf_times_NdotL(N, V, L, np.array(albedo), metallic, roughness)
    # the shader's max(denominator, 0.001) guard is inactive in these cases
    assert 4.0 * V[2] * L[2] > 0.001
    mat = pyrt.LearnOpenGLPBR(albedo=albedo, metallic=metallic, roughness=roughness)
    got = mat.f_cos(V[None], L[None], LocalCtx(1))[0]
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-15)


def test_learnopengl_is_metallic_roughness_with_schlick_ggx_k_direct(rng):
    wo, wi = _random_pairs(rng, 2000)
    mat = pyrt.LearnOpenGLPBR(albedo=[0.7, 0.4, 0.2], metallic=0.3, roughness=0.6)
    assert isinstance(mat, pyrt.MetallicRoughness) and mat.geometry == "schlick_ue4"
    np.testing.assert_allclose(mat.f_cos(wo, wi, LocalCtx(2000)), brdfs.gltf_metallic_roughness_f_cos(
        wo, wi, [0.7, 0.4, 0.2], 0.3, 0.6, geometry="schlick_ue4"), rtol=0, atol=0)
    assert pyrt.MATERIALS["learnopengl"] is pyrt.LearnOpenGLPBR
