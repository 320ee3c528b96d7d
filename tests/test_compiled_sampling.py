"""The compiled BSDF sampling (:mod:`pyrt.materials.compiled_sampling`) against the materials' NumPy samplers.

For every compiled material family (the record its ``compiled_record`` packs; several parameter sets for the
microfacet mixtures: every distribution, ``p_spec`` 0 < p < 1 and 1, roughness 0), compiled in ``numba.njit`` loops:

- the same ``u`` gives the same local direction, weight and pdf as the material's NumPy ``sample(wo, u, ctx)``
  (1e-6 relative, 1e-12 absolute), for random ``wo`` and ``u`` plus grazing ``wo`` (cos 1e-3, 1e-6, 0, -1e-6),
  normal incidence and ``u`` at 0 and just below 1;
- the pdf of any ``(wo, wi)`` (below the horizon too) equals the NumPy ``pdf`` (same tolerance);
- the sampled directions follow the compiled pdf: the chi-square harness of tests/test_material_contracts.py
  (200k samples, 12 x 24 cells, rejected at p < 1e-4) run on the compiled sampler and pdf;
- a clear coat over a GLTF record (its coat's normal the shading normal; tilted: tests/test_compiled_clearcoat.py)
  likewise;
- the frame (:func:`coordinate_frame`, :func:`to_local`, :func:`to_world`) is the NumPy path's bit for bit.
"""
import types

import numba
import numpy as np
import pytest

import pyrt
from material_helpers import LocalCtx, direction_cos, unit, wo_u_cases
from pyrt.geometry.surface import SurfaceBatch
from pyrt.materials import compiled as MC
from pyrt.materials import compiled_sampling as CS
from pyrt.shaders import sampling as S
from pyrt.shaders import vec
from pyrt.textures import compiled as TC
from test_material_contracts import _chi_square_p

pytestmark = pytest.mark.filterwarnings("ignore:invalid value encountered:RuntimeWarning",
                                        "ignore:divide by zero encountered:RuntimeWarning")

MATERIALS = {
    "lambert": lambda: pyrt.Lambert((0.7, 0.5, 0.3)),
    "blinn_phong": lambda: pyrt.BlinnPhong(kd=0.5, ks=0.3, exponent=40.0),
    "phong": lambda: pyrt.Phong(kd=0.4, ks=0.3, exponent=20.0),
    "phong_classic": lambda: pyrt.PhongClassic(kd=0.4, ks=0.5, exponent=10.0),
    "blinn_phong_classic": lambda: pyrt.BlinnPhongClassic(kd=0.3, ks=0.5, exponent=30.0),
    "oren_nayar": lambda: pyrt.OrenNayar(0.6, sigma=0.4),
    "ward": lambda: pyrt.Ward(kd=0.3, ks=0.4, alpha=0.2),
    "ct_ggx_spec": lambda: pyrt.CookTorrance(kd=0.0, ks=1.0, roughness=0.5),
    "ct_ggx_mix": lambda: pyrt.CookTorrance(kd=(0.5, 0.3, 0.2), ks=0.3, roughness=0.3, fresnel="conductor",
                                            metal="gold"),
    "ct_ggx_smooth": lambda: pyrt.CookTorrance(kd=0.2, ks=0.6, roughness=0.0),
    "ct_beckmann": lambda: pyrt.CookTorrance(kd=0.3, ks=0.6, alpha=0.3, distribution="beckmann"),
    "ct_blinn": lambda: pyrt.CookTorrance(kd=0.2, ks=0.5, roughness=0.4, distribution="blinn", ior=1.5),
    "ct_black": lambda: pyrt.CookTorrance(kd=0.0, ks=0.0, roughness=0.5),
    "mr_dielectric": lambda: pyrt.MetallicRoughness(base_color=(0.8, 0.3, 0.2), metallic=0.0, roughness=0.5),
    "mr_metal": lambda: pyrt.MetallicRoughness(base_color=(0.9, 0.7, 0.3), metallic=1.0, roughness=0.3),
    "mr_half": lambda: pyrt.MetallicRoughness(base_color=0.6, metallic=0.5, roughness=0.8,
                                              geometry="smith_correlated"),
    "learnopengl": lambda: pyrt.LearnOpenGLPBR(albedo=(0.5, 0.6, 0.7), metallic=0.3, roughness=0.6),
    "gltf_pbr": lambda: pyrt.GltfPBR.example(),
    "gltf_pbr_metal": lambda: pyrt.GltfPBR(base_color=(0.9, 0.6, 0.4), metallic=0.7, roughness=0.35, specular=0.5,
                                           ior=1.33, geometry="smith_correlated"),
    "clearcoat": lambda: pyrt.Clearcoat.example(),
    "clearcoat_smooth": lambda: pyrt.Clearcoat(pyrt.GltfPBR.example(), clearcoat=0.6, roughness=0.03),
}
NAMES = sorted(MATERIALS)
#: one material per sampler for the chi-square test (the cosine families share one sampler; the mixtures differ by
#: their record). Lobes no narrower than roughness 0.5: the harness's 8 x 8 Gauss points per cell do not integrate
#: a narrower lobe at 75 degrees (the NumPy CookTorrance(roughness=0.3) itself fails there, p ~ 1e-60)
CHI2 = {
    "lambert": MATERIALS["lambert"],
    "ward": MATERIALS["ward"],
    "ct_ggx_spec": MATERIALS["ct_ggx_spec"],
    "ct_ggx_mix": lambda: pyrt.CookTorrance(kd=(0.5, 0.3, 0.2), ks=0.3, roughness=0.5, fresnel="conductor",
                                            metal="gold"),
    "ct_beckmann": lambda: pyrt.CookTorrance(kd=0.3, ks=0.6, roughness=0.5, distribution="beckmann"),
    "ct_blinn": lambda: pyrt.CookTorrance(kd=0.2, ks=0.5, roughness=0.5, distribution="blinn", ior=1.5),
    "mr_dielectric": MATERIALS["mr_dielectric"],
    "mr_metal": lambda: pyrt.MetallicRoughness(base_color=(0.9, 0.7, 0.3), metallic=1.0, roughness=0.5),
    "learnopengl": MATERIALS["learnopengl"],
    "gltf_pbr": lambda: pyrt.GltfPBR(base_color=(0.8, 0.5, 0.3), metallic=0.4, roughness=0.5, specular=0.7,
                                     specular_color=(1.0, 0.8, 0.6), ior=1.7),
    "clearcoat": lambda: pyrt.Clearcoat(pyrt.MetallicRoughness(base_color=(0.7, 0.1, 0.1), roughness=0.5),
                                        clearcoat=0.8, roughness=0.5),
}


def _record(mat):
    tag, rec = mat.compiled_record(lambda t: None)
    return tag, np.ascontiguousarray(rec, dtype=np.float64)


@numba.njit
def _sample_many(tag, rec, wo, u, wi, weight, pdf):
    tex_tag = np.zeros(1, dtype=np.int64)
    tex_par = np.zeros(8)
    albedo = MC.albedo_at(tag, rec, 0, tex_tag, tex_par, 0.0, 0.0, TC.NO_FOOTPRINT, MC.WHITE)
    for k in range(wo.shape[0]):
        r = CS.sample_f(tag, rec, 0, albedo, wo[k, 0], wo[k, 1], wo[k, 2], u[k, 0], u[k, 1])
        wi[k, 0], wi[k, 1], wi[k, 2] = r[0], r[1], r[2]
        weight[k, 0], weight[k, 1], weight[k, 2] = r[3], r[4], r[5]
        pdf[k] = r[6]
        d = CS.sample_wi(tag, rec, 0, albedo, wo[k, 0], wo[k, 1], wo[k, 2], u[k, 0], u[k, 1])
        if d[0] != r[0] or d[1] != r[1] or d[2] != r[2] or d[3] != r[6]:
            pdf[k] = np.nan            # sample_wi and sample_f disagree


@numba.njit
def _pdf_many(tag, rec, wo, wi, out):
    tex_tag = np.zeros(1, dtype=np.int64)
    tex_par = np.zeros(8)
    albedo = MC.albedo_at(tag, rec, 0, tex_tag, tex_par, 0.0, 0.0, TC.NO_FOOTPRINT, MC.WHITE)
    for k in range(wo.shape[0]):
        out[k] = CS.pdf_wi(tag, rec, 0, albedo, wo[k, 0], wo[k, 1], wo[k, 2], wi[k, 0], wi[k, 1], wi[k, 2])


class Compiled:
    """A material whose ``sample`` and ``pdf`` are the compiled twins of ``mat``'s (for the chi-square harness)."""

    def __init__(self, mat):
        self.tag, self.rec = _record(mat)

    def sample(self, wo, u, ctx):
        n = wo.shape[0]
        wi, weight, pdf = np.zeros((n, 3)), np.zeros((n, 3)), np.zeros(n)
        _sample_many(self.tag, self.rec, np.ascontiguousarray(wo, dtype=np.float64),
                     np.ascontiguousarray(u, dtype=np.float64), wi, weight, pdf)
        return wi, weight, pdf

    def pdf(self, wo, wi, ctx):
        out = np.zeros(wo.shape[0])
        _pdf_many(self.tag, self.rec, np.ascontiguousarray(wo, dtype=np.float64),
                  np.ascontiguousarray(wi, dtype=np.float64), out)
        return out


@pytest.mark.parametrize("name", NAMES)
def test_same_u_gives_the_numpy_direction_weight_and_pdf(name):
    mat = MATERIALS[name]()
    wo, u = wo_u_cases()
    wi, weight, pdf = Compiled(mat).sample(wo, u, None)
    assert not np.any(np.isnan(pdf)), "sample_wi and sample_f disagree"
    want_wi, want_w, want_pdf = mat.sample(wo, u, LocalCtx(wo.shape[0]))
    np.testing.assert_allclose(wi, want_wi, rtol=1e-6, atol=1e-12)
    np.testing.assert_allclose(pdf, want_pdf, rtol=1e-6, atol=1e-12)
    np.testing.assert_allclose(weight, want_w, rtol=1e-6, atol=1e-12)
    assert np.all(np.isfinite(weight)) and np.all(weight >= 0)


@pytest.mark.parametrize("name", NAMES)
def test_pdf_equals_the_numpy_pdf(name):
    mat = MATERIALS[name]()
    rng = np.random.default_rng(5)
    n = 3000
    wo, wi = unit(rng.normal(size=(n, 3))), unit(rng.normal(size=(n, 3)))
    wo[: 2 * n // 3, 2] = np.abs(wo[: 2 * n // 3, 2])
    wi[: 2 * n // 3, 2] = np.abs(wi[: 2 * n // 3, 2])
    # the sampler's own directions (the lobe's peak), grazing pairs and wo = +-wi
    swo, su = wo_u_cases(seed=9, n=500)
    swi = Compiled(mat).sample(swo, su, None)[0]
    g = np.array([direction_cos(c, 0.2) for c in (1e-6, 1e-3, 0.0, -1e-6, 1.0)])
    wo = np.concatenate([wo, swo, g, g, g])
    wi = np.concatenate([wi, swi, g, -g, g[::-1]])
    got = Compiled(mat).pdf(wo, wi, None)
    np.testing.assert_allclose(got, mat.pdf(wo, wi, LocalCtx(wo.shape[0])), rtol=1e-6, atol=1e-12)
    assert np.all(np.isfinite(got)) and np.all(got >= 0) and np.all(got[wi[:, 2] <= 0] == 0)


@pytest.mark.parametrize("name", sorted(CHI2))
@pytest.mark.parametrize("theta_o", [30.0, 75.0])
def test_compiled_sampler_follows_its_compiled_pdf_chi_square(name, theta_o):
    assert _chi_square_p(Compiled(CHI2[name]()), theta_o) > 1e-4


def test_the_chi_square_harness_rejects_a_wrong_compiled_pdf():
    """The harness has power on the compiled twins: the sampler of one roughness against the pdf of another."""
    sampler = Compiled(pyrt.CookTorrance(kd=0.0, ks=1.0, roughness=0.5))
    wrong = Compiled(pyrt.CookTorrance(kd=0.0, ks=1.0, roughness=0.55))
    sampler.pdf = wrong.pdf
    assert _chi_square_p(sampler, 30.0) < 1e-6


def test_every_compiled_family_is_covered():
    """Every tag with a non-delta lobe has a material here (a new compiled family needs its sampler tested)."""
    tags = {_record(MATERIALS[n]())[0] for n in NAMES}
    lobed = {t for t in range(1, 64) if MC.has_diffuse(t)}
    assert lobed <= tags


def test_sample_and_pdf_of_tags_without_a_lobe_are_zero():
    rec = np.zeros(MC.RECORD)
    a = (0.0,) * 8
    for tag in (MC.MIRROR, MC.GLASS, MC.CONDUCTOR, MC.EMITTER):
        assert CS.sample_wi(tag, rec, 0, a, 0.0, 0.6, 0.8, 0.3, 0.4)[3] == 0.0
        assert CS.pdf_wi(tag, rec, 0, a, 0.0, 0.6, 0.8, 0.0, -0.6, 0.8) == 0.0


# ----------------------------------------------------------------------------------------- frames and warps

def _normals(rng, n=2000):
    nn = unit(rng.normal(size=(n, 3)))
    special = [(0, 0, 1), (0, 0, -1), (1, 0, 0), (0, 1, 0), (0.6, 0.8, 0.0), (0.6, 0.0, -0.8),
               (1e-9, 0.0, -1.0), (0.0, 1e-8, 1.0)]
    return np.concatenate([nn, unit(np.array(special, dtype=np.float64))])


def test_coordinate_frame_is_the_numpy_frame_bit_for_bit(rng):
    n = _normals(rng)
    s, t = vec.coordinate_frame(n)
    got = np.array([sum(CS.coordinate_frame(*row), ()) for row in n])
    np.testing.assert_array_equal(got, np.concatenate([s, t], axis=1))


def test_to_local_and_to_world_are_the_surface_batch_frame_bit_for_bit(rng):
    n = _normals(rng)
    s, t = vec.coordinate_frame(n)
    v = rng.normal(size=n.shape)
    batch = types.SimpleNamespace(frame_s=s, frame_t=t, ns=n)
    want_local = vec.to_local(v, s, t, n)
    want_world = SurfaceBatch.to_world(batch, v)
    got_local = np.array([CS.to_local(tuple(v[k]), tuple(s[k]), tuple(t[k]), tuple(n[k])) for k in range(n.shape[0])])
    got_world = np.array([CS.to_world(tuple(v[k]), tuple(s[k]), tuple(t[k]), tuple(n[k])) for k in range(n.shape[0])])
    np.testing.assert_array_equal(got_local, want_local)
    np.testing.assert_array_equal(got_world, want_world)


@numba.njit
def _frames_compiled(n, v, out):
    for k in range(n.shape[0]):
        s, t = CS.coordinate_frame(n[k, 0], n[k, 1], n[k, 2])
        nk = (n[k, 0], n[k, 1], n[k, 2])
        w = CS.to_world((v[k, 0], v[k, 1], v[k, 2]), s, t, nk)
        out[k, 0:3] = s
        out[k, 3:6] = t
        out[k, 6:9] = w
        out[k, 9:12] = CS.to_local(w, s, t, nk)


def test_frames_compiled_equal_the_python_call(rng):
    n = _normals(rng, 200)
    v = rng.normal(size=n.shape)
    out = np.zeros((n.shape[0], 12))
    _frames_compiled(n, v, out)
    for k in range(n.shape[0]):
        s, t = CS.coordinate_frame(*n[k])
        w = CS.to_world(tuple(v[k]), s, t, tuple(n[k]))
        np.testing.assert_array_equal(out[k], np.concatenate([s, t, w, CS.to_local(w, s, t, tuple(n[k]))]))
    np.testing.assert_allclose(out[:, 9:12], v, atol=1e-12)


def test_warps_and_the_power_heuristic_match_numpy(rng):
    u = rng.random((2000, 2))
    u[:6] = [(0.5, 0.5), (0.0, 0.0), (0.5, 0.0), (0.0, 0.5), (0.9999999, 0.5), (0.25, 0.75)]
    np.testing.assert_allclose([CS.square_to_cosine_hemisphere(*x) for x in u], S.square_to_cosine_hemisphere(u),
                               rtol=1e-6, atol=1e-12)
    np.testing.assert_allclose([CS.square_to_uniform_sphere(*x) for x in u], S.square_to_uniform_sphere(u),
                               rtol=1e-6, atol=1e-12)
    w = S.square_to_cosine_hemisphere(u)
    np.testing.assert_allclose([CS.cosine_hemisphere_pdf(z) for z in w[:, 2]], S.cosine_hemisphere_pdf(w), rtol=1e-12)
    pf, pg = rng.random(500) * 3, rng.random(500) * 3
    pf[:3], pg[:3] = (0.0, 0.0, 1.0), (0.0, 1.0, 0.0)
    for beta in (1.0, 2.0):
        for nf, ng in ((1, 1), (2, 3), (4, 1)):
            np.testing.assert_allclose([CS.power_heuristic(a, b, beta, nf, ng) for a, b in zip(pf, pg)],
                                       S.power_heuristic(pf, pg, beta, nf, ng), rtol=1e-12, atol=0)
