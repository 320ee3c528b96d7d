"""The vectorised packet stages against the general ones they stand in for, on random scratch contents (grazing and
below-horizon cosines, misses, lights that cannot reach the side): :func:`lambert_stage` gives bit for bit what
:func:`bsdf_stage` gives for Lambert hits (the value, the lit flag, the shadow packet's lanes, the count), and
:func:`shadow_add` adds what the kernel's per-lane rule adds."""
import numba
import numpy as np

from pyrt.core import unmanaged as U
from pyrt.geometry import embree_jit as E
from pyrt.integrators import kernel_cache
from pyrt.integrators.compiled_layout import (
    LANES, V_A, V_COSI, V_COSIO, V_COSO, V_F, V_GOK, V_L, V_LIT, V_MAT, V_S, V_SIZE)
from pyrt.integrators.compiled_lighting import bsdf_stage, lambert_stage, shadow_add
from pyrt.lights import compiled as LC
from pyrt.materials import compiled as MC

kernel_cache.use_cache_dir()      # cached with the render kernels (keyed on their sources' hash)


@numba.njit(cache=True)
def _both_bsdf(V0, mats_tag, mats_par, lights_par, n):
    """(scratch, valid lanes, count) after bsdf_stage and after lambert_stage, from the same scratch."""
    Va, Vb = V0.copy(), V0.copy()
    sa, sb = E.packet_alloc(LANES), E.packet_alloc(LANES)
    na = bsdf_stage(U.pointer(mats_tag), U.pointer(mats_par), U.pointer(lights_par), 0, U.pointer(Va), U.pointer(sa),
                    LANES, n)
    nb = lambert_stage(U.pointer(lights_par), 0, U.pointer(Vb), U.pointer(sb), LANES, n)
    return Va, Vb, E.packet_valid(sa).copy(), E.packet_valid(sb).copy(), na, nb


@numba.njit(cache=True)
def _shadow_add(V0, blocked, n, inv):
    V = V0.copy()
    sh = E.packet_alloc(LANES)
    for lane in range(n):
        E.packet_set_dir(U.pointer(sh), LANES, lane, 0.0, 0.0, 1.0, -np.inf if blocked[lane] else 1.0)
    shadow_add(U.pointer(V), U.pointer(sh), LANES, n, inv)
    return V


kernel_cache.restore()


def _scratch(rng):
    V = np.zeros(V_SIZE * LANES)
    cos = rng.uniform(-1.0, 1.0, (3, LANES))
    cos[:, :4] = (1e-12, -0.0, 0.0, 1e-300)             # grazing and zero cosines
    for k, f in enumerate((V_COSO, V_COSI, V_COSIO)):
        V[f * LANES:(f + 1) * LANES] = cos[k]
    V[V_S * LANES:(V_S + 1) * LANES] = rng.uniform(0.0, 3.0, LANES)
    V[V_GOK * LANES:(V_GOK + 1) * LANES] = rng.random(LANES) < 0.8
    V[V_MAT * LANES:(V_MAT + 1) * LANES] = np.where(rng.random(LANES) < 0.2, -1.0, 0.0)
    V[V_A * LANES:(V_A + 3) * LANES] = rng.uniform(0.0, 1.0, 3 * LANES)
    V[V_A * LANES] = 0.0                                  # a black lane: no shadow ray
    V[V_L * LANES:(V_L + 3) * LANES] = rng.uniform(0.0, 1.0, 3 * LANES)
    V[V_F * LANES:(V_F + 3) * LANES] = rng.uniform(0.0, 1.0, 3 * LANES)
    V[V_LIT * LANES:(V_LIT + 1) * LANES] = rng.random(LANES) < 0.7
    return V


def test_lambert_stage_is_bsdf_stage_on_lambert_hits():
    rng = np.random.default_rng(11)
    mats_tag = np.array([MC.LAMBERT], dtype=np.int64)
    mats_par = np.zeros(MC.RECORD)
    mats_par[0] = -1.0                                   # a constant albedo slot (the stages read V_A)
    lights_par = np.zeros(LC.RECORD)
    lights_par[6:9] = (2.0, 0.5, 0.0)                    # one channel of the light is black
    lit = []
    for trial in range(50):
        n = LANES if trial % 2 else int(rng.integers(1, LANES))
        Va, Vb, va, vb, na, nb = _both_bsdf(_scratch(rng), mats_tag, mats_par, lights_par, n)
        assert na == nb
        lit.append(na / n)
        assert np.array_equal(va, vb)
        for f in (V_F, V_F + 1, V_F + 2, V_LIT):
            assert np.array_equal(Va[f * LANES:f * LANES + n].view(np.int64), Vb[f * LANES:f * LANES + n].view(np.int64))
    assert 0.1 < np.mean(lit) < 0.9                       # lanes with and without a shadow ray


def test_shadow_add_adds_only_traced_unblocked_lanes():
    rng = np.random.default_rng(12)
    V0 = _scratch(rng)
    blocked = rng.random(LANES) < 0.4
    n = 13
    V = _shadow_add(V0, blocked, n, 0.25)
    lit = V0[V_LIT * LANES:(V_LIT + 1) * LANES] != 0.0
    for c in range(3):
        L0, F0 = V0[(V_L + c) * LANES:(V_L + c + 1) * LANES], V0[(V_F + c) * LANES:(V_F + c + 1) * LANES]
        want = L0.copy()
        add = lit[:n] & ~blocked[:n]
        want[:n][add] += F0[:n][add] * 0.25
        assert np.array_equal(V[(V_L + c) * LANES:(V_L + c + 1) * LANES], want)
    assert np.array_equal(V[:V_L * LANES], V0[:V_L * LANES])   # nothing else written
