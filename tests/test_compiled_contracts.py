"""The material contracts (tests/test_material_contracts.py) on the compiled kernel's evaluation.

For every registered material whose example packs into the compiled material table (``compiled_record``), the
kernel's own switch (:func:`pyrt.materials.compiled_sampling.f_cos_world` in the shading frame:
:func:`pyrt.materials.compiled.f_cos`, a clear coat's ``f_cos_local``; compiled here in a small Numba loop over the same
quadrature and direction sets as the NumPy contracts) must be finite, non-negative and zero below the horizon,
reciprocal where the material declares it, and conserve energy (white furnace, directional albedo <= 1) — and it
must equal the material's NumPy ``f_cos`` on the quadrature nodes (1e-6 relative).
"""
import numba
import numpy as np
import pytest

import pyrt
from material_helpers import LocalCtx, direction
from pyrt.materials import compiled as MC
from pyrt.materials import compiled_sampling as CS
from pyrt.textures import compiled as TC
from test_material_contracts import QUAD_DW, QUAD_W, _reciprocity_pair

NAMES = sorted(pyrt.MATERIALS)
COMPILED = [n for n in NAMES if pyrt.MATERIALS[n].has_diffuse
            and pyrt.MATERIALS[n].example().compiled_record(lambda t: None) is not None]


@numba.njit
def _f_cos_many(tag, rec, wo, wi, out):
    tex_tag = np.zeros(1, dtype=np.int64)
    tex_par = np.zeros(8)
    for k in range(wo.shape[0]):
        albedo = MC.albedo_at(tag, rec, 0, tex_tag, tex_par, 0.0, 0.0, TC.NO_FOOTPRINT, MC.WHITE)
        r = CS.f_cos_world(tag, rec, 0, albedo, (wo[k, 0], wo[k, 1], wo[k, 2]), (wi[k, 0], wi[k, 1], wi[k, 2]),
                           (0.0, 0.0, 1.0))
        out[k, 0], out[k, 1], out[k, 2] = r


def compiled_f_cos(mat, wo, wi):
    """The compiled f_cos (N, 3) of ``mat`` for local directions ``wo``, ``wi`` (N, 3)."""
    tag, rec = mat.compiled_record(lambda t: None)
    out = np.zeros((wo.shape[0], 3))
    _f_cos_many(tag, np.ascontiguousarray(rec, dtype=np.float64), np.ascontiguousarray(wo, dtype=np.float64),
                np.ascontiguousarray(wi, dtype=np.float64), out)
    return out


def test_the_compiled_set_is_what_the_kernel_claims():
    assert {"lambert", "blinn_phong", "phong", "cook_torrance", "metallic_roughness", "oren_nayar",
            "clearcoat"} <= set(COMPILED)


@pytest.mark.parametrize("name", COMPILED)
def test_compiled_f_cos_equals_the_numpy_f_cos_on_the_quadrature(name):
    mat = pyrt.MATERIALS[name].example()
    for theta_o in (0.0, 45.0, 80.0):
        wo = np.tile(direction(theta_o), (QUAD_W.shape[0], 1))
        want = mat.f_cos(wo, QUAD_W, LocalCtx(QUAD_W.shape[0]))
        np.testing.assert_allclose(compiled_f_cos(mat, wo, QUAD_W), want, rtol=1e-6, atol=1e-12)


@pytest.mark.parametrize("name", COMPILED)
def test_compiled_f_cos_is_finite_non_negative_and_zero_below_the_horizon(name):
    mat = pyrt.MATERIALS[name].example()
    rng = np.random.default_rng(1)
    wo, wi = rng.normal(size=(4000, 3)), rng.normal(size=(4000, 3))
    wo /= np.linalg.norm(wo, axis=1, keepdims=True)
    wi /= np.linalg.norm(wi, axis=1, keepdims=True)
    wo[:, 2] = np.abs(wo[:, 2])
    wo[:10, 2] = 0.0
    wo[:10] /= np.linalg.norm(wo[:10], axis=1, keepdims=True)
    f = compiled_f_cos(mat, wo, wi)
    assert np.all(np.isfinite(f)) and np.all(f >= 0) and np.all(f[wi[:, 2] <= 0] == 0) and f.max() > 0


@pytest.mark.parametrize("name", [n for n in COMPILED if pyrt.MATERIALS[n].reciprocal])
def test_compiled_reciprocity_where_declared(name):
    mat = pyrt.MATERIALS[name].example()

    class Compiled:
        @staticmethod
        def f_cos(a, b, ctx):
            return compiled_f_cos(mat, a, b)
    f_ab, f_ba = _reciprocity_pair(Compiled)
    np.testing.assert_allclose(f_ab, f_ba, rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("name", COMPILED)
@pytest.mark.parametrize("theta_o", [0.0, 45.0, 80.0])
def test_compiled_white_furnace(name, theta_o):
    """Directional albedo <= 1 per channel by the contracts' quadrature (error < 1e-3), for the reciprocal models
    (the classic ones are not energy conserving by construction)."""
    mat = pyrt.MATERIALS[name].example()
    wo = np.tile(direction(theta_o), (QUAD_W.shape[0], 1))
    rho = np.sum(compiled_f_cos(mat, wo, QUAD_W) * QUAD_DW[:, None], axis=0)
    assert np.all(np.isfinite(rho)) and np.all(rho >= 0)
    if mat.reciprocal:
        assert np.all(rho <= 1.0 + 2e-3), rho
