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

@register_jitable(inline="always")
def mix64(x):
    """SplitMix64's finaliser (Steele et al. 2014): a bijective 64-bit mixer, ``x`` a uint64."""
    x = (x ^ (x >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
    x = (x ^ (x >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    return x ^ (x >> np.uint64(31))


@register_jitable(inline="always")
def key64(seed, pixel, sample):
    """The 64-bit key of one camera sample: ``seed``, ``pixel`` (row-major index) and ``sample`` mixed."""
    h = mix64(np.uint64(seed) + np.uint64(0x9E3779B97F4A7C15))
    h = mix64(h ^ np.uint64(pixel))
    return mix64(h ^ (np.uint64(sample) * np.uint64(0xD1B54A32D192ED03)))


@register_jitable(inline="always")
def pixel_key(seed, pixel):
    """The 64-bit key of a pixel's samples (:func:`sample_key`): ``seed`` and ``pixel`` mixed."""
    return mix64(mix64(np.uint64(seed) + np.uint64(0x9E3779B97F4A7C15)) ^ np.uint64(pixel))


@register_jitable(inline="always")
def sample_key(pix_key, sample):
    """The 64-bit key of sample ``sample`` of the pixel whose key is ``pix_key``: one mix per sample."""
    return mix64(pix_key ^ (np.uint64(sample) * np.uint64(0xD1B54A32D192ED03)))


@register_jitable(inline="always")
def uniform_pair(key):
    """Two floats in [0, 1) with 24 bits each (a sample's position in its pixel): one mix of ``key``."""
    h = mix64(key + np.uint64(0x9E3779B97F4A7C15))
    return (float(h >> np.uint64(40)) * (1.0 / 16777216.0),
            float((h >> np.uint64(16)) & np.uint64(0xFFFFFF)) * (1.0 / 16777216.0))


@register_jitable(inline="always")
def uniform(key, dim):
    """A float64 in [0, 1) for dimension ``dim`` of the sample whose key is ``key`` (:func:`key64`): 53 bits of
    ``mix64(key + (dim + 1) * golden)``."""
    h = mix64(key + np.uint64(dim + 1) * np.uint64(0x9E3779B97F4A7C15))
    return float(h >> np.uint64(11)) * (1.0 / 9007199254740992.0)


@register_jitable(inline="always")
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


# ----------------------------------------------------------------------------------------- BRDFs and Fresnel

@register_jitable(inline="always")
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


@register_jitable(inline="always")
def upper_cos(cos_o, cos_i):
    """``cos_i`` where both cosines are positive, else 0 (:func:`pyrt.shaders.brdfs._upper_cos`)."""
    return cos_i if (cos_o > 0.0 and cos_i > 0.0) else 0.0


@register_jitable(inline="always")
def blinn_phong_normalization(exponent):
    """``(e + 2)(e + 4) / (8 pi (2^(-e/2) + e))`` (:func:`pyrt.shaders.brdfs.blinn_phong_normalization`)."""
    return (exponent + 2.0) * (exponent + 4.0) / (8.0 * math.pi * (2.0 ** (-exponent / 2.0) + exponent))


@register_jitable(inline="always")
def blinn_phong_spec(cos_o, cos_i, cos_io, exponent):
    """The specular factor ``c(n) max(n.h, 0)^n`` of :func:`pyrt.shaders.brdfs.blinn_phong_normalized_f_cos_cosines`
    from the cosines ``n.wo``, ``n.wi``, ``wo.wi`` (the half vector never built)."""
    hl = math.sqrt(max(2.0 + 2.0 * cos_io, 0.0))
    cos_h = (cos_o + cos_i) / hl if hl > 0.0 else 0.0
    return blinn_phong_normalization(exponent) * max(cos_h, 0.0) ** exponent


# ----------------------------------------------------------------------------------------- lights

@register_jitable(inline="always")
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


@register_jitable(inline="always")
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


@register_jitable(inline="always")
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


@register_jitable(inline="always")
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


@register_jitable(inline="always")
def gamma(n, eps):
    """pbrt's ``gamma_n = n eps / (1 - n eps)`` for the unit roundoff ``eps``."""
    return n * eps / (1.0 - n * eps)
