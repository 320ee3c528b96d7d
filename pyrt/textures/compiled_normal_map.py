"""The compiled form of tangent-space normal maps: the scalar twin of :func:`pyrt.textures.normal_map.perturb_normal`
for one hit (held to it by tests/test_compiled_diffs.py).

The map's texels are looked up by the caller (a row of the texture table, :func:`pyrt.textures.compiled.texture_rgb`);
:func:`perturb` decodes them (:func:`pyrt.shaders.textures.decode_normal_map`), mirrors them on back faces, builds
the tangent frame (:func:`pyrt.shaders.textures.tangent_frame`) from the tangents the caller gives (the mesh's
interpolated vertex tangent and bitangent where it has them, :func:`pyrt.integrators.compiled_diffs.vertex_tangents`;
else the triangle's UV tangents, :func:`uv_tangents`, :func:`pyrt.geometry.uvsets.uv_tangents`), applies them
(:func:`pyrt.shaders.textures.apply_tangent_normal`), keeps the unperturbed normal where the result faces away from
the viewer, and with ``bend`` tilts it so that the mirror reflection of ``wo`` stays above the surface
(:func:`pyrt.shaders.vec.valid_reflection_normal`). Vectors are 3-tuples of float64.
"""
from __future__ import annotations

import math

from numba.extending import register_jitable


@register_jitable(forceinline=True)
def _dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@register_jitable(forceinline=True)
def _normalize(a):
    """``a / |a|``; the zero vector stays zero (:func:`pyrt.shaders.vec.normalize`)."""
    n = math.sqrt(_dot(a, a))
    inv = 1.0 / n if n > 0.0 else 0.0
    return a[0] * inv, a[1] * inv, a[2] * inv


@register_jitable
def coordinate_frame(n):
    """:func:`pyrt.shaders.vec.coordinate_frame` of one unit normal: ``(s, t)`` (Duff et al. 2017)."""
    sign = 1.0 if n[2] >= 0.0 else -1.0
    a = -1.0 / (sign + n[2])
    b = n[0] * n[1] * a
    return ((1.0 + sign * n[0] * n[0] * a, sign * b, -sign * n[0]), (b, sign + n[1] * n[1] * a, -n[1]))


@register_jitable
def uv_tangents(e1, e2, du1, du2, ng):
    """``(dpdu, dpdv)`` of a triangle with edges ``e1, e2`` and UV edges ``du1, du2`` (2-tuples); a frame around
    ``ng`` where the UV map is degenerate (:func:`pyrt.geometry.uvsets.uv_tangents`)."""
    det = du1[0] * du2[1] - du1[1] * du2[0]
    if not abs(det) > 1e-20:
        return coordinate_frame(ng)
    inv = 1.0 / det
    dpdu = ((du2[1] * e1[0] - du1[1] * e2[0]) * inv, (du2[1] * e1[1] - du1[1] * e2[1]) * inv,
            (du2[1] * e1[2] - du1[1] * e2[2]) * inv)
    dpdv = ((du1[0] * e2[0] - du2[0] * e1[0]) * inv, (du1[0] * e2[1] - du2[0] * e1[1]) * inv,
            (du1[0] * e2[2] - du2[0] * e1[2]) * inv)
    return dpdu, dpdv


@register_jitable
def tangent_frame(ns, dpdu, dpdv):
    """:func:`pyrt.shaders.textures.tangent_frame` of one hit: ``(t, b)``."""
    k = _dot(ns, dpdu)
    t = _normalize((dpdu[0] - ns[0] * k, dpdu[1] - ns[1] * k, dpdu[2] - ns[2] * k))
    if _dot(t, t) < 0.5:
        t = coordinate_frame(ns)[0]
    b = (ns[1] * t[2] - ns[2] * t[1], ns[2] * t[0] - ns[0] * t[2], ns[0] * t[1] - ns[1] * t[0])
    if _dot(b, dpdv) < 0.0:
        b = (-b[0], -b[1], -b[2])
    return t, b


@register_jitable
def valid_reflection_normal(ng, wo, n):
    """:func:`pyrt.shaders.vec.valid_reflection_normal` of one hit."""
    cos_o = _dot(n, wo)
    r = (2.0 * cos_o * n[0] - wo[0], 2.0 * cos_o * n[1] - wo[1], 2.0 * cos_o * n[2] - wo[2])
    ng_r = _dot(ng, r)
    t = min(0.9 * _dot(ng, wo), 0.01)
    if cos_o <= 0.0:
        r = (-wo[0], -wo[1], -wo[2])
        ng_r = -_dot(ng, wo)
        t = 0.01
    elif not ng_r < t:
        return n
    k = t - ng_r
    rl = _normalize((r[0] + ng[0] * k, r[1] + ng[1] * k, r[2] + ng[2] * k))
    h = (wo[0] + rl[0], wo[1] + rl[1], wo[2] + rl[2])
    hl = math.sqrt(_dot(h, h))
    if not hl > 0.0:
        return ng
    inv = 1.0 / hl
    return h[0] * inv, h[1] * inv, h[2] * inv


@register_jitable
def perturb(rgb, strength, flip_green, bend, ns, ng, wo, front, dpdu, dpdv):
    """The shading normal ``ns`` perturbed by the normal-map texels ``rgb`` (module notes): ``strength`` scales the
    tangential components, ``flip_green`` reads DirectX-style maps, ``bend`` is the map's ``reflection == "bend"``;
    ``front`` False mirrors the perturbation (a back face); ``dpdu``, ``dpdv`` give the tangent frame."""
    x = (2.0 * rgb[0] - 1.0) * strength
    y = (2.0 * rgb[1] - 1.0) * (-strength if flip_green else strength)
    z = 2.0 * rgb[2] - 1.0
    if not front:
        x, y = -x, -y
    if (x == 0.0 and y == 0.0) or z <= 0.0:
        n = ns
    else:
        t, b = tangent_frame(ns, dpdu, dpdv)
        n = _normalize((x * t[0] + y * b[0] + z * ns[0], x * t[1] + y * b[1] + z * ns[1],
                        x * t[2] + y * b[2] + z * ns[2]))
    if _dot(n, wo) <= 0.0:
        n = ns
    if bend:
        n = valid_reflection_normal(ng, wo, n)
    return n
