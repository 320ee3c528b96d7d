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

Surface records are rows of a float64 array of :data:`S_SIZE` columns (offsets ``S_*``); everything per sample
lives in rows of per-tile scratch arrays, nothing is allocated per ray. Arrays are indexed, never sliced, in the
per-sample code: a view costs two atomic reference-count updates (measured: the first version, which passed row
views, spent more time in them than in Embree), and every helper is inlined (``inline="always"``) so that Numba
can drop the reference counting of its array arguments.
"""
from __future__ import annotations

import math

import numba
import numpy as np
from numba import prange

from pyrt.integrators import kernel_cache

kernel_cache.use_cache_dir()      # before the decorators below (and those of the modules they inline) run

from pyrt.core.unmanaged import keep_alive, unmanaged as U  # noqa: E402
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
C_POS, C_FWD, C_RIGHT, C_UP, C_TAN, C_W, C_H, C_JITTER, C_K, C_AX = 0, 3, 6, 9, 12, 13, 14, 15, 16, 17
#: length of the camera record
N_CAM = 18
#: integer options
O_SEED, O_SPP, O_MAX_DEPTH, O_SPLIT, O_TERMINATOR, O_NLIGHTS, O_SPP_LO, O_FALLBACK, O_GRID = 0, 1, 2, 3, 4, 5, 6, 7, 8
#: length of the integer options
N_OPTS = 9
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

_njit = numba.njit(nogil=True, cache=True, error_model="numpy", inline="always")


@_njit
def camera_ray(cam, x, y, D, r):
    """Unit direction (float64) through raster point ``(x, y)`` into row ``r`` of ``D``
    (:meth:`pyrt.core.camera.Camera.directions`, with ``sx = x k - a_x``, ``sy = a_y - y k`` from the camera
    record's precomputed ``k = 2 tan(fov/2) / H``, ``a_x = tan(fov/2) W / H``, ``a_y = tan(fov/2)``: no division
    but the normalisation's)."""
    sx = x * cam[C_K] - cam[C_AX]
    sy = cam[C_TAN] - y * cam[C_K]
    inv = 1.0 / math.sqrt(1.0 + sx * sx + sy * sy)
    for c in range(3):
        D[r, c] = inv * (cam[C_FWD + c] + sx * cam[C_RIGHT + c] + sy * cam[C_UP + c])


@_njit
def pixel_position(cam, spp, grid, sample, key, pix_key):
    """Raster offset ``(sx, sy)`` in [0, 1)^2 of sample ``sample`` of ``spp`` in its pixel: an ``n x n`` jittered grid
    when ``spp = n^2`` (``grid`` = n, else 0), else a Latin hypercube (x stratum ``sample``, y stratum a per-pixel
    permutation of it); the pixel centre for one unjittered sample. No integer division (a 64-bit ``idiv`` per
    sample was measured at a fifth of the kernel's time): the grid cell from a float floor."""
    if spp == 1 and cam[C_JITTER] == 0.0:
        return 0.5, 0.5
    u0, u1 = J.uniform_pair(key)
    if grid > 0:
        inv = 1.0 / grid
        cy = math.floor((sample + 0.5) * inv)
        return (sample - cy * grid + u0) * inv, (cy + u1) * inv
    inv = 1.0 / spp
    return (sample + u0) * inv, (J.permute(sample, spp, pix_key) + u1) * inv


@_njit
def surface(geo_f, geo_i, fallback, geom, prim, u, v, D, dr, S, r):
    """Rebuild the hit ``(geom, prim, u, v)`` of the ray along the unit ``D[dr]`` into the surface record ``S[r]``
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
        S[r, S_P + c] = b0 * verts[i0, c] + b1 * verts[i1, c] + b2 * verts[i2, c]
        S[r, S_WO + c] = -D[dr, c]
    cos_g = fnorm[face, 0] * S[r, S_WO] + fnorm[face, 1] * S[r, S_WO + 1] + fnorm[face, 2] * S[r, S_WO + 2]
    front = cos_g >= 0.0
    sign = 1.0 if front else -1.0
    for c in range(3):
        S[r, S_NG + c] = sign * fnorm[face, c]
    S[r, S_FRONT] = 1.0 if front else 0.0
    S[r, S_FACE] = face
    S[r, S_MAT] = fmat[face, 0]
    smooth = fsmooth[face, 0] != 0
    S[r, S_SMOOTH] = 1.0 if smooth else 0.0
    for c in range(3):
        S[r, S_NS + c] = S[r, S_NG + c]
        S[r, S_NV + c] = S[r, S_NG + c]
        S[r, S_LIFT + c] = S[r, S_P + c]
    if smooth:
        n0 = b0 * normals[i0, 0] + b1 * normals[i1, 0] + b2 * normals[i2, 0]
        n1 = b0 * normals[i0, 1] + b1 * normals[i1, 1] + b2 * normals[i2, 1]
        n2 = b0 * normals[i0, 2] + b1 * normals[i1, 2] + b2 * normals[i2, 2]
        ln = math.sqrt(n0 * n0 + n1 * n1 + n2 * n2)
        if ln > 0.0:
            n0, n1, n2 = sign * n0 / ln, sign * n1 / ln, sign * n2 / ln
        S[r, S_NV], S[r, S_NV + 1], S[r, S_NV + 2] = n0, n1, n2
        bad = n0 * n0 + n1 * n1 + n2 * n2 == 0.0
        if fallback and not bad:
            bad = n0 * S[r, S_WO] + n1 * S[r, S_WO + 1] + n2 * S[r, S_WO + 2] <= 0.0
        if not bad:
            S[r, S_NS], S[r, S_NS + 1], S[r, S_NS + 2] = n0, n1, n2
        # Hanika's terminator lift: p' = p - sum_i b_i min(0, (p - v_i) . n_i) n_i, n_i turned to the ng side
        for k in range(3):
            vi = i0 if k == 0 else (i1 if k == 1 else i2)
            bk = b0 if k == 0 else (b1 if k == 1 else b2)
            h = sign * ((S[r, S_P] - verts[vi, 0]) * normals[vi, 0] + (S[r, S_P + 1] - verts[vi, 1]) * normals[vi, 1]
                        + (S[r, S_P + 2] - verts[vi, 2]) * normals[vi, 2])
            w = bk * min(h, 0.0) * sign
            for c in range(3):
                S[r, S_LIFT + c] -= normals[vi, c] * w
    # local_bound_magnitude: |ng| . gamma_4(f64) absmax + 8 eps32 extent (absmax widened by the lift)
    g4 = J.gamma(4.0, J.EPS64)
    m = 0.0
    ml = 0.0
    for c in range(3):
        a = fabs[face, c]
        m += abs(S[r, S_NG + c]) * g4 * a
        ml += abs(S[r, S_NG + c]) * g4 * (a + abs(S[r, S_LIFT + c] - S[r, S_P + c]))
    S[r, S_MAG] = m + 8.0 * J.EPS32 * fext[face, 0]
    S[r, S_MAG_LIFT] = ml + 8.0 * J.EPS32 * fext[face, 0]
    S[r, S_U] = b0 * uvs[i0, 0] + b1 * uvs[i1, 0] + b2 * uvs[i2, 0]
    S[r, S_V] = b0 * uvs[i0, 1] + b1 * uvs[i1, 1] + b2 * uvs[i2, 1]


@_njit
def offset_origin(S, r, base, mag, side, O, orow):
    """``round_away(base + side mag ng)`` (:func:`pyrt.geometry.offsets.local_bound`) of the record ``S[r]`` into
    ``O[orow]``: float64 values of float32 numbers, each one float32 ulp further along the offset."""
    for c in range(3):
        off = side * mag * S[r, S_NG + c]
        O[orow, c] = J.float32_step(S[r, base + c] + off, off)


@_njit
def shadow_ray(S, r, WI, dist, lx, ly, lz, terminator, O):
    """The shadow ray from the hit ``S[r]`` toward a light ``dist`` away along ``WI[r]`` (ending at ``(lx, ly, lz)``
    for a light at a point): origin into ``O[r]`` and the returned ``tmax`` (:meth:`pyrt.geometry.offsets.Strategy.
    shadow`, ``robust`` tmax; ``inf`` for directional light)."""
    if terminator:
        offset_origin(S, r, S_LIFT, S[r, S_MAG_LIFT], 1.0, O, r)
    else:
        cg = WI[r, 0] * S[r, S_NG] + WI[r, 1] * S[r, S_NG + 1] + WI[r, 2] * S[r, S_NG + 2]
        offset_origin(S, r, S_P, S[r, S_MAG], 1.0 if cg >= 0.0 else -1.0, O, r)
    if not math.isfinite(dist):
        return math.inf
    t_end = (lx - O[r, 0]) * WI[r, 0] + (ly - O[r, 1]) * WI[r, 1] + (lz - O[r, 2]) * WI[r, 2]
    mag = max(abs(O[r, 0]), abs(O[r, 1]), abs(O[r, 2]), abs(lx), abs(ly), abs(lz))
    margin = max(1e-4 * t_end, 16.0 * J.EPS32 * mag)
    return max(t_end - margin, 0.5 * t_end)


@_njit
def light_term(S, r, ltags, lpars, j, mtag, mpars, m, A, terminator, WI, O, F):
    """Light ``j``'s contribution at the hit ``S[r]`` before shadowing: ``F[r]`` = f_cos * E, the shadow ray's
    origin ``O[r]`` and direction ``WI[r]``; returns its tmax, or -1 where the light cannot contribute (wrong side,
    no irradiance, zero BSDF: no shadow ray is traced, :func:`pyrt.integrators.direct._lit_lanes`). ``A[r]`` is the
    material's diffuse colour at the hit."""
    dist, s = LC.sample_li(ltags[j], lpars, j, S[r, S_P], S[r, S_P + 1], S[r, S_P + 2], WI, r)
    if not s > 0.0 or not max(lpars[j, 6], lpars[j, 7], lpars[j, 8]) > 0.0:
        return -1.0
    w0, w1, w2 = WI[r, 0], WI[r, 1], WI[r, 2]
    cg = w0 * S[r, S_NG] + w1 * S[r, S_NG + 1] + w2 * S[r, S_NG + 2]
    cv = w0 * S[r, S_NV] + w1 * S[r, S_NV + 1] + w2 * S[r, S_NV + 2]
    if not (cg > 0.0 or cv > 0.0):
        return -1.0
    cos_i = w0 * S[r, S_NS] + w1 * S[r, S_NS + 1] + w2 * S[r, S_NS + 2]
    cos_o = S[r, S_WO] * S[r, S_NS] + S[r, S_WO + 1] * S[r, S_NS + 1] + S[r, S_WO + 2] * S[r, S_NS + 2]
    cos_io = w0 * S[r, S_WO] + w1 * S[r, S_WO + 1] + w2 * S[r, S_WO + 2]
    MC.f_cos(mtag, mpars, m, A, r, cos_o, cos_i, cos_io, F, r)
    if not max(F[r, 0], F[r, 1], F[r, 2]) > 0.0:
        return -1.0
    for c in range(3):
        F[r, c] = F[r, c] * s * lpars[j, 6 + c]
    return shadow_ray(S, r, WI, dist, lpars[j, 0], lpars[j, 1], lpars[j, 2], terminator, O)


@_njit
def emitted(S, r, mtag, mpars, m, A, optf, LE):
    """Emission and ambient light at the hit ``S[r]`` into ``LE[r]`` (the Whitted integrator's per-material pass)."""
    for c in range(3):
        LE[r, c] = 0.0
    if mtag == MC.LAMBERT:
        for c in range(3):
            LE[r, c] += mpars[m, 4 + c]
    if MC.has_diffuse(mtag):
        for c in range(3):
            LE[r, c] += A[r, c] * optf[F_AMBIENT + c]


@_njit
def spawn(S, r, mtag, mpars, m, thr0, thr1, thr2, depth, opts, optf, key, dim, stack, top):
    """Push the delta lobes of the hit ``S[r]`` (reached with throughput ``thr`` at bounce ``depth``) onto ``stack``
    (rows: origin, direction, throughput, depth) from row ``top``; returns ``(top, dim)``
    (:meth:`pyrt.integrators.whitted.Integrator._spawn_specular`: mirror reflections the shading normal sends below
    the geometric surface are dropped; from the split depth on a dielectric follows one lobe, chosen by weight)."""
    cos_o = S[r, S_WO] * S[r, S_NS] + S[r, S_WO + 1] * S[r, S_NS + 1] + S[r, S_WO + 2] * S[r, S_NS + 2]
    wr0 = 2.0 * cos_o * S[r, S_NS] - S[r, S_WO]
    wr1 = 2.0 * cos_o * S[r, S_NS + 1] - S[r, S_WO + 1]
    wr2 = 2.0 * cos_o * S[r, S_NS + 2] - S[r, S_WO + 2]
    cutoff = optf[F_CUTOFF]
    if mtag == MC.MIRROR:
        if not (wr0 * S[r, S_NG] + wr1 * S[r, S_NG + 1] + wr2 * S[r, S_NG + 2] > 0.0):
            return top, dim
        t0, t1, t2 = thr0 * mpars[m, 0], thr1 * mpars[m, 1], thr2 * mpars[m, 2]
        if max(t0, t1, t2) > cutoff and top < STACK:
            top = _push(S, r, stack, top, wr0, wr1, wr2, t0, t1, t2, depth + 1)
        return top, dim
    # glass
    eta = mpars[m, 0] if S[r, S_FRONT] != 0.0 else 1.0 / mpars[m, 0]
    R = J.fr_dielectric(cos_o, eta)
    sin2_t = max(0.0, 1.0 - cos_o * cos_o) / (eta * eta)
    if sin2_t >= 1.0:
        R = 1.0
    T = 1.0 - R
    cos_t = math.sqrt(max(0.0, 1.0 - sin2_t))
    k = cos_o / eta - cos_t
    wt0 = -S[r, S_WO] / eta + k * S[r, S_NS]
    wt1 = -S[r, S_WO + 1] / eta + k * S[r, S_NS + 1]
    wt2 = -S[r, S_WO + 2] / eta + k * S[r, S_NS + 2]
    wR = R
    wT = T / (eta * eta) if T > 0.0 else 0.0
    if opts[O_SPLIT] >= 0 and depth >= opts[O_SPLIT] and T > 0.0:
        # choose_one_lobe: probability by the lobes' mean weight (the tint is common to both)
        tint = (mpars[m, 1] + mpars[m, 2] + mpars[m, 3]) / 3.0
        mr, mt = R * tint, wT * tint
        total = mr + mt
        u = J.uniform(key, dim)
        dim += 1
        if total > 0.0:
            p_r = mr / total
            if u < p_r:
                wR, wT = (wR / p_r if mr > 0.0 else 0.0), 0.0
            else:
                wR, wT = 0.0, (wT / (1.0 - p_r) if mt > 0.0 else 0.0)
        else:
            wR, wT = 0.0, 0.0
    t0, t1, t2 = thr0 * mpars[m, 1] * wR, thr1 * mpars[m, 2] * wR, thr2 * mpars[m, 3] * wR
    if max(t0, t1, t2) > cutoff and top < STACK:
        top = _push(S, r, stack, top, wr0, wr1, wr2, t0, t1, t2, depth + 1)
    if T > 0.0:
        t0, t1, t2 = thr0 * mpars[m, 1] * wT, thr1 * mpars[m, 2] * wT, thr2 * mpars[m, 3] * wT
        if max(t0, t1, t2) > cutoff and top < STACK:
            top = _push(S, r, stack, top, wt0, wt1, wt2, t0, t1, t2, depth + 1)
    return top, dim


@_njit
def _push(S, r, stack, top, d0, d1, d2, t0, t1, t2, depth):
    """One spawned ray from the hit ``S[r]`` on the stack: direction normalised, origin offset to the side it leaves
    toward."""
    ln = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
    if ln > 0.0:
        d0, d1, d2 = d0 / ln, d1 / ln, d2 / ln
    side = 1.0 if d0 * S[r, S_NG] + d1 * S[r, S_NG + 1] + d2 * S[r, S_NG + 2] >= 0.0 else -1.0
    for c in range(3):
        off = side * S[r, S_MAG] * S[r, S_NG + c]
        stack[top, c] = J.float32_step(S[r, S_P + c] + off, off)
    stack[top, 3], stack[top, 4], stack[top, 5] = d0, d1, d2
    stack[top, 6], stack[top, 7], stack[top, 8] = t0, t1, t2
    stack[top, 9] = depth
    return top + 1


@numba.njit(nogil=True, cache=True, error_model="numpy")
def trace_stack(scene, geo_f, geo_i, mats_tag, mats_par, tex_tag, tex_par, lights_tag, lights_par, opts, optf,
                key, dim, stack, top, L, lane, S, D, A, LE, WI, O, F, r, ray_buf, counters):
    """Trace the specular rays on ``stack`` (and those they spawn) with single-ray queries, adding their radiance
    into ``L[lane]``: the deeper bounces of one camera sample. Row ``r`` of the scratch arrays is this function's."""
    fallback = opts[O_FALLBACK] != 0
    terminator = opts[O_TERMINATOR] != 0
    while top > 0:
        top -= 1
        thr0, thr1, thr2 = stack[top, 6], stack[top, 7], stack[top, 8]
        depth = int(stack[top, 9])
        for c in range(3):
            D[r, c] = stack[top, 3 + c]
        counters[N_SECONDARY] += 1
        hit, t, prim, geom, u, v, _, _, _ = E.intersect1(scene, stack[top, 0], stack[top, 1], stack[top, 2],
                                                         D[r, 0], D[r, 1], D[r, 2], 0.0, T_INF, ray_buf)
        if not hit:
            L[lane, 0] += thr0 * optf[F_BG]
            L[lane, 1] += thr1 * optf[F_BG + 1]
            L[lane, 2] += thr2 * optf[F_BG + 2]
            continue
        surface(geo_f, geo_i, fallback, geom, prim, u, v, D, r, S, r)
        m = int(S[r, S_MAT])
        mtag = mats_tag[m]
        MC.albedo_at(mtag, mats_par, m, tex_tag, tex_par, S[r, S_U], S[r, S_V], A, r)
        emitted(S, r, mtag, mats_par, m, A, optf, LE)
        if MC.has_diffuse(mtag):
            for j in range(opts[O_NLIGHTS]):
                tmax = light_term(S, r, lights_tag, lights_par, j, mtag, mats_par, m, A, terminator, WI, O, F)
                if tmax < 0.0:
                    continue
                counters[N_SHADOW] += 1
                if not E.occluded1(scene, O[r, 0], O[r, 1], O[r, 2], WI[r, 0], WI[r, 1], WI[r, 2], 0.0,
                                   min(tmax, T_INF), ray_buf):
                    for c in range(3):
                        LE[r, c] += F[r, c]
        L[lane, 0] += thr0 * LE[r, 0]
        L[lane, 1] += thr1 * LE[r, 1]
        L[lane, 2] += thr2 * LE[r, 2]
        if depth < opts[O_MAX_DEPTH] and MC.has_delta(mtag):
            top, dim = spawn(S, r, mtag, mats_par, m, thr0, thr1, thr2, depth, opts, optf, key, dim, stack, top)
    return dim


@numba.njit(nogil=True, cache=True, error_model="numpy")
def render_tile(scene, tile, cam, geo_f, geo_i, mats_tag, mats_par, tex_tag, tex_par, lights_tag, lights_par,
                opts, optf, sums, sqs, counters, width):
    """Render the pixels of tile ``tile`` (row-major over the image's tiles of :data:`TILE` pixels) at the samples
    ``[opts[O_SPP_LO], opts[O_SPP])`` of each pixel's set of ``opts[O_SPP]``, ``width`` samples (a packet) at a time:
    their radiance summed into ``sums`` and squared into ``sqs`` (pixel rows of the image), rays counted into
    ``counters`` (4,)."""
    # every array the per-sample code binds is an unmanaged view (pyrt.core.unmanaged: no atomic reference counting);
    # the arrays allocated here are kept alive by their last use at the end of the function
    pk_own, sh_own, ray_own = E.packet_alloc(width), E.packet_alloc(width), E.ray_alloc()
    n_rows = width + 1                       # one row per lane, and the last one for the specular tree
    scratch = np.zeros((8, n_rows, S_SIZE))      # S, and the rows of D, A, LE, WI, O, F, L in its first columns
    stack_own = np.zeros((STACK, 10))
    flags_own = np.zeros((2, width), dtype=np.bool_)
    keys_own = np.zeros(width, dtype=np.uint64)
    pk, sh, ray_buf = U(pk_own), U(sh_own), U(ray_own)
    S, D, A, LE, WI, O, F = (U(scratch[0]), U(scratch[1]), U(scratch[2]), U(scratch[3]), U(scratch[4]), U(scratch[5]),
                             U(scratch[6]))
    L = U(scratch[7])
    stack, keys, hits, lit = U(stack_own), U(keys_own), U(flags_own[0]), U(flags_own[1])
    cam, opts, optf, sums, sqs, counters = U(cam), U(opts), U(optf), U(sums), U(sqs), U(counters)
    mats_tag, mats_par, tex_tag, tex_par = U(mats_tag), U(mats_par), U(tex_tag), U(tex_par)
    lights_tag, lights_par = U(lights_tag), U(lights_par)
    geo_f = (U(geo_f[0]), U(geo_f[1]), U(geo_f[2]), U(geo_f[3]), U(geo_f[4]), U(geo_f[5]))
    geo_i = (U(geo_i[0]), U(geo_i[1]), U(geo_i[2]), U(geo_i[3]))
    W, H = int(cam[C_W]), int(cam[C_H])
    tiles_x = (W + TILE - 1) // TILE
    x0, y0 = (tile % tiles_x) * TILE, (tile // tiles_x) * TILE
    spp, spp_lo, grid = opts[O_SPP], opts[O_SPP_LO], opts[O_GRID]
    seed = opts[O_SEED]
    nl = opts[O_NLIGHTS]
    max_depth = opts[O_MAX_DEPTH]
    fallback = opts[O_FALLBACK] != 0
    terminator = opts[O_TERMINATOR] != 0
    cx, cy, cz = cam[C_POS], cam[C_POS + 1], cam[C_POS + 2]
    for py in range(y0, min(y0 + TILE, H)):
        for px in range(x0, min(x0 + TILE, W)):
            pix = py * W + px
            pkey = J.pixel_key(seed, pix)
            perm_seed = np.int64(pkey & np.uint64(0x7FFFFFFF))
            for s0 in range(spp_lo, spp, width):
                n = min(width, spp - s0)
                for lane in range(n):          # a loop of arithmetic only: the lanes' latencies overlap
                    s = s0 + lane
                    key = J.sample_key(pkey, s)
                    keys[lane] = key
                    ox, oy = pixel_position(cam, spp, grid, s, key, perm_seed)
                    camera_ray(cam, px + ox, py + oy, D, lane)
                E.packet_clear(pk)
                for lane in range(n):
                    E.packet_set_ray(pk, lane, cx, cy, cz, D[lane, 0], D[lane, 1], D[lane, 2], 0.0, T_INF)
                counters[N_PRIMARY] += n
                E.intersect_packet(scene, pk, True)
                any_diffuse = False
                for lane in range(n):
                    hit, t, prim, geom, u, v, _, _, _ = E.packet_hit(pk, lane)
                    hits[lane] = hit
                    if not hit:
                        for c in range(3):
                            L[lane, c] = optf[F_BG + c]
                        continue
                    surface(geo_f, geo_i, fallback, geom, prim, u, v, D, lane, S, lane)
                    m = int(S[lane, S_MAT])
                    mtag = mats_tag[m]
                    MC.albedo_at(mtag, mats_par, m, tex_tag, tex_par, S[lane, S_U], S[lane, S_V], A, lane)
                    emitted(S, lane, mtag, mats_par, m, A, optf, LE)
                    for c in range(3):
                        L[lane, c] = LE[lane, c]
                    any_diffuse |= MC.has_diffuse(mtag)
                # direct light: per light, the packet's shadow rays in one masked query
                for j in range(nl if any_diffuse else 0):
                    E.packet_clear(sh)
                    n_sh = 0
                    for lane in range(n):
                        lit[lane] = False
                        if not hits[lane]:
                            continue
                        m = int(S[lane, S_MAT])
                        mtag = mats_tag[m]
                        if not MC.has_diffuse(mtag):
                            continue
                        tmax = light_term(S, lane, lights_tag, lights_par, j, mtag, mats_par, m, A, terminator, WI,
                                          O, F)
                        if tmax < 0.0:
                            continue
                        E.packet_set_ray(sh, lane, O[lane, 0], O[lane, 1], O[lane, 2], WI[lane, 0], WI[lane, 1],
                                         WI[lane, 2], 0.0, min(tmax, T_INF))
                        lit[lane] = True
                        n_sh += 1
                    if n_sh == 0:
                        continue
                    counters[N_SHADOW] += n_sh
                    E.occluded_packet(scene, sh, True)
                    for lane in range(n):
                        if lit[lane] and not E.packet_blocked(sh, lane):
                            for c in range(3):
                                L[lane, c] += F[lane, c]
                # the specular tree of each sample, then the film
                for lane in range(n):
                    if hits[lane] and max_depth > 0:
                        m = int(S[lane, S_MAT])
                        mtag = mats_tag[m]
                        if MC.has_delta(mtag):
                            top, dim = spawn(S, lane, mtag, mats_par, m, 1.0, 1.0, 1.0, 0, opts, optf, keys[lane],
                                             DIM_LOBE, stack, 0)
                            if top > 0:
                                trace_stack(scene, geo_f, geo_i, mats_tag, mats_par, tex_tag, tex_par, lights_tag,
                                            lights_par, opts, optf, keys[lane], dim, stack, top, L, lane, S, D, A,
                                            LE, WI, O, F, width, ray_buf, counters)
                    l0, l1, l2 = L[lane, 0], L[lane, 1], L[lane, 2]
                    if not (math.isfinite(l0) and math.isfinite(l1) and math.isfinite(l2)):
                        counters[N_NONFINITE] += 1
                        l0 = l1 = l2 = 0.0
                    sums[pix, 0] += l0
                    sums[pix, 1] += l1
                    sums[pix, 2] += l2
                    sqs[pix, 0] += l0 * l0
                    sqs[pix, 1] += l1 * l1
                    sqs[pix, 2] += l2 * l2
    # the owners of the unmanaged views live until here
    keep_alive(pk_own)
    keep_alive(sh_own)
    keep_alive(ray_own)
    keep_alive(scratch)
    keep_alive(stack_own)
    keep_alive(flags_own)
    keep_alive(keys_own)


@numba.njit(nogil=True, cache=True, error_model="numpy", parallel=True)
def render_tiles(scene, tiles, cam, geo_f, geo_i, mats_tag, mats_par, tex_tag, tex_par, lights_tag, lights_par,
                 opts, optf, sums, sqs, counters, width):
    """:func:`render_tile` for every tile of ``tiles`` (threads over them); ``counters`` (len(tiles), 4)."""
    for k in prange(tiles.shape[0]):
        render_tile(scene, tiles[k], cam, geo_f, geo_i, mats_tag, mats_par, tex_tag, tex_par, lights_tag,
                    lights_par, opts, optf, sums, sqs, counters[k], width)


kernel_cache.restore()
