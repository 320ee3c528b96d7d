"""One hit's direct light and glossy rays in the compiled tile kernel: the specular tree's hits and the glossy integrator.

:func:`hit_light` is the direct light at one hit (single shadow rays), the same estimate as the NumPy path's
:meth:`pyrt.integrators.whitted.Integrator._direct_light` and, at the glossy integrator's glossy hits,
:meth:`pyrt.integrators.glossy.GlossyIntegrator._direct_light`:

- every light by its own estimator (delta lights one shadow ray, area lights their light and BSDF samples under
  MIS, the environment light :func:`pyrt.integrators.compiled_lighting.env_hit`, the emissive-mesh light
  :func:`pyrt.integrators.compiled_mesh_stage.mesh_hit`, its samples weighted against the glossy rays at a glossy
  hit);
- at a glossy hit the environment light by samples of its full map alone, weighted by the power heuristic against
  the glossy rays (:func:`env_glossy`; :func:`escape_weight` weighs the environment the rays reach);
- at a glossy hit (one that traces ``nb`` BSDF-sampled rays, :func:`spawn_glossy`) an area light whose visible
  emitter mesh is in the scene (:data:`pyrt.lights.compiled.TRACED`) by its light samples alone, weighted by the power
  heuristic against the ``nb`` glossy rays (which reach its mesh, :func:`emission_weight`); another area light by its
  light samples alone, weight 1;
- where the hit chooses a light (``light_select_depth``, :mod:`pyrt.integrators.light_choice`), one delta light
  instead of all of them (:func:`chosen_light`), picked by its unshadowed irradiance and divided by the choice's
  probability.

:func:`clamp_sampled` is the glossy integrator's ``glossy_clamp`` of the direct light at hits of glossy rays. The
random numbers are keyed per hit (the hit's key, dimensions :data:`DIM_CHOOSE` and :data:`DIM_GLOSSY`): the two paths
agree in distribution, not sample by sample. The larger functions are compiled once each (not inlined into their
callers: a kernel's compile time grows with its inlined code; their arguments are numbers, tuples and pointers, so a
call costs no reference counting).
"""
from __future__ import annotations

import math

from pyrt.integrators import kernel_cache

kernel_cache.use_cache_dir()      # before the decorators below run

from pyrt.integrators.compiled_shadows import shadow_options, shadow_ray  # noqa: E402
from pyrt.integrators.compiled_diffs import _own  # noqa: E402
from pyrt.integrators.compiled_diffs import push_ray  # noqa: E402
from pyrt.integrators.compiled_layout import (  # noqa: E402
    DIM_CHOOSE, DIM_ENV, DIM_GLOSSY, DIM_ROULETTE, F_CUTOFF, T_INF, F_GLOSSY_T, LANES, O_DIFFS, O_GLOSSY_DEPTH,
    O_GLOSSY_N, O_MAX_DEPTH, O_NLIGHTS, O_ROULETTE, O_SELECT, O_TERMINATOR, STACK, STACK_LAYER, STACK_PDF, STACK_ROW,
    STACK_TB, V_D, V_GL, V_LIFT, V_MAG, V_MAG_LIFT, V_MAT, V_NG, V_NS, V_NV, V_P, _njit, lane_inputs, lane_vec)
from pyrt.integrators.compiled_lighting import (  # noqa: E402
    area_bsdf_sample, area_light_weight, area_u, direct_light, env_hit)
from pyrt.integrators import compiled_mesh_stage as MS  # noqa: E402
from pyrt.lights import compiled as LC  # noqa: E402
from pyrt.lights import compiled_env as CE  # noqa: E402
from pyrt.materials import compiled as MC  # noqa: E402
from pyrt.materials import compiled_sampling as CS  # noqa: E402
from pyrt.shaders import jit as J  # noqa: E402
from pyrt.shaders.jit import dot  # noqa: E402


@_njit
def selectable(ltag):
    """Whether the light choice may pick a light of tag ``ltag`` (:func:`pyrt.integrators.light_choice.selectable`:
    point, spot and directional lights; the kernel's have one sample and no BSDF samples)."""
    return ltag != LC.ENV and ltag < LC.RECT


@_own
def chosen_light(lights_tag, lights_par, nl, mtag, mats_par, m, albedo, p, ng, ns, nv, wo, lift, mag, mag_lift,
                 terminator, u):
    """:func:`pyrt.integrators.light_choice.one_light_estimate` at one hit: the delta light ``j`` picked with
    probability ``w_j / sum w`` (``w_j`` the mean over RGB of its unshadowed irradiance, 0 where it cannot reach the
    hit's side) by the number ``u``; returns ``(ok, tmax, origin, wi, value)``, the value divided by the
    probability (``ok`` False: no light can contribute, or the BSDF is 0)."""
    total = 0.0
    for j in range(nl):
        total += _choice_weight(lights_tag, lights_par, j, p, ng, nv)
    c = 0.0
    pick = -1
    last = -1
    x = u * total
    for j in range(nl):
        w = _choice_weight(lights_tag, lights_par, j, p, ng, nv)
        if not selectable(lights_tag[j]):
            continue
        last = j
        c += w
        if pick < 0 and x < c:
            pick = j
    pick = last if pick < 0 else pick
    if not total > 0.0 or pick < 0:
        return False, 0.0, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)
    w = _choice_weight(lights_tag, lights_par, pick, p, ng, nv)
    if not w > 0.0:
        return False, 0.0, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)
    ok, tmax, o, wi, f = direct_light(lights_tag, lights_par, pick, mtag, mats_par, m, albedo, p, ng, ns, nv, wo, lift,
                                      mag, mag_lift, terminator, 0.0, 0.0)
    k = total / w
    return ok, tmax, o, wi, (f[0] * k, f[1] * k, f[2] * k)


@_njit
def _choice_weight(lights_tag, lights_par, j, p, ng, nv):
    """The light choice's weight of light ``j`` at the hit ``p``: the mean over RGB of its irradiance ``E`` where it
    is lit and reaches the hit's side (``ng . wi > 0`` or ``nv . wi > 0``), else 0 (also for lights it does not
    pick)."""
    if not selectable(lights_tag[j]):
        return 0.0
    jb = j * LC.RECORD
    w0, w1, w2, _dist, s = LC.sample_li(lights_tag[j], lights_par, j, p[0], p[1], p[2])
    e = s * (lights_par[jb + 6] + lights_par[jb + 7] + lights_par[jb + 8]) / 3.0
    side = w0 * ng[0] + w1 * ng[1] + w2 * ng[2] > 0.0 or w0 * nv[0] + w1 * nv[1] + w2 * nv[2] > 0.0
    return e if s > 0.0 and side and e > 0.0 else 0.0


@_own
def hit_light(scene, G, lights_tag, lights_par, nl, mats_tag, mats_par, tex_tag, tex_par, etag, erec, edata, mtag, m,
              albedo, p, ng, ns, nv, wo, lift, mag, mag_lift, terminator, hkey, sopt, ray_buf, nb, choose):
    """The direct light at one hit (module docstring) of material ``m`` (tag ``mtag``, inputs ``albedo``) whose
    random numbers are keyed by ``hkey``: ``nb`` > 0 at a glossy hit (its glossy rays' count), ``choose`` where one
    delta light stands for all of them; shadow rays through see-through surfaces as ``sopt`` says
    (:func:`pyrt.integrators.compiled_shadows.shadow_ray`). Returns ``(r, g, b, shadow rays)``."""
    le0 = le1 = le2 = 0.0
    n_sh = 0
    if choose:
        ok, tmax, o, wi, f = chosen_light(lights_tag, lights_par, nl, mtag, mats_par, m, albedo, p, ng, ns, nv, wo,
                                          lift, mag, mag_lift, terminator, J.uniform(hkey, DIM_CHOOSE))
        if ok:
            t0, t1, t2, n = shadow_ray(scene, G, mats_tag, mats_par, tex_tag, tex_par, sopt, o, wi, tmax, ray_buf)
            n_sh += n
            le0, le1, le2 = le0 + f[0] * t0, le1 + f[1] * t1, le2 + f[2] * t2
    for j in range(nl):
        jb = j * LC.RECORD
        ltag = lights_tag[j]
        if ltag == LC.ENV and nb > 0:
            # a glossy hit: the map's samples against the glossy rays (its own BSDF half is left to them), or nothing
            # from a light that does not sample its map there (escaped glossy rays carry the environment)
            if lights_par[jb + 2] != 0.0:
                e = env_glossy(scene, G, etag, erec, edata, mtag, mats_tag, mats_par, tex_tag, tex_par, sopt, m, albedo,
                               p, ng, ns, nv, wo, lift, mag, mag_lift, terminator, hkey, int(lights_par[jb]), nb,
                               ray_buf)
                le0, le1, le2 = le0 + e[0], le1 + e[1], le2 + e[2]
                n_sh += e[3]
            continue
        if ltag == LC.ENV:
            e = env_hit(scene, G, etag, erec, edata, mtag, mats_tag, mats_par, tex_tag, tex_par, sopt, m, albedo, p, ng,
                        ns, nv, wo, lift, mag, mag_lift, terminator, hkey, int(lights_par[jb]),
                        int(lights_par[jb + 1]), ray_buf)
            le0, le1, le2 = le0 + e[0], le1 + e[1], le2 + e[2]
            n_sh += int(e[3])
            continue
        if choose and selectable(ltag):
            continue
        if ltag == LC.MESH:     # the emissive-mesh light: its samples (against the glossy rays at a glossy hit)
            e = MS.mesh_hit(scene, G, lights_par, j, mtag, mats_tag, mats_par, tex_tag, tex_par, sopt, m, albedo, p, ng,
                            ns, nv, wo, lift, mag, mag_lift, terminator, hkey, nb, ray_buf)
            le0, le1, le2 = le0 + e[0], le1 + e[1], le2 + e[2]
            n_sh += e[3]
            continue
        area = ltag >= LC.RECT
        n_j = int(lights_par[jb + LC.AREA_SAMPLES]) if area else 1
        n_b = int(lights_par[jb + LC.AREA_SAMPLES + 1]) if area else 0
        traced = area and lights_par[jb + LC.TRACED] != 0.0
        if nb > 0:              # a glossy hit: the light samples alone (against the glossy rays where they reach it)
            n_b = 0
        k_j, k_b = J.isqrt(n_j), J.isqrt(n_b)
        for s in range(n_j + n_b):
            if s < n_j:
                u0, u1 = area_u(hkey, j, s, n_j, k_j) if area else (0.0, 0.0)
                ok, tmax, o, wi, f = direct_light(lights_tag, lights_par, j, mtag, mats_par, m, albedo, p, ng, ns, nv,
                                                  wo, lift, mag, mag_lift, terminator, u0, u1)
                if ok and (n_b > 0 or (nb > 0 and traced)):
                    k = area_light_weight(ltag, lights_par, j, mtag, mats_par, m, albedo, p, ns, wo, wi, n_j,
                                          n_b if nb == 0 else nb)
                    f = (f[0] * k, f[1] * k, f[2] * k)
                inv = 1.0 / n_j
            else:
                u0, u1 = area_u(hkey, j + 4096, s - n_j, n_b, k_b)
                ok, o, wi, tmax, f = area_bsdf_sample(ltag, lights_par, j, mtag, mats_par, m, albedo, p, ng, ns, nv,
                                                      wo, lift, mag, mag_lift, terminator, u0, u1, n_j, n_b)
                inv = 1.0 / n_b
            if not ok:
                continue
            t0, t1, t2, n = shadow_ray(scene, G, mats_tag, mats_par, tex_tag, tex_par, sopt, o, wi, tmax, ray_buf)
            n_sh += n
            le0 += f[0] * inv * t0
            le1 += f[1] * inv * t1
            le2 += f[2] * inv * t2
    return le0, le1, le2, n_sh


@_own
def env_glossy(scene, G, etag, erec, edata, mtag, mats_tag, mats_par, tex_tag, tex_par, sopt, m, albedo, p, ng, ns, nv,
               wo, lift, mag, mag_lift, terminator, key, n_l, nb, ray_buf):
    """The environment light at a glossy hit (:meth:`pyrt.integrators.glossy.GlossyIntegrator._env_light_sampling`):
    ``n_l`` samples of the full map (:func:`pyrt.lights.compiled_env.sample`, the second number stratified over
    them), ``f_cos L / pdf`` each, weighted by the power heuristic of ``n_l`` map samples against the ``nb`` glossy
    rays; single shadow rays to infinity (:func:`pyrt.integrators.compiled_shadows.shadow_ray`). Returns ``(r, g, b,
    shadow rays)``."""
    fs, ft = CS.coordinate_frame(ns[0], ns[1], ns[2])
    wol = CS.to_local(wo, fs, ft, ns)
    l0 = l1 = l2 = 0.0
    n_sh = 0
    for s in range(n_l):
        d = DIM_ENV + 4 * s
        wx, wy, wz, pdf = CE.sample(etag, erec, edata, J.uniform(key, d), (s + J.uniform(key, d + 1)) / n_l)
        if not pdf > 0.0:
            continue
        wi = (wx, wy, wz)
        cg = dot(wi, ng)
        if not (cg > 0.0 or dot(wi, nv) > 0.0):
            continue
        L = CE.radiance(etag, erec, edata, wx, wy, wz)
        f = CS.f_cos_world(mtag, mats_par, m, albedo, wo, wi, ns)
        if not max(f[0] * L[0], f[1] * L[1], f[2] * L[2]) > 0.0:
            continue
        wil = CS.to_local(wi, fs, ft, ns)
        pdf_b = CS.pdf_wi(mtag, mats_par, m, albedo, wol[0], wol[1], wol[2], wil[0], wil[1], wil[2])
        k = CS.power_heuristic(pdf, pdf_b, 2.0, float(n_l), float(nb)) / (pdf * n_l)
        o = J.shadow_origin(p, ng, lift, mag, mag_lift, cg, terminator)
        t0, t1, t2, n = shadow_ray(scene, G, mats_tag, mats_par, tex_tag, tex_par, sopt, o, wi, T_INF, ray_buf)
        n_sh += n
        l0, l1, l2 = l0 + f[0] * L[0] * k * t0, l1 + f[1] * L[1] * k * t1, l2 + f[2] * L[2] * k * t2
    return l0, l1, l2, n_sh


@_njit
def escape_weight(etag, erec, edata, n_l, d, pdf):
    """The MIS weight of the environment a glossy ray (density ``pdf``) reaches along ``d`` when an environment light
    samples its map at glossy hits with ``n_l`` samples (:meth:`pyrt.integrators.glossy.GlossyIntegrator.
    _escape_weight`; 1 for a delta ray or without such a light)."""
    if n_l == 0 or not pdf > 0.0:
        return 1.0
    return CS.power_heuristic(pdf, CE.pdf(etag, erec, edata, d[0], d[1], d[2]), 2.0, 1.0, float(n_l))


@_njit
def clamp_sampled(l0, l1, l2, thr, limit):
    """:func:`pyrt.integrators.whitted.clamp_sampled` for one hit of a glossy ray: the direct light ``l`` scaled down
    to ``limit`` where ``max(thr * l)`` exceeds it (the colour kept)."""
    mx = max(thr[0] * l0, thr[1] * l1, thr[2] * l2)
    if mx > limit:
        k = limit / mx
        return l0 * k, l1 * k, l2 * k
    return l0, l1, l2


@_njit
def is_glossy(mats_par, m, albedo, threshold):
    """Whether the non-delta lobe of material ``m`` at a hit of inputs ``albedo`` is glossy enough for glossy rays
    (:meth:`pyrt.integrators.glossy.GlossyIntegrator._sampled_hits`: ``glossy_alpha <= glossy_threshold``)."""
    return MC.glossy_alpha(mats_par, m, albedo) <= threshold


@_njit
def glossy_u(key, s, n, k):
    """The random numbers of glossy ray ``s`` of a hit's ``n`` (key ``key``): stratified as the area lights' samples
    (:func:`pyrt.lights.compiled.stratum`: a jittered ``k x k`` grid, else Latin-hypercube strata permuted per hit),
    jittered from dimensions :data:`DIM_GLOSSY` on (:func:`pyrt.core.sampler.stratified_samples` on the NumPy path)."""
    perm = 0
    if n > 1 and k * k != n:
        perm = J.permute(s, n, int(J.uniform(key, DIM_GLOSSY - 1) * 4294967296.0))
    d = DIM_GLOSSY + 2 * s
    return LC.stratum(s, n, k, J.uniform(key, d), J.uniform(key, d + 1), perm)


@_njit
def survive(t, cutoff, roulette, key, dim):
    """:func:`pyrt.integrators.roulette.survivors` for one spawned ray of throughput ``t`` (a 3-tuple): ``(alive, t,
    dim)``. A ray whose largest channel ``m`` is above ``cutoff`` goes on unchanged; with ``roulette`` (and ``cutoff``
    > 0) one with ``0 < m <= cutoff`` goes on with probability ``q = m / cutoff`` (the number ``uniform(key, dim)``,
    ``dim`` then advanced by one) and throughput ``t / q``; the others are dropped."""
    m = max(t[0], t[1], t[2])
    if m > cutoff:
        return True, t, dim
    if not (roulette and cutoff > 0.0 and m > 0.0):
        return False, t, dim
    q = m / cutoff
    if J.uniform(key, dim) < q:
        return True, (t[0] / q, t[1] / q, t[2] / q), dim + 1
    return False, t, dim + 1


@_own
def spawn_glossy(p, ng, ns, wo, mag, mtag, mats_par, m, albedo, thr, depth, nb, cutoff, roulette, key, stack, top, V,
                 lane, diffs):
    """Push the ``nb`` glossy rays of a hit (:meth:`pyrt.integrators.glossy.GlossyIntegrator._spawn_glossy`: BSDF
    samples of material ``m``, throughput ``thr * weight / nb``, density ``nb * pdf`` in the row's
    :data:`STACK_PDF`; a reflection below the geometric surface is dropped, as is a ray whose throughput is at most
    ``cutoff`` unless it survives the ``roulette`` (:func:`survive`, ray ``s``'s number from dimension
    :data:`DIM_ROULETTE` ``+ s``)); returns the new top."""
    fs, ft = CS.coordinate_frame(ns[0], ns[1], ns[2])
    wol = CS.to_local(wo, fs, ft, ns)
    k = J.isqrt(nb)
    for s in range(nb):
        u0, u1 = glossy_u(key, s, nb, k)
        wx, wy, wz, r, g, b, pdf = CS.sample_f(mtag, mats_par, m, albedo, wol[0], wol[1], wol[2], u0, u1)
        if not pdf > 0.0:
            continue
        wi = CS.to_world((wx, wy, wz), fs, ft, ns)
        if not dot(wi, ng) > 0.0:
            continue
        alive, t, _ = survive((thr[0] * r / nb, thr[1] * g / nb, thr[2] * b / nb), cutoff, roulette, key,
                              DIM_ROULETTE + s)
        if not alive or top >= STACK:
            continue
        top = push(p, ng, mag, stack, top, wi, t, depth + 1, V, lane, diffs, ns, wo, 0.0, nb * pdf)
    return top


@_njit
def push(p, ng, mag, stack, top, d, thr, depth, V, lane, diffs, ns, wo, eta, pdf):
    """One spawned ray from the hit at ``p`` on the stack: direction normalised, origin offset to the side it leaves
    toward, ``pdf`` its density (0: a delta ray); with ``diffs`` its differentials from lane ``lane`` of ``V``
    (``eta`` 0: a reflection, else refraction)."""
    d0, d1, d2 = d
    ln = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
    if ln > 0.0:
        d0, d1, d2 = d0 / ln, d1 / ln, d2 / ln
    o = J.round_away(p, mag, 1.0 if d0 * ng[0] + d1 * ng[1] + d2 * ng[2] >= 0.0 else -1.0, ng)
    row = STACK_ROW * top
    stack[row], stack[row + 1], stack[row + 2] = o
    stack[row + 3], stack[row + 4], stack[row + 5] = d0, d1, d2
    stack[row + 6], stack[row + 7], stack[row + 8] = thr
    stack[row + 9] = depth
    stack[row + STACK_PDF] = pdf
    stack[row + STACK_TB], stack[row + STACK_LAYER] = 0.0, 0.0
    push_ray(stack, row, V, lane, diffs, p, ns, wo, (d0, d1, d2), eta)
    return top + 1


@_njit
def emission_weight(lights_tag, lights_par, nl, mats_par, m, o, d, pdf, p, ng, geom, prim):
    """The MIS weight of the emission a glossy ray (density ``pdf``) from ``o`` along ``d`` reaches at ``p`` on
    material ``m`` (scene mesh ``geom``'s triangle ``prim``, geometric normal ``ng``):
    :meth:`pyrt.integrators.glossy.GlossyIntegrator._emission_weight`, the power heuristic against the samples of the
    area light whose visible emitter the material is and of the emissive-mesh lights that sample the triangle
    (:func:`pyrt.integrators.compiled_mesh_stage.emission_weight`); 1 where no light samples it."""
    if not pdf > 0.0:
        return 1.0
    j = int(mats_par[m * MC.RECORD + MC.TRACED]) - 1
    p_area = 0.0
    if j >= 0:
        n_l = lights_par[j * LC.RECORD + LC.AREA_SAMPLES]
        p_area = n_l * LC.area_pdf_dist(lights_tag[j], lights_par, j, o[0], o[1], o[2], d[0], d[1], d[2])[0]
    return MS.emission_weight(lights_tag, lights_par, nl, o, p, ng, geom, prim, pdf, p_area)


@_njit
def camera_glossy(opts):
    """Whether camera hits may trace glossy rays (the glossy integrator with ``glossy_depth`` and ``max_depth`` > 0)."""
    return opts[O_GLOSSY_N] > 0 and opts[O_GLOSSY_DEPTH] > 0 and opts[O_MAX_DEPTH] > 0


@_own
def set_aside(V, n, mats_tag, mats_par, opts, optf):
    """Take the camera hits that are lit lane by lane (:func:`lane_hit`: glossy hits, or every hit when
    ``light_select_depth`` is 0) out of the packet's light stages: their material into :data:`V_GL` (plus one; 0
    elsewhere) and -1 into :data:`V_MAT` meanwhile. Returns whether another lane has a non-delta lobe (the light
    stages have work)."""
    glossy, choose = camera_glossy(opts), opts[O_SELECT] == 0
    rest = False
    for lane in range(LANES):
        V[V_GL * LANES + lane] = 0.0
    for lane in range(n):
        m = int(V[V_MAT * LANES + lane])
        if m < 0 or not MC.has_diffuse(mats_tag[m]):
            continue
        if choose or (glossy and is_glossy(mats_par, m, lane_inputs(V, lane), optf[F_GLOSSY_T])):
            V[V_GL * LANES + lane] = m + 1.0
            V[V_MAT * LANES + lane] = -1.0
        else:
            rest = True
    return rest


@_own
def lane_hit(scene, G, V, lane, key, stack, top, ray_buf, lights_tag, lights_par, mats_tag, mats_par, tex_tag,
             tex_par, etag, erec, edata, opts, optf, m, weight):
    """A camera hit set aside by :func:`set_aside` (material ``m``, its fields in lane ``lane`` of ``V``; the
    sample's key ``key``; its weight ``weight``, a blend surface's coverage, else 1): its direct light
    (:func:`hit_light`, unweighted) and its glossy rays (throughput ``weight``) pushed on ``stack`` from row ``top``
    (:func:`spawn_glossy`). Returns ``(r, g, b, stack top, shadow rays)``."""
    d = lane_vec(V, V_D, lane)
    wo = (-d[0], -d[1], -d[2])
    p, ng, ns, nv = lane_vec(V, V_P, lane), lane_vec(V, V_NG, lane), lane_vec(V, V_NS, lane), lane_vec(V, V_NV, lane)
    mag = V[V_MAG * LANES + lane]
    terminator = opts[O_TERMINATOR] != 0
    lift = lane_vec(V, V_LIFT, lane) if terminator else p        # (written with the terminator lift only)
    mag_lift = V[V_MAG_LIFT * LANES + lane] if terminator else mag
    albedo = lane_inputs(V, lane)
    mtag = mats_tag[m]
    glossy = camera_glossy(opts) and is_glossy(mats_par, m, albedo, optf[F_GLOSSY_T])
    nb = opts[O_GLOSSY_N] if glossy else 0
    hkey = J.sample_key(key, 0)
    l0, l1, l2, n_sh = hit_light(scene, G, lights_tag, lights_par, opts[O_NLIGHTS], mats_tag, mats_par, tex_tag,
                                 tex_par, etag, erec, edata, mtag, m, albedo, p, ng, ns, nv, wo, lift, mag, mag_lift,
                                 terminator, hkey, shadow_options(opts), ray_buf, nb, opts[O_SELECT] == 0)
    if glossy:
        top = spawn_glossy(p, ng, ns, wo, mag, mtag, mats_par, m, albedo, (weight, weight, weight), 0, nb,
                           optf[F_CUTOFF], opts[O_ROULETTE] != 0, hkey, stack, top, V, lane, opts[O_DIFFS] != 0)
    return l0, l1, l2, top, n_sh


kernel_cache.restore()
