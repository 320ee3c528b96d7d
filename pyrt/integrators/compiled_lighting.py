"""The direct-light stages of the compiled tile kernel (:mod:`pyrt.integrators.compiled_kernel`).

Per light, a packet's shadow rays are built in three short loops over its lanes, each compiled so that it can
vectorise: :func:`light_stage` (punctual and directional lights: branch-free) or :func:`area_stage` (rectangle, disk
and sphere lights: a stratified sample per hit, padded over the pixel's samples) writes each lane's cosines,
irradiance scale and shadow ray into the scratch; :func:`shadow_fill` copies the rays into the packet;
:func:`bsdf_stage` evaluates the BSDF and switches on the lanes whose ray is worth tracing. :func:`direct_light` is
the same estimate for one hit of the specular tree (single rays). The environment light (``strategy="mis"``) has a
stage of its own, :func:`env_stage` (:func:`env_sample` per lane, one technique at a time: its light samples and
its BSDF samples, MIS-weighted); ``strategy="preview"`` is :mod:`pyrt.integrators.compiled_preview`'s.
"""
from __future__ import annotations

import math

import numba

from pyrt.integrators import kernel_cache

kernel_cache.use_cache_dir()      # before the decorators below run

from pyrt.core import unmanaged as U  # noqa: E402
from pyrt.integrators import compiled_env_stage as ES  # noqa: E402
from pyrt.integrators import compiled_preview as PV  # noqa: E402
from pyrt.integrators.compiled_shadows import keep_rays, packet_walk, shadow_ray, walks  # noqa: E402
from pyrt.geometry import embree_jit as E  # noqa: E402
from pyrt.integrators.compiled_layout import (  # noqa: E402
    LANES, V_D, V_P, V_NG, V_NS, V_NV,
    V_LIFT, V_MAG, V_MAG_LIFT, V_MAT, V_A, V_F,
    V_LIT, V_COSO, V_COSI, V_COSIO, V_S, V_GOK,
    V_SO, V_WI, V_TMAX, T_INF, DIM_AREA, MAX_AREA_SAMPLES, V_L, DIM_ENV, N_SHADOW, V_EWI, V_EW, V_ELOC, V_EPDF,
    V_EUV, V_EOK, V_EU,
    _njit, _stage, lane_inputs, lane_vec, padded_numbers, set_lane_vec)
from pyrt.lights import compiled as LC  # noqa: E402
from pyrt.lights import compiled_env as CE  # noqa: E402
from pyrt.materials import compiled as MC  # noqa: E402
from pyrt.materials import compiled_sampling as CS  # noqa: E402
from pyrt.shaders import jit as J  # noqa: E402
from pyrt.shaders.jit import dot  # noqa: E402


@_njit
def direct_light(ltags, lpars, j, mtag, mpars, m, albedo, p, ng, ns, nv, wo, lift, mag, mag_lift, terminator, u0, u1):
    """Light ``j``'s contribution at a hit before shadowing: ``(ok, tmax, origin, wi, f)`` with ``f`` = f_cos * E and
    the shadow ray (origin offset to the side of ``wi``: :meth:`pyrt.geometry.offsets.Strategy.shadow`, ``robust``
    tmax, ``inf`` for directional light). ``ok`` False where the light cannot contribute (wrong side, no irradiance,
    zero BSDF: no shadow ray is traced, :func:`pyrt.integrators.direct._lit_lanes`). ``(u0, u1)``: an area light's
    sample (:func:`pyrt.lights.compiled.area_sample`; its shadow ray ends at the sampled point)."""
    jb = j * LC.RECORD
    if ltags[j] >= LC.RECT:
        w0, w1, w2, dist, s = LC.area_sample(ltags[j], lpars, j, p[0], p[1], p[2], u0, u1)
        end = (p[0] + w0 * dist, p[1] + w1 * dist, p[2] + w2 * dist)
    else:
        w0, w1, w2, dist, s = LC.sample_li(ltags[j], lpars, j, p[0], p[1], p[2])
        end = (lpars[jb], lpars[jb + 1], lpars[jb + 2])
    wi = (w0, w1, w2)
    cg = dot(wi, ng)
    ok = s > 0.0 and max(lpars[jb + 6], lpars[jb + 7], lpars[jb + 8]) > 0.0 and (cg > 0.0 or dot(wi, nv) > 0.0)
    f = CS.f_cos_world(mtag, mpars, m, albedo, wo, wi, ns)
    ok = ok and max(f[0], f[1], f[2]) > 0.0
    f = (f[0] * s * lpars[jb + 6], f[1] * s * lpars[jb + 7], f[2] * s * lpars[jb + 8])
    o = J.shadow_origin(p, ng, lift, mag, mag_lift, cg, terminator)
    tmax = J.robust_tmax(o, wi, end[0], end[1], end[2], math.isfinite(dist))
    return ok, min(tmax, T_INF), o, wi, f


@_njit
def area_u(key, j, s, ns, k):
    """The random numbers of sample ``s`` of area light ``j``'s ``ns`` at a hit of the specular tree whose key is
    ``key``: stratified per hit (:func:`pyrt.lights.compiled.stratum`: a jittered ``k x k`` grid, else
    Latin-hypercube strata with a permutation per hit and light), jittered from dimensions of their own
    (:data:`DIM_AREA`)."""
    d = DIM_AREA + 2 * (j * MAX_AREA_SAMPLES + s)
    return LC.stratum(s, ns, k, J.uniform(key, d), J.uniform(key, d + 1), _lhs_perm(key, j, s, ns, k))


@_njit
def _lhs_perm(key, j, s, ns, k):
    """Element ``s`` of the hit's permutation of its ``ns`` Latin-hypercube strata for light ``j`` (0 where the
    samples are a grid)."""
    if ns > 1 and k * k != ns:
        return J.permute(s, ns, int(J.uniform(key, DIM_AREA - 1 - j) * 4294967296.0))
    return 0


@_njit
def light_lane(ltag, kind, rec, i_max, V, lane, terminator):
    """The BSDF-free part of :func:`direct_light` for lane ``lane`` of the packet (its hit in the scratch ``V``), the
    light given by its tag, distance-falloff kind and :func:`pyrt.lights.compiled.light_record` ``rec`` (``i_max``:
    its largest intensity component): into the scratch the cosines ``ns.wi``, ``wi.wo``, the irradiance scale,
    whether the light reaches the hit's side (:data:`V_COSI`, :data:`V_COSIO`, :data:`V_S`, :data:`V_GOK`) and the shadow ray (:data:`V_SO`,
    :data:`V_WI`, :data:`V_TMAX`: origin offset, direction, robust tmax).

    Written for the vectoriser: it reads and writes the scratch only (a write to another buffer, as far as the
    compiler knows, could change what it reads: no vector loop), and has no branch (flags combined with ``&`` /
    ``|``, the offset's base point and magnitude chosen by selects, float32 rounding by selects, the tmax of a
    distant light by a select). The same arithmetic as :func:`direct_light`: the same bits."""
    p = lane_vec(V, V_P, lane)
    ng = lane_vec(V, V_NG, lane)
    w0, w1, w2, dist, s = LC.sample_li_record(ltag, kind, rec, p[0], p[1], p[2])
    wi = (w0, w1, w2)
    cg = dot(wi, ng)
    gok = (s > 0.0) & (i_max > 0.0) & ((cg > 0.0) | (dot(wi, lane_vec(V, V_NV, lane)) > 0.0))
    d = lane_vec(V, V_D, lane)
    V[V_COSI * LANES + lane] = dot(wi, lane_vec(V, V_NS, lane))
    V[V_COSIO * LANES + lane] = dot(wi, (-d[0], -d[1], -d[2]))
    V[V_S * LANES + lane] = s
    V[V_GOK * LANES + lane] = 1.0 if gok else 0.0
    # the origin: the lifted point to the ng side (terminator), else p to the side of wi
    lift = lane_vec(V, V_LIFT, lane)
    base = (lift[0] if terminator else p[0], lift[1] if terminator else p[1], lift[2] if terminator else p[2])
    mag = V[V_MAG_LIFT * LANES + lane] if terminator else V[V_MAG * LANES + lane]
    o = J.round_away_vec(base, mag, 1.0 if (terminator | (cg >= 0.0)) else -1.0, ng)
    tmax = J.robust_tmax(o, wi, rec[0], rec[1], rec[2], math.isfinite(dist))
    set_lane_vec(V, V_SO, lane, o)
    set_lane_vec(V, V_WI, lane, wi)
    V[V_TMAX * LANES + lane] = min(tmax, T_INF)


@_stage
def area_lane(ltag, lpars, j, e_max, V, lane, u0, u1, terminator):
    """:func:`light_lane` for area light ``j`` (tag ``ltag``, largest radiance component ``e_max``) sampled with
    ``(u0, u1)``: the same fields of the scratch; the shadow ray ends at the sampled point. Not inlined by Numba:
    inlined into :func:`area_stage` (with tuple-valued conditional expressions, which Numba's inliner warned about)
    its stores of the shadow ray were lost (measured: those fields stayed zero); compiled on its own they are
    not."""
    p = lane_vec(V, V_P, lane)
    ng = lane_vec(V, V_NG, lane)
    w0, w1, w2, dist, s = LC.area_sample(ltag, lpars, j, p[0], p[1], p[2], u0, u1)
    wi = (w0, w1, w2)
    cg = dot(wi, ng)
    gok = (s > 0.0) & (e_max > 0.0) & ((cg > 0.0) | (dot(wi, lane_vec(V, V_NV, lane)) > 0.0))
    d = lane_vec(V, V_D, lane)
    V[V_COSI * LANES + lane] = dot(wi, lane_vec(V, V_NS, lane))
    V[V_COSIO * LANES + lane] = dot(wi, (-d[0], -d[1], -d[2]))
    V[V_S * LANES + lane] = s
    V[V_GOK * LANES + lane] = 1.0 if gok else 0.0
    o = J.shadow_origin(p, ng, lane_vec(V, V_LIFT, lane), V[V_MAG * LANES + lane], V[V_MAG_LIFT * LANES + lane], cg,
                        terminator)
    tmax = J.robust_tmax(o, wi, p[0] + w0 * dist, p[1] + w1 * dist, p[2] + w2 * dist, True)
    set_lane_vec(V, V_SO, lane, o)
    set_lane_vec(V, V_WI, lane, wi)
    V[V_TMAX * LANES + lane] = min(tmax, T_INF)


@_stage
def area_stage(ltag, lpars, j, V, keys, n, s, ns, k, terminator, pair, lane_s, spp, lane_k32):
    """:func:`area_lane` of sample ``s`` of area light ``j``'s ``ns`` per hit (``k = isqrt(ns)``) for the camera
    hits in lanes ``[0, n)`` (lane ``l``: camera sample ``lane_s[l]`` of its pixel's ``spp``): stratified per hit
    (:func:`pyrt.lights.compiled.stratum`), each stratum's jitter padded over the pixel's samples as the NumPy
    path's (:func:`pyrt.shaders.jit_sampling.padded_sobol_2d` of the pixel's seed ``lane_k32[l]`` and the
    dimension pair ``pair``: the pixel's ``spp`` jitters of one stratum are one stratified set)."""
    U.wide_vectors()
    jb = j * LC.RECORD
    e_max = max(lpars[jb + 6], lpars[jb + 7], lpars[jb + 8])
    padded_numbers(V, V_EU, lane_s, spp, lane_k32, pair, n, 0, 1)
    for lane in range(n):
        x0, x1 = V[V_EU * LANES + lane], V[(V_EU + 1) * LANES + lane]
        u0, u1 = LC.stratum(s, ns, k, x0, x1, _lhs_perm(keys[lane], j, s, ns, k))
        area_lane(ltag, lpars, j, e_max, V, lane, u0, u1, terminator)


@_stage
def light_stage(ltags, lpars, j, V, n, terminator):
    """:func:`light_lane` of light ``j`` for lanes ``[0, n)``: one loop per light type, and for a point light with
    the inverse-square falloff one of its own (tag and kind constants in each, so that their switches fold away:
    the if-converted switch of the falloff kinds alone cost five vector divisions a lane)."""
    U.wide_vectors()
    ltag = ltags[j]
    rec = LC.light_record(lpars, j)
    kind = rec[6]
    jb = j * LC.RECORD
    i_max = max(lpars[jb + 6], lpars[jb + 7], lpars[jb + 8])
    if ltag == LC.POINT and kind == 0:
        for lane in range(n):
            light_lane(LC.POINT, 0, rec, i_max, V, lane, terminator)
    elif ltag == LC.DIRECTIONAL:
        for lane in range(n):
            light_lane(LC.DIRECTIONAL, kind, rec, i_max, V, lane, terminator)
    else:
        for lane in range(n):
            light_lane(ltag, kind, rec, i_max, V, lane, terminator)


@_stage
def camera_fill(V, pk, w, n):
    """The camera rays' directions (:data:`V_D`) into lanes ``[0, n)`` of the packet ``pk`` (width ``w``; the origin
    is the camera's, set once), tfar unbounded, each lane a miss until the query: one vectorised loop."""
    U.wide_vectors()
    U.noalias_args()
    for lane in range(n):
        d = lane_vec(V, V_D, lane)
        E.packet_set_dir(pk, w, lane, d[0], d[1], d[2], T_INF)


@_stage
def shadow_fill(V, sh, w, n):
    """The shadow rays of :func:`light_stage` from the scratch into lanes ``[0, n)`` of the packet ``sh`` (width
    ``w``; :func:`bsdf_stage` switches them on). A loop of its own: it reads one buffer and writes another."""
    U.wide_vectors()
    for lane in range(n):
        o, wi = lane_vec(V, V_SO, lane), lane_vec(V, V_WI, lane)
        E.packet_set_origin(sh, w, lane, o[0], o[1], o[2])
        E.packet_set_dir(sh, w, lane, wi[0], wi[1], wi[2], V[V_TMAX * LANES + lane])


@_stage
def lambert_stage(lpars, j, V, sh, w, n):
    """:func:`bsdf_stage` for a packet whose hits are all Lambert (or misses): the same values, in one loop that LLVM
    vectorises (no material dispatch): ``f = albedo max(cos_i, 0) / pi`` (:func:`pyrt.materials.compiled.f_cos`)."""
    U.wide_vectors()
    U.noalias_args()
    jb = j * LC.RECORD
    e0, e1, e2 = lpars[jb + 6], lpars[jb + 7], lpars[jb + 8]
    n_sh = 0
    for lane in range(n):
        cos_o, cos_i = V[V_COSO * LANES + lane], V[V_COSI * LANES + lane]
        k = (cos_i if (cos_o > 0.0) & (cos_i > 0.0) else 0.0) * MC.INV_PI
        a = lane_vec(V, V_A, lane)
        f = (a[0] * k, a[1] * k, a[2] * k)
        s = V[V_S * LANES + lane]
        ok = (V[V_GOK * LANES + lane] != 0.0) & (max(f[0], f[1], f[2]) > 0.0) & (V[V_MAT * LANES + lane] >= 0.0)
        set_lane_vec(V, V_F, lane, (f[0] * s * e0, f[1] * s * e1, f[2] * s * e2))
        V[V_LIT * LANES + lane] = 1.0 if ok else 0.0
        E.packet_set_active(sh, w, lane, ok)
        n_sh += ok
    return n_sh


@_stage
def shadow_add(V, sh, w, n, inv):
    """After a shadow packet's occlusion query: each lane's light contribution (:data:`V_F` times ``inv``) added to
    its radiance where its shadow ray was traced and not blocked (one vectorised loop)."""
    U.wide_vectors()
    U.noalias_args()
    for lane in range(n):
        add = (V[V_LIT * LANES + lane] != 0.0) & ~E.lane_blocked(sh, w, lane)
        for c in range(3):
            V[(V_L + c) * LANES + lane] += V[(V_F + c) * LANES + lane] * inv if add else 0.0


@_njit
def bsdf_stage(mats_tag, mats_par, lpars, j, V, sh, w, n):
    """The BSDF part of :func:`direct_light` for lanes ``[0, n)`` after :func:`light_stage`: ``f = f_cos * E``
    into :data:`V_F`, whether the shadow ray is traced into :data:`V_LIT` and the shadow packet's lane switched on
    accordingly (a miss, a material without a non-delta lobe, a light that cannot reach the side, a zero BSDF:
    off); returns the number of shadow rays."""
    jb = j * LC.RECORD
    e0, e1, e2 = lpars[jb + 6], lpars[jb + 7], lpars[jb + 8]
    n_sh = 0
    for lane in range(n):
        m = int(V[V_MAT * LANES + lane])
        mm = max(m, 0)
        mtag = mats_tag[mm]
        if MC.is_coated(mtag, mats_par, mm):       # the coat's lobe needs the directions
            d = lane_vec(V, V_D, lane)
            f = CS.f_cos_world(mtag, mats_par, mm, lane_inputs(V, lane), (-d[0], -d[1], -d[2]),
                               lane_vec(V, V_WI, lane), lane_vec(V, V_NS, lane))
        else:
            f = MC.f_cos(mtag, mats_par, mm, lane_inputs(V, lane), V[V_COSO * LANES + lane],
                         V[V_COSI * LANES + lane], V[V_COSIO * LANES + lane])
        s = V[V_S * LANES + lane]
        ok = V[V_GOK * LANES + lane] != 0.0 and max(f[0], f[1], f[2]) > 0.0 and m >= 0 and MC.has_diffuse(mtag)
        set_lane_vec(V, V_F, lane, (f[0] * s * e0, f[1] * s * e1, f[2] * s * e2))
        V[V_LIT * LANES + lane] = 1.0 if ok else 0.0
        E.packet_set_active(sh, w, lane, ok)
        n_sh += ok
    return n_sh


@_stage
def env_direction(etag, erec, edata, mtag, mpars, m, albedo, ns, wo, u0, u1, bsdf_technique):
    """The first half of :func:`env_sample`: the sample's direction, ``(ok, wi, w, pdf, local, uv)``: ``ok`` False
    where the sample has no density (BSDF technique: or no weight), ``w`` the BSDF sample's weight (RGB; zeros for
    the light technique), ``pdf`` the technique's density, ``local`` and ``uv`` the direction's
    :func:`pyrt.lights.compiled_env.lookup_coords` (a light sample's as its sampler made them,
    :func:`pyrt.lights.compiled_env.mis_sample_uv`), whose texels (and, BSDF technique, light densities) it
    prefetches for :func:`env_value`."""
    fs, ft = CS.coordinate_frame(ns[0], ns[1], ns[2])
    if bsdf_technique:
        wol = CS.to_local(wo, fs, ft, ns)
        x, y, z, w_r, w_g, w_b, pdf = CS.sample_f(mtag, mpars, m, albedo, wol[0], wol[1], wol[2], u0, u1)
        wi = CS.to_world((x, y, z), fs, ft, ns)
        ok = pdf > 0.0 and max(w_r, w_g, w_b) > 0.0
        lx, ly, lz, u, v = CE.lookup_coords(etag, erec, wi[0], wi[1], wi[2])
    else:
        # the light sample's own lat-long coordinates (no atan2 / acos round trip: CE.mis_sample_uv)
        x, y, z, pdf, lx, ly, lz, u, v = CE.mis_sample_uv(etag, erec, edata, u0, u1)
        wi = (x, y, z)
        w_r = w_g = w_b = 0.0
        ok = pdf > 0.0
    CE.prefetch_lookup(etag, erec, edata, u, v, bsdf_technique)
    return ok, wi, (w_r, w_g, w_b), pdf, (lx, ly, lz), (u, v)


@_stage
def env_value(etag, erec, edata, mtag, mpars, m, albedo, p, ng, ns, nv, wo, lift, mag, mag_lift, terminator,
              bsdf_technique, ok, wi, w, pdf, loc, uv):
    """The second half of :func:`env_sample`, from :func:`env_direction`'s ``(ok, wi, w, pdf, loc, uv)``: the
    lookups, the BSDF value (light technique), the MIS weight and the shadow ray's origin, ``(ok, origin, wi,
    value)``."""
    if bsdf_technique:
        l0, l1, l2, pdf_l = CE.radiance_mis_pdf_at(etag, erec, edata, wi[0], wi[1], wi[2], loc[0], loc[1], loc[2],
                                                   uv[0], uv[1])
        k = CE.mis_weights(erec, pdf_l, pdf)[1] if ok else 0.0
        val = (w[0] * l0 * k, w[1] * l1 * k, w[2] * l2 * k)
    else:
        le = CE.radiance_at(etag, erec, edata, wi[0], wi[1], wi[2], uv[0], uv[1])
        ok = ok and max(le[0], le[1], le[2]) > 0.0
        val = (0.0, 0.0, 0.0)
        if ok:
            fs, ft = CS.coordinate_frame(ns[0], ns[1], ns[2])
            wol = CS.to_local(wo, fs, ft, ns)
            wil = CS.to_local(wi, fs, ft, ns)
            f = CS.f_cos_local(mtag, mpars, m, albedo, wol[0], wol[1], wol[2], wil[0], wil[1], wil[2])
            k = CE.mis_weights(erec, pdf, CS.pdf_wi(mtag, mpars, m, albedo, wol[0], wol[1], wol[2], wil[0], wil[1],
                                                    wil[2]))[0] / pdf
            val = (f[0] * le[0] * k, f[1] * le[1] * k, f[2] * le[2] * k)
    cg = dot(wi, ng)
    ok = ok and (cg > 0.0 or dot(wi, nv) > 0.0) and max(val[0], val[1], val[2]) > 0.0
    o = J.shadow_origin(p, ng, lift, mag, mag_lift, cg, terminator)
    return ok, o, wi, val


@_stage
def env_sample(etag, erec, edata, mtag, mpars, m, albedo, p, ng, ns, nv, wo, lift, mag, mag_lift, terminator, u0,
               u1, bsdf_technique):
    """One sample of the environment light at a hit of material ``m`` (``strategy="mis"``,
    :func:`pyrt.integrators.direct.environment_estimate`): the light technique (:func:`pyrt.lights.compiled_env.
    mis_sample`, ``f_cos L / pdf`` times its MIS weight; :func:`pyrt.integrators.direct._add_environment_sample`) or,
    with ``bsdf_technique``, the BSDF's (:func:`pyrt.materials.compiled_sampling.sample_f`, ``weight L`` times its
    weight; ``_add_bsdf_sample``), in the shading frame of ``ns``. Returns ``(ok, origin, wi, value)``: ``ok`` False
    where the sample adds nothing (no density, the wrong side, zero value: no shadow ray); the shadow ray leaves
    ``origin`` along ``wi`` unbounded (the environment is at infinity)."""
    ok, wi, w, pdf, loc, uv = env_direction(etag, erec, edata, mtag, mpars, m, albedo, ns, wo, u0, u1,
                                            bsdf_technique)
    return env_value(etag, erec, edata, mtag, mpars, m, albedo, p, ng, ns, nv, wo, lift, mag, mag_lift, terminator,
                     bsdf_technique, ok, wi, w, pdf, loc, uv)


@_stage
def env_stage(etag, erec, edata, mats_tag, mats_par, V, n, terminator, bsdf_technique, s, count, pair, lane_s, spp,
              lane_k32, sh, w, lambert):
    """:func:`env_sample` for the camera hits in lanes ``[0, n)`` (round ``s`` of ``count`` samples of one
    technique: the second random number stratified over the rounds, as the NumPy path's ``u[:, 1] = (s + u) /
    n``), each lane's numbers padded over its pixel's samples (dimension pair ``pair``, as :func:`area_stage`):
    the value into :data:`V_F`, whether it is traced into :data:`V_LIT`, the shadow ray into the packet ``sh``
    (width ``w``, the lane switched on accordingly). A lat-long map's light samples come from the vectorised stages of
    :mod:`pyrt.integrators.compiled_env_stage` (the same numbers as :func:`env_direction`); with ``lambert`` (every
    hit of the packet Lambert) both techniques' samples do (:func:`pyrt.integrators.compiled_env_stage.
    lambert_env_stage`). Returns the number of shadow
    rays."""
    # two passes: every lane's direction first, its texels prefetched (:func:`env_direction`), then the lookups and
    # values (:func:`env_value`): the lanes' cache misses overlap (the lookups are memory-bound on large maps)
    o_table, integral = ES.packet_sampling(etag, erec)
    if lambert and o_table >= 0:
        return ES.lambert_env_stage(erec, edata, V, n, terminator, bsdf_technique, s, count, pair, lane_s, spp,
                                    lane_k32, o_table, integral, sh, w)
    o_table = -1 if bsdf_technique else o_table
    padded_numbers(V, V_EU, lane_s, spp, lane_k32, pair, n, s, count)
    if o_table >= 0:
        # a lat-long map's light samples for the whole packet in two vectorised stages (compiled_env_stage)
        ES.light_cells(erec, edata, V, o_table)
        ES.light_directions(erec, V, integral)
    for lane in range(n if o_table < 0 else 0):
        m = int(V[V_MAT * LANES + lane])
        mm = max(m, 0)
        mtag = mats_tag[mm]
        ok = False
        if m >= 0 and MC.has_diffuse(mtag):
            d = lane_vec(V, V_D, lane)
            ok, wi, wv, pdf, loc, uv = env_direction(etag, erec, edata, mtag, mats_par, mm, lane_inputs(V, lane),
                                                     lane_vec(V, V_NS, lane), (-d[0], -d[1], -d[2]),
                                                     V[V_EU * LANES + lane], V[(V_EU + 1) * LANES + lane],
                                                     bsdf_technique)
            set_lane_vec(V, V_EWI, lane, wi)
            set_lane_vec(V, V_EW, lane, wv)
            set_lane_vec(V, V_ELOC, lane, loc)
            V[V_EPDF * LANES + lane] = pdf
            V[V_EUV * LANES + lane] = uv[0]
            V[(V_EUV + 1) * LANES + lane] = uv[1]
        V[V_EOK * LANES + lane] = 1.0 if ok else 0.0
    for lane in range(n if o_table >= 0 else 0):
        m = int(V[V_MAT * LANES + lane])
        ok = m >= 0 and MC.has_diffuse(mats_tag[max(m, 0)]) and V[V_EPDF * LANES + lane] > 0.0
        set_lane_vec(V, V_EW, lane, (0.0, 0.0, 0.0))
        if ok:
            CE.prefetch_lookup(etag, erec, edata, V[V_EUV * LANES + lane], V[(V_EUV + 1) * LANES + lane], False)
        V[V_EOK * LANES + lane] = 1.0 if ok else 0.0
    n_sh = 0
    for lane in range(n):
        ok = V[V_EOK * LANES + lane] != 0.0
        if ok:
            mm = int(V[V_MAT * LANES + lane])
            d = lane_vec(V, V_D, lane)
            ok, o, wi, val = env_value(etag, erec, edata, mats_tag[mm], mats_par, mm, lane_inputs(V, lane),
                                       lane_vec(V, V_P, lane), lane_vec(V, V_NG, lane), lane_vec(V, V_NS, lane),
                                       lane_vec(V, V_NV, lane), (-d[0], -d[1], -d[2]), lane_vec(V, V_LIFT, lane),
                                       V[V_MAG * LANES + lane], V[V_MAG_LIFT * LANES + lane], terminator,
                                       bsdf_technique, True, lane_vec(V, V_EWI, lane), lane_vec(V, V_EW, lane),
                                       V[V_EPDF * LANES + lane], lane_vec(V, V_ELOC, lane),
                                       (V[V_EUV * LANES + lane], V[(V_EUV + 1) * LANES + lane]))
            if ok:
                set_lane_vec(V, V_F, lane, val)
                E.packet_set_origin(sh, w, lane, o[0], o[1], o[2])
                E.packet_set_dir(sh, w, lane, wi[0], wi[1], wi[2], T_INF)
        V[V_LIT * LANES + lane] = 1.0 if ok else 0.0
        E.packet_set_active(sh, w, lane, ok)
        n_sh += ok
    return n_sh


@_stage
def area_light_weight(ltag, lpars, j, mtag, mpars, m, albedo, p, ns, wo, wi, n_l, n_b):
    """The power-heuristic weight of a light sample toward ``wi`` of area light ``j`` with ``n_b`` BSDF samples
    beside its ``n_l`` light samples (:func:`pyrt.integrators.direct.area_mis_estimate`'s ``w_light``: the light's
    density and the BSDF's of the hit's inputs ``albedo``, in the shading frame of ``ns``)."""
    pdf_l = LC.area_pdf_dist(ltag, lpars, j, p[0], p[1], p[2], wi[0], wi[1], wi[2])[0]
    fs, ft = CS.coordinate_frame(ns[0], ns[1], ns[2])
    wol, wil = CS.to_local(wo, fs, ft, ns), CS.to_local(wi, fs, ft, ns)
    pdf_b = CS.pdf_wi(mtag, mpars, m, albedo, wol[0], wol[1], wol[2], wil[0], wil[1], wil[2])
    return CS.power_heuristic(pdf_l, pdf_b, 2.0, float(n_l), float(n_b))


@_stage
def area_bsdf_sample(ltag, lpars, j, mtag, mpars, m, albedo, p, ng, ns, nv, wo, lift, mag, mag_lift, terminator, u0,
                     u1, n_l, n_b):
    """One BSDF sample toward area light ``j`` (``area_mis_estimate``'s second technique): ``(ok, origin, wi, tmax,
    value)``, ``value = weight L w_b`` where the sampled direction reaches the light's front (:func:`pyrt.lights.
    compiled.area_pdf_dist`), the shadow ray to that point (robust tmax); ``ok`` False where it adds nothing."""
    fs, ft = CS.coordinate_frame(ns[0], ns[1], ns[2])
    wol = CS.to_local(wo, fs, ft, ns)
    x, y, z, w_r, w_g, w_b, pdf_b = CS.sample_f(mtag, mpars, m, albedo, wol[0], wol[1], wol[2], u0, u1)
    wi = CS.to_world((x, y, z), fs, ft, ns)
    cg = dot(wi, ng)
    ok = (cg > 0.0 or dot(wi, nv) > 0.0) and pdf_b > 0.0 and max(w_r, w_g, w_b) > 0.0
    pdf_l, dist = LC.area_pdf_dist(ltag, lpars, j, p[0], p[1], p[2], wi[0], wi[1], wi[2])
    ok = ok and math.isfinite(dist)
    k = CS.power_heuristic(pdf_b, pdf_l, 2.0, float(n_b), float(n_l)) if ok else 0.0
    b = j * LC.RECORD
    val = (w_r * lpars[b + 6] * k, w_g * lpars[b + 7] * k, w_b * lpars[b + 8] * k)
    ok = ok and max(val[0], val[1], val[2]) > 0.0
    o = J.shadow_origin(p, ng, lift, mag, mag_lift, cg, terminator)
    d = dist if ok else 1.0
    tmax = J.robust_tmax(o, wi, p[0] + wi[0] * d, p[1] + wi[1] * d, p[2] + wi[2] * d, True)
    return ok, o, wi, min(tmax, T_INF), val


@_stage
def area_mis_stage(ltag, lpars, j, mats_tag, mats_par, V, n, n_l, n_b):
    """The light samples' MIS weights (:func:`area_light_weight`) into their values (:data:`V_F`) for the lanes
    whose shadow ray is traced, after :func:`bsdf_stage`."""
    for lane in range(n):
        if V[V_LIT * LANES + lane] != 0.0:
            m = int(V[V_MAT * LANES + lane])
            d = lane_vec(V, V_D, lane)
            k = area_light_weight(ltag, lpars, j, mats_tag[m], mats_par, m, lane_inputs(V, lane),
                                  lane_vec(V, V_P, lane), lane_vec(V, V_NS, lane), (-d[0], -d[1], -d[2]),
                                  lane_vec(V, V_WI, lane), n_l, n_b)
            f = lane_vec(V, V_F, lane)
            set_lane_vec(V, V_F, lane, (f[0] * k, f[1] * k, f[2] * k))


@_stage
def area_bsdf_stage(ltag, lpars, j, mats_tag, mats_par, V, keys, n, terminator, s, n_l, n_b, k_b, pair, lane_s, spp,
                    lane_k32, sh, w):
    """:func:`area_bsdf_sample` number ``s`` of ``n_b`` for the camera hits in lanes ``[0, n)`` (stratified per hit
    as the light samples, :func:`pyrt.lights.compiled.stratum`, the jitter padded: dimension pair ``pair``): the
    value into :data:`V_F`, whether it is traced into :data:`V_LIT`, the shadow ray into the packet ``sh``
    (width ``w``). Returns the number of shadow rays."""
    n_sh = 0
    padded_numbers(V, V_EU, lane_s, spp, lane_k32, pair, n, 0, 1)
    for lane in range(n):
        x0, x1 = V[V_EU * LANES + lane], V[(V_EU + 1) * LANES + lane]
        u0, u1 = LC.stratum(s, n_b, k_b, x0, x1, _lhs_perm(keys[lane], j + 4096, s, n_b, k_b))
        m = int(V[V_MAT * LANES + lane])
        mm = max(m, 0)
        mtag = mats_tag[mm]
        ok = False
        if m >= 0 and MC.has_diffuse(mtag):
            d = lane_vec(V, V_D, lane)
            ok, o, wi, tmax, val = area_bsdf_sample(
                ltag, lpars, j, mtag, mats_par, mm, lane_inputs(V, lane), lane_vec(V, V_P, lane),
                lane_vec(V, V_NG, lane), lane_vec(V, V_NS, lane), lane_vec(V, V_NV, lane), (-d[0], -d[1], -d[2]),
                lane_vec(V, V_LIFT, lane), V[V_MAG * LANES + lane], V[V_MAG_LIFT * LANES + lane], terminator, u0, u1,
                n_l, n_b)
            if ok:
                set_lane_vec(V, V_F, lane, val)
                E.packet_set_origin(sh, w, lane, o[0], o[1], o[2])
                E.packet_set_dir(sh, w, lane, wi[0], wi[1], wi[2], tmax)
        V[V_LIT * LANES + lane] = 1.0 if ok else 0.0
        E.packet_set_active(sh, w, lane, ok)
        n_sh += ok
    return n_sh


@numba.njit(nogil=True, cache=True, error_model="numpy")
def env_hit(scene, G, etag, erec, edata, mtag, mats_tag, mats_par, tex_tag, tex_par, sopt, m, albedo, p, ng, ns, nv, wo,
            lift, mag, mag_lift, terminator, key, n_l, n_b, ray_buf):
    """The environment light at one hit of the specular tree: ``n_l`` light and ``n_b`` BSDF samples
    (:func:`env_sample`; round ``s`` draws the light sample's numbers, then the
    BSDF sample's, each second number stratified over its technique's rounds), single shadow rays
    (:func:`pyrt.integrators.compiled_shadows.shadow_ray`); returns ``(r, g, b, shadow rays)``."""
    if erec[CE.R_PREVIEW] != 0.0:       # strategy="preview": no samples, no shadow rays
        e = PV.preview(etag, erec, edata, mtag, mats_par, m, albedo, ng, ns, wo)
        return e[0], e[1], e[2], 0.0
    a0 = a1 = a2 = 0.0
    b0 = b1 = b2 = 0.0
    n_sh = 0
    for s in range(max(n_l, n_b)):
        for tech in range(2):
            count = n_l if tech == 0 else n_b
            if s >= count:
                continue
            d = DIM_ENV + 4 * s + 2 * tech
            ok, o, wi, val = env_sample(etag, erec, edata, mtag, mats_par, m, albedo, p, ng, ns, nv, wo, lift, mag,
                                        mag_lift, terminator, J.uniform(key, d), (s + J.uniform(key, d + 1)) / count,
                                        tech == 1)
            if not ok:
                continue
            t0, t1, t2, n = shadow_ray(scene, G, mats_tag, mats_par, tex_tag, tex_par, sopt, o, wi, T_INF, ray_buf)
            n_sh += n
            if tech == 0:
                a0, a1, a2 = a0 + val[0] * t0, a1 + val[1] * t1, a2 + val[2] * t2
            else:
                b0, b1, b2 = b0 + val[0] * t0, b1 + val[1] * t1, b2 + val[2] * t2
    return a0 / n_l + b0 / n_b, a1 / n_l + b1 / n_b, a2 / n_l + b2 / n_b, float(n_sh)


@numba.njit(nogil=True, cache=True, error_model="numpy")
def env_rounds(scene, G, etag, erec, edata, mats_tag, mats_par, tex_tag, tex_par, sopt, V, n, terminator, pair, lane_s,
               spp, lane_k32, sh, w, n_l, n_b, cnt, ray_buf, lambert):
    """The environment light at the packet's camera hits: ``max(n_l, n_b)`` rounds, each the light technique's
    sample (while the round is below ``n_l``) then the BSDF technique's (below ``n_b``), each a masked occlusion
    query of the packet (:func:`env_stage`; blocked rays walked through see-through surfaces as ``sopt`` says,
    :func:`pyrt.integrators.compiled_shadows.packet_walk`); their values divided by their
    technique's count added into :data:`V_L`. Returns the next free padded dimension pair (one per sample drawn,
    in the NumPy path's order); ``lambert``: every hit of the packet is Lambert (:func:`env_stage`).
    ``strategy="preview"``: :func:`pyrt.integrators.compiled_preview.preview_stage` (no random numbers: the same
    ``pair`` returned)."""
    if erec[CE.R_PREVIEW] != 0.0:
        PV.preview_stage(etag, erec, edata, mats_tag, mats_par, V, n)
        return pair
    for s in range(max(n_l, n_b)):
        for tech in range(2):
            count = n_l if tech == 0 else n_b
            if s >= count:
                continue
            E.packet_activate(sh, w, 0)
            n_sh = env_stage(etag, erec, edata, mats_tag, mats_par, V, n, terminator, tech == 1, s, count, pair,
                             lane_s, spp, lane_k32, sh, w, lambert)
            pair += 1
            if n_sh == 0:
                continue
            cnt[N_SHADOW] += n_sh
            if walks(sopt):
                keep_rays(sh, w, V, n)
            E.packet_query(scene, sh, w, tech == 0, True)     # BSDF samples: incoherent
            if walks(sopt):
                cnt[N_SHADOW] += packet_walk(scene, G, mats_tag, mats_par, tex_tag, tex_par, sopt, sh, w, V, n,
                                             ray_buf)
            inv = 1.0 / count
            for lane in range(n):
                add = V[V_LIT * LANES + lane] != 0.0 and not E.lane_blocked(sh, w, lane)
                for c in range(3):
                    V[(V_L + c) * LANES + lane] += V[(V_F + c) * LANES + lane] * inv if add else 0.0
    return pair


kernel_cache.restore()
