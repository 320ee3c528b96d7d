"""Scalar twins of the noise-free environment preview's kernels (``strategy="preview"``), for the compiled kernel.

Each function is ``numba.extending.register_jitable`` and the scalar form, for ONE direction, of the NumPy function
named in its docstring (:mod:`shaders.envmap`'s SH irradiance and roughness-indexed lookup, :mod:`shaders.dfg`'s
tables and dominant direction), the same operations in the same order; ``tests/test_compiled_preview_env.py`` holds
each to its twin to 1e-6 relative in float64 on random inputs, grazing ones included. Tables are read from one flat
float64 array ``data`` at an offset (how :mod:`pyrt.lights.compiled_env_preview` packs them); nothing here knows
the layout beyond the arguments.
"""
from __future__ import annotations

import math

from numba.extending import register_jitable

from .jit import wrap_int
from .jit_math import acos, atan2
from .jit_brdfs import GLTF_DIELECTRIC_F0

#: :mod:`shaders.envmap`'s SH constants (R&H 2001 eq. 3, closed form)
SH_C0 = 0.5 / math.sqrt(math.pi)
SH_C1 = math.sqrt(3.0 / (4.0 * math.pi))
SH_C2 = math.sqrt(15.0 / (4.0 * math.pi))
SH_C20 = math.sqrt(5.0 / (16.0 * math.pi))
SH_C22 = math.sqrt(15.0 / (16.0 * math.pi))
#: the preview's lobes of :meth:`pyrt.materials.MetallicRoughness.preview_lobes` and of ``GltfPBR``'s
F0_DIELECTRIC = GLTF_DIELECTRIC_F0


@register_jitable
def sh9_irradiance(data, o, x, y, z):
    """``E(n)`` (RGB) at the unit normal ``n`` (environment frame): :func:`shaders.envmap.sh9_irradiance` with its
    ``SH9_COSINE_LOBE[:, None] * coeffs`` (9, 3) already at ``data[o:o + 27]``, row-major (the basis of
    :func:`shaders.envmap.sh9_basis`, summed over the nine terms in order)."""
    b0 = SH_C0
    b1 = y * SH_C1
    b2 = z * SH_C1
    b3 = x * SH_C1
    b4 = x * y * SH_C2
    b5 = y * z * SH_C2
    b6 = z * z * (3.0 * SH_C20) - SH_C20
    b7 = x * z * SH_C2
    b8 = (x * x - y * y) * SH_C22
    e0 = e1 = e2 = 0.0
    k = 0
    for b in (b0, b1, b2, b3, b4, b5, b6, b7, b8):
        e0 += b * data[o + k]
        e1 += b * data[o + k + 1]
        e2 += b * data[o + k + 2]
        k += 3
    return e0, e1, e2


@register_jitable(forceinline=True)
def latlong_dir_to_uv(dx, dy, dz):
    """Lat-long ``(u, v)`` of a unit direction: :func:`shaders.envmap.latlong_dir_to_uv` (by :mod:`.jit_math`'s
    :func:`~.jit_math.atan2` and :func:`~.jit_math.acos`: no libm call, so a packet stage using it vectorises)."""
    u = atan2(dx, -dz) * (0.5 / math.pi)
    u = u - math.floor(u)
    u = 0.0 if u >= 1.0 else u
    return u, acos(dy) / math.pi


@register_jitable(forceinline=True)
def bilinear_latlong(data, o, h, w, u, v):
    """RGB of the float64 lat-long map ``(h, w, 3)`` at ``data[o:]``, bilinear at lat-long ``(u, v)`` (wrapping in
    u, clamping in v): :func:`shaders.textures.lookup_bilinear` at the texture coordinates ``(u, 1 - v)``."""
    tv = 1.0 - v
    x = u * w - 0.5
    y = (1.0 - tv) * h - 0.5
    x0, y0 = math.floor(x), math.floor(y)
    fx, fy = x - x0, y - y0
    ix0, iy0 = int(x0), int(y0)
    cx0, cx1 = wrap_int(ix0, w), wrap_int(ix0 + 1, w)
    ry0, ry1 = min(max(iy0, 0), h - 1) * w, min(max(iy0 + 1, 0), h - 1) * w
    w0, w1, w2, w3 = (1.0 - fx) * (1.0 - fy), fx * (1.0 - fy), (1.0 - fx) * fy, fx * fy
    t0, t1, t2, t3 = o + 3 * (ry0 + cx0), o + 3 * (ry0 + cx1), o + 3 * (ry1 + cx0), o + 3 * (ry1 + cx1)
    r = w0 * data[t0] + w1 * data[t1] + w2 * data[t2] + w3 * data[t3]
    g = w0 * data[t0 + 1] + w1 * data[t1 + 1] + w2 * data[t2 + 1] + w3 * data[t3 + 1]
    b = w0 * data[t0 + 2] + w1 * data[t1 + 2] + w2 * data[t2 + 2] + w3 * data[t3 + 2]
    return r, g, b


@register_jitable
def roughness_map_lookup(data, hdr, n_levels, dx, dy, dz, alpha):
    """:func:`shaders.envmap.roughness_map_lookup` at one unit direction ``d`` (the maps' frame) and width
    ``alpha``: the stack's header at ``data[hdr:]`` holds per level ``(alpha_k, h_k, w_k, offset_k)``, increasing
    ``alpha_k``; linear in ``alpha`` between the two levels around it (clamped to the stack), both read at the same
    ``(u, v)``."""
    a_lo, a_hi = data[hdr], data[hdr + 4 * (n_levels - 1)]
    a = min(max(alpha, a_lo), a_hi)
    k = 0
    while k < n_levels - 2 and data[hdr + 4 * (k + 1)] <= a:     # searchsorted(alphas, a, "right") - 1, clipped
        k += 1
    p, q = hdr + 4 * k, hdr + 4 * (k + 1)
    f = (a - data[p]) / (data[q] - data[p])
    u, v = latlong_dir_to_uv(dx, dy, dz)
    lo = bilinear_latlong(data, int(data[p + 3]), int(data[p + 1]), int(data[p + 2]), u, v)
    hi = bilinear_latlong(data, int(data[q + 3]), int(data[q + 1]), int(data[q + 2]), u, v)
    return ((1.0 - f) * lo[0] + f * hi[0], (1.0 - f) * lo[1] + f * hi[1], (1.0 - f) * lo[2] + f * hi[2])


@register_jitable
def dfg_lookup(data, o, n_mu, n_r, mu, alpha):
    """:func:`shaders.dfg.lookup` of the ``(n_mu, n_r)`` table at ``data[o:]`` (row-major) at ``mu`` and ``alpha``."""
    x = min(max(mu * n_mu - 0.5, 0.0), n_mu - 1.0)
    y = min(max(math.sqrt(max(alpha, 0.0)) * (n_r - 1), 0.0), n_r - 1.0)
    i0 = min(int(x), n_mu - 2)
    j0 = min(int(y), n_r - 2)
    fx, fy = x - i0, y - j0
    t = o + i0 * n_r + j0
    return ((1 - fx) * (1 - fy) * data[t] + fx * (1 - fy) * data[t + n_r]
            + (1 - fx) * fy * data[t + 1] + fx * fy * data[t + n_r + 1])


@register_jitable
def dfg_lookup_1d(data, o, n, mu):
    """:func:`shaders.dfg.lookup_1d` of the ``(n,)`` table at ``data[o:]`` at ``mu``."""
    x = min(max(mu * n - 0.5, 0.0), n - 1.0)
    i0 = min(int(x), n - 2)
    f = x - i0
    return (1 - f) * data[o + i0] + f * data[o + i0 + 1]


@register_jitable
def dominant_direction(wo, n, alpha):
    """:func:`shaders.dfg.dominant_direction` of one view ``wo`` about the normal ``n`` (3-tuples)."""
    c = wo[0] * n[0] + wo[1] * n[1] + wo[2] * n[2]
    r0, r1, r2 = -wo[0] + 2.0 * c * n[0], -wo[1] + 2.0 * c * n[1], -wo[2] + 2.0 * c * n[2]
    s = 1.0 - min(max(alpha, 0.0), 1.0)
    f = s * (math.sqrt(s) + alpha)
    d0, d1, d2 = n[0] + f * (r0 - n[0]), n[1] + f * (r1 - n[1]), n[2] + f * (r2 - n[2])
    inv = max(math.sqrt(d0 * d0 + d1 * d1 + d2 * d2), 1e-300)
    return d0 / inv, d1 / inv, d2 / inv


@register_jitable(forceinline=True)
def ggx_lobe_alpha_for_solid_angle(omega):
    """:func:`shaders.envmap.ggx_lobe_alpha_for_solid_angle` of one solid angle."""
    return math.sqrt(max(omega, 0.0) / (4.0 * math.pi))


@register_jitable(forceinline=True)
def view_cosine(wo, n):
    """:func:`pyrt.materials.preview.view_cosine`: ``n . wo`` clamped to [1e-4, 1] (the tables' domain)."""
    return min(max(wo[0] * n[0] + wo[1] * n[1] + wo[2] * n[2], 1e-4), 1.0)


@register_jitable
def metallic_roughness_lobes(br, bg, bb, m, e5, a, b):
    """:meth:`pyrt.materials.MetallicRoughness.preview_lobes` given the tables' values at the hit (``e5 = E5(mu)``,
    ``a, b = A, B (mu, alpha)``): ``(diffuse (RGB), glossy weight (RGB))``, diffuse ``base (1 - m)(1 - F0)(1 - E5)``
    and the lobe's ``F0 A + B``, ``F0 = 0.04 (1 - m) + base m``."""
    f0r = F0_DIELECTRIC * (1.0 - m) + br * m
    f0g = F0_DIELECTRIC * (1.0 - m) + bg * m
    f0b = F0_DIELECTRIC * (1.0 - m) + bb * m
    k = 1.0 - e5
    return ((br * (1.0 - m) * (1.0 - f0r) * k, bg * (1.0 - m) * (1.0 - f0g) * k, bb * (1.0 - m) * (1.0 - f0b) * k),
            (f0r * a + b, f0g * a + b, f0b * a + b))


@register_jitable
def gltf_pbr_lobes(br, bg, bb, m, s, f0r, f0g, f0b, t, share, e5, a, b):
    """:meth:`pyrt.materials.GltfPBR.preview_lobes` of an isotropic hit (specular ``s``, dielectric F0 ``f0``,
    transmission ``t``, specular share ``share``: ``1 - t`` on a smooth transmitting hit, else 1): diffuse
    ``(1 - m)(1 - t)(1 - s (F0m + (1 - F0m) E5)) base`` (``F0m`` the largest channel of ``f0``), the lobe's
    ``(1 - m) s share (f0 A + B) + m (base A + B)``."""
    f0m = max(f0r, f0g, f0b)
    k = (1.0 - m) * (1.0 - s * (f0m + (1.0 - f0m) * e5)) * (1.0 - t)
    ks = (1.0 - m) * s * share
    return ((k * br, k * bg, k * bb),
            (ks * (f0r * a + b) + m * (br * a + b), ks * (f0g * a + b) + m * (bg * a + b),
             ks * (f0b * a + b) + m * (bb * a + b)))
