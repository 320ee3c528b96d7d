"""Ray-origin offsets for secondary and shadow rays: one place, selectable per render.

A strategy is a function ``strategy(surf, w) -> origins`` taking a :class:`pyrt.geometry.SurfaceBatch`
and the new rays' unit directions ``w`` (N, 3) and returning float64 ray origins (N, 3) that, once
cast to float32 for Embree (whose rays start at t = 0), lie on the side of the surface the ray leaves
toward and do not re-hit the surface they start on.

``surf.p_error`` holds ``sum_i |b_i| |v_i|`` (component-wise), the magnitude that bounds the
float32 error of the hit point (the hit is rebuilt in float64 from the float32 vertices Embree sees).
"""
from __future__ import annotations

import numpy as np

from shaders.vec import dot

_EPS32 = np.finfo(np.float32).eps / 2  # unit roundoff of float32, 2^-24


def _gamma(n):
    return n * _EPS32 / (1 - n * _EPS32)


def _round_away(origins, direction):
    """Cast to float32 and step one float32 ulp further along ``direction``'s sign per component."""
    o32 = origins.astype(np.float32)
    up = np.nextafter(o32, np.float32(np.inf))
    down = np.nextafter(o32, np.float32(-np.inf))
    o32 = np.where(direction > 0, up, np.where(direction < 0, down, o32))
    return o32.astype(np.float64)


#: Relative error of Embree's float32 ray-triangle test, in units of 2^-24 of the largest vertex
#: coordinate magnitude. pbrt's hit-point bound alone is zero for a plane through the origin
#: (y = 0 exactly), yet Embree's test (computed relative to the ray origin with the full x/z
#: magnitudes) still reports self-hits there: the whole floor of the default scene was in shadow.
#: 4 removed every self-hit in that scene; 16 keeps a 4x margin. Tuned by the acne suite.
EMBREE_REL_ERROR = 16.0


def error_bound(surf, w):
    """pbrt-v4 style: push the origin along the geometric normal just past the hit point's error bound.

    ``d = |n_g| . (gamma_7 * sum_i |b_i v_i|) + EMBREE_REL_ERROR * 2^-24 * max_j (sum_i |b_i v_i|)_j``;
    origin = p +- d n_g (to the side ``w`` leaves toward), then rounded one float32 ulp further
    outward (pbrt-v4 ``OffsetRayOrigin``). The second term covers the error of Embree's own float32
    intersection test, which pbrt's bound (made for pbrt's intersector) does not.
    """
    err = _gamma(7) * surf.p_error
    d = dot(np.abs(surf.ng), err) + EMBREE_REL_ERROR * _EPS32 * np.max(surf.p_error, axis=1)
    side = np.where(dot(w, surf.ng) >= 0, 1.0, -1.0)
    off = (d * side)[:, None] * surf.ng
    return _round_away(surf.p + off, off)


STRATEGIES = {"error_bound": error_bound}
DEFAULT = "error_bound"


def get_strategy(offset):
    """Resolve ``offset`` (a name in :data:`STRATEGIES` or a callable) to a strategy function."""
    if callable(offset):
        return offset
    if offset is None:
        offset = DEFAULT
    try:
        return STRATEGIES[offset]
    except KeyError:
        raise ValueError(f"unknown offset strategy {offset!r}; choose one of {sorted(STRATEGIES)} "
                         "or pass a callable(surf, w) -> origins") from None


#: Shadow rays stop this fraction short of the light (pbrt-v4 uses 1 - ShadowEpsilon, 1e-4).
SHADOW_TMAX_SCALE = 1.0 - 1e-4
