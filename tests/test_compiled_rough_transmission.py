"""The compiled rough transmission (:mod:`pyrt.materials.compiled_transmission`) against its NumPy twins.

Compiled in ``numba.njit`` loops:

- the thin wall's lobe, the rough interface (GGX BSDF of :class:`pyrt.RoughDielectric`) and their pdfs equal the
  NumPy kernels (:func:`pyrt.shaders.brdfs.thin_transmission_spec_cos` times ``1 - s max F``,
  :func:`pyrt.shaders.brdfs.rough_dielectric_f_cos`, ``rough_dielectric_pdf``, ``sample_rough_dielectric``) to 1e-6
  relative on random directions of both sides and grazing ones;
- the glTF mixture (:func:`gltf_f_cos`, :func:`gltf_pdf`, :func:`gltf_sample_f`) equals :class:`pyrt.GltfPBR`'s
  ``f_cos``, ``pdf`` and ``sample`` (same ``u``: same direction, weight and pdf) for thin and volume transmission,
  several parameter sets, smooth hits included (the opaque model's sampling);
- contracts: the sampled directions follow the compiled pdf over the whole sphere (chi-square, rejected at
  p < 1e-4; the harness rejects a wrong pdf), the white furnace (reflected plus transmitted power <= 1, and the
  sampler's mean weight equals the quadrature of ``f_cos``), the thin lobe's reciprocity and the interface's
  ``f(wo, wi) / eta_o^2 = f(wi, wo) / eta_i^2``;
- the fallback: the glossy integrator with rough transmission names its materials (TransmissionTest, when
  ../shared/khronos-gltf is present).
"""
import os

import numba
import numpy as np
import pytest

import pyrt
from material_helpers import LocalCtx, chi_square_cells_p, direction, direction_cos, unit, wo_u_cases
from pyrt.integrators import compiled as C
from pyrt.materials import compiled as MC
from pyrt.materials import compiled_transmission as CT
from pyrt.materials.gltf_pbr import SMOOTH_ROUGHNESS
from pyrt.materials.gltf_record import GLTF_PBR, gltf_record
from pyrt.shaders import brdfs, fresnel
from pyrt.textures import compiled as TC
from test_material_contracts import QUAD_DW, QUAD_W

pytestmark = pytest.mark.filterwarnings("ignore:invalid value encountered:RuntimeWarning",
                                        "ignore:divide by zero encountered:RuntimeWarning")

MATERIALS = {
    "thin": lambda: pyrt.GltfPBR(base_color=(0.9, 0.6, 0.3), metallic=0.2, roughness=0.4, transmission=0.8,
                                 specular=0.7, specular_color=(1.0, 0.8, 0.6), ior=1.7),
    "thin_full": lambda: pyrt.GltfPBR(base_color=(0.8, 0.8, 0.2), metallic=0.0, roughness=0.6, transmission=1.0,
                                      geometry="smith_correlated"),
    "thin_metal": lambda: pyrt.GltfPBR(base_color=(0.7, 0.3, 0.3), metallic=0.9, roughness=0.2, transmission=0.5),
    "thin_smooth": lambda: pyrt.GltfPBR(base_color=(0.7, 0.3, 0.3), metallic=0.1, roughness=0.02, transmission=0.5),
    "volume": lambda: pyrt.GltfPBR(base_color=(0.6, 0.9, 0.7), metallic=0.1, roughness=0.5, transmission=0.9,
                                   ior=1.45, thin=False),
    "volume_sharp": lambda: pyrt.GltfPBR(base_color=0.9, roughness=0.15, transmission=1.0, ior=1.33, thin=False),
}
NAMES = sorted(MATERIALS)
#: lobes no narrower than roughness 0.5 for the chi-square harness's 8 x 8 Gauss points per cell
CHI2 = {
    "thin": lambda: pyrt.GltfPBR(base_color=(0.9, 0.6, 0.3), metallic=0.2, roughness=0.6, transmission=0.8,
                                 specular=0.7, ior=1.7),
    "thin_full": MATERIALS["thin_full"],
    "volume": lambda: pyrt.GltfPBR(base_color=0.8, roughness=0.6, transmission=0.9, ior=1.45, thin=False),
}


def _inputs(mat):
    """``(record, inputs, t, thin, eta, geometry)`` of a GltfPBR's constant parameters as the kernel reads them
    (:func:`pyrt.materials.compiled.gltf_inputs` of its GLTF record; front face: ``eta = ior``)."""
    tag, rec = gltf_record(mat, lambda t: None, model=GLTF_PBR, geometry=mat.geometry, specular=mat.specular,
                           specular_color=mat.specular_color, f0_ior=float(fresnel.f0_from_ior(mat.ior_value)))
    rec = np.ascontiguousarray(rec, dtype=np.float64)
    albedo = np.array(_albedo(rec))
    return rec, albedo, float(mat.transmission), bool(mat.thin), float(mat.ior_value), int(rec[19])


@numba.njit
def _albedo(rec):
    return MC.albedo_at(MC.GLTF, rec, 0, np.zeros(1, dtype=np.int64), np.zeros(8), 0.0, 0.0, TC.NO_FOOTPRINT,
                        MC.WHITE)


@numba.njit
def _tuple(a):
    return (a[0], a[1], a[2], a[3], a[4], a[5], a[6], a[7], a[8], a[9], a[10], a[11], a[12], a[13], a[14], a[15],
            a[16], a[17])


@numba.njit
def _gltf_many(rec, a, t, thin, eta, geometry, wo, wi, u, f, pdf, swi, sw, spdf):
    albedo = _tuple(a)
    for k in range(wo.shape[0]):
        r = CT.gltf_f_cos(albedo, t, thin, eta, geometry, wo[k, 0], wo[k, 1], wo[k, 2], wi[k, 0], wi[k, 1], wi[k, 2])
        f[k, 0], f[k, 1], f[k, 2] = r
        pdf[k] = CT.gltf_pdf(rec, 0, albedo, t, thin, eta, wo[k, 0], wo[k, 1], wo[k, 2], wi[k, 0], wi[k, 1],
                             wi[k, 2])
        s = CT.gltf_sample_f(rec, 0, albedo, t, thin, eta, geometry, wo[k, 0], wo[k, 1], wo[k, 2], u[k, 0], u[k, 1])
        swi[k, 0], swi[k, 1], swi[k, 2] = s[0], s[1], s[2]
        sw[k, 0], sw[k, 1], sw[k, 2] = s[3], s[4], s[5]
        spdf[k] = s[6]


class Compiled:
    """A material whose ``f_cos``, ``sample`` and ``pdf`` are the compiled twins of a GltfPBR's."""

    def __init__(self, mat):
        self.rec, self.albedo, self.t, self.thin, self.eta, self.geometry = _inputs(mat)

    def _run(self, wo, wi, u):
        n = wo.shape[0]
        out = [np.zeros((n, 3)), np.zeros(n), np.zeros((n, 3)), np.zeros((n, 3)), np.zeros(n)]
        c = [np.ascontiguousarray(x, dtype=np.float64) for x in (wo, wi, u)]
        _gltf_many(self.rec, self.albedo, self.t, self.thin, self.eta, self.geometry, *c, *out)
        return out

    def f_cos(self, wo, wi, ctx=None):
        return self._run(wo, wi, np.zeros((wo.shape[0], 2)))[0]

    def pdf(self, wo, wi, ctx=None):
        return self._run(wo, wi, np.zeros((wo.shape[0], 2)))[1]

    def sample(self, wo, u, ctx=None):
        return tuple(self._run(wo, np.zeros_like(wo), u)[2:])


def _pairs(seed=5, n=3000):
    """``wo`` (upper hemisphere, grazing and normal included) and ``wi`` over the whole sphere (grazing on both
    sides, ``wi = -wo`` straight through and ``wi`` mirrored)."""
    rng = np.random.default_rng(seed)
    wo, wi = unit(rng.normal(size=(n, 3))), unit(rng.normal(size=(n, 3)))
    wo[:, 2] = np.abs(wo[:, 2])
    g = np.array([direction_cos(c, 0.3) for c in (1.0, 0.999999, 0.5, 1e-3, 1e-6, 0.0)])
    gi = np.array([direction_cos(c, 2.0) for c in (1e-6, -1e-6, 1e-3, -1e-3, -0.5, -1.0)])
    wo_g = np.repeat(g, len(gi), axis=0)
    wi_g = np.tile(gi, (len(g), 1))
    return (np.concatenate([wo, wo_g, g, g, wo[:500]]),
            np.concatenate([wi, wi_g, -g, g * [1.0, 1.0, -1.0], -wo[:500]]))


# ----------------------------------------------------------------------------------------- the lobes' twins

@numba.njit
def _lobes_many(wo, wi, u, alpha, eta, s, f0, out, dirs):
    for k in range(wo.shape[0]):
        a, b = (wo[k, 0], wo[k, 1], wo[k, 2]), (wi[k, 0], wi[k, 1], wi[k, 2])
        out[k, 0] = CT.thin_btdf(a[0], a[1], a[2], b[0], b[1], b[2], alpha, s, f0[0], f0[1], f0[2])
        out[k, 1] = CT.thin_btdf_pdf(a[0], a[1], a[2], b[0], b[1], b[2], alpha)
        out[k, 2] = CT.rough_dielectric_f_cos(a[0], a[1], a[2], b[0], b[1], b[2], alpha, eta)
        out[k, 3] = CT.rough_dielectric_pdf(a[0], a[1], a[2], b[0], b[1], b[2], alpha, eta)
        r = CT.sample_rough_dielectric(a[0], a[1], a[2], u[k, 0], u[k, 1], alpha, eta)
        dirs[k, 0], dirs[k, 1], dirs[k, 2], dirs[k, 3] = r[0], r[1], r[2], 1.0 if r[3] else 0.0
        r = CT.sample_thin_btdf(a[0], a[1], a[2], u[k, 0], u[k, 1], alpha)
        dirs[k, 4], dirs[k, 5], dirs[k, 6], dirs[k, 7] = r[0], r[1], r[2], 1.0 if r[3] else 0.0


@pytest.mark.parametrize("alpha", [1e-5, 0.04, 0.25, 0.8])
@pytest.mark.parametrize("eta", [1.5, 1.0 / 1.33])
def test_lobes_equal_the_numpy_kernels(alpha, eta):
    """Both sides of the interface (``wo`` below too), grazing directions, ``wi = -wo``."""
    wo, wi = _pairs()
    wo = np.concatenate([wo, -wo[:800]])
    wi = np.concatenate([wi, wi[:800]])
    u = np.random.default_rng(8).random((wo.shape[0], 2))
    u[:20] = [[0.0, 0.0], [np.nextafter(1.0, 0.0), 0.5]] * 10
    s, f0 = 0.7, np.array([0.06, 0.04, 0.03])
    out, dirs = np.zeros((wo.shape[0], 4)), np.zeros((wo.shape[0], 8))
    _lobes_many(wo, wi, u, alpha, eta, s, f0, out, dirs)
    spec, cos_oh = brdfs.thin_transmission_spec_cos(wo, wi, alpha)
    thin = spec * (1.0 - s * fresnel.fr_schlick(cos_oh, np.broadcast_to(f0, (wo.shape[0], 3))).max(axis=1))
    np.testing.assert_allclose(out[:, 0], thin, rtol=1e-6, atol=1e-12)
    mat = pyrt.GltfPBR(roughness=np.sqrt(alpha), transmission=1.0)
    ctx = LocalCtx(wo.shape[0])
    up = wo[:, 2] > 0
    np.testing.assert_allclose(out[up, 1], mat._btdf_pdf(wo, wi, ctx)[up], rtol=1e-6, atol=1e-12)
    np.testing.assert_allclose(out[:, 2], brdfs.rough_dielectric_f_cos(wo, wi, alpha, eta), rtol=1e-6, atol=1e-12)
    np.testing.assert_allclose(out[:, 3], brdfs.rough_dielectric_pdf(wo, wi, alpha, eta), rtol=1e-6, atol=1e-12)
    want, valid = brdfs.sample_rough_dielectric(wo, u, alpha, np.full(wo.shape[0], eta))
    np.testing.assert_array_equal(dirs[:, 3] != 0, valid)
    np.testing.assert_allclose(dirs[:, :3], want, rtol=1e-6, atol=1e-12)
    assert np.all(np.isfinite(out)) and np.all(out >= 0) and thin.max() > 0


# ----------------------------------------------------------------------------------------- the glTF mixture

@pytest.mark.parametrize("name", NAMES)
def test_f_cos_and_pdf_equal_gltf_pbr(name):
    mat = MATERIALS[name]()
    wo, wi = _pairs()
    c = Compiled(mat)
    ctx = LocalCtx(wo.shape[0])
    got = c.f_cos(wo, wi)
    np.testing.assert_allclose(got, mat.f_cos(wo, wi, ctx), rtol=1e-6, atol=1e-12)
    np.testing.assert_allclose(c.pdf(wo, wi), mat.pdf(wo, wi, ctx), rtol=1e-6, atol=1e-12)
    assert np.all(np.isfinite(got)) and np.all(got >= 0)
    if name != "thin_smooth":
        assert got[wi[:, 2] < 0].max() > 0       # the lobe below the horizon is there


@pytest.mark.parametrize("name", NAMES)
def test_same_u_gives_the_gltf_pbr_direction_weight_and_pdf(name):
    mat = MATERIALS[name]()
    wo, u = wo_u_cases()
    wi, weight, pdf = Compiled(mat).sample(wo, u)
    want_wi, want_w, want_pdf = mat.sample(wo, u, LocalCtx(wo.shape[0]))
    ok = want_pdf > 0        # where NumPy's opaque sampler keeps an invalid lane's direction, the twin's is zero
    np.testing.assert_allclose(wi[ok], want_wi[ok], rtol=1e-6, atol=1e-12)
    np.testing.assert_allclose(pdf, want_pdf, rtol=1e-6, atol=1e-12)
    np.testing.assert_allclose(weight, want_w, rtol=1e-6, atol=1e-12)
    assert np.all(np.isfinite(weight)) and np.all(weight >= 0)
    if name != "thin_smooth":           # both lobes sampled (the reflection's only below full transmission)
        assert np.any(wi[ok, 2] < 0) and (mat.transmission == 1.0 or np.any(wi[ok, 2] > 0))


def test_the_rough_share_switches_at_the_smooth_limit():
    """``gltf_shares`` of the GltfPBR's ``_transmission_weights``: the rough lobe's weight above the limit, the
    specular share ``1 - t`` at or below it."""
    a = (0.0,) * 6 + (0.25, SMOOTH_ROUGHNESS) + (0.0,) * 10
    assert CT.gltf_shares(a, 0.8) == (0.0, pytest.approx(0.2))
    a = (0.0,) * 6 + (0.25, np.nextafter(SMOOTH_ROUGHNESS, 1.0)) + (0.0,) * 10
    assert CT.gltf_shares(a, 0.8) == (pytest.approx(0.6), 1.0)


# ----------------------------------------------------------------------------------------- contracts

def _sphere_chi_square_p(mat, theta_o, n=200_000, nt=24, nphi=24):
    """p-value of the chi-square test of ``mat.sample`` against ``mat.pdf`` over the whole sphere: 200k sampled
    directions in ``nt x nphi`` (cos theta in [-1, 1], phi) cells against the pdf integrated over each cell
    (:func:`material_helpers.chi_square_cells_p`); cells with expectation < 5 and the invalid samples (pdf 0) pooled
    with the missing mass."""
    wo_d = direction(theta_o, 10.0)
    wi, _, pdf = mat.sample(np.tile(wo_d, (n, 1)), np.random.default_rng(4).random((n, 2)))
    return chi_square_cells_p(lambda w: mat.pdf(np.tile(wo_d, (w.shape[0], 1)), w), wi, pdf > 0,
                              np.linspace(-1.0, 1.0, nt + 1), np.linspace(-np.pi, np.pi, nphi + 1))


@pytest.mark.parametrize("name", sorted(CHI2))
@pytest.mark.parametrize("theta_o", [30.0, 75.0])
def test_sampler_follows_its_pdf_over_the_sphere_chi_square(name, theta_o):
    assert _sphere_chi_square_p(Compiled(CHI2[name]()), theta_o) > 1e-4


def test_the_sphere_harness_rejects_a_wrong_pdf():
    """The harness has power: the sampler of roughness 0.6 against the pdf of roughness 0.66."""
    sampler = Compiled(CHI2["thin_full"]())
    sampler.pdf = Compiled(pyrt.GltfPBR(base_color=(0.8, 0.8, 0.2), roughness=0.66, transmission=1.0,
                                        geometry="smith_correlated")).pdf
    assert _sphere_chi_square_p(sampler, 30.0) < 1e-6


@pytest.mark.parametrize("thin", [True, False])
@pytest.mark.parametrize("theta_o", [0.0, 45.0, 80.0])
def test_white_furnace(thin, theta_o):
    """A white, non-metallic surface: reflected plus transmitted power (the volume's 1/eta^2 compression undone)
    <= 1 by quadrature at full transmission; at transmission 0.7 and 1 the sampler's mean weight equals the
    quadrature of ``f_cos`` over the sphere within 4 standard errors (at 1 the specular reflection on top is
    sampled too: :func:`pyrt.materials.compiled_transmission.transmission_choice`)."""
    ior = 1.5
    n = QUAD_W.shape[0]
    wo = np.tile(direction(theta_o), (n, 1))
    below = QUAD_W * [1.0, 1.0, -1.0]

    def quadrature(c):
        return (np.sum(c.f_cos(wo, QUAD_W) * QUAD_DW[:, None], axis=0),
                np.sum(c.f_cos(wo, below) * QUAD_DW[:, None], axis=0))
    up, down = quadrature(Compiled(pyrt.GltfPBR(base_color=1.0, roughness=0.5, transmission=1.0, ior=ior, thin=thin)))
    power = up + (1.0 if thin else ior ** 2) * down
    assert np.all(power <= 1.0 + 2e-3) and np.all(power > 0.5), power
    for t in (0.7, 1.0):
        c = Compiled(pyrt.GltfPBR(base_color=1.0, roughness=0.5, transmission=t, ior=ior, thin=thin))
        up, down = quadrature(c)
        m = 400_000
        _, weight, _ = c.sample(np.tile(direction(theta_o), (m, 1)), np.random.default_rng(6).random((m, 2)))
        se = weight.std(axis=0) / np.sqrt(m)
        assert np.all(np.abs(weight.mean(axis=0) - (up + down)) < 4 * se + 1e-3), (t, weight.mean(axis=0), up + down)


def _across(seed, n=2000):
    """``n`` random pairs of unit directions on either side of the surface: ``a`` above, ``b`` below (both at least
    ~0.05 off the horizon before normalising)."""
    rng = np.random.default_rng(seed)
    a, b = unit(rng.normal(size=(n, 3))), unit(rng.normal(size=(n, 3)))
    a[:, 2] = np.abs(a[:, 2]) + 0.05
    b[:, 2] = -np.abs(b[:, 2]) - 0.05
    return unit(a), unit(b)


def test_thin_lobe_is_reciprocal():
    """``f(wo, wi) = f(wi', wo')`` with the pair mirrored through the sheet (the light's path reversed)."""
    a, b = _across(2)
    out_ab, out_ba = np.zeros((2000, 4)), np.zeros((2000, 4))
    flip = np.array([1.0, 1.0, -1.0])
    f0 = np.array([0.05, 0.04, 0.03])
    _lobes_many(a, b, np.zeros((2000, 2)), 0.3, 1.5, 0.8, f0, out_ab, np.zeros((2000, 8)))
    _lobes_many(b * flip, a * flip, np.zeros((2000, 2)), 0.3, 1.5, 0.8, f0, out_ba, np.zeros((2000, 8)))
    np.testing.assert_allclose(out_ab[:, 0] / -b[:, 2], out_ba[:, 0] / a[:, 2], rtol=1e-9, atol=1e-12)
    assert out_ab[:, 0].max() > 0


def test_interface_obeys_generalised_reciprocity():
    """The radiance-mode BTDF: ``f(wo, wi) / eta_o^2 = f(wi, wo) / eta_i^2`` (outside index 1, inside ``eta``)."""
    a, b = _across(3)
    eta = 1.5
    out_ab, out_ba = np.zeros((2000, 4)), np.zeros((2000, 4))
    _lobes_many(a, b, np.zeros((2000, 2)), 0.3, eta, 0.0, np.zeros(3), out_ab, np.zeros((2000, 8)))
    _lobes_many(b, a, np.zeros((2000, 2)), 0.3, eta, 0.0, np.zeros(3), out_ba, np.zeros((2000, 8)))
    np.testing.assert_allclose(out_ab[:, 2] / -b[:, 2], out_ba[:, 2] / a[:, 2] / eta ** 2, rtol=1e-9, atol=1e-12)
    assert out_ab[:, 2].max() > 0


# ----------------------------------------------------------------------------------------- the fallback

TRANSMISSION_TEST = os.path.join(os.path.dirname(__file__), "..", "..", "shared", "khronos-gltf", "TransmissionTest",
                                 "TransmissionTest.glb")


def test_rough_transmission_falls_back_with_its_materials_named():
    scene = pyrt.Scene(pyrt.Camera())
    rough = pyrt.GltfPBR(roughness=0.4, transmission=1.0, name="frosted")
    glass = pyrt.RoughDielectric(roughness=0.3, name="rough_glass")
    for m in (rough, glass, pyrt.GltfPBR(roughness=0.01, transmission=1.0, name="clear")):
        scene.add_material(m)
    reasons = C.glossy_reasons(scene)
    assert len(reasons) == 1 and "rough transmission" in reasons[0]
    assert "frosted" in reasons[0] and "rough_glass" in reasons[0] and "clear" not in reasons[0]


@pytest.mark.skipif(not os.path.exists(TRANSMISSION_TEST), reason="../shared/khronos-gltf is absent")
def test_transmission_test_falls_back_naming_its_rough_materials():
    """TransmissionTest's previews render through the NumPy path, the reason naming its rough transmitting
    materials (the compiled kernel does not sample rough transmission yet)."""
    from pyrt.apps.preview.render import PreviewScene
    from pyrt.io.assets.gltf import load_gltf

    scene = PreviewScene(load_gltf(TRANSMISSION_TEST)).scene
    reasons = C.unsupported(None, integrator="glossy", scene=scene, transparent_shadows=True)
    rough = [r for r in reasons if r.startswith("the glossy integrator with rough transmission")]
    assert len(rough) == 1 and "YellowTransRough" in rough[0] and "GreenMaskRough" in rough[0]
