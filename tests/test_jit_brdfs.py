"""The scalar BRDFs of :mod:`pyrt.shaders.jit_brdfs` against the materials' own NumPy ``f_cos``.

For each material family (Phong, PhongClassic, BlinnPhongClassic, OrenNayar, isotropic Ward, CookTorrance with every
distribution / geometry / Fresnel option, MetallicRoughness, LearnOpenGLPBR) and the smooth Conductor's delta lobe,
a packer below turns an instance with constant parameters into the float arguments of its scalar twin (what the
material's ``compiled_record`` would store), and the twin, run as plain Python (``register_jitable`` functions are
Python functions too), must agree with ``material.f_cos(wo, wi, ctx)`` on unit directions of a local frame (z = the
normal): random pairs plus grazing (cos 1e-6, 0, -1e-6), below-horizon, ``wo.wi = +-1``, normal-incidence and
exact-mirror pairs, to 1e-6 relative (1e-12 absolute) in float64. One test compiles every twin in a ``numba.njit``
loop and checks it returns the Python call's values (a function that is not nopython-compatible fails there).
"""
import math

import numba
import numpy as np
import pytest

from pyrt.materials import (BlinnPhongClassic, Conductor, CookTorrance, LearnOpenGLPBR, MetallicRoughness, OrenNayar,
                            Phong, PhongClassic, Ward)
from pyrt.materials.base import is_texture
from pyrt.shaders import fresnel as _fresnel
from pyrt.shaders import jit_brdfs as JB
from pyrt.shaders import metals as _metals
from pyrt.shaders import microfacet as _mf
from pyrt.shaders.vec import dot, half_vector
from pyrt.textures import CheckerTexture

from material_helpers import LocalCtx

# NumPy's kernels compute masked lanes (Fresnel at wo.h = 0 under total internal reflection, ...) before np.where
pytestmark = pytest.mark.filterwarnings("ignore:invalid value encountered:RuntimeWarning")


# ----------------------------------------------------------------------------------------- packers

def _rgb(v):
    return tuple(float(x) for x in np.broadcast_to(np.asarray(v, dtype=np.float64), (3,)))


def _constant(*values):
    return not any(is_texture(v) for v in values)


def pack_phong(m):
    """Phong, PhongClassic, BlinnPhongClassic -> ``(kd_r, kd_g, kd_b, ks_r, ks_g, ks_b, exponent)``."""
    if not _constant(m.kd, m.ks, m.exponent):
        return None
    return (*_rgb(m.kd), *_rgb(m.ks), float(m.exponent))


def pack_oren_nayar(m):
    """OrenNayar -> ``(albedo_r, albedo_g, albedo_b, sigma)``."""
    if not _constant(m.albedo_value, m.sigma):
        return None
    return (*_rgb(m.albedo_value), float(m.sigma))


def pack_ward(m):
    """Ward -> ``(kd_r, kd_g, kd_b, ks_r, ks_g, ks_b, alpha, variant)``; None when anisotropic (or textured)."""
    if not _constant(m.kd, m.ks, m.alpha_x, m.alpha_y) or m.alpha_x != m.alpha_y:
        return None
    return (*_rgb(m.kd), *_rgb(m.ks), float(m.alpha_x), JB.WARD_VARIANTS.index(m.variant))


def pack_cook_torrance(m):
    """CookTorrance -> ``(kd_rgb, ks_rgb, alpha, distribution, geometry, fresnel, p_rgb, k_rgb)``."""
    if not _constant(m.kd, m.ks, m.rough):
        return None
    alpha = float(m.rough) ** 2 if m.rough_kind == "roughness" else float(m.rough)
    p, k = (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)
    if m.fresnel == "schlick":
        p = _rgb(m.f0)
    elif m.fresnel == "dielectric":
        p = (float(m.ior), float(m.ior), float(m.ior))
    elif m.fresnel == "conductor":
        p, k = _rgb(m.eta), _rgb(m.k)
    return (*_rgb(m.kd), *_rgb(m.ks), alpha, JB.DISTRIBUTIONS.index(m.distribution),
            JB.GEOMETRY_TERMS.index(m.geometry), JB.FRESNEL_MODELS.index(m.fresnel), *p, *k)


def pack_metallic_roughness(m):
    """MetallicRoughness, LearnOpenGLPBR -> ``(base_r, base_g, base_b, metallic, roughness, geometry)``."""
    if not _constant(m.base_color, m.metallic, m.roughness):
        return None
    return (*_rgb(m.base_color), float(m.metallic), float(m.roughness), JB.GEOMETRY_TERMS.index(m.geometry))


def pack_conductor(m):
    """Conductor -> ``(eta_r, eta_g, eta_b, k_r, k_g, k_b)`` for :func:`conductor_delta_weight`."""
    return (*_rgb(m.eta), *_rgb(m.k))


#: material class -> (scalar f_cos from (cos_o, cos_i, cos_io), from (cos_o, cos_i, cos_h, cos_oh) or None, packer)
MODELS = {
    Phong: (JB.phong_f_cos, None, pack_phong),
    PhongClassic: (JB.phong_classic_f_cos, None, pack_phong),
    BlinnPhongClassic: (JB.blinn_phong_classic_f_cos, None, pack_phong),
    OrenNayar: (JB.oren_nayar_f_cos, None, pack_oren_nayar),
    Ward: (JB.ward_f_cos, JB.ward_f_cos_h, pack_ward),
    CookTorrance: (JB.cook_torrance_f_cos, JB.cook_torrance_f_cos_h, pack_cook_torrance),
    MetallicRoughness: (JB.metallic_roughness_f_cos, JB.metallic_roughness_f_cos_h, pack_metallic_roughness),
    LearnOpenGLPBR: (JB.metallic_roughness_f_cos, JB.metallic_roughness_f_cos_h, pack_metallic_roughness),
}


# ----------------------------------------------------------------------------------------- directions

def _unit(v):
    v = np.asarray(v, dtype=np.float64)
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _dir(cos_t, phi):
    s = math.sqrt(max(0.0, 1.0 - cos_t * cos_t))
    return np.array([s * math.cos(phi), s * math.sin(phi), cos_t])


def _pairs(n_random=120, seed=7):
    """Unit ``(wo, wi)`` (N, 3) each: random pairs (two thirds above the horizon), and the special cases."""
    rng = np.random.default_rng(seed)
    wo, wi = _unit(rng.normal(size=(n_random, 3))), _unit(rng.normal(size=(n_random, 3)))
    up = rng.random(n_random) < 2 / 3
    wo[up, 2], wi[up, 2] = np.abs(wo[up, 2]), np.abs(wi[up, 2])
    special = []
    for c in (1.0, 0.9, 0.5, 1e-3, 1e-6, 0.0, -1e-6, -0.5, -1.0):
        w = _dir(c, 0.3)
        special += [(w, w), (w, -w)]                                      # wo.wi = 1 and -1
    for c in (1.0, 0.95, 0.7, 0.3, 0.15):                                 # exact mirror pairs
        special.append((_dir(c, 0.4), _dir(c, 0.4 + math.pi)))
    for c in (1e-6, 0.0, -1e-6):                                          # one grazing, the other random
        for phi in (0.0, 1.0, 2.5):
            special += [(_dir(c, 0.0), _dir(0.6, phi)), (_dir(0.6, phi), _dir(c, 0.0)),
                        (_dir(c, 0.0), _dir(0.05, phi))]
    for dphi in (0.0, 0.5, math.pi / 2, 2.0):                             # both grazing (not opposite)
        special.append((_dir(1e-6, 0.1), _dir(2e-6, 0.1 + dphi)))
    special += [(_dir(0.5, 0.0), _dir(-0.5, 1.0)), (_dir(-0.3, 0.0), _dir(0.8, 1.0)),
                (_dir(-0.3, 0.0), _dir(-0.8, 1.0)), (_dir(1.0, 0.0), _dir(0.2, 2.0))]
    so, si = zip(*special)
    return np.concatenate([wo, np.array(so)]), np.concatenate([wi, np.array(si)])


def _hard_pairs():
    """Pairs where ``n.h`` is ill-conditioned from the cosines: both grazing on (nearly) opposite azimuths, and
    mirror pairs at grazing (``1 + wo.wi`` cancels to a few ulps)."""
    special = []
    for c in (1e-6, 1e-4, 1e-2, 0.05):
        special.append((_dir(c, 0.2), _dir(c, 0.2 + math.pi)))           # exact mirror pair at grazing
        special.append((_dir(c, 0.2), _dir(2 * c, 0.2 + math.pi - 1e-3)))
    return np.array([p[0] for p in special]), np.array([p[1] for p in special])


WO, WI = _pairs()
HWO, HWI = _hard_pairs()


def _cosines(wo, wi):
    """``(cos_o, cos_i, cos_io)`` as pyrt's LocalCosineQuery computes them."""
    return wo[:, 2], wi[:, 2], dot(wo, wi)


def _half_cosines(wo, wi):
    """``(n.h, wo.h)`` as :func:`pyrt.shaders.brdfs.microfacet_spec_cos` computes them (the normalised half vector)."""
    h, _ = half_vector(wo, wi)
    return h[:, 2], np.clip(np.einsum("ij,ij->i", wo, h), 0.0, 1.0)


def _close(got, want):
    got, want = np.asarray(got, dtype=np.float64), np.asarray(want, dtype=np.float64)
    assert np.all(np.isfinite(got)), got
    np.testing.assert_allclose(got, want, rtol=1e-6, atol=1e-12)


def _numpy(material, wo, wi):
    return material.f_cos(wo, wi, LocalCtx(wo.shape[0], wo))


def _scalar(fn, args, *cosines):
    return np.array([fn(*c, *args) for c in zip(*cosines)])


def _check(material, hard=True):
    fn, fn_h, pack = MODELS[type(material)]
    args = pack(material)
    assert args is not None
    want = _numpy(material, WO, WI)
    assert np.all(np.isfinite(want))
    _close(_scalar(fn, args, *_cosines(WO, WI)), want)
    if fn_h is not None:
        co, ci, _ = _cosines(WO, WI)
        _close(_scalar(fn_h, args, co, ci, *_half_cosines(WO, WI)), want)
        if hard:
            # the half-vector form matches NumPy everywhere; the cosine form stays finite and non-negative there
            want = _numpy(material, HWO, HWI)
            co, ci, _ = _cosines(HWO, HWI)
            _close(_scalar(fn_h, args, co, ci, *_half_cosines(HWO, HWI)), want)
            got = _scalar(fn, args, *_cosines(HWO, HWI))
            assert np.all(np.isfinite(got)) and np.all(got >= 0.0)


# ----------------------------------------------------------------------------------------- the models

def test_option_tables_match_pyrt():
    assert JB.DISTRIBUTIONS == _mf.DISTRIBUTIONS
    assert JB.GEOMETRY_TERMS == _mf.GEOMETRY_TERMS
    assert JB.FRESNEL_MODELS == _fresnel.FRESNEL_MODELS
    assert JB.ALPHA_MIN == _mf.ALPHA_MIN


def test_directions_cover_the_degenerate_cases():
    co, ci, cio = _cosines(WO, WI)
    assert np.any(cio == 1.0) and np.any(cio == -1.0)
    for c in (0.0, 1e-6, -1e-6):
        assert np.any(np.isclose(co, c, rtol=1e-3, atol=0)) and np.any(np.isclose(ci, c, rtol=1e-3, atol=0))
    assert np.all(np.abs(np.linalg.norm(WO, axis=1) - 1) < 1e-12)


@pytest.mark.parametrize("cls", [Phong, PhongClassic, BlinnPhongClassic])
@pytest.mark.parametrize("exponent", [0.0, 1.0, 2.5, 32.0, 1000.0])
def test_phong_family(cls, exponent):
    for kd, ks in (((0.5, 0.2, 0.1), (0.3, 0.4, 0.5)), (0.0, 1.0), (1.0, 0.0)):
        _check(cls(kd=kd, ks=ks, exponent=exponent))


def test_classic_ks_above_one():
    _check(PhongClassic(kd=0.2, ks=(3.0, 1.5, 0.0), exponent=8.0))
    _check(BlinnPhongClassic(kd=0.2, ks=(3.0, 1.5, 0.0), exponent=8.0))


@pytest.mark.parametrize("sigma", [0.0, 0.05, 0.35, 1.0, math.pi / 2])
def test_oren_nayar(sigma):
    _check(OrenNayar((0.8, 0.5, 0.2), sigma=sigma))


def test_oren_nayar_degrees():
    _check(OrenNayar(0.6, sigma_deg=20.0))


@pytest.mark.parametrize("variant", JB.WARD_VARIANTS)
@pytest.mark.parametrize("alpha", [1e-4, 0.01, 0.2, 1.0])
def test_ward_isotropic(variant, alpha):
    _check(Ward(kd=(0.2, 0.1, 0.0), ks=(0.5, 0.6, 0.7), alpha=alpha, variant=variant))


def test_ward_isotropic_given_as_alpha_xy_with_a_tangent():
    _check(Ward(kd=0.1, ks=0.8, alpha_x=0.15, alpha_y=0.15, tangent=(1.0, 2.0, 0.5)))


def test_ward_anisotropic_is_not_packed():
    assert pack_ward(Ward(alpha_x=0.1, alpha_y=0.3)) is None


FRESNELS = [dict(f0=(0.9, 0.6, 0.05)), dict(ior=1.5), dict(ior=0.8), dict(metal="gold"),
            dict(eta=(0.2, 1.0, 2.5), k=(3.0, 0.0, 1.0)), dict(fresnel="none")]


@pytest.mark.parametrize("distribution", _mf.DISTRIBUTIONS)
@pytest.mark.parametrize("geometry", _mf.GEOMETRY_TERMS)
def test_cook_torrance(distribution, geometry):
    for fr in FRESNELS:
        for rough in (dict(roughness=0.0), dict(roughness=0.08), dict(roughness=0.6), dict(roughness=1.0),
                      dict(alpha=0.3)):
            _check(CookTorrance(kd=(0.3, 0.2, 0.1), ks=(0.6, 0.7, 0.8), distribution=distribution,
                                geometry=geometry, **fr, **rough), hard=rough.get("roughness") in (0.0, 0.6))


@pytest.mark.filterwarnings("ignore::RuntimeWarning")
def test_both_directions_within_1e_100_of_the_horizon():
    """Where ``cos^4`` of the half vector underflows the scalar Beckmann D is 0; NumPy's ``beckmann_d`` divides 0 by 0
    there (NaN f_cos). The twins stay finite, and agree with NumPy wherever NumPy is finite."""
    wo, wi = _unit([[1.0, 0.0, 1e-100], [1.0, 0.0, 1e-200]]), _unit([[0.0, 1.0, 1e-100], [0.0, -1.0, 1e-300]])
    for d in _mf.DISTRIBUTIONS:
        for g in _mf.GEOMETRY_TERMS:
            m = CookTorrance(kd=0.2, ks=0.8, distribution=d, geometry=g, roughness=0.5)
            want = _numpy(m, wo, wi)
            got = _scalar(JB.cook_torrance_f_cos, pack_cook_torrance(m), *_cosines(wo, wi))
            assert np.all(np.isfinite(got)) and np.all(got >= 0.0)
            ok = np.isfinite(want)
            assert d == "beckmann" or np.all(ok)
            np.testing.assert_allclose(got[ok], want[ok], rtol=1e-6, atol=1e-12)


def test_cook_torrance_defaults():
    _check(CookTorrance())
    _check(CookTorrance(distribution="blinn"))      # its default geometry is vgroove
    _check(CookTorrance(kd=0.5, ks=0.5, metal="copper", roughness=0.3))


@pytest.mark.parametrize("geometry", ["smith_separable", "smith_correlated"])
@pytest.mark.parametrize("metallic", [0.0, 0.4, 1.0])
def test_metallic_roughness(geometry, metallic):
    for roughness in (0.0, 0.03, 0.5, 1.0):
        _check(MetallicRoughness(base_color=(0.9, 0.5, 0.1), metallic=metallic, roughness=roughness,
                                 geometry=geometry), hard=roughness in (0.0, 0.5))


@pytest.mark.parametrize("metallic", [0.0, 0.7, 1.0])
def test_learnopengl(metallic):
    for roughness in (0.0, 0.05, 0.5, 1.0):
        _check(LearnOpenGLPBR(albedo=(0.2, 0.8, 0.4), metallic=metallic, roughness=roughness))


@pytest.mark.parametrize("params", [dict(metal=name) for name in _metals.METALS]
                         + [dict(eta=(0.2, 1.0, 2.5), k=(3.0, 0.0, 1.0)), dict(eta=1.0, k=0.0)])
def test_conductor_delta_weight(params):
    m = Conductor(**params)
    args = pack_conductor(m)
    wo = np.concatenate([WO, _unit([[0.3, 0.0, 1e-300], [1.0, 0.0, 0.0]])])
    lobes = m.delta_lobes(wo, LocalCtx(wo.shape[0], wo))
    assert len(lobes) == 1
    _close([JB.conductor_delta_weight(c, *args) for c in wo[:, 2]], lobes[0].weight)


def test_packers_refuse_textures():
    tex = CheckerTexture()
    assert pack_phong(Phong(kd=tex, ks=0.1)) is None
    assert pack_oren_nayar(OrenNayar(tex)) is None
    assert pack_cook_torrance(CookTorrance(roughness=tex)) is None
    assert pack_metallic_roughness(MetallicRoughness(base_color=tex)) is None


# ----------------------------------------------------------------------------------------- compiled

def _compiled_loop(fn, n_cos, n_args):
    """``fn`` over rows of cosines (3, or 4 for the ``*_f_cos_h`` forms) in a ``numba.njit`` loop; the call is
    spelt out (Numba cannot call a closure's function with ``*args``)."""
    call = ", ".join([f"cos[j, {i}]" for i in range(n_cos)] + [f"args[{i}]" for i in range(n_args)])
    src = (f"def run(cos, args):\n    out = np.empty((cos.shape[0], 3))\n    for j in range(cos.shape[0]):\n"
           f"        out[j, 0], out[j, 1], out[j, 2] = fn({call})\n    return out\n")
    namespace = {"np": np, "fn": fn}
    exec(src, namespace)
    return numba.njit(namespace["run"])


@numba.njit
def _conductor_loop(c, eta_r, eta_g, eta_b, k_r, k_g, k_b):
    out = np.empty((c.size, 3))
    for j in range(c.size):
        out[j, 0], out[j, 1], out[j, 2] = JB.conductor_delta_weight(c[j], eta_r, eta_g, eta_b, k_r, k_g, k_b)
    return out


def test_scalar_functions_compile_in_nopython_mode():
    """Every twin in a nopython loop returns what the Python call returns (every option of the integer switches
    reached: each distribution, geometry term and Fresnel model once)."""
    wo, wi = np.concatenate([WO, HWO]), np.concatenate([WI, HWI])
    cos3 = np.stack(_cosines(wo, wi), axis=1)
    cos4 = np.stack([wo[:, 2], wi[:, 2], *_half_cosines(wo, wi)], axis=1)
    cases = [Phong(kd=0.3, ks=0.5, exponent=20.0), PhongClassic(exponent=7.5), BlinnPhongClassic(exponent=3.0),
             OrenNayar(0.7, sigma=0.4), Ward(alpha=0.1, variant="ward"), Ward(alpha=0.3), MetallicRoughness(),
             LearnOpenGLPBR(metallic=1.0, roughness=0.2)]
    cases += [CookTorrance(kd=0.2, ks=0.8, distribution=d, geometry=g, roughness=0.4, **fr)
              for d, g, fr in zip(_mf.DISTRIBUTIONS * 2, _mf.GEOMETRY_TERMS, FRESNELS)]
    loops = {}
    for m in cases:
        fn, fn_h, pack = MODELS[type(m)]
        args = pack(m)
        for f, cos in ((fn, cos3), (fn_h, cos4)):
            if f is not None:
                loop = loops.setdefault(f, _compiled_loop(f, cos.shape[1], len(args)))
                np.testing.assert_allclose(loop(cos, args), _scalar(f, args, *cos.T), rtol=1e-13, atol=1e-300)
    args = pack_conductor(Conductor(metal="copper"))
    c = np.concatenate([WO[:, 2], [0.0, -0.5, 1e-300]])
    np.testing.assert_allclose(_conductor_loop(c, *args), [JB.conductor_delta_weight(x, *args) for x in c],
                               rtol=1e-13, atol=1e-300)
