"""The vectorised packet stages against the general ones they stand in for, on random scratch contents (grazing and
below-horizon cosines, misses, lights that cannot reach the side): :func:`lambert_stage` gives bit for bit what
:func:`bsdf_stage` gives for Lambert hits (the value, the lit flag, the shadow packet's lanes, the count),
:func:`shadow_add` adds what the kernel's per-lane rule adds, and the environment stage's two passes (directions
and prefetches, then lookups) give bit for bit what :func:`env_sample` gives lane by lane, the light samples of its
vectorised stages too."""
import numba
import numpy as np
import pytest

from pyrt.core import unmanaged as U
from pyrt.geometry import embree_jit as E
from pyrt.integrators import kernel_cache
from pyrt.integrators.compiled_layout import (
    LANES, V_A, V_COSI, V_COSIO, V_COSO, V_F, V_GOK, V_L, V_LIT, V_MAT, V_S, V_SIZE)
from pyrt.integrators.compiled_layout import (V_D, V_EU, V_LIFT, V_MAG, V_MAG_LIFT, V_NG, V_NS, V_NV, V_P, lane_inputs,
                                              lane_vec, padded_numbers)
from pyrt.integrators.compiled_lighting import bsdf_stage, env_sample, env_stage, lambert_stage, shadow_add
from pyrt.lights import compiled as LC
from pyrt.materials import compiled as MC
from pyrt.shaders import jit_sampling as JS

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


@numba.njit(cache=True)
def _env_both(etag, erec, edata, mats_tag, mats_par, V0, n, tech, lane_s, spp, lane_k32, pair, lambert):
    """(scratch, shadow packet, count) of env_stage; (scratch, shadow origins, directions, flags, count) of
    env_sample lane by lane, from the same scratch."""
    Va, Vb = V0.copy(), V0.copy()
    sa = E.packet_alloc(LANES)
    E.packet_prepare(U.pointer(sa), LANES, 0.0, 0.0, 0.0)
    na = env_stage(etag, U.pointer(erec), U.pointer(edata), U.pointer(mats_tag), U.pointer(mats_par), U.pointer(Va),
                   n, True, tech, 1, 2, pair, U.pointer(lane_s), spp, U.pointer(lane_k32), U.pointer(sa), LANES,
                   lambert)
    nb = 0
    V = U.pointer(Vb)
    org, wis, oks = np.zeros((n, 3)), np.zeros((n, 3)), np.zeros(n, dtype=np.bool_)
    for lane in range(n):
        x0, x1 = JS.padded_sobol_2d(lane_s[lane], spp, lane_k32[lane], pair)
        m = int(Vb[V_MAT * LANES + lane])
        if m >= 0 and MC.has_diffuse(mats_tag[m]):
            d = lane_vec(V, V_D, lane)
            ok, o, wi, val = env_sample(etag, U.pointer(erec), U.pointer(edata), mats_tag[m], U.pointer(mats_par), m,
                                        lane_inputs(V, lane), lane_vec(V, V_P, lane), lane_vec(V, V_NG, lane),
                                        lane_vec(V, V_NS, lane), lane_vec(V, V_NV, lane), (-d[0], -d[1], -d[2]),
                                        lane_vec(V, V_LIFT, lane), Vb[V_MAG * LANES + lane],
                                        Vb[V_MAG_LIFT * LANES + lane], True, x0, (1 + x1) / 2, tech)
            oks[lane] = ok
            for c in range(3):
                org[lane, c], wis[lane, c] = o[c], wi[c]
                if ok:
                    Vb[(V_F + c) * LANES + lane] = val[c]
        Vb[V_LIT * LANES + lane] = 1.0 if oks[lane] else 0.0
        nb += oks[lane]
    return Va, sa, na, Vb, org, wis, oks, nb


@numba.njit(cache=True)
def _padded(lane_s, spp, lane_k32, pair, n, s, count):
    V = np.zeros(V_SIZE * LANES)
    padded_numbers(U.pointer(V), V_EU, U.pointer(lane_s), spp, U.pointer(lane_k32), pair, n, s, count)
    return V[V_EU * LANES:(V_EU + 2) * LANES].copy()


kernel_cache.restore()


def test_padded_numbers_equal_padded_sobol_2d_per_lane():
    """The packet's padded numbers (the per-pixel hashes once per run of one pixel's lanes) are
    :func:`padded_sobol_2d` lane by lane, bit for bit: one pixel's lanes, runs of several pixels, a pixel seen again
    after another, a short packet (``(0.5, (s + 0.5) / count)`` past ``n``), a progressive set (``spp`` 0)."""
    rng = np.random.default_rng(21)
    for spp, runs, n in ((16, [16], 16), (4, [4, 4, 4, 4], 16), (2, [2, 3, 1, 2, 8], 11), (0, [5, 11], 16)):
        seeds = rng.integers(0, 2**32, len(runs)).astype(np.uint64)
        seeds[-1] = seeds[0]                               # a pixel seed seen again after another
        lane_k32 = np.repeat(seeds, runs).astype(np.uint64)
        lane_s = rng.integers(0, max(spp, 64), LANES).astype(np.int64) % max(spp, 64)
        for s_, count in ((0, 1), (2, 3)):
            got = _padded(lane_s, spp, lane_k32, 7, n, s_, count)
            for lane in range(LANES):
                x0, x1 = JS.padded_sobol_2d(lane_s[lane], spp, lane_k32[lane], 7) if lane < n else (0.5, 0.5)
                assert got[lane] == x0 and got[LANES + lane] == (s_ + x1) / count, (spp, lane)


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


def _unit(rng, n):
    v = rng.normal(size=(n, 3))
    return v / np.linalg.norm(v, axis=1, keepdims=True)


@pytest.mark.parametrize("lambert", [False, True], ids=["mixed", "all_lambert"])
def test_env_stage_two_passes_equal_env_sample_lane_by_lane(lambert):
    """Random hits (normals, views, points; Lambert, rough gold and no hit) under a sky with a sun, both techniques:
    the stage's values, lit flags, shadow packet (every byte) and count equal a loop of :func:`env_sample`. A packet of
    Lambert hits and misses only takes the vectorised Lambert stages (``lambert``): the same bits."""
    import pyrt
    from pyrt.integrators import compiled

    s = pyrt.Scene(pyrt.Camera(position=(0, 1, 4), target=(0, 0, 0), width=8, height=8))
    s.add_plane((0, 0, 0), 4.0, pyrt.Lambert(albedo=(0.6, 0.5, 0.4)))
    s.add_sphere((0, 0.5, 0), 0.5, pyrt.CookTorrance(metal="gold", roughness=0.4), subdivisions=2)
    pyrt.set_environment(s, pyrt.LatLongEnvironment(pyrt.procedural_sky(64, 32, sun_direction=(0.5, 0.6, 0.4),
                                                                         sun_angle=4.0)))
    ps = pyrt.PreparedScene(s)
    cs = compiled.CompiledScene(ps)
    erec = np.ascontiguousarray(cs.env_record)
    rng = np.random.default_rng(5)
    lit = []
    for trial in range(40):
        n = LANES if trial % 2 else int(rng.integers(1, LANES))
        V = np.zeros(V_SIZE * LANES)
        ns = _unit(rng, LANES)
        ng = ns + 0.2 * _unit(rng, LANES)
        ng /= np.linalg.norm(ng, axis=1, keepdims=True)
        d = _unit(rng, LANES)
        d = np.where(np.sum(d * ng, axis=1, keepdims=True) < 0, d, -d)
        d[:2] = -ng[:2] + 1e-9                       # head-on views
        p = rng.uniform(-2, 2, (LANES, 3))
        for field, x in ((V_NS, ns), (V_NG, ng), (V_NV, ng), (V_D, d), (V_P, p), (V_LIFT, p),
                         (V_A, rng.uniform(0, 1, (LANES, 3)))):
            for c in range(3):
                V[(field + c) * LANES:(field + c + 1) * LANES] = x[:, c]
        V[V_MAG * LANES:(V_MAG + 1) * LANES] = 1e-6
        V[V_MAG_LIFT * LANES:(V_MAG_LIFT + 1) * LANES] = 1e-6
        V[V_MAT * LANES:(V_MAT + 1) * LANES] = rng.integers(-1, 1 if lambert else 2, LANES)
        lane_s = rng.integers(0, 16, LANES).astype(np.int64)
        lane_k32 = rng.integers(0, 2**32, LANES).astype(np.uint64)
        for tech in (False, True):
            Va, sa, na, Vb, org, wis, oks, nb = _env_both(cs.env_tag, erec, cs.env_data, cs.materials[0],
                                                          cs.materials[1], V, n, tech, lane_s, 16, lane_k32, trial,
                                                          lambert)
            assert na == nb
            lit.append(na / n)
            assert np.array_equal(E.packet_valid(sa)[:n] != 0, oks) and not E.packet_valid(sa)[n:].any()
            f32 = sa.reshape(-1)[:E.LANE_WORDS * LANES].reshape(E.LANE_WORDS, LANES)[:, :n]
            for c in range(3):                       # the packet's float32 origin and direction of the traced lanes
                assert np.array_equal(f32[E.ORG_X + c][oks], org[oks, c].astype(np.float32))
                assert np.array_equal(f32[E.DIR_X + c][oks], wis[oks, c].astype(np.float32))
            for f in (V_F, V_F + 1, V_F + 2, V_LIT):
                assert np.array_equal(Va[f * LANES:f * LANES + n], Vb[f * LANES:f * LANES + n])
    assert 0.1 < np.mean(lit) < 0.95


def _light_stage_env(kind):
    """(tag, record, data) of a packed environment and light for the light-sample stages' tests."""
    import pyrt
    from pyrt.lights import compiled_env as CE

    sky = pyrt.procedural_sky(64, 32, sun_direction=(0.5, 0.6, 0.4), sun_angle=4.0)
    env = {"nearest": lambda: pyrt.LatLongEnvironment(sky, filter="nearest"),
           "flat": lambda: pyrt.LatLongEnvironment(np.full((8, 16, 3), 0.7, dtype=np.float32)),
           "constant": lambda: pyrt.ConstantEnvironment((0.3, 0.5, 0.7)),
           "rotated": lambda: pyrt.LatLongEnvironment(sky, rotate=(-70.0, [0.2, 1.0, 0.1]), intensity=2.0),
           }.get(kind, lambda: pyrt.LatLongEnvironment(sky))()
    light = pyrt.EnvironmentLight(env, compensate=kind != "full")
    tag, rec, data = CE.pack_environment(env, light)
    return tag, np.ascontiguousarray(rec), data


def test_light_sample_stages_equal_the_per_lane_sampler():
    """The packet's light samples from the two vectorised stages (:mod:`pyrt.integrators.compiled_env_stage`) equal
    :func:`pyrt.lights.compiled_env.mis_sample_uv` lane by lane, bit for bit (world and environment-frame
    directions, density, lat-long coordinates), for the compensated and the full table, a rotated map and a flat one
    (its compensated table holds only rounding residue), on random sample numbers and on 0, 1e-12, 1/2 and just
    below 1 in both; environments the stages do not serve (nearest filter, a constant map) keep the per-lane code."""
    from pyrt.integrators import compiled_env_stage as ES
    from pyrt.integrators.compiled_layout import V_ELOC, V_EPDF, V_EU, V_EUV, V_EWI
    from pyrt.lights import compiled_env as CE

    for kind in ("nearest", "constant"):
        tag, rec, _ = _light_stage_env(kind)
        assert ES.packet_sampling(tag, rec) == (-1, 0.0), kind
    rng = np.random.default_rng(8)
    edge = [0.0, 1e-12, 0.5, np.nextafter(1.0, 0.0)]
    corners = np.array([(a, b) for a in edge for b in edge])
    for kind in ("compensated", "full", "rotated", "flat"):
        tag, rec, data = _light_stage_env(kind)
        o, integral = ES.packet_sampling(tag, rec)
        assert o == int(rec[CE.R_C_TABLE] if kind != "full" else rec[CE.R_TABLE]) and integral > 0, kind
        for u in [corners] + [rng.random((LANES, 2)) for _ in range(60)]:
            V = np.zeros(V_SIZE * LANES)
            V[V_EU * LANES:(V_EU + 1) * LANES] = u[:, 0]
            V[(V_EU + 1) * LANES:(V_EU + 2) * LANES] = u[:, 1]
            ES.light_cells(rec, data, V, o)
            ES.light_directions(rec, V, integral)
            for lane in range(LANES):
                want = CE.mis_sample_uv(tag, rec, data, u[lane, 0], u[lane, 1])
                got = tuple(V[(f + c) * LANES + lane] for f, k in ((V_EWI, 3), (V_EPDF, 1), (V_ELOC, 3), (V_EUV, 2))
                            for c in range(k))
                assert got == tuple(want), (kind, u[lane])
