"""The compiled Whitted / direct-lighting tile kernel (Numba, nopython, nogil).

One call renders a list of 8 x 8 pixel tiles (``prange`` over them, the tiles shuffled so that every thread gets
a share of the whole image). Per pixel, its samples go in packets of up to 16 (the samples of one pixel are the
most coherent rays there are): camera rays -> ``rtcIntersect16`` (COHERENT) -> the hit rebuilt in float64 from the
triangle's vertices and the barycentrics -> direct light from every light, each light's shadow rays of the packet
one masked ``rtcOccluded16`` -> the specular tree (mirror, glass reflection and refraction, the split-depth rule)
as a per-sample loop over a small stack with single-ray queries -> per-pixel sums and squared sums in float64.

The estimator is :class:`pyrt.integrators.whitted.Integrator`'s for the scenes :mod:`pyrt.integrators.compiled`
accepts (delta lights, constant background, no coverage, no nested media): the same hit reconstruction
(:func:`pyrt.geometry.surface.surface_from_hits`), offsets (:mod:`pyrt.geometry.offsets`, ``robust`` with or
without the terminator lift: local error bound along ng, float32 rounding one ulp outward, robust shadow tmax),
light sides, BRDFs, Fresnel and lobe choice. Random numbers are counter-based (:func:`pyrt.shaders.jit.uniform`
of seed, pixel, sample and dimension), so the image depends on the seed alone, not on the threads.

Surface records are float64 arrays of :data:`S_SIZE` entries (offsets ``S_*``); everything per sample lives in
per-tile scratch arrays, nothing is allocated per ray.
"""
from __future__ import annotations

import math

import numba
import numpy as np
from numba import prange

from pyrt.integrators import kernel_cache

kernel_cache.use_cache_dir()      # before the decorators below (and those of the modules they inline) run

from pyrt.geometry import embree_jit as E  # noqa: E402
from pyrt.lights import compiled as LC  # noqa: E402
from pyrt.materials import compiled as MC  # noqa: E402
from pyrt.shaders import jit as J  # noqa: E402

#: pixels per tile side
TILE = 8
#: surface record layout (float64): hit point, geometric normal (viewer side), shading normal, interpolated vertex
#: normal (= ng on flat faces), wo, flags, ids, uv, lifted point, local-bound magnitudes
S_P, S_NG, S_NS, S_NV, S_WO = 0, 3, 6, 9, 12
S_FRONT, S_FACE, S_MAT, S_SMOOTH = 15, 16, 17, 18
S_U, S_V = 19, 20
S_LIFT = 21
S_MAG, S_MAG_LIFT = 24, 25
S_SIZE = 26
#: camera record layout (float64)
C_POS, C_FWD, C_RIGHT, C_UP, C_TAN, C_W, C_H, C_JITTER = 0, 3, 6, 9, 12, 13, 14, 15
#: integer options
O_SEED, O_SPP, O_MAX_DEPTH, O_SPLIT, O_TERMINATOR, O_NLIGHTS, O_SPP_LO, O_FALLBACK = 0, 1, 2, 3, 4, 5, 6, 7
#: length of the integer options
N_OPTS = 8
#: float options
F_CUTOFF, F_BG, F_AMBIENT = 0, 1, 4
#: ray counters per tile
N_PRIMARY, N_SECONDARY, N_SHADOW, N_NONFINITE = 0, 1, 2, 3
#: the largest stack of pending specular rays a sample can need (2 per bounce below the split depth)
STACK = 64
#: Embree's "unbounded" tfar (:data:`pyrt.geometry.accel.T_INFINITE`)
T_INF = 1e37
#: the first random dimension of the glass lobe choice (0, 1: the pixel position)
DIM_LOBE = 2

_njit = numba.njit(nogil=True, cache=True)


@_njit
def camera_ray(cam, x, y, d):
    """Unit direction (float64) through raster point ``(x, y)`` into ``d`` (:meth:`pyrt.core.camera.Camera.directions`)."""
    th = cam[C_TAN]
    w, h = cam[C_W], cam[C_H]
    sx = (2.0 * x / w - 1.0) * th * w / h
    sy = (1.0 - 2.0 * y / h) * th
    inv = 1.0 / math.sqrt(1.0 + sx * sx + sy * sy)
    for c in range(3):
        d[c] = inv * cam[C_FWD + c] + sx * inv * cam[C_RIGHT + c] + sy * inv * cam[C_UP + c]


@_njit
def pixel_position(cam, spp, sample, key, pix_key):
    """Raster offset ``(sx, sy)`` in [0, 1)^2 of sample ``sample`` of ``spp`` in its pixel: an ``n x n`` jittered grid
    when ``spp = n^2``, else a Latin hypercube (x stratum ``sample``, y stratum a per-pixel permutation of it);
    the pixel centre for one unjittered sample."""
    if spp == 1 and cam[C_JITTER] == 0.0:
        return 0.5, 0.5
    u0 = J.uniform(key, 0)
    u1 = J.uniform(key, 1)
    n = int(math.sqrt(spp) + 0.5)
    if n * n == spp:
        return (sample % n + u0) / n, (sample // n + u1) / n
    return (sample + u0) / spp, (J.permute(sample, spp, pix_key) + u1) / spp


@_njit
def surface(geo_f, geo_i, mats_tag, mats_par, tex_tag, tex_par, fallback, geom, prim, u, v, d, S):
    """Rebuild the hit ``(geom, prim, u, v)`` of a ray along unit ``d`` into the surface record ``S``
    (:func:`pyrt.geometry.surface.surface_from_hits`): float64 hit point from the vertices, the face normal turned to
    the viewer, the interpolated vertex normal (back-facing -> ng when ``fallback``), uv, the terminator-lifted
    point and the local-bound offset magnitudes (:func:`pyrt.geometry.offsets.local_bound_magnitude`)."""
    verts, normals, uvs, fnorm, fabs = geo_f[0], geo_f[1], geo_f[2], geo_f[3], geo_f[4]
    fext = geo_f[5]
    faces, foff, fmat, fsmooth = geo_i[0], geo_i[1], geo_i[2], geo_i[3]
    face = foff[geom, 0] + prim
    i0, i1, i2 = faces[face, 0], faces[face, 1], faces[face, 2]
    b1, b2 = np.float64(u), np.float64(v)
    b0 = 1.0 - b1 - b2
    for c in range(3):
        S[S_P + c] = b0 * verts[i0, c] + b1 * verts[i1, c] + b2 * verts[i2, c]
        S[S_WO + c] = -d[c]
    cos_g = fnorm[face, 0] * S[S_WO] + fnorm[face, 1] * S[S_WO + 1] + fnorm[face, 2] * S[S_WO + 2]
    front = cos_g >= 0.0
    sign = 1.0 if front else -1.0
    for c in range(3):
        S[S_NG + c] = sign * fnorm[face, c]
    S[S_FRONT] = 1.0 if front else 0.0
    S[S_FACE] = face
    S[S_MAT] = fmat[face, 0]
    smooth = fsmooth[face, 0] != 0
    S[S_SMOOTH] = 1.0 if smooth else 0.0
    for c in range(3):
        S[S_NS + c] = S[S_NG + c]
        S[S_NV + c] = S[S_NG + c]
        S[S_LIFT + c] = S[S_P + c]
    if smooth:
        n0 = b0 * normals[i0, 0] + b1 * normals[i1, 0] + b2 * normals[i2, 0]
        n1 = b0 * normals[i0, 1] + b1 * normals[i1, 1] + b2 * normals[i2, 1]
        n2 = b0 * normals[i0, 2] + b1 * normals[i1, 2] + b2 * normals[i2, 2]
        ln = math.sqrt(n0 * n0 + n1 * n1 + n2 * n2)
        if ln > 0.0:
            n0, n1, n2 = sign * n0 / ln, sign * n1 / ln, sign * n2 / ln
        S[S_NV], S[S_NV + 1], S[S_NV + 2] = n0, n1, n2
        bad = n0 * n0 + n1 * n1 + n2 * n2 == 0.0
        if fallback and not bad:
            bad = n0 * S[S_WO] + n1 * S[S_WO + 1] + n2 * S[S_WO + 2] <= 0.0
        if not bad:
            S[S_NS], S[S_NS + 1], S[S_NS + 2] = n0, n1, n2
        # Hanika's terminator lift: p' = p - sum_i b_i min(0, (p - v_i) . n_i) n_i, n_i turned to the ng side
        bs = (b0, b1, b2)
        ids = (i0, i1, i2)
        for k in range(3):
            vi = ids[k]
            h = sign * ((S[S_P] - verts[vi, 0]) * normals[vi, 0] + (S[S_P + 1] - verts[vi, 1]) * normals[vi, 1]
                        + (S[S_P + 2] - verts[vi, 2]) * normals[vi, 2])
            h = min(h, 0.0)
            w = bs[k] * h * sign
            for c in range(3):
                S[S_LIFT + c] -= normals[vi, c] * w
    # local_bound_magnitude: |ng| . gamma_4(f64) absmax + 8 eps32 extent (absmax widened by the lift)
    g4 = J.gamma(4.0, J.EPS64)
    m = 0.0
    ml = 0.0
    for c in range(3):
        a = fabs[face, c]
        m += abs(S[S_NG + c]) * g4 * a
        ml += abs(S[S_NG + c]) * g4 * (a + abs(S[S_LIFT + c] - S[S_P + c]))
    S[S_MAG] = m + 8.0 * J.EPS32 * fext[face, 0]
    S[S_MAG_LIFT] = ml + 8.0 * J.EPS32 * fext[face, 0]
    uv0 = b0 * uvs[i0, 0] + b1 * uvs[i1, 0] + b2 * uvs[i2, 0]
    uv1 = b0 * uvs[i0, 1] + b1 * uvs[i1, 1] + b2 * uvs[i2, 1]
    S[S_U], S[S_V] = uv0, uv1


@_njit
def offset_origin(S, base, mag, side, o):
    """``round_away(base + side mag ng)`` (:func:`pyrt.geometry.offsets.local_bound`): the origin into ``o`` as
    float64 values of float32 numbers, each component one float32 ulp further along the offset."""
    for c in range(3):
        off = side * mag * S[S_NG + c]
        o[c] = J.float32_step(S[base + c] + off, off)


@_njit
def shadow_ray(S, wi, dist, lpos, terminator, o):
    """The shadow ray toward a light ``dist`` away along ``wi`` (ending at ``lpos`` for a light at a point):
    origin into ``o`` and the returned ``tmax`` (:meth:`pyrt.geometry.offsets.Strategy.shadow`, ``robust`` tmax;
    ``inf`` for directional light)."""
    if terminator:
        offset_origin(S, S_LIFT, S[S_MAG_LIFT], 1.0, o)
    else:
        side = 1.0 if wi[0] * S[S_NG] + wi[1] * S[S_NG + 1] + wi[2] * S[S_NG + 2] >= 0.0 else -1.0
        offset_origin(S, S_P, S[S_MAG], side, o)
    if not math.isfinite(dist):
        return math.inf
    t_end = (lpos[0] - o[0]) * wi[0] + (lpos[1] - o[1]) * wi[1] + (lpos[2] - o[2]) * wi[2]
    mag = max(abs(o[0]), abs(o[1]), abs(o[2]), abs(lpos[0]), abs(lpos[1]), abs(lpos[2]))
    margin = max(1e-4 * t_end, 16.0 * J.EPS32 * mag)
    return max(t_end - margin, 0.5 * t_end)


@_njit
def light_term(S, tag, par, mtag, mpar, albedo, terminator, wi, o, f):
    """One light's contribution at the hit ``S`` before shadowing: ``f`` (3,) = f_cos * E, the shadow ray's
    origin ``o`` and direction ``wi``; returns its tmax, or -1 where the light cannot contribute (wrong side, no
    irradiance, zero BSDF: no shadow ray is traced, :func:`pyrt.integrators.direct._lit_lanes`)."""
    dist, s = LC.sample_li(tag, par, S[S_P], S[S_P + 1], S[S_P + 2], wi)
    if not s > 0.0 or not max(par[6], par[7], par[8]) > 0.0:
        return -1.0
    cg = wi[0] * S[S_NG] + wi[1] * S[S_NG + 1] + wi[2] * S[S_NG + 2]
    cv = wi[0] * S[S_NV] + wi[1] * S[S_NV + 1] + wi[2] * S[S_NV + 2]
    if not (cg > 0.0 or cv > 0.0):
        return -1.0
    cos_i = wi[0] * S[S_NS] + wi[1] * S[S_NS + 1] + wi[2] * S[S_NS + 2]
    cos_o = S[S_WO] * S[S_NS] + S[S_WO + 1] * S[S_NS + 1] + S[S_WO + 2] * S[S_NS + 2]
    cos_io = wi[0] * S[S_WO] + wi[1] * S[S_WO + 1] + wi[2] * S[S_WO + 2]
    MC.f_cos(mtag, mpar, albedo, cos_o, cos_i, cos_io, f)
    if not max(f[0], f[1], f[2]) > 0.0:
        return -1.0
    for c in range(3):
        f[c] = f[c] * s * par[6 + c]
    lpos = par[0:3]
    return shadow_ray(S, wi, dist, lpos, terminator, o)


@_njit
def emitted(S, mtag, mpar, albedo, optf, out):
    """Emission and ambient light at the hit ``S`` into ``out`` (3,) (the Whitted integrator's per-material pass)."""
    for c in range(3):
        out[c] = 0.0
    if mtag == MC.LAMBERT:
        for c in range(3):
            out[c] += mpar[4 + c]
    if MC.has_diffuse(mtag):
        for c in range(3):
            out[c] += albedo[c] * optf[F_AMBIENT + c]


@_njit
def spawn(S, mtag, mpar, thr, depth, opts, optf, key, dim, stack, top):
    """Push the delta lobes of the hit ``S`` (reached with throughput ``thr`` at bounce ``depth``) onto ``stack``
    (rows: origin, direction, throughput, depth) from row ``top``; returns ``(top, dim)``
    (:meth:`pyrt.integrators.whitted.Integrator._spawn_specular`: mirror reflections the shading normal sends below
    the geometric surface are dropped; from the split depth on a dielectric follows one lobe, chosen by weight)."""
    cos_o = S[S_WO] * S[S_NS] + S[S_WO + 1] * S[S_NS + 1] + S[S_WO + 2] * S[S_NS + 2]
    wr0 = 2.0 * cos_o * S[S_NS] - S[S_WO]
    wr1 = 2.0 * cos_o * S[S_NS + 1] - S[S_WO + 1]
    wr2 = 2.0 * cos_o * S[S_NS + 2] - S[S_WO + 2]
    cutoff = optf[F_CUTOFF]
    if mtag == MC.MIRROR:
        if not (wr0 * S[S_NG] + wr1 * S[S_NG + 1] + wr2 * S[S_NG + 2] > 0.0):
            return top, dim
        t0, t1, t2 = thr[0] * mpar[0], thr[1] * mpar[1], thr[2] * mpar[2]
        if max(t0, t1, t2) > cutoff and top < STACK:
            top = _push(S, stack, top, wr0, wr1, wr2, t0, t1, t2, depth + 1)
        return top, dim
    # glass
    eta = mpar[0] if S[S_FRONT] != 0.0 else 1.0 / mpar[0]
    R = J.fr_dielectric(cos_o, eta)
    sin2_t = max(0.0, 1.0 - cos_o * cos_o) / (eta * eta)
    tir = sin2_t >= 1.0
    if tir:
        R = 1.0
    T = 1.0 - R
    cos_t = math.sqrt(max(0.0, 1.0 - sin2_t))
    k = cos_o / eta - cos_t
    wt0 = -S[S_WO] / eta + k * S[S_NS]
    wt1 = -S[S_WO + 1] / eta + k * S[S_NS + 1]
    wt2 = -S[S_WO + 2] / eta + k * S[S_NS + 2]
    wR = R
    wT = T / (eta * eta) if T > 0.0 else 0.0
    if opts[O_SPLIT] >= 0 and depth >= opts[O_SPLIT] and T > 0.0:
        # choose_one_lobe: probability by the lobes' mean weight (the tint is common to both)
        mr = R * (mpar[1] + mpar[2] + mpar[3]) / 3.0
        mt = wT * (mpar[1] + mpar[2] + mpar[3]) / 3.0
        total = mr + mt
        u = J.uniform(key, dim)
        dim += 1
        if total > 0.0:
            p_r = mr / total
            if u * 1.0 < p_r:
                wR, wT = (wR / p_r if mr > 0.0 else 0.0), 0.0
            else:
                wR, wT = 0.0, (wT / (1.0 - p_r) if mt > 0.0 else 0.0)
        else:
            wR, wT = 0.0, 0.0
    t0, t1, t2 = thr[0] * mpar[1] * wR, thr[1] * mpar[2] * wR, thr[2] * mpar[3] * wR
    if max(t0, t1, t2) > cutoff and top < STACK:
        top = _push(S, stack, top, wr0, wr1, wr2, t0, t1, t2, depth + 1)
    if T > 0.0:
        t0, t1, t2 = thr[0] * mpar[1] * wT, thr[1] * mpar[2] * wT, thr[2] * mpar[3] * wT
        if max(t0, t1, t2) > cutoff and top < STACK:
            top = _push(S, stack, top, wt0, wt1, wt2, t0, t1, t2, depth + 1)
    return top, dim


@_njit
def _push(S, stack, top, d0, d1, d2, t0, t1, t2, depth):
    """One spawned ray on the stack: direction normalised, origin offset to the side it leaves toward."""
    ln = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
    if ln > 0.0:
        d0, d1, d2 = d0 / ln, d1 / ln, d2 / ln
    side = 1.0 if d0 * S[S_NG] + d1 * S[S_NG + 1] + d2 * S[S_NG + 2] >= 0.0 else -1.0
    row = stack[top]
    for c in range(3):
        off = side * S[S_MAG] * S[S_NG + c]
        row[c] = J.float32_step(S[S_P + c] + off, off)
    row[3], row[4], row[5] = d0, d1, d2
    row[6], row[7], row[8] = t0, t1, t2
    row[9] = depth
    return top + 1


@_njit
def trace_stack(scene, geo_f, geo_i, mats_tag, mats_par, tex_tag, tex_par, lights_tag, lights_par, opts, optf,
                key, dim, stack, top, L, S, scratch, ray_buf, counters):
    """Trace the specular rays on ``stack`` (and those they spawn) with single-ray queries, adding their radiance
    into ``L`` (3,): the deeper bounces of one camera sample."""
    fallback = opts[O_FALLBACK] != 0
    terminator = opts[O_TERMINATOR] != 0
    wi, o, f, albedo, Le, d = scratch[0], scratch[1], scratch[2], scratch[3], scratch[4], scratch[5]
    while top > 0:
        top -= 1
        row = stack[top]
        thr0, thr1, thr2 = row[6], row[7], row[8]
        depth = int(row[9])
        for c in range(3):
            d[c] = row[3 + c]
        counters[N_SECONDARY] += 1
        hit, t, prim, geom, u, v, _, _, _ = E.intersect1(scene, row[0], row[1], row[2], d[0], d[1], d[2], 0.0,
                                                         T_INF, ray_buf)
        if not hit:
            L[0] += thr0 * optf[F_BG]
            L[1] += thr1 * optf[F_BG + 1]
            L[2] += thr2 * optf[F_BG + 2]
            continue
        surface(geo_f, geo_i, mats_tag, mats_par, tex_tag, tex_par, fallback, geom, prim, u, v, d, S)
        m = int(S[S_MAT])
        mtag, mpar = mats_tag[m], mats_par[m]
        MC.albedo_at(mtag, mpar, tex_tag, tex_par, S[S_U], S[S_V], albedo)
        emitted(S, mtag, mpar, albedo, optf, Le)
        if MC.has_diffuse(mtag):
            for j in range(opts[O_NLIGHTS]):
                tmax = light_term(S, lights_tag[j], lights_par[j], mtag, mpar, albedo, terminator, wi, o, f)
                if tmax < 0.0:
                    continue
                counters[N_SHADOW] += 1
                if not E.occluded1(scene, o[0], o[1], o[2], wi[0], wi[1], wi[2], 0.0, min(tmax, T_INF), ray_buf):
                    for c in range(3):
                        Le[c] += f[c]
        L[0] += thr0 * Le[0]
        L[1] += thr1 * Le[1]
        L[2] += thr2 * Le[2]
        if depth < opts[O_MAX_DEPTH] and MC.has_delta(mtag):
            thr = scratch[6]
            thr[0], thr[1], thr[2] = thr0, thr1, thr2
            top, dim = spawn(S, mtag, mpar, thr, depth, opts, optf, key, dim, stack, top)
    return dim


@_njit
def render_tile(scene, tile, cam, geo_f, geo_i, mats_tag, mats_par, tex_tag, tex_par, lights_tag, lights_par,
                opts, optf, sums, sqs, counters, width):
    """Render the pixels of tile ``tile`` (row-major over the image's tiles of :data:`TILE` pixels) at the samples
    ``[opts[O_SPP_LO], opts[O_SPP])`` of each pixel's set of ``opts[O_SPP]``: their radiance summed into ``sums``
    and squared into ``sqs`` (pixel rows of the image), rays counted into ``counters`` (4,)."""
    W, H = int(cam[C_W]), int(cam[C_H])
    tiles_x = (W + TILE - 1) // TILE
    x0, y0 = (tile % tiles_x) * TILE, (tile // tiles_x) * TILE
    spp, spp_lo = opts[O_SPP], opts[O_SPP_LO]
    seed = opts[O_SEED]
    nl = opts[O_NLIGHTS]
    fallback = opts[O_FALLBACK] != 0
    terminator = opts[O_TERMINATOR] != 0
    pk = E.packet_alloc(width)
    sh = E.packet_alloc(width)
    ray_buf = E.ray_alloc()
    Ss = np.zeros((width, S_SIZE))
    Ls = np.zeros((width, 3))
    dirs = np.zeros((width, 3))
    keys = np.zeros(width, dtype=np.uint64)
    dims = np.zeros(width, dtype=np.int64)
    hits = np.zeros(width, dtype=np.bool_)
    f_l = np.zeros((width, 3))
    wi_l = np.zeros((width, 3))
    o_l = np.zeros((width, 3))
    albedo = np.zeros((width, 3))
    scratch = np.zeros((8, 3))
    stack = np.zeros((STACK, 10))
    S1 = np.zeros(S_SIZE)
    L1 = np.zeros(3)
    Le = np.zeros(3)
    thr = np.ones(3)
    for py in range(y0, min(y0 + TILE, H)):
        for px in range(x0, min(x0 + TILE, W)):
            pix = py * W + px
            pix_key = np.int64(J.key64(seed, pix, 0xFFFFFFFF) & np.uint64(0x7FFFFFFF))
            for s0 in range(spp_lo, spp, width):
                n = min(width, spp - s0)
                E.packet_clear(pk)
                for lane in range(n):
                    s = s0 + lane
                    key = J.key64(seed, pix, s)
                    keys[lane] = key
                    dims[lane] = DIM_LOBE
                    ox, oy = pixel_position(cam, spp, s, key, pix_key)
                    d = dirs[lane]
                    camera_ray(cam, px + ox, py + oy, d)
                    E.packet_set_ray(pk, lane, cam[C_POS], cam[C_POS + 1], cam[C_POS + 2], d[0], d[1], d[2], 0.0,
                                     T_INF)
                    Ls[lane, 0] = Ls[lane, 1] = Ls[lane, 2] = 0.0
                counters[N_PRIMARY] += n
                E.intersect_packet(scene, pk, True)
                for lane in range(n):
                    hit, t, prim, geom, u, v, _, _, _ = E.packet_hit(pk, lane)
                    hits[lane] = hit
                    if not hit:
                        for c in range(3):
                            Ls[lane, c] = optf[F_BG + c]
                        continue
                    S = Ss[lane]
                    surface(geo_f, geo_i, mats_tag, mats_par, tex_tag, tex_par, fallback, geom, prim, u, v,
                            dirs[lane], S)
                    m = int(S[S_MAT])
                    MC.albedo_at(mats_tag[m], mats_par[m], tex_tag, tex_par, S[S_U], S[S_V], albedo[lane])
                    emitted(S, mats_tag[m], mats_par[m], albedo[lane], optf, Le)
                    for c in range(3):
                        Ls[lane, c] = Le[c]
                # direct light: per light, the packet's shadow rays in one masked query
                for j in range(nl):
                    E.packet_clear(sh)
                    any_ray = False
                    for lane in range(n):
                        if not hits[lane]:
                            continue
                        S = Ss[lane]
                        m = int(S[S_MAT])
                        if not MC.has_diffuse(mats_tag[m]):
                            continue
                        tmax = light_term(S, lights_tag[j], lights_par[j], mats_tag[m], mats_par[m], albedo[lane],
                                          terminator, wi_l[lane], o_l[lane], f_l[lane])
                        if tmax < 0.0:
                            continue
                        E.packet_set_ray(sh, lane, o_l[lane, 0], o_l[lane, 1], o_l[lane, 2], wi_l[lane, 0],
                                         wi_l[lane, 1], wi_l[lane, 2], 0.0, min(tmax, T_INF))
                        any_ray = True
                        counters[N_SHADOW] += 1
                    if not any_ray:
                        continue
                    E.occluded_packet(scene, sh, True)
                    valid = E.packet_valid(sh)
                    for lane in range(n):
                        if valid[lane] != 0 and not E.packet_blocked(sh, lane):
                            for c in range(3):
                                Ls[lane, c] += f_l[lane, c]
                # the specular tree of each sample, then the film
                for lane in range(n):
                    if hits[lane] and opts[O_MAX_DEPTH] > 0:
                        S = Ss[lane]
                        m = int(S[S_MAT])
                        if MC.has_delta(mats_tag[m]):
                            thr[0] = thr[1] = thr[2] = 1.0
                            top, dim = spawn(S, mats_tag[m], mats_par[m], thr, 0, opts, optf, keys[lane],
                                             dims[lane], stack, 0)
                            if top > 0:
                                L1[0] = L1[1] = L1[2] = 0.0
                                trace_stack(scene, geo_f, geo_i, mats_tag, mats_par, tex_tag, tex_par, lights_tag,
                                            lights_par, opts, optf, keys[lane], dim, stack, top, L1, S1, scratch,
                                            ray_buf, counters)
                                for c in range(3):
                                    Ls[lane, c] += L1[c]
                    l0, l1, l2 = Ls[lane, 0], Ls[lane, 1], Ls[lane, 2]
                    if not (math.isfinite(l0) and math.isfinite(l1) and math.isfinite(l2)):
                        counters[N_NONFINITE] += 1
                        l0 = l1 = l2 = 0.0
                    sums[pix, 0] += l0
                    sums[pix, 1] += l1
                    sums[pix, 2] += l2
                    sqs[pix, 0] += l0 * l0
                    sqs[pix, 1] += l1 * l1
                    sqs[pix, 2] += l2 * l2


@numba.njit(nogil=True, cache=True, parallel=True)
def render_tiles(scene, tiles, cam, geo_f, geo_i, mats_tag, mats_par, tex_tag, tex_par, lights_tag, lights_par,
                 opts, optf, sums, sqs, counters, width):
    """:func:`render_tile` for every tile of ``tiles`` (threads over them); ``counters`` (len(tiles), 4)."""
    for k in prange(tiles.shape[0]):
        render_tile(scene, tiles[k], cam, geo_f, geo_i, mats_tag, mats_par, tex_tag, tex_par, lights_tag,
                    lights_par, opts, optf, sums, sqs, counters[k], width)


kernel_cache.restore()
