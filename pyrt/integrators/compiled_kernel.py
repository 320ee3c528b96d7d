"""The compiled Whitted / direct-lighting tile kernel (Numba, nopython, nogil).

One call renders a list of 8 x 8 pixel tiles (``prange`` over them, the tiles shuffled so that every thread gets
a share of the whole image). Per pixel, its samples go in packets of up to 16 (the samples of one pixel are the
most coherent rays there are): camera rays -> ``rtcIntersect16`` (COHERENT) -> the hit rebuilt in float64 from the
triangle's vertices and the barycentrics -> direct light from every light, each light's shadow rays of the packet
one masked ``rtcOccluded16`` (blocked rays walked through see-through surfaces: :mod:`.compiled_shadows`) -> the
specular tree (mirror, glass reflection and refraction, the split-depth rule) as a per-sample loop over a small stack
with single-ray queries -> per-pixel sums and squared sums in float64.

The estimator is :class:`pyrt.integrators.whitted.Integrator`'s for the scenes :mod:`pyrt.integrators.compiled`
accepts (no nested media; culled back faces, alpha masks and blend surfaces by
:mod:`pyrt.integrators.compiled_coverage`, a blend hit's continuation a row of the specular stack): the same hit reconstruction
(:func:`pyrt.geometry.surface.surface_from_hits`), offsets (:mod:`pyrt.geometry.offsets`, ``robust`` with or without
the terminator lift: local error bound along ng, float32 rounding one ulp outward, robust shadow tmax), light sides,
BRDFs, Fresnel and lobe choice. Random numbers are counter-based (:func:`pyrt.shaders.jit.uniform` of seed, pixel,
sample and dimension), so the image depends on the seed alone, not on the threads.

A packet's values pass between its stages in a per-tile scratch ``V`` (field-major: field ``f`` of lane ``l`` at
``f * LANES + l``, offsets ``V_*``); per-ray values in the specular tree are locals; nothing is allocated per ray.
The per-sample code reads every array through a raw pointer (:func:`pyrt.core.unmanaged.pointer`): Numba's
reference counting is atomic and a call per binding of an array (measured: it outweighed Embree in the first
version). Helpers are inlined by LLVM (``forceinline=True``); the lane loops that vectorise are compiled as functions of their own (``_stage``).
"""
from __future__ import annotations

import math

import numba
import numpy as np
from numba import prange

from pyrt.integrators import kernel_cache

kernel_cache.use_cache_dir()      # before the decorators below (and those of the modules they inline) run

from pyrt.core import unmanaged as U  # noqa: E402
from pyrt.geometry import embree_jit as E  # noqa: E402
from pyrt.integrators.compiled_layout import (  # noqa: E402
    TILE, LANES, V_D, V_P, V_NG, V_NS, V_NV, V_LIFT, V_MAG, V_MAG_LIFT, V_FRONT, V_MAT, V_L, V_COSO, C_POS, C_FWD,
    C_RIGHT, C_UP, C_TAN, C_W, C_H, C_JITTER, C_K, C_AX, O_SEED, O_SPP, O_MAX_DEPTH, O_SPLIT, O_TERMINATOR, O_NLIGHTS,
    O_SPP_LO, O_FALLBACK, O_GRID, F_CUTOFF, F_BG, N_PRIMARY, N_SECONDARY, O_COVER, O_LAYERS, N_SHADOW, N_NONFINITE,
    STACK, STACK_ROW, STACK_PDF, STACK_TB, STACK_LAYER, T_INF, DIM_LOBE, MED_ROW, O_MEDIA, V_X, O_GLOSSY_N, O_GLOSSY_DEPTH, O_SELECT,
    F_GLOSSY_T, F_GLOSSY_CLAMP, V_GL, O_GLOSSY_ENV, O_ROULETTE, ADAPTIVE_KEYS, O_ENV, O_AOV, O_SQ, N_AOV, V_T, O_DIFFS,
    TILES_PER_TASK, _njit, add_aovs, buffer_pointers, film_add, geometry_pointers, lane_vec, packet_buffers, pass_add,
    release, set_lane_inputs, set_lane_vec, table_pointers)
from pyrt.integrators import compiled_diffs as D, compiled_media as CMD, compiled_mesh_stage as MS  # noqa: E402
from pyrt.integrators.compiled_coverage import (  # noqa: E402
    MASKS, cover_finish, cover_packet, cover_single, lane_through, split_blend)
from pyrt.integrators.compiled_shadows import keep_rays, packet_walk, shadow_options, walks  # noqa: E402
from pyrt.integrators.compiled_hit import (clamp_sampled, emission_weight, escape_weight, hit_light,  # noqa: E402
                                           is_glossy, lane_hit, push, set_aside, spawn_glossy, survive)
from pyrt.integrators.compiled_surface import face_surfaces, with_ambient  # noqa: E402
from pyrt.integrators.compiled_lighting import (  # noqa: E402
    area_bsdf_stage, area_mis_stage, area_stage, bsdf_stage, camera_fill, env_rounds, lambert_stage, light_stage,
    shadow_add, shadow_fill)
from pyrt.lights import compiled as LC  # noqa: E402
from pyrt.lights import compiled_env as CE  # noqa: E402
from pyrt.materials import compiled as MC  # noqa: E402
from pyrt.shaders import jit as J  # noqa: E402
from pyrt.shaders import jit_sampling as JS  # noqa: E402
from pyrt.shaders.jit import dot  # noqa: E402

#: ``shade_packet``'s ``spp`` for the adaptive passes' progressive sample sets, a typed int64: a literal ``-1``
#: argument would compile ``shade_packet`` a second time for that entry (Numba specialises a call between kernels
#: on ``Literal[int](-1)``), two minutes of a cold compile
PROGRESSIVE = np.int64(-1)


@_njit
def camera_dir(cam, x, y):
    """Unit direction (float64 3-tuple) through raster point ``(x, y)`` (:meth:`pyrt.core.camera.Camera.directions`,
    with ``sx = x k - a_x``, ``sy = a_y - y k`` from the camera record's precomputed ``k = 2 tan(fov/2) / H``,
    ``a_x = tan(fov/2) W / H``, ``a_y = tan(fov/2)``: no division but the normalisation's)."""
    sx = x * cam[C_K] - cam[C_AX]
    sy = cam[C_TAN] - y * cam[C_K]
    inv = 1.0 / math.sqrt(1.0 + sx * sx + sy * sy)
    return (inv * (cam[C_FWD] + sx * cam[C_RIGHT] + sy * cam[C_UP]),
            inv * (cam[C_FWD + 1] + sx * cam[C_RIGHT + 1] + sy * cam[C_UP + 1]),
            inv * (cam[C_FWD + 2] + sx * cam[C_RIGHT + 2] + sy * cam[C_UP + 2]))


@_njit
def spawn(p, ng, ns, wo, front, mag, mtag, mpars, m, base, eta_in, thr, depth, split, cutoff, rr, key, dim, stack,
          top, V, lane, diffs):
    """Push the delta lobes of a hit of material ``m`` (reached with throughput ``thr``, a 3-tuple, at bounce
    ``depth``) onto ``stack`` (rows: origin, direction, throughput, depth) from row ``top``; returns ``(top, dim)``
    (:meth:`pyrt.integrators.whitted.Integrator._spawn_specular`: mirror reflections the shading normal sends below
    the geometric surface are dropped; from the split depth (``split`` >= 0) on a dielectric follows one lobe, chosen
    by weight; a lobe at or below ``cutoff`` is dropped, or with ``rr`` continues by Russian roulette,
    :func:`pyrt.integrators.compiled_hit.survive`, its number the sample's next dimension ``dim``). ``base``: a GLTF
    hit's base colour (RGB, its inputs' :func:`pyrt.materials.compiled.gltf_inputs`: the tint of its transmission);
    ``eta_in`` > 0: the refraction's relative index from the ray's interface stack
    (:mod:`pyrt.integrators.compiled_media`)."""
    cos_o = dot(wo, ns)
    wr = (2.0 * cos_o * ns[0] - wo[0], 2.0 * cos_o * ns[1] - wo[1], 2.0 * cos_o * ns[2] - wo[2])
    if not MC.is_dielectric(mtag, mpars, m):   # mirror-like: one reflection lobe (MC.mirror_weight)
        if not dot(wr, ng) > 0.0:
            return top, dim
        w = MC.mirror_weight(mtag, mpars, m, cos_o)
        alive, t, dim = survive((thr[0] * w[0], thr[1] * w[1], thr[2] * w[2]), cutoff, rr, key, dim)
        if alive and top < STACK:
            top = push(p, ng, mag, stack, top, wr, t, depth + 1, V, lane, diffs, ns, wo, 0.0, 0.0)
        return top, dim
    # a dielectric (GLASS, smooth glTF transmission): reflection and refraction (MC.dielectric_lobes)
    eta, fr, ft = MC.dielectric_lobes(mtag, mpars, m, cos_o, front, eta_in, base)
    sin2_t = max(0.0, 1.0 - cos_o * cos_o) / (eta * eta)
    cos_t = math.sqrt(max(0.0, 1.0 - sin2_t))
    k = cos_o / eta - cos_t
    wt = (-wo[0] / eta + k * ns[0], -wo[1] / eta + k * ns[1], -wo[2] / eta + k * ns[2]) if eta != 1.0 else \
        (-wo[0], -wo[1], -wo[2])
    wR = wT = 1.0
    mr, mt = (fr[0] + fr[1] + fr[2]) / 3.0, (ft[0] + ft[1] + ft[2]) / 3.0
    if split >= 0 and depth >= split and mt > 0.0:
        # choose_one_lobe: probability by the lobes' mean weight
        total = mr + mt
        u = J.uniform(key, dim)
        dim += 1
        p_r = mr / total
        if u < p_r:
            wR, wT = (1.0 / p_r if mr > 0.0 else 0.0), 0.0
        else:
            wR, wT = 0.0, 1.0 / (1.0 - p_r)
    alive, t, dim = survive((thr[0] * fr[0] * wR, thr[1] * fr[1] * wR, thr[2] * fr[2] * wR), cutoff, rr, key, dim)
    if alive and top < STACK:
        top = push(p, ng, mag, stack, top, wr, t, depth + 1, V, lane, diffs, ns, wo, 0.0, 0.0)
    if mt > 0.0:
        alive, t, dim = survive((thr[0] * ft[0] * wT, thr[1] * ft[1] * wT, thr[2] * ft[2] * wT), cutoff, rr, key,
                                dim)
        if alive and top < STACK:
            top = push(p, ng, mag, stack, top, wt, t, depth + 1, V, lane, diffs, ns, wo, eta, 0.0)
    return top, dim


@numba.njit(nogil=True, cache=True, error_model="numpy")
def trace_stack(scene, G, mats_tag, mats_par, tex_tag, tex_par, lights_tag, lights_par, erec, edata, opts, optf, key,
                dim, stack, top, ray_buf, counters, r0, r1, r2, V, lane):
    """Trace the rays on ``stack`` (and those they spawn) with single-ray queries: the deeper bounces of one camera
    sample (lane ``lane`` of ``V``), delta rays and the glossy integrator's BSDF-sampled rays (their density in the
    row's :data:`STACK_PDF`: the emission they reach is MIS-weighted, the direct light at their hits clamped by
    ``glossy_clamp`` and lit by one chosen light from bounce ``light_select_depth`` on); returns the radiance
    ``(r0, r1, r2)`` plus theirs. Everything per ray is local; every table, the stack and the ray buffer are pointers
    (:func:`pyrt.core.unmanaged.pointer`)."""
    diffs = opts[O_DIFFS] != 0
    fallback = opts[O_FALLBACK] != 0
    terminator = opts[O_TERMINATOR] != 0
    split, cutoff, max_depth, nl = opts[O_SPLIT], optf[F_CUTOFF], opts[O_MAX_DEPTH], opts[O_NLIGHTS]
    rr = opts[O_ROULETTE] != 0
    gl_n, gl_depth, select = opts[O_GLOSSY_N], opts[O_GLOSSY_DEPTH], opts[O_SELECT]
    threshold, limit = optf[F_GLOSSY_T], optf[F_GLOSSY_CLAMP]
    etag = opts[O_ENV]
    cover, masks, layers = opts[O_COVER] != 0, opts[O_COVER] == MASKS, opts[O_LAYERS]
    sopt = shadow_options(opts)
    media = opts[O_MEDIA] != 0
    n_sec = n_sh = n_re = 0
    while top > 0:
        top -= 1
        row = STACK_ROW * top
        if media:       # the ray's interface stack in hand (its children's rows overwrite this one)
            CMD.copy(stack, top, MED_ROW)
            if CMD.lost(stack, MED_ROW):
                continue
        top0 = top
        thr = (stack[row + 6], stack[row + 7], stack[row + 8])
        depth = int(stack[row + 9])
        bpdf, tb, layer = stack[row + STACK_PDF], stack[row + STACK_TB], stack[row + STACK_LAYER]
        o = (stack[row], stack[row + 1], stack[row + 2])
        d0, d1, d2 = stack[row + 3], stack[row + 4], stack[row + 5]
        D.load_ray(stack, row, V, lane, diffs)
        n_sec += 1
        hit, _, prim, geom, u, v, _, _, _ = E.intersect1(scene, o[0], o[1], o[2], d0, d1, d2, 0.0, T_INF, ray_buf)
        a = 1.0
        if cover:   # culled faces, cut-outs and a = 0 skipped, blend weight a (compiled_coverage); dropped: nothing
            hit, prim, geom, u, v, dropped, n_skip, a = cover_single(
                scene, G, mats_par, tex_tag, tex_par, layers, masks, hit, prim, geom, u, v, (d0, d1, d2), ray_buf,
                int(layer), V, lane, diffs)
            n_re += n_skip
            layer += n_skip + 1.0
            if dropped:
                continue
        o_seg, length = o, 0.0
        if media:       # false hits crossed (nested dielectrics), compiled_media
            hit, prim, geom, u, v, o_seg, length, ok, n_skip = CMD.skip_false(
                scene, G, fallback, mats_par, tex_tag, tex_par, layers, cover, stack, hit, prim, geom, u, v, o,
                (d0, d1, d2), ray_buf, V, lane, diffs)
            n_re += n_skip
            if not ok:
                continue
        if not hit:     # (a camera ray's continuation, bounce 0, sees what a camera ray sees)
            bg = CE.missed(etag, erec, edata, d0, d1, d2, depth == 0) if etag else (optf[F_BG], optf[F_BG + 1],
                                                                                   optf[F_BG + 2])
            if media:   # escaped from inside an absorbing medium: 0 in its absorbing channels
                k = CMD.attenuation(stack, MED_ROW, mats_par, math.inf)
                bg = (bg[0] * k[0], bg[1] * k[1], bg[2] * k[2])
            if bpdf > 0.0:      # an escaped glossy ray: MIS against the map's samples at glossy hits
                k = escape_weight(etag, erec, edata, opts[O_GLOSSY_ENV], (d0, d1, d2), bpdf)
                bg = (bg[0] * k, bg[1] * k, bg[2] * k)
            r0 += thr[0] * bg[0]
            r1 += thr[1] * bg[1]
            r2 += thr[2] * bg[2]
            continue
        wo = (-d0, -d1, -d2)
        p, ng, ns, nv, lift, mag, mag_lift, front, face, uv = J.hit_surface(G, fallback, terminator, geom, prim, u, v,
                                                                          wo)
        eta_in = 0.0
        if media:       # Beer-Lambert over the ray's length in its current medium; the index it refracts by
            k = CMD.attenuation(stack, MED_ROW, mats_par, length + math.sqrt(
                (p[0] - o_seg[0]) ** 2 + (p[1] - o_seg[1]) ** 2 + (p[2] - o_seg[2]) ** 2))
            thr = (thr[0] * k[0], thr[1] * k[1], thr[2] * k[2])
            if CMD.participates(mats_par, G[8][face]):
                eta_in = CMD.classify(stack, MED_ROW, mats_par, G[8][face], front)[1]
        if a < 1.0:             # a blend surface: this hit weighted a, the ray continued past it with 1 - a
            top, thr = split_blend(stack, top, p, ng, mag, o, (d0, d1, d2), thr, depth, bpdf, tb, layer, a, cutoff,
                                   V, lane, diffs)
        m = G[8][face]
        mtag = mats_tag[m]
        albedo, ns, em = D.hit_inputs(G, V, lane, opts, face, u, v, p, ng, ns, wo, front, uv, mtag, mats_par, m,
                                      tex_tag, tex_par)
        if bpdf > 0.0:          # the emission a glossy ray reaches (from its first origin): MIS against light samples
            o = (o[0] - tb * d0, o[1] - tb * d1, o[2] - tb * d2)
            k = emission_weight(lights_tag, lights_par, nl, mats_par, m, o, (d0, d1, d2), bpdf, p, ng, geom, prim)
            em = (em[0] * k, em[1] * k, em[2] * k)
        le0, le1, le2 = with_ambient(mtag, em, albedo, optf)
        sampled = False
        if MC.has_diffuse(mtag):
            sampled = depth < gl_depth and depth < max_depth and is_glossy(mats_par, m, albedo, threshold)
            nb = (gl_n if depth == 0 else 1) if sampled else 0
            l0, l1, l2, n = hit_light(scene, G, lights_tag, lights_par, nl, mats_tag, mats_par, tex_tag, tex_par, etag,
                                      erec, edata, mtag, m, albedo, p, ng, ns, nv, wo, lift, mag, mag_lift, terminator,
                                      J.sample_key(key, n_sec), sopt, ray_buf, nb,
                                      0 <= select <= depth and (bpdf > 0.0 or depth == 0))
            n_sh += n
            if bpdf > 0.0 and limit < math.inf:
                l0, l1, l2 = clamp_sampled(l0, l1, l2, thr, limit)
            le0, le1, le2 = le0 + l0, le1 + l1, le2 + l2
        r0 += thr[0] * le0
        r1 += thr[1] * le1
        r2 += thr[2] * le2
        if sampled:
            top = spawn_glossy(p, ng, ns, wo, mag, mtag, mats_par, m, albedo, thr, depth, gl_n if depth == 0 else 1,
                               cutoff, rr, J.sample_key(key, n_sec), stack, top, V, lane, diffs)
        if depth < max_depth and MC.has_delta(mtag, mats_par, m):
            top, dim = spawn(p, ng, ns, wo, front, mag, mtag, mats_par, m, (albedo[3], albedo[4], albedo[5]), eta_in,
                             thr, depth, split, cutoff, rr, key, dim, stack, top, V, lane, diffs)
        if media:       # the spawned rays' interface stacks
            CMD.spawned(stack, MED_ROW, top0, top, mats_par, m, front, ng)
    counters[N_SECONDARY] += n_sec + n_re
    counters[N_SHADOW] += n_sh
    return r0, r1, r2


@numba.njit(nogil=True, cache=True, error_model="numpy")
def shade_packet(scene, G, cam, pk, sh, ray_buf, V, stack, keys, lane_s, lane_k32, spp, n, w, mats_tag, mats_par,
                 tex_tag, tex_par, lights_tag, lights_par, erec, edata, opts, optf, cnt):
    """Trace and shade a packet of ``n`` camera rays (directions in the scratch ``V`` at :data:`V_D`, lane ``l``'s
    random numbers keyed by ``keys[l]``, its padded light samples by sample ``lane_s[l]`` of its pixel's set of
    ``spp`` (``spp`` <= 0: a progressive set) and the pixel seed ``lane_k32[l]``): the camera packet's query, the
    hits' surfaces, per light the shadow rays in one masked query, the specular tree of each sample; each lane's
    radiance into :data:`V_L` (a non-finite value zeroed and counted), rays counted into ``cnt``. ``erec``,
    ``edata``: the environment's record and data (:mod:`pyrt.lights.compiled_env`; its tag ``opts[O_ENV]``); ``cam``
    the camera record (its position: the packet's origin). Every argument but the numbers and the geometry tuple
    ``G`` is a pointer."""
    fmat = G[8]
    etag = opts[O_ENV]
    nl = opts[O_NLIGHTS]
    max_depth, split, cutoff = opts[O_MAX_DEPTH], opts[O_SPLIT], optf[F_CUTOFF]
    fallback = opts[O_FALLBACK] != 0
    terminator = opts[O_TERMINATOR] != 0
    bg = (optf[F_BG], optf[F_BG + 1], optf[F_BG + 2])
    want_aovs = opts[O_AOV] != 0
    n_prim = n_shadow = n_bad = 0
    camera_fill(V, pk, w, n)
    E.packet_activate(pk, w, n)
    n_prim += n
    E.packet_query(scene, pk, w, True, False)
    cover, masks = opts[O_COVER] != 0, opts[O_COVER] == MASKS
    sopt = shadow_options(opts)
    walk = walks(sopt)
    if cover:               # culled back faces and mask cut-outs skipped: lanes on one re-traced (compiled_coverage)
        cnt[N_SECONDARY] += cover_packet(scene, G, mats_par, tex_tag, tex_par, cam, pk, w, V, n, opts[O_LAYERS],
                                         masks, opts[O_DIFFS] != 0)
    # the hits' surfaces, albedo and emission: vectorised passes when the lanes hit at most a few triangles of
    # constant-albedo materials (compiled_surface), else lane by lane (a miss: face 0 computed and dropped)
    # (not with differentials: the lane-by-lane loop computes them)
    by_face, any_diffuse, lambert = (False, False, False) if opts[O_DIFFS] != 0 else face_surfaces(
        G, mats_tag, mats_par, tex_tag, tex_par, optf, pk, w, V, n, fallback, terminator, etag, erec, edata)
    if not by_face:
        any_diffuse = False
        lambert = True
        for lane in range(n):
            geom, prim = E.packet_geom_prim(pk, w, lane)
            hit = geom != -1
            geom, prim = (geom, prim) if hit else (0, 0)
            u, v = E.packet_uv(pk, w, lane)
            d = lane_vec(V, V_D, lane)
            p, ng, ns, nv, lift, mag, mag_lift, front, face, uv = J.hit_surface(
                G, fallback, terminator, geom, prim, u, v, (-d[0], -d[1], -d[2]))
            m = fmat[face]
            mtag = mats_tag[m]
            albedo, ns, em = D.hit_inputs(G, V, lane, opts, face, u, v, p, ng, ns, (-d[0], -d[1], -d[2]), front, uv,
                                          mtag, mats_par, m, tex_tag, tex_par)
            le = with_ambient(mtag, em, albedo, optf)
            any_diffuse = any_diffuse or (hit and MC.has_diffuse(mtag))
            lambert = lambert and (mtag == MC.LAMBERT or not hit)
            set_lane_vec(V, V_P, lane, p)
            set_lane_vec(V, V_NG, lane, ng)
            set_lane_vec(V, V_NS, lane, ns)
            set_lane_vec(V, V_NV, lane, nv)
            if terminator:      # read only with the terminator lift (its stores cost: a packet's loops are store-bound)
                set_lane_vec(V, V_LIFT, lane, lift)
                V[V_MAG_LIFT * LANES + lane] = mag_lift
            set_lane_inputs(V, lane, albedo, mtag == MC.GLTF)
            if not hit and etag != 0:
                le = CE.missed(etag, erec, edata, d[0], d[1], d[2], True)
            set_lane_vec(V, V_L, lane, le if hit or etag != 0 else bg)
            V[V_MAG * LANES + lane] = mag
            V[V_FRONT * LANES + lane] = 1.0 if front else 0.0
            V[V_MAT * LANES + lane] = m if hit else -1
            V[V_COSO * LANES + lane] = dot((-d[0], -d[1], -d[2]), ns)
            if want_aovs:
                V[V_T * LANES + lane] = E.packet_tfar(pk, w, lane) if hit else math.inf
    if cover:
        cover_finish(V, n)
    # camera hits lit lane by lane (compiled_hit: glossy hits, hits that choose a light) leave the light stages
    per_lane = (opts[O_GLOSSY_N] > 0 and opts[O_GLOSSY_DEPTH] > 0 and max_depth > 0) or opts[O_SELECT] == 0
    if per_lane:
        any_diffuse = set_aside(V, n, mats_tag, mats_par, opts, optf)
    # direct light: per light, the packet's shadow rays (geometry, then the BSDF) in one masked query
    pair = 0                # the padded dimension pairs of the area lights' samples
    for j in range(nl if any_diffuse else 0):
        ltag = lights_tag[j]
        if ltag == LC.ENV:
            pair = env_rounds(scene, G, etag, erec, edata, mats_tag, mats_par, tex_tag, tex_par, sopt, V, n,
                              terminator, pair, lane_s, spp, lane_k32, sh, w, int(lights_par[j * LC.RECORD]),
                              int(lights_par[j * LC.RECORD + 1]), cnt, ray_buf, lambert)
            continue
        if ltag == LC.MESH:     # the emissive-mesh light's samples (compiled_mesh_stage)
            pair = MS.mesh_rounds(scene, G, lights_par, j, mats_tag, mats_par, tex_tag, tex_par, sopt, V, keys, n,
                                  terminator, pair, lane_s, spp, lane_k32, sh, w, cnt, ray_buf)
            continue
        area = ltag >= LC.RECT
        n_j = int(lights_par[j * LC.RECORD + LC.AREA_SAMPLES]) if area else 1
        n_b = int(lights_par[j * LC.RECORD + LC.AREA_SAMPLES + 1]) if area else 0
        k_j, k_b = J.isqrt(n_j), J.isqrt(n_b)
        # the light samples (with BSDF samples beside them: MIS-weighted), then the BSDF samples
        for s in range(n_j + n_b):
            E.packet_activate(sh, w, 0)
            if s >= n_j:
                n_sh = area_bsdf_stage(ltag, lights_par, j, mats_tag, mats_par, V, keys, n, terminator, s - n_j, n_j,
                                       n_b, k_b, pair + s, lane_s, spp, lane_k32, sh, w)
                if walk:                                  # the rays packet_walk may walk
                    keep_rays(sh, w, V, n)
            else:
                if area:
                    area_stage(ltag, lights_par, j, V, keys, n, s, n_j, k_j, terminator, pair + s, lane_s, spp,
                               lane_k32)
                else:
                    light_stage(lights_tag, lights_par, j, V, n, terminator)
                shadow_fill(V, sh, w, n)
                if lambert:
                    n_sh = lambert_stage(lights_par, j, V, sh, w, n)
                else:
                    n_sh = bsdf_stage(mats_tag, mats_par, lights_par, j, V, sh, w, n)
                if n_b > 0 and n_sh > 0:
                    area_mis_stage(ltag, lights_par, j, mats_tag, mats_par, V, n, n_j, n_b)
            if n_sh == 0:
                continue
            n_shadow += n_sh
            E.packet_query(scene, sh, w, s < n_j, True)
            if walk:
                n_shadow += packet_walk(scene, G, mats_tag, mats_par, tex_tag, tex_par, sopt, sh, w, V, n, ray_buf)
            shadow_add(V, sh, w, n, 1.0 / (n_j if s < n_j else n_b))
        pair += n_j + n_b if area else 0
    # the specular tree of each sample, then the film
    for lane in range(n):
        l0, l1, l2 = lane_vec(V, V_L, lane)
        m = int(V[V_MAT * LANES + lane])
        top, dim, a = 0, DIM_LOBE, 1.0
        if masks:           # a blend hit: weight a, the ray continued past it with 1 - a (compiled_coverage)
            top, a = lane_through(V, lane, cam, stack, 0, cutoff, opts[O_DIFFS] != 0)
        if per_lane and V[V_GL * LANES + lane] != 0.0:
            m = int(V[V_GL * LANES + lane]) - 1
            V[V_MAT * LANES + lane] = m
            e0, e1, e2, top, n_sh = lane_hit(scene, G, V, lane, keys[lane], stack, top, ray_buf, lights_tag,
                                             lights_par, mats_tag, mats_par, tex_tag, tex_par, etag, erec, edata,
                                             opts, optf, m, a)
            l0, l1, l2 = l0 + e0, l1 + e1, l2 + e2
            n_shadow += n_sh
        l0, l1, l2 = l0 * a, l1 * a, l2 * a
        if m >= 0 and max_depth > 0 and MC.has_delta(mats_tag[m], mats_par, m):
            d = lane_vec(V, V_D, lane)
            top, dim = spawn(lane_vec(V, V_P, lane), lane_vec(V, V_NG, lane), lane_vec(V, V_NS, lane),
                             (-d[0], -d[1], -d[2]), V[V_FRONT * LANES + lane] != 0.0,
                             V[V_MAG * LANES + lane], mats_tag[m], mats_par, m, lane_vec(V, V_X, lane), 0.0,
                             (a, a, a), 0, split, cutoff, opts[O_ROULETTE] != 0, keys[lane], DIM_LOBE, stack, top, V,
                             lane, opts[O_DIFFS] != 0)
        if opts[O_MEDIA] != 0 and m >= 0:   # the camera ray's stack is empty (vacuum); its children's
            CMD.clear(stack, MED_ROW)
            CMD.spawned(stack, MED_ROW, 0, top, mats_par, m, V[V_FRONT * LANES + lane] != 0.0,
                        lane_vec(V, V_NG, lane))
        if top > 0:
            l0, l1, l2 = trace_stack(scene, G, mats_tag, mats_par, tex_tag, tex_par, lights_tag,
                                     lights_par, erec, edata, opts, optf, keys[lane], dim, stack, top, ray_buf,
                                     cnt, l0, l1, l2, V, lane)
        set_lane_vec(V, V_L, lane, (l0, l1, l2))
        if not (math.isfinite(l0) and math.isfinite(l1) and math.isfinite(l2)):
            n_bad += 1
            set_lane_vec(V, V_L, lane, (0.0, 0.0, 0.0))
    cnt[N_PRIMARY] += n_prim
    cnt[N_SHADOW] += n_shadow
    cnt[N_NONFINITE] += n_bad


@numba.njit(nogil=True, cache=True, error_model="numpy")
def render_tile(bufs, scene, tile, cam, geo_f, geo_i, mats_tag, mats_par, tex_tag, tex_par, lights_tag, lights_par,
                env_data, opts, optf, sums, sqs, aovs, counters, width):
    """Render the pixels of tile ``tile`` (row-major over the image's tiles of :data:`TILE` pixels) at the samples
    ``[opts[O_SPP_LO], opts[O_SPP])`` of each pixel's set of ``opts[O_SPP]``, ``width`` samples (a packet) at a time
    in pixel order (one pixel's samples when they fill a packet, several pixels' at low spp): their radiance summed
    into ``sums`` and squared into ``sqs`` (pixel rows of the image), with ``opts[O_AOV]`` the camera hits' AOVs
    summed into ``aovs`` (:data:`N_AOV` columns), rays counted into ``counters`` (4,). ``bufs``: the calling
    thread's :func:`pyrt.integrators.compiled_layout.packet_buffers` (allocated once for several tiles: per tile,
    their allocation and zeroing was a tenth of a 1-spp render's kernel time). With ``opts[O_SQ]`` the squared
    radiance is summed into ``sqs`` (pixel rows), else ``sqs`` is not touched.

    A packet goes through stages, each a short loop over its lanes whose values pass between stages in the
    scratch ``V`` (field-major: one field of all lanes is contiguous), so that the lanes' work overlaps and the
    compiler can vectorise: camera rays, the hits' surfaces, per light the shadow rays (then one occlusion query),
    the specular trees, the film. The per-sample code reads every array through a pointer
    (:func:`pyrt.core.unmanaged.pointer`): it binds no array, so it makes no reference-counting calls."""
    U.wide_vectors()
    pk, sh, ray_buf, V, stack, keys, lane_pix, lane_s, lane_key, lane_k32, lane_xy = buffer_pointers(bufs)
    film_s, film_q, film_a = U.pointer(sums), U.pointer(sqs), U.pointer(aovs)
    want_aovs = opts[O_AOV] != 0
    want_sq = opts[O_SQ] != 0
    erec, edata, cam, opts, optf, mats_tag, mats_par, tex_tag, tex_par, lights_tag, lights_par, cnt = \
        table_pointers(env_data, cam, opts, optf, mats_tag, mats_par, tex_tag, tex_par, lights_tag, lights_par, counters)
    G = geometry_pointers(geo_f, geo_i)
    w = width
    W, H = int(cam[C_W]), int(cam[C_H])
    tiles_x = (W + TILE - 1) // TILE
    x0, y0 = (tile % tiles_x) * TILE, (tile // tiles_x) * TILE
    spp, spp_lo, grid = opts[O_SPP], opts[O_SPP_LO], opts[O_GRID]
    centre = spp == 1 and cam[C_JITTER] == 0.0
    ginv = 1.0 / max(grid, 1)
    spp_f, rows_f = float(spp), float(J.isqrt(spp))
    seed = opts[O_SEED]
    E.packet_prepare(pk, w, cam[C_POS], cam[C_POS + 1], cam[C_POS + 2])
    E.packet_prepare(sh, w, 0.0, 0.0, 0.0)
    # the tile's (pixel, sample) items in pixel order, ``width`` at a time: a packet holds one pixel's samples when
    # they fill it, and several pixels' (a row piece of the tile) when spp is low
    tw, th = min(x0 + TILE, W) - x0, min(y0 + TILE, H) - y0
    n_items = tw * th * (spp - spp_lo)
    cur_x = cur_y = 0
    cur_s = spp_lo
    cur_pix = y0 * W + x0
    cur_key, cur_k32 = J.pixel_key(seed, cur_pix), JS.hash32_2(seed, cur_pix)
    for t0 in range(0, n_items, w):
        n = min(w, n_items - t0)
        first = 0
        if cur_s + n <= spp:                # one pixel's samples: all but the last lane in a loop without branches
            xf, yf = float(x0 + cur_x), float(y0 + cur_y)
            for lane in range(n - 1):
                lane_pix[lane], lane_s[lane] = cur_pix, cur_s + lane
                lane_xy[lane], lane_xy[LANES + lane] = xf, yf
                lane_key[lane], lane_k32[lane] = cur_key, cur_k32
            cur_s += n - 1
            first = n - 1
        for lane in range(first, n):        # each lane's pixel and sample (counters: no division)
            lane_pix[lane], lane_s[lane] = cur_pix, cur_s
            lane_xy[lane], lane_xy[LANES + lane] = float(x0 + cur_x), float(y0 + cur_y)
            lane_key[lane], lane_k32[lane] = cur_key, cur_k32
            cur_s += 1
            if cur_s == spp:
                cur_s = spp_lo
                cur_x += 1
                if cur_x == tw:
                    cur_x = 0
                    cur_y += 1
                cur_pix = (y0 + cur_y) * W + x0 + cur_x
                cur_key, cur_k32 = J.pixel_key(seed, cur_pix), JS.hash32_2(seed, cur_pix)
        # camera rays: arithmetic only, no branch (vectorised); the square grid (spp = n^2) and the equal-area grid
        # of any spp in loops of their own
        if grid > 0:
            for lane in range(n):
                s = lane_s[lane]
                key = J.sample_key(lane_key[lane], s)
                keys[lane] = key
                u0, u1 = J.uniform_pair(key)
                cy = math.floor((s + 0.5) * ginv)
                ox, oy = (s - cy * grid + u0) * ginv, (cy + u1) * ginv
                ox, oy = (0.5, 0.5) if centre else (ox, oy)
                set_lane_vec(V, V_D, lane, camera_dir(cam, lane_xy[lane] + ox, lane_xy[LANES + lane] + oy))
        else:
            for lane in range(n):
                s = lane_s[lane]
                key = J.sample_key(lane_key[lane], s)
                keys[lane] = key
                u0, u1 = J.uniform_pair(key)
                ox, oy = J.strata_position(spp_f, rows_f, float(s), u0, u1)
                set_lane_vec(V, V_D, lane, camera_dir(cam, lane_xy[lane] + ox, lane_xy[LANES + lane] + oy))
        D.camera_diffs(V, cam, opts, n)
        shade_packet(scene, G, cam, pk, sh, ray_buf, V, stack, keys, lane_s, lane_k32, spp, n, w, mats_tag, mats_par,
                     tex_tag, tex_par, lights_tag, lights_par, erec, edata, opts, optf, cnt)
        film_add(V, lane_pix, n, film_s, film_q, want_sq)
        if want_aovs:
            for lane in range(n):
                add_aovs(V, lane, film_a, lane_pix[lane] * N_AOV)


@numba.njit(nogil=True, cache=True, error_model="numpy", parallel=True)
def render_tiles(scene, tiles, cam, geo_f, geo_i, mats_tag, mats_par, tex_tag, tex_par, lights_tag, lights_par,
                 env_data, opts, optf, sums, sqs, aovs, counters, width):
    """:func:`render_tile` for every tile of ``tiles`` (threads over them, :data:`TILES_PER_TASK` consecutive tiles
    of the list at a time, each such task allocating its packet buffers once); ``counters`` (len(tiles), 4)."""
    n = tiles.shape[0]
    for c in prange((n + TILES_PER_TASK - 1) // TILES_PER_TASK):
        bufs = packet_buffers(width)
        for k in range(c * TILES_PER_TASK, min(n, (c + 1) * TILES_PER_TASK)):
            render_tile(bufs, scene, tiles[k], cam, geo_f, geo_i, mats_tag, mats_par, tex_tag, tex_par, lights_tag,
                        lights_par, env_data, opts, optf, sums, sqs, aovs, counters[k], width)
        release(bufs)     # the owners of the buffers' pointers live until here


@numba.njit(nogil=True, cache=True, error_model="numpy")
def pixel_block(bufs, scene, cam, geo_f, geo_i, mats_tag, mats_par, tex_tag, tex_par, lights_tag, lights_par, env_data,
                opts, optf, P, C, base, dscale, lo, hi, both, half_b, counters, width):
    """Rows ``[lo, hi)`` of an adaptive pass (:func:`render_pixels`), packet buffers ``bufs``: pixel ``P[i]`` gets
    ``C[i]`` (even) new samples, half to half-buffer A, half to B, each half's Owen-scrambled Sobol' sequence
    continued at ``base[i]`` (``sobol_owen_2d(base + j, hash32(seed, pixel, half))``: the NumPy path's camera rays;
    area-light samples continue a progressive padded set of seed ``hash32(seed, pixel, half, 0x9AD)``). Radiance
    summed into ``both[i]``, B's into ``half_b[i]``, rays into ``counters`` (4,); ``dscale[i]`` scales ``P[i]``'s
    differentials (:meth:`pyrt.core.camera.Camera.rays_at`). The sums do not depend on how a pass is cut."""
    U.wide_vectors()
    pk, sh, ray_buf, V, stack, keys, lane_pix, lane_s, lane_key, lane_k32, lane_xy = buffer_pointers(bufs)
    erec, edata, cam, opts, optf, mats_tag, mats_par, tex_tag, tex_par, lights_tag, lights_par, cnt = \
        table_pointers(env_data, cam, opts, optf, mats_tag, mats_par, tex_tag, tex_par, lights_tag, lights_par, counters)
    G, w = geometry_pointers(geo_f, geo_i), width
    W, seed = int(cam[C_W]), opts[O_SEED]
    E.packet_prepare(pk, w, cam[C_POS], cam[C_POS + 1], cam[C_POS + 2])
    E.packet_prepare(sh, w, 0.0, 0.0, 0.0)
    n_items = np.sum(C[lo:hi])
    cur_i, cur_j, h, pix, px, py = lo, 0, 0, 0, 0.0, 0.0
    k32, (kx, ky) = JS.hash32_4(seed, 0, 0, 0x9AD), JS.sobol_owen_keys(0)
    for t0 in range(0, n_items, w):
        n = min(w, n_items - t0)
        for lane in range(n):       # each lane's row of P and half (in lane_pix), index and keys: hashed once a half
            if cur_j == 0 or cur_j == h:
                is_b = 0 if cur_j == 0 else 1
                if is_b == 0:
                    pix, h = P[cur_i], C[cur_i] // 2
                    px, py = float(pix % W), float(pix // W)
                k32, (kx, ky) = JS.hash32_4(seed, pix, is_b, 0x9AD), JS.sobol_owen_keys(JS.hash32_3(seed, pix, is_b))
            is_b = 1 if cur_j >= h else 0
            lane_pix[lane] = cur_i * 2 + is_b
            lane_s[lane] = base[cur_i] + cur_j - is_b * h
            lane_k32[lane], lane_key[lane], keys[lane] = k32, kx, ky
            lane_xy[lane], lane_xy[LANES + lane] = px, py
            cur_j += 1
            if cur_j == C[cur_i]:
                cur_i, cur_j = cur_i + 1, 0
        for lane in range(n):       # the samples' raster positions and the lanes' keys (Sobol' bits: scalar)
            q, idx = lane_pix[lane], lane_s[lane]
            u0, u1 = JS.sobol_owen_2d_keyed(idx, lane_key[lane], keys[lane])
            keys[lane] = J.key64(seed, P[q >> 1], ADAPTIVE_KEYS + idx * 2 + (q & 1))
            lane_xy[lane] += u0
            lane_xy[LANES + lane] += u1
        for lane in range(n):       # camera rays: arithmetic only, no branch (vectorised, as render_tile's)
            set_lane_vec(V, V_D, lane, camera_dir(cam, lane_xy[lane], lane_xy[LANES + lane]))
        if opts[O_DIFFS] != 0:
            for lane in range(n):
                D.camera_lane_diffs(V, cam, opts, lane, dscale[lane_pix[lane] >> 1])
        shade_packet(scene, G, cam, pk, sh, ray_buf, V, stack, keys, lane_s, lane_k32, PROGRESSIVE, n, w, mats_tag,
                     mats_par, tex_tag, tex_par, lights_tag, lights_par, erec, edata, opts, optf, cnt)
        pass_add(V, lane_pix, n, both, half_b)


@numba.njit(nogil=True, cache=True, error_model="numpy", parallel=True)
def render_pixels(scene, cam, geo_f, geo_i, mats_tag, mats_par, tex_tag, tex_par, lights_tag, lights_par, env_data,
                  opts, optf, P, C, base, dscale, starts, blocks, both, half_b, counters, width):
    """Blocks ``blocks`` of an adaptive pass (:func:`pyrt.render.adaptive.render_adaptive`), threads over them:
    block ``b`` is rows ``[starts[b], starts[b + 1])`` of ``P`` (:func:`pixel_block`, with packet buffers of its own;
    its rays counted into ``counters[b]``)."""
    for k in prange(blocks.shape[0]):
        b = blocks[k]
        bufs = packet_buffers(width)
        pixel_block(bufs, scene, cam, geo_f, geo_i, mats_tag, mats_par, tex_tag, tex_par, lights_tag, lights_par,
                    env_data, opts, optf, P, C, base, dscale, starts[b], starts[b + 1], both, half_b, counters[b],
                    width)
        release(bufs)     # the owners of the buffers' pointers live until here


kernel_cache.restore()
