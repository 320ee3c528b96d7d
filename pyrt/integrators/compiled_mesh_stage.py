"""The emissive-mesh light in the compiled tile kernel: its light samples at camera hits (a packet stage) and at one
hit of the specular tree or a glossy ray (single shadow rays), and the MIS weight of its emission that glossy rays
reach.

The estimate is :func:`pyrt.integrators.direct.light_sampling_estimate` of :class:`pyrt.EmissiveMeshLight`:
``n`` samples per hit (stratified as the area lights', :func:`pyrt.lights.compiled.stratum`; at camera hits each
stratum's jitter padded over the pixel's samples as the NumPy path's), each ``f_cos L / pdf`` of a point on a chosen
triangle (:func:`pyrt.lights.compiled_mesh.sample`) with a shadow ray to it. At a hit that traces ``nb`` glossy rays
each sample is weighted by the power heuristic ``w_l`` of ``n`` light samples against them
(:meth:`pyrt.integrators.glossy.GlossyIntegrator._direct_light`), and a glossy ray that hits one of the light's
triangles weighs its emission by ``w_b`` with the light's density at that point (:func:`emission_weight`,
``GlossyIntegrator._emission_weight``).
"""
from __future__ import annotations

import math

from pyrt.integrators import kernel_cache

kernel_cache.use_cache_dir()      # before the decorators below run

from pyrt.geometry import embree_jit as E  # noqa: E402
from pyrt.integrators.compiled_layout import (  # noqa: E402
    LANES, N_SHADOW, T_INF, V_D, V_EU, V_F, V_LIFT, V_LIT, V_MAG, V_MAG_LIFT, V_MAT, V_NG, V_NS, V_NV, V_P, _njit,
    _stage, lane_inputs, lane_vec, padded_numbers, set_lane_vec)
from pyrt.integrators.compiled_lighting import _lhs_perm, area_u, shadow_add  # noqa: E402
from pyrt.integrators.compiled_shadows import keep_rays, packet_walk, shadow_ray, walks  # noqa: E402
from pyrt.lights import compiled as LC  # noqa: E402
from pyrt.lights import compiled_mesh as CM  # noqa: E402
from pyrt.materials import compiled as MC  # noqa: E402
from pyrt.materials import compiled_sampling as CS  # noqa: E402
from pyrt.shaders import jit as J  # noqa: E402
from pyrt.shaders.jit import dot  # noqa: E402


@_njit
def mesh_light(lpars, j, mtag, mpars, m, albedo, p, ng, ns, nv, wo, lift, mag, mag_lift, terminator, u0, u1):
    """One sample of mesh light ``j`` at a hit before shadowing (:func:`pyrt.integrators.compiled_lighting.
    direct_light` for this light): ``(ok, tmax, origin, wi, f, pdf)``, ``f = f_cos L / pdf``, the shadow ray to the
    sampled point (robust tmax); ``ok`` False where it adds nothing (no density, the wrong side, no radiance, a zero
    BSDF: :func:`pyrt.integrators.direct._lit_lanes`)."""
    wx, wy, wz, dist, pdf, r, g, b = CM.sample(lpars, j, p[0], p[1], p[2], u0, u1)
    wi = (wx, wy, wz)
    cg = dot(wi, ng)
    ok = pdf > 0.0 and max(r, g, b) > 0.0 and (cg > 0.0 or dot(wi, nv) > 0.0)
    f = CS.f_cos_world(mtag, mpars, m, albedo, wo, wi, ns)
    ok = ok and max(f[0], f[1], f[2]) > 0.0
    k = 1.0 / pdf if ok else 0.0
    f = (f[0] * (r * k), f[1] * (g * k), f[2] * (b * k))
    o = J.shadow_origin(p, ng, lift, mag, mag_lift, cg, terminator)
    tmax = J.robust_tmax(o, wi, p[0] + wx * dist, p[1] + wy * dist, p[2] + wz * dist, True)
    return ok, min(tmax, T_INF), o, wi, f, pdf


@_stage
def mesh_stage(lpars, j, mats_tag, mats_par, V, keys, n, terminator, s, ns, k, pair, lane_s, spp, lane_k32, sh, w):
    """Sample ``s`` of mesh light ``j``'s ``ns`` per hit (``k = isqrt(ns)``) for the camera hits in lanes ``[0, n)``,
    their numbers as :func:`pyrt.integrators.compiled_lighting.area_stage`'s (the dimension pair ``pair``): the value
    into :data:`V_F`, whether it is traced into :data:`V_LIT`, the shadow ray into the packet ``sh`` (width ``w``, the
    lane switched on accordingly). Returns the number of shadow rays."""
    n_sh = 0
    padded_numbers(V, V_EU, lane_s, spp, lane_k32, pair, n, 0, 1)
    for lane in range(n):
        x0, x1 = V[V_EU * LANES + lane], V[(V_EU + 1) * LANES + lane]
        u0, u1 = LC.stratum(s, ns, k, x0, x1, _lhs_perm(keys[lane], j, s, ns, k))
        m = int(V[V_MAT * LANES + lane])
        mm = max(m, 0)
        mtag = mats_tag[mm]
        ok = False
        if m >= 0 and MC.has_diffuse(mtag):
            d = lane_vec(V, V_D, lane)
            ok, tmax, o, wi, f, _ = mesh_light(
                lpars, j, mtag, mats_par, mm, lane_inputs(V, lane), lane_vec(V, V_P, lane), lane_vec(V, V_NG, lane),
                lane_vec(V, V_NS, lane), lane_vec(V, V_NV, lane), (-d[0], -d[1], -d[2]), lane_vec(V, V_LIFT, lane),
                V[V_MAG * LANES + lane], V[V_MAG_LIFT * LANES + lane], terminator, u0, u1)
            if ok:
                set_lane_vec(V, V_F, lane, f)
                E.packet_set_origin(sh, w, lane, o[0], o[1], o[2])
                E.packet_set_dir(sh, w, lane, wi[0], wi[1], wi[2], tmax)
        V[V_LIT * LANES + lane] = 1.0 if ok else 0.0
        E.packet_set_active(sh, w, lane, ok)
        n_sh += ok
    return n_sh


@_stage
def mesh_rounds(scene, G, lights_par, j, mats_tag, mats_par, tex_tag, tex_par, sopt, V, keys, n, terminator, pair,
                lane_s, spp, lane_k32, sh, w, cnt, ray_buf):
    """Mesh light ``j`` at the packet's camera hits: per sample one :func:`mesh_stage` and a masked occlusion query
    (blocked rays walked through see-through surfaces as ``sopt`` says, :func:`pyrt.integrators.compiled_shadows.
    packet_walk`), the values divided by the sample count added into the lanes' radiance. Returns the next free
    padded dimension pair (one per sample, as an area light's)."""
    n_j = int(lights_par[j * LC.RECORD + LC.AREA_SAMPLES])
    k_j = J.isqrt(n_j)
    for s in range(n_j):
        E.packet_activate(sh, w, 0)
        n_sh = mesh_stage(lights_par, j, mats_tag, mats_par, V, keys, n, terminator, s, n_j, k_j, pair + s, lane_s,
                          spp, lane_k32, sh, w)
        if n_sh == 0:
            continue
        cnt[N_SHADOW] += n_sh
        if walks(sopt):                          # the rays packet_walk may walk
            keep_rays(sh, w, V, n)
        E.packet_query(scene, sh, w, True, True)
        if walks(sopt):
            cnt[N_SHADOW] += packet_walk(scene, G, mats_tag, mats_par, tex_tag, tex_par, sopt, sh, w, V, n, ray_buf)
        shadow_add(V, sh, w, n, 1.0 / n_j)
    return pair + n_j


@_stage
def mesh_hit(scene, G, lights_par, j, mtag, mats_tag, mats_par, tex_tag, tex_par, sopt, m, albedo, p, ng, ns, nv, wo,
             lift, mag, mag_lift, terminator, hkey, nb, ray_buf):
    """Mesh light ``j`` at one hit whose random numbers are keyed by ``hkey`` (:func:`pyrt.integrators.
    compiled_lighting.area_u`): its ``n`` samples, single shadow rays (:func:`pyrt.integrators.compiled_shadows.
    shadow_ray`), each weighted by the power heuristic against the hit's ``nb`` glossy rays (``nb`` 0: weight 1).
    Returns ``(r, g, b, shadow rays)``."""
    n_j = int(lights_par[j * LC.RECORD + LC.AREA_SAMPLES])
    k_j = J.isqrt(n_j)
    fs, ft = CS.coordinate_frame(ns[0], ns[1], ns[2])
    wol = CS.to_local(wo, fs, ft, ns)
    l0 = l1 = l2 = 0.0
    n_sh = 0
    for s in range(n_j):
        u0, u1 = area_u(hkey, j, s, n_j, k_j)
        ok, tmax, o, wi, f, pdf = mesh_light(lights_par, j, mtag, mats_par, m, albedo, p, ng, ns, nv, wo, lift, mag,
                                             mag_lift, terminator, u0, u1)
        if not ok:
            continue
        t0, t1, t2, n = shadow_ray(scene, G, mats_tag, mats_par, tex_tag, tex_par, sopt, o, wi, tmax, ray_buf)
        n_sh += n
        k = 1.0
        if nb > 0:
            wil = CS.to_local(wi, fs, ft, ns)
            pdf_b = CS.pdf_wi(mtag, mats_par, m, albedo, wol[0], wol[1], wol[2], wil[0], wil[1], wil[2])
            k = CS.power_heuristic(pdf, pdf_b, 2.0, float(n_j), float(nb))
        l0 += f[0] * k * t0
        l1 += f[1] * k * t1
        l2 += f[2] * k * t2
    return l0 / n_j, l1 / n_j, l2 / n_j, n_sh


@_njit
def emission_weight(lights_tag, lights_par, nl, o, p, ng, geom, prim, pdf, p_area):
    """The MIS weight of the emission a glossy ray (density ``pdf``) from ``o`` reaches at ``p`` on scene mesh
    ``geom``'s triangle ``prim`` (geometric normal ``ng``), given the area lights' density ``p_area`` (their samples
    times their pdf) of its direction: the power heuristic against every mesh light's samples times its density at
    the point (:meth:`pyrt.EmissiveMeshLight.pdf_hit`), 1 where no light samples it."""
    p_l = p_area
    for j in range(nl):
        if lights_tag[j] != LC.MESH:
            continue
        dx, dy, dz = p[0] - o[0], p[1] - o[1], p[2] - o[2]
        dist = math.sqrt(dx * dx + dy * dy + dz * dz)
        inv = 1.0 / dist if dist > 0.0 else 0.0
        cos_l = (dx * ng[0] + dy * ng[1] + dz * ng[2]) * inv
        p_l += lights_par[j * LC.RECORD + LC.AREA_SAMPLES] * CM.pdf_hit(lights_par, j, o[0], o[1], o[2], geom, prim,
                                                                       dist, cos_l)
    if not p_l > 0.0:
        return 1.0
    return CS.power_heuristic(pdf, p_l, 2.0, 1.0, 1.0)


kernel_cache.restore()
