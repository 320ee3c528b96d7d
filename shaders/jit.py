"""Scalar twins of the NumPy kernels, for the compiled (Numba) tile kernels.

Every function here is ``numba.extending.register_jitable``: callable from nopython code (where the compiled
render kernel inlines it) and from plain Python on floats. Each is the scalar form of a NumPy kernel of this
package, named after it; ``tests/test_jit_shaders.py`` holds every one to its NumPy twin to 1e-6 relative in
float64 on random inputs, grazing angles included, so the two paths cannot drift apart silently.

Conventions as in the NumPy kernels: directions point away from the surface, cosines are against the shading
normal, a BRDF returns ``f * cos(theta_i)``; invalid lanes give 0, never NaN.

Random numbers (counter-based, pbrt-v4 / Cycles style): :func:`uniform` hashes ``(seed, pixel, sample, dim)`` to
a float in [0, 1): the same numbers whatever thread renders a tile, so an image depends on the seed alone.
"""
from __future__ import annotations

import math

import numpy as np
from numba.extending import register_jitable

#: float32 unit roundoff 2^-24 and float64's 2^-53 (:mod:`pyrt.geometry.offsets`)
EPS32 = 2.0 ** -24
EPS64 = 2.0 ** -53
INV_PI = 1.0 / math.pi


# ----------------------------------------------------------------------------------------- counter-based RNG

@register_jitable(forceinline=True)
def mix64(x):
    """SplitMix64's finaliser (Steele et al. 2014): a bijective 64-bit mixer, ``x`` a uint64."""
    x = (x ^ (x >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
    x = (x ^ (x >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    return x ^ (x >> np.uint64(31))


@register_jitable(forceinline=True)
def key64(seed, pixel, sample):
    """The 64-bit key of one camera sample: ``seed``, ``pixel`` (row-major index) and ``sample`` mixed."""
    h = mix64(np.uint64(seed) + np.uint64(0x9E3779B97F4A7C15))
    h = mix64(h ^ np.uint64(pixel))
    return mix64(h ^ (np.uint64(sample) * np.uint64(0xD1B54A32D192ED03)))


@register_jitable(forceinline=True)
def pixel_key(seed, pixel):
    """The 64-bit key of a pixel's samples (:func:`sample_key`): ``seed`` and ``pixel`` mixed."""
    return mix64(mix64(np.uint64(seed) + np.uint64(0x9E3779B97F4A7C15)) ^ np.uint64(pixel))


@register_jitable(forceinline=True)
def sample_key(pix_key, sample):
    """The 64-bit key of sample ``sample`` of the pixel whose key is ``pix_key``: one mix per sample."""
    return mix64(pix_key ^ (np.uint64(sample) * np.uint64(0xD1B54A32D192ED03)))


@register_jitable(forceinline=True)
def uniform_pair(key):
    """Two floats in [0, 1) with 24 bits each (a sample's position in its pixel): one mix of ``key``."""
    h = mix64(key + np.uint64(0x9E3779B97F4A7C15))
    return (float(h >> np.uint64(40)) * (1.0 / 16777216.0),
            float((h >> np.uint64(16)) & np.uint64(0xFFFFFF)) * (1.0 / 16777216.0))


@register_jitable(forceinline=True)
def uniform(key, dim):
    """A float64 in [0, 1) for dimension ``dim`` of the sample whose key is ``key`` (:func:`key64`): 53 bits of
    ``mix64(key + (dim + 1) * golden)``."""
    h = mix64(key + np.uint64(dim + 1) * np.uint64(0x9E3779B97F4A7C15))
    return float(h >> np.uint64(11)) * (1.0 / 9007199254740992.0)


@register_jitable(forceinline=True)
def permute(i, n, seed):
    """Element ``i`` of a random permutation of ``range(n)`` chosen by ``seed`` (Kensler 2013, "Correlated
    Multi-Jittered Sampling", ``permute``): a bijection on [0, n) by cycle-walking a 32-bit hash on the next
    power of 2. Integers in, integer out; ``n`` >= 1. (32-bit arithmetic written as masked 64-bit: Numba widens
    small integers.)"""
    m32 = np.uint64(0xFFFFFFFF)
    w = np.uint64(n - 1)
    w |= w >> np.uint64(1)
    w |= w >> np.uint64(2)
    w |= w >> np.uint64(4)
    w |= w >> np.uint64(8)
    w |= w >> np.uint64(16)
    p = np.uint64(seed) & m32
    x = np.uint64(i)
    while True:
        x ^= p
        x = (x * np.uint64(0xE170893D)) & m32
        x ^= p >> np.uint64(16)
        x ^= (x & w) >> np.uint64(4)
        x ^= p >> np.uint64(8)
        x = (x * np.uint64(0x0929EB3F)) & m32
        x ^= p >> np.uint64(23)
        x ^= (x & w) >> np.uint64(1)
        x = (x * (np.uint64(1) | (p >> np.uint64(27)))) & m32
        x = (x * np.uint64(0x6935FA69)) & m32
        x ^= (x & w) >> np.uint64(11)
        x = (x * np.uint64(0x74DCB303)) & m32
        x ^= (x & w) >> np.uint64(2)
        x = (x * np.uint64(0x9E501CC3)) & m32
        x ^= (x & w) >> np.uint64(2)
        x = (x * np.uint64(0xC860A3DF)) & m32
        x &= w
        x ^= x >> np.uint64(5)
        if x < np.uint64(n):
            break
    return np.int64((x + p) % np.uint64(n))


@register_jitable(forceinline=True)
def strata_position(spp, rows, s, u0, u1):
    """Raster offset in [0, 1)^2 of sample ``s`` of a pixel's ``spp`` (all three float64 integers) with the jitter
    ``(u0, u1)``: the equal-area jittered grid of :func:`pyrt.core.sampler.pixel_strata` (``rows = isqrt(spp)``
    rows, row ``j`` holding samples ``[floor(j spp / rows), floor((j + 1) spp / rows))`` side by side; the
    ``n x n`` grid when ``spp = n^2``), for any ``spp``. No integer division (a 64-bit ``idiv`` per sample was
    measured at a fifth of the kernel's time): floors of float64 quotients, exact for integers below 2^26 (a
    quotient that is not an integer is at least 1 / spp from one, far more than its rounding error)."""
    row = math.floor(((s + 1.0) * rows - 1.0) / spp)
    first = math.floor(row * spp / rows)
    n_row = math.floor((row + 1.0) * spp / rows) - first
    return (s - first + u0) / n_row, (first + u1 * n_row) / spp


@register_jitable(forceinline=True)
def isqrt(n):
    """``floor(sqrt(n))`` of a non-negative integer, exact (the float root corrected)."""
    k = int(math.sqrt(n))
    while k * k > n:
        k -= 1
    while (k + 1) * (k + 1) <= n:
        k += 1
    return k


# ----------------------------------------------------------------------------------------- BRDFs and Fresnel

@register_jitable(forceinline=True)
def fr_dielectric(cos_i, eta):
    """Exact unpolarised Fresnel reflectance (:func:`pyrt.shaders.fresnel.fr_dielectric`): ``cos_i`` < 0 flips
    the interface (``eta -> 1/eta``); 1 under total internal reflection."""
    cos_i = min(max(cos_i, -1.0), 1.0)
    if cos_i < 0.0:
        eta = 1.0 / eta
        cos_i = -cos_i
    sin2_t = (1.0 - cos_i * cos_i) / (eta * eta)
    if sin2_t >= 1.0:
        return 1.0
    cos_t = math.sqrt(max(0.0, 1.0 - sin2_t))
    r_par = (eta * cos_i - cos_t) / (eta * cos_i + cos_t)
    r_perp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t)
    return 0.5 * (r_par * r_par + r_perp * r_perp)


@register_jitable(forceinline=True)
def upper_cos(cos_o, cos_i):
    """``cos_i`` where both cosines are positive, else 0 (:func:`pyrt.shaders.brdfs._upper_cos`)."""
    return cos_i if (cos_o > 0.0 and cos_i > 0.0) else 0.0


@register_jitable(forceinline=True)
def blinn_phong_normalization(exponent):
    """``(e + 2)(e + 4) / (8 pi (2^(-e/2) + e))`` (:func:`pyrt.shaders.brdfs.blinn_phong_normalization`)."""
    return (exponent + 2.0) * (exponent + 4.0) / (8.0 * math.pi * (2.0 ** (-exponent / 2.0) + exponent))


@register_jitable(forceinline=True)
def blinn_phong_spec(cos_o, cos_i, cos_io, exponent):
    """The specular factor ``c(n) max(n.h, 0)^n`` of :func:`pyrt.shaders.brdfs.blinn_phong_normalized_f_cos_cosines`
    from the cosines ``n.wo``, ``n.wi``, ``wo.wi`` (the half vector never built)."""
    hl = math.sqrt(max(2.0 + 2.0 * cos_io, 0.0))
    cos_h = (cos_o + cos_i) / hl if hl > 0.0 else 0.0
    return blinn_phong_normalization(exponent) * max(cos_h, 0.0) ** exponent


# ----------------------------------------------------------------------------------------- lights

@register_jitable(forceinline=True)
def smoothstep(x, edge0, edge1):
    """Hermite smoothstep (:func:`pyrt.shaders.lights.smoothstep`): 0 below ``edge0``, 1 above ``edge1``."""
    denom = edge1 - edge0
    if denom != 0.0:
        t = (x - edge0) / denom
    else:
        t = 1.0 if x >= edge1 else 0.0
    t = min(max(t, 0.0), 1.0)
    return t * t * (3.0 - 2.0 * t)


#: spot falloff kinds by the index the compiled light records use (order of :data:`SPOT_KINDS`)
SPOT_KINDS = ("smoothstep", "gltf", "linear_angle")


@register_jitable(forceinline=True)
def spot_falloff(kind, cos_theta, cos_inner, cos_outer):
    """The spot cone falloff ``g`` of :data:`pyrt.shaders.lights.SPOT_FALLOFFS`, ``kind`` an index of
    :data:`SPOT_KINDS`: 0 pbrt-v4's smoothstep in cos, 1 glTF's squared linear in cos, 2 Mitsuba's linear in angle."""
    if kind == 0:
        return smoothstep(cos_theta, cos_outer, cos_inner)
    if kind == 1:
        denom = cos_inner - cos_outer
        if denom != 0.0:
            t = (cos_theta - cos_outer) / denom
        else:
            t = 1.0 if cos_theta >= cos_outer else 0.0
        t = min(max(t, 0.0), 1.0)
        return t * t
    theta = math.acos(min(max(cos_theta, -1.0), 1.0))
    inner = math.acos(min(max(cos_inner, -1.0), 1.0))
    outer = math.acos(min(max(cos_outer, -1.0), 1.0))
    denom = outer - inner
    if denom != 0.0:
        t = (outer - theta) / denom
    else:
        t = 1.0 if theta <= outer else 0.0
    return min(max(t, 0.0), 1.0)


#: distance falloff kinds by index (order of :data:`pyrt.shaders.lights.DISTANCE_FALLOFFS`)
DISTANCE_KINDS = ("inverse_square", "inverse_square_eps", "smooth_range", "gltf_range", "clq")


@register_jitable(forceinline=True)
def wrap_int(i, n):
    """Python's ``i % n`` (in ``[0, n)``, ``n`` > 0) with the integer division only where ``i`` lies outside
    ``[-n, 2n)``: a texel index one step past either edge, the common case of wrapped lookups, costs a comparison
    instead of a 64-bit division (tens of cycles)."""
    if 0 <= i < n:
        return i
    if n <= i < 2 * n:
        return i - n
    if -n <= i < 0:
        return i + n
    return i % n


@register_jitable(forceinline=True)
def distance_falloff(kind, r, eps, light_range, kc, kl, kq):
    """``f(r)`` (m^-2) of :func:`pyrt.shaders.lights.distance_falloff`, ``kind`` an index of :data:`DISTANCE_KINDS`;
    0 at ``r >= light_range`` (``inf``: no range) and where the inverse-square kinds diverge."""
    if kind == 1:
        re = r + eps
        f = 1.0 / (re * re) if re > 0.0 else 0.0
    elif kind == 4:
        den = kc + r * (kl + kq * r)
        f = 1.0 / den if den > 0.0 else 0.0
    else:
        r2 = r * r
        f = 1.0 / r2 if r2 > 0.0 else 0.0
        if kind == 2 or kind == 3:
            q = r / light_range
            q2 = q * q
            w = min(max(1.0 - q2 * q2, 0.0), 1.0)
            f = f * (w * w if kind == 2 else w)
    if not r < light_range:
        f = 0.0
    return f


# ----------------------------------------------------------------------------------------- ray offsets

#: the smallest positive float32 (a subnormal), 2^-149
TINY32 = 2.0 ** -149
#: the smallest positive normal float32, 2^-126
NORMAL32 = 2.0 ** -126


@register_jitable(forceinline=True)
def float32_step(x, direction):
    """The float32 value of ``x`` (a float64) rounded to nearest, then one float32 ulp further toward the sign
    of ``direction`` (none for 0): one component of :func:`pyrt.geometry.offsets._round_away`
    (``np.nextafter``), returned as a float64 holding a float32 value.

    No library call: for a normal ``x32 = m 2^e`` (1 <= m < 2) a move by ``0.6 m`` ulps of its binade, rounded to
    float32, lands on the neighbour on that side (0.6-1.2 ulps round to 1; below a power of two, where the spacing
    halves, 0.6 ulps round to one half-ulp step); subnormals and 0 step by 2^-149 exactly. Bit-identical to
    ``np.nextafter`` (tests/test_jit_shaders.py)."""
    x32 = np.float32(x)
    if direction == 0.0:
        return np.float64(x32)
    sgn = 1.0 if direction > 0.0 else -1.0
    a = abs(np.float64(x32))
    if a < NORMAL32:
        return np.float64(np.float32(np.float64(x32) + sgn * TINY32))
    if not a <= 3.4028234663852886e38:     # inf, nan: as nextafter (inf stays inf one way, nan stays nan)
        return np.float64(np.nextafter(x32, np.float32(sgn * np.inf)))
    return np.float64(np.float32(np.float64(x32) + sgn * a * (0.6 * 2.0 ** -23)))


#: the largest finite float32
MAX32 = 3.4028234663852886e38


@register_jitable(forceinline=True)
def float32_step_vec(x, direction):
    """:func:`float32_step` written with selects only (no branch): the same bits, for the loops over a packet's
    lanes that the compiler vectorises (a branch per lane stops the vectoriser; in scalar code the branches of
    :func:`float32_step` were measured faster). Every case is computed and the right one chosen: the normal
    step, the subnormal step 2^-149, and at an infinity ``np.nextafter``'s answer (outward it stays, inward it
    becomes the largest float32 of its sign; NaN stays NaN)."""
    x32 = np.float64(np.float32(x))
    sgn = 1.0 if direction > 0.0 else -1.0
    a = abs(x32)
    step = TINY32 if a < NORMAL32 else a * (0.6 * 2.0 ** -23)
    r = np.float64(np.float32(x32 + sgn * step))
    r = r if a <= MAX32 else (math.copysign(MAX32, x32) if sgn * x32 < 0.0 else x32)
    return x32 if direction == 0.0 else r


@register_jitable(forceinline=True)
def gamma(n, eps):
    """pbrt's ``gamma_n = n eps / (1 - n eps)`` for the unit roundoff ``eps``."""
    return n * eps / (1.0 - n * eps)


# ----------------------------------------------------------------------------------------- hits and ray offsets
# The compiled kernel's surface at a hit (:func:`pyrt.geometry.surface.surface_from_hits` with the local error bound
# of :mod:`pyrt.geometry.offsets`) and its offset rounding, from geometry tables given as flat pointers
# (:func:`pyrt.core.unmanaged.pointer`). tests/test_compiled_render.py holds them, through the kernel's images, to
# the NumPy path at pixel centres (the shading normal within an ulp: one division for three).


@register_jitable(forceinline=True)
def dot(a, b):
    """``a . b`` of two 3-tuples (summed left to right, as the NumPy path's ``vec.dot``)."""
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@register_jitable(forceinline=True)
def row3(a, i):
    """Row ``i`` of an (n, 3) table given by its pointer: a 3-tuple."""
    return a[3 * i], a[3 * i + 1], a[3 * i + 2]


@register_jitable(forceinline=True)
def bary3(b0, b1, b2, x0, x1, x2):
    """``b0 x0 + b1 x1 + b2 x2`` of three 3-tuples."""
    return (b0 * x0[0] + b1 * x1[0] + b2 * x2[0], b0 * x0[1] + b1 * x1[1] + b2 * x2[1],
            b0 * x0[2] + b1 * x1[2] + b2 * x2[2])


@register_jitable(forceinline=True)
def hit_surface(G, fallback, terminator, geom, prim, u, v, wo):
    """The surface at the hit ``(geom, prim, u, v)`` of a ray leaving toward ``wo`` (-direction)
    (:func:`pyrt.geometry.surface.surface_from_hits`): ``(p, ng, ns, nv, lift, mag, mag_lift, front, face, uv)`` with
    the float64 hit point from the vertices, the face normal turned to the viewer, the shading normal (the
    interpolated vertex normal ``nv``, or ng where it is degenerate or, with ``fallback``, back-facing), the
    terminator-lifted point (p without ``terminator``) and the local-bound offset magnitudes
    (:func:`pyrt.geometry.offsets.local_bound_magnitude`) at p and at the lifted point. ``G``: the geometry tables'
    pointers (:func:`pyrt.integrators.compiled_kernel.geometry_pointers`)."""
    verts, normals, uvs, fnorm, fabs, fext, faces, foff, _, fsmooth, _, _ = G
    face = foff[geom] + prim
    i0, i1, i2 = faces[3 * face], faces[3 * face + 1], faces[3 * face + 2]
    b1, b2 = np.float64(u), np.float64(v)
    b0 = 1.0 - b1 - b2
    v0, v1, v2 = row3(verts, i0), row3(verts, i1), row3(verts, i2)
    p = bary3(b0, b1, b2, v0, v1, v2)
    fn = row3(fnorm, face)
    front = dot(fn, wo) >= 0.0
    sign = 1.0 if front else -1.0
    ng = (sign * fn[0], sign * fn[1], sign * fn[2])
    ns, nv, lift = ng, ng, p
    if fsmooth[face] != 0:
        n0_, n1_, n2_ = row3(normals, i0), row3(normals, i1), row3(normals, i2)
        n0, n1, n2 = bary3(b0, b1, b2, n0_, n1_, n2_)
        ln = math.sqrt(n0 * n0 + n1 * n1 + n2 * n2)
        if ln > 0.0:          # one division (a division is ~4x a multiplication's cost): within an ulp of n / ln
            k = sign / ln
            n0, n1, n2 = n0 * k, n1 * k, n2 * k
        nv = (n0, n1, n2)
        bad = n0 * n0 + n1 * n1 + n2 * n2 == 0.0
        if fallback and not bad:
            bad = dot(nv, wo) <= 0.0
        if not bad:
            ns = nv
        if terminator:
            # Hanika's terminator lift: p' = p - sum_i b_i min(0, (p - v_i) . n_i) n_i, n_i turned to the ng side
            l0, l1, l2 = p
            for k in range(3):
                vk, nk = (v0, n0_) if k == 0 else ((v1, n1_) if k == 1 else (v2, n2_))
                bk = b0 if k == 0 else (b1 if k == 1 else b2)
                h = sign * ((p[0] - vk[0]) * nk[0] + (p[1] - vk[1]) * nk[1] + (p[2] - vk[2]) * nk[2])
                w = bk * min(h, 0.0) * sign
                l0 -= nk[0] * w
                l1 -= nk[1] * w
                l2 -= nk[2] * w
            lift = (l0, l1, l2)
    # local_bound_magnitude: |ng| . gamma_4(f64) absmax + 8 eps32 extent (absmax widened by the lift)
    g4 = gamma(4.0, EPS64)
    m = 0.0
    ml = 0.0
    for c in range(3):
        a = fabs[3 * face + c]
        m += abs(ng[c]) * g4 * a
        ml += abs(ng[c]) * g4 * (a + abs(lift[c] - p[c]))
    mag = m + 8.0 * EPS32 * fext[face]
    mag_lift = ml + 8.0 * EPS32 * fext[face]
    uv = (b0 * uvs[2 * i0] + b1 * uvs[2 * i1] + b2 * uvs[2 * i2],
          b0 * uvs[2 * i0 + 1] + b1 * uvs[2 * i1 + 1] + b2 * uvs[2 * i2 + 1])
    return p, ng, ns, nv, lift, mag, mag_lift, front, face, uv


#: :data:`pyrt.geometry.offsets.SHADOW_TMAX_SCALE`'s margin and :data:`pyrt.geometry.offsets.LIGHT_END_REL_ERROR`
SHADOW_MARGIN, LIGHT_END_REL_ERROR = 1e-4, 16.0


@register_jitable(forceinline=True)
def robust_tmax(o, wi, lx, ly, lz, finite):
    """The ``robust`` shadow-ray length (:func:`pyrt.geometry.offsets.robust_tmax`) from the origin ``o`` along ``wi``
    to the light's point ``(lx, ly, lz)``: ``t_end - max(1e-4 t_end, 16 2^-24 max(|o|, |end|))``, at least half of
    ``t_end``; ``inf`` where ``finite`` is False (directional light). Written with selects: the vectorised light stage
    calls it too."""
    t_end = (lx - o[0]) * wi[0] + (ly - o[1]) * wi[1] + (lz - o[2]) * wi[2]
    mag = max(abs(o[0]), abs(o[1]), abs(o[2]), abs(lx), abs(ly), abs(lz))
    margin = max(SHADOW_MARGIN * t_end, LIGHT_END_REL_ERROR * EPS32 * mag)
    return max(t_end - margin, 0.5 * t_end) if finite else math.inf


@register_jitable(forceinline=True)
def round_away(base, mag, side, ng):
    """``round_away(base + side mag ng)`` (:func:`pyrt.geometry.offsets.local_bound`): a 3-tuple of float64 values of
    float32 numbers, each one float32 ulp further along the offset."""
    k = side * mag
    return (float32_step(base[0] + k * ng[0], k * ng[0]), float32_step(base[1] + k * ng[1], k * ng[1]),
            float32_step(base[2] + k * ng[2], k * ng[2]))


@register_jitable(forceinline=True)
def shadow_origin(p, ng, lift, mag, mag_lift, cg, terminator):
    """The origin of a shadow ray leaving the hit ``p`` toward a direction with ``cg = wi . ng``
    (:meth:`pyrt.geometry.offsets.Strategy.shadow`, ``robust``): with the terminator lift the lifted point offset to
    the ng side, else ``p`` offset to the side of ``wi`` (:func:`round_away`). The branch-free form for the vectorised
    light stage is written with :func:`round_away_vec` in its loop."""
    if terminator:
        return round_away(lift, mag_lift, 1.0, ng)
    return round_away(p, mag, 1.0 if cg >= 0.0 else -1.0, ng)


@register_jitable(forceinline=True)
def round_away_vec(base, mag, side, ng):
    """:func:`round_away` with :func:`float32_step_vec` (selects, no branch): the same bits, for
    the lane loops the compiler vectorises."""
    k = side * mag
    return (float32_step_vec(base[0] + k * ng[0], k * ng[0]), float32_step_vec(base[1] + k * ng[1], k * ng[1]),
            float32_step_vec(base[2] + k * ng[2], k * ng[2]))
