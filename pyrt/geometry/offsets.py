"""Ray-origin offsets for secondary and shadow rays: one place, selectable per render.

Embree's rays start at t = 0 and read float32 origins, so a ray spawned at a surface point must start
a little off the surface: too little and it re-hits the surface it leaves (shadow acne, black specks in
mirrors and glass), too much and it starts beyond a nearby occluder (light leaking through thin walls,
shadows detached from their casters, "peter-panning"). :mod:`pyrt.apps.acne` measures every strategy below
on stress scenes with analytic ground truth; ``python -m pyrt.apps.acne`` prints the table.

Interface
---------
A *strategy* is a :class:`Strategy`: ``strategy(surf, w) -> origins`` gives float64 origins (N, 3) of
secondary rays with unit directions ``w`` (N, 3) leaving the hits of ``surf``
(:class:`pyrt.geometry.SurfaceBatch`), and ``strategy.shadow(surf, wi, dist) -> (origins, tmax)`` gives
shadow rays toward a light at distance ``dist`` (``inf`` for directional light). ``pyrt.Whitted(offset=...)``
(the integrator of ``pyrt.render``) takes a name of :data:`STRATEGIES` or any callable
``f(surf, w) -> origins``; a plain
callable is wrapped by :func:`get_strategy` (its shadow rays end ``SHADOW_TMAX_SCALE`` short of the
light, pbrt's rule, and it gets no terminator lift).

Origin functions (``f(surf, w) -> origins``; all push to the side of the surface ``w`` leaves toward)
---------------------------------------------------------------------------------------------------
``none``            the hit point itself.
``ray_epsilon``     ``p + RAY_EPSILON w`` (a fixed 1e-4 along the ray: acne at grazing angles and at
                    large scales, leaks at small scales).
``normal_epsilon``  ``p +- NORMAL_EPSILON ng``.
``scaled_epsilon``  ``p +- (1 + max_j |p_j|) RAY_EPSILON_MITSUBA ng``: Mitsuba 3's relative epsilon
                    (``math::RayEpsilon`` = 1500 * 2^-24), here along the normal. Its "1 +" stops it from
                    scaling down (millimetre scenes leak) and far from the origin it grows with |p|.
``wachter_binder_rtg``  Wachter & Binder, "A Fast and Robust Method for Avoiding Self-Intersection"
                    (Ray Tracing Gems ch. 6): add ``256 n`` (as integers) to the float32 bit patterns of
                    the coordinates; coordinates below 1/32 in magnitude get the fixed ``n / 65536``.
``wachter_binder``  the same with a *scale-aware floor*: the published constants 1/32 and 1/65536 assume
                    a scene of size ~1; a 1e-4-sized scene is smaller than the floor offset 1.5e-5 times
                    a few, so it leaks. Here both thresholds are multiplied by the hit triangle's
                    largest vertex coordinate magnitude ``s`` (``s/32`` and ``s/65536``), which leaves
                    scenes of size 1 essentially unchanged.
``error_bound``     pbrt-v4 ``OffsetRayOrigin``: push along ng past the bound ``gamma_7 sum_i |b_i v_i|``
                    of the hit point's float32 error, plus :data:`EMBREE_REL_ERROR` for Embree's own
                    float32 test, then one float32 ulp outward.
``local_bound``     the bound this renderer actually needs (see :func:`local_bound`): hit points are
                    rebuilt in float64 from float32 vertices, so their error is negligible and the
                    remaining error is Embree's float32 ray-plane test, which scales with the *local*
                    size of the triangle relative to the ray origin, not with the absolute coordinates.
                    Rounding the origin to float32 is done outward per component, which can only
                    increase the distance from the plane.

Shadow rays
-----------
``tmax`` policies: ``"exact"`` (up to the light: a light mounted on a surface is hit by its own surface
about half the time), ``"relative"`` (``t * SHADOW_TMAX_SCALE``, pbrt's ShadowEpsilon), ``"epsilon"``
(``t - RAY_EPSILON``, for the fixed-epsilon strategy) and ``"robust"`` (:func:`robust_tmax`: the
relative margin or the float32 uncertainty of the geometry at the light's end, whichever is larger).

The shadow terminator (:func:`terminator_point`, Hanika, "Hacking the Shadow Terminator", Ray Tracing
Gems II ch. 4): on a smooth-shaded low-poly mesh the interpolated normal faces the light over a band
where the flat facet already faces away; the shadow ray from the flat facet then hits the mesh and the
terminator turns into a staircase of facets. Lifting the shadow-ray origin onto the smooth surface
implied by the vertex normals (convex regions only) lets those rays escape. Lights let these hits
through with :meth:`pyrt.geometry.SurfaceBatch.light_side`.

The default (:data:`DEFAULT`) is ``"robust"``: ``local_bound`` origins, ``"robust"`` tmax and the
terminator lift on faces with interpolated normals — the only strategy with 0 acne and 0 leak pixels
over the whole acne matrix (see ``python -m pyrt.apps.acne`` and docs in the README).
``"robust_no_terminator"`` is the same without the lift, for comparisons with renderers that trace
the true triangles (an 80-face smooth sphere then leaves its terminator band black).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pyrt.core.errors import RenderError
from pyrt.shaders.vec import converted, dot, max_component, scale_rows, sub_from_point, take_rows, to_float32

_EPS32 = np.finfo(np.float32).eps / 2  # unit roundoff of float32, 2^-24
_EPS64 = np.finfo(np.float64).eps / 2


def _gamma(n, eps=_EPS32):
    return n * eps / (1 - n * eps)


def _side(surf, w):
    """+1 where ``w`` leaves on the ng side (the side of the viewer), -1 where it goes through."""
    return np.where(dot(w, surf.ng) >= 0, 1.0, -1.0)


def _round_away(origins, direction, as32=False):
    """Cast to float32 and step one float32 ulp further along ``direction``'s sign per component.

    Rounding to nearest moves a component by at most half an ulp; the extra step makes the move
    along ``direction`` at least half an ulp, so the float32 origin is never closer to the surface
    than the float64 one (along the normal the steps only add distance).
    """
    o32 = to_float32(origins)
    toward = np.where(direction > 0, np.float32(np.inf), np.where(direction < 0, np.float32(-np.inf), o32))
    out = np.nextafter(o32, toward.astype(np.float32, copy=False))
    return out if as32 else converted(out, np.float64)


# ---------------------------------------------------------------------------------------- origin functions
def none(surf, w):
    """No offset: the hit point (self-intersects about half the time)."""
    return np.array(surf.p, dtype=np.float64, copy=True)


#: Fixed offset along the ray, in scene units (the classic "1e-4" of many hobby renderers).
RAY_EPSILON = 1e-4
#: Fixed offset along the geometric normal, in scene units.
NORMAL_EPSILON = 1e-4
#: Mitsuba 3's ``math::RayEpsilon<float>`` = 1500 * 2^-24 ~ 8.9e-5, used relative to ``1 + max|p|``.
RAY_EPSILON_MITSUBA = 1500.0 * _EPS32


def ray_epsilon(surf, w):
    """``p + RAY_EPSILON w``: a fixed distance along the new ray."""
    return surf.p + RAY_EPSILON * w


def normal_epsilon(surf, w):
    """``p +- NORMAL_EPSILON ng`` toward the side ``w`` leaves to."""
    return surf.p + (NORMAL_EPSILON * _side(surf, w))[:, None] * surf.ng


def scaled_epsilon(surf, w):
    """``p +- (1 + max_j |p_j|) RAY_EPSILON_MITSUBA ng``: an epsilon relative to the hit coordinates."""
    eps = (1.0 + np.max(np.abs(surf.p), axis=1)) * RAY_EPSILON_MITSUBA
    return surf.p + (eps * _side(surf, w))[:, None] * surf.ng


#: Wachter & Binder's constants (Ray Tracing Gems ch. 6): below ``origin`` use ``float_scale * n``,
#: else add ``int_scale * n`` to the float32 bit pattern.
WB_ORIGIN, WB_FLOAT_SCALE, WB_INT_SCALE = 1.0 / 32.0, 1.0 / 65536.0, 256.0


def _wachter_binder(p, n, origin, float_scale):
    """The RTG ch. 6 ``offset_ray(p, n)`` in float32; ``origin``/``float_scale`` scalars or (N, 1)."""
    p32 = p.astype(np.float32)
    n32 = n.astype(np.float32)
    of_i = (np.float32(WB_INT_SCALE) * n32).astype(np.int32)      # C cast: truncation toward zero
    bits = p32.view(np.int32)
    p_i = np.where(p32 < 0, bits - of_i, bits + of_i).view(np.float32)
    small = np.abs(p32) < np.asarray(origin, dtype=np.float32)
    p_f = p32 + (np.asarray(float_scale, dtype=np.float32) * n32).astype(np.float32)
    return np.where(small, p_f, p_i).astype(np.float64)


def wachter_binder_rtg(surf, w):
    """Wachter & Binder's integer-ulp offset with the published constants (floor 1/65536 ~ 1.5e-5)."""
    n = _side(surf, w)[:, None] * surf.ng
    return _wachter_binder(surf.p, n, WB_ORIGIN, WB_FLOAT_SCALE)


def _triangle_scale(surf):
    """Largest vertex-coordinate magnitude of each hit triangle (N, 1); tiny floor avoids 0."""
    tv = surf.tri_v
    s = np.max(np.abs(tv), axis=(1, 2)) if tv is not None else max_component(surf.p_error)
    return np.maximum(s, np.finfo(np.float32).tiny)[:, None]


def wachter_binder(surf, w):
    """Wachter & Binder with a scale-aware floor: thresholds ``s/32`` and ``s/65536``, ``s`` = max |vertex|.

    The published floor ``n / 65536`` (1.5e-5) is as large as a 1e-4-sized scene's features; scaling it
    (and the 1/32 switch) by the triangle's coordinate magnitude keeps the method's intent (a floor
    ~2^-16 of the coordinates near the origin) at every scale.
    """
    n = _side(surf, w)[:, None] * surf.ng
    s = _triangle_scale(surf)
    return _wachter_binder(surf.p, n, WB_ORIGIN * s, WB_FLOAT_SCALE * s)


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
    d = dot(np.abs(surf.ng), err) + EMBREE_REL_ERROR * _EPS32 * max_component(surf.p_error)
    side = _side(surf, w)
    off = (d * side)[:, None] * surf.ng
    return _round_away(surf.p + off, off)


#: Embree's float32 ray-plane test, in units of 2^-24 of the triangle's extent around the hit point.
#: Measured with the acne matrix (``robust``): 0 gives 114 failing cases (e.g. origins on the plane y = 0
#: are only pushed to denormals, which Embree flushes to zero); 0.25, 1, 4 and 16 all give 0 failing cases
#: and 0 self-hits in tests/test_offsets.py. 16 keeps a 64x margin over 0.25 at no measurable cost in
#: leaks (16 ulps of the triangle's size).
LOCAL_REL_ERROR = 16.0


def local_bound(surf, w):
    """Error bound for float64 hit points on float32 triangles, relative to the triangle's local size.

    The hit point is rebuilt in float64 from the float32 vertices, so it lies on the triangle's plane to
    ``gamma_4(float64) sum_i |b_i v_i|`` (negligible); Embree's float32 test computes ``v_i - o`` and
    the plane distance with a relative error of a few 2^-24 of ``|v_i - o|``, i.e. of the triangle's
    extent around the hit point ``L = max_i ||v_i - p||_inf`` -- *not* of the absolute coordinates
    (far from the origin the differences are exact, Sterbenz). So
    ``d = |n_g| . gamma_4(f64) sum_i|b_i v_i| + LOCAL_REL_ERROR * 2^-24 * L`` along ng, then the float32
    cast rounds each component one ulp outward (:func:`_round_away`), which moves the origin at least
    half an ulp *away* from the plane: the rounding of the origin needs no term of its own.

    Assumption (shared with every per-triangle bound): a coplanar neighbour the ray may graze has a
    size comparable to the hit triangle's.
    """
    d = local_bound_magnitude(surf)
    off = (d * _side(surf, w))[:, None] * surf.ng
    return _round_away(surf.p + off, off)


#: The same bound from precomputed per-face quantities (:class:`pyrt.geometry.GeometryTable`): the
#: triangle's bounding-box extent E satisfies L <= E <= 2 L, so 8 E lies in [8 L, 16 L], inside the range
#: the acne suite validated for LOCAL_REL_ERROR (0.25 ... 16 all give 0 failures).
LOCAL_REL_ERROR_EXTENT = 8.0


def local_bound_magnitude(surf):
    """The distance along ng that :func:`local_bound` pushes by (N,): independent of the ray direction.

    Uses the per-face bounds ``tri_extent`` / ``tri_absmax`` when the batch has them (no per-hit
    reduction over the triangle's vertices), else the exact per-hit quantities.
    """
    ext = surf.tri_extent
    if ext is None:
        tv = surf.tri_v
        L = max_component(np.abs(tv - surf.p[:, None, :]).reshape(-1, 9))
        return dot(np.abs(surf.ng), _gamma(4, _EPS64) * surf.p_error) + LOCAL_REL_ERROR * _EPS32 * L
    absmax = surf.tri_absmax
    if isinstance(surf, _Lifted):
        absmax = absmax + np.abs(surf.p - surf._surf.p)   # the lifted point may lie off the triangle
    return dot(np.abs(surf.ng), _gamma(4, _EPS64) * absmax) + LOCAL_REL_ERROR_EXTENT * _EPS32 * ext




# ---------------------------------------------------------------------------------------- shadow terminator
def terminator_point(surf):
    """Hanika's shadow-terminator lift (Ray Tracing Gems II, ch. 4, "Hacking the Shadow Terminator").

    For each vertex ``v_i`` with normal ``n_i`` (turned to the side of ng), project the flat hit point
    onto the vertex's tangent plane, but only upward (``min(0, (p - v_i) . n_i)``: convex regions), and
    blend the three projections with the barycentrics::

        p' = p - sum_i b_i min(0, (p - v_i) . n_i) n_i

    Flat faces (``tri_n`` zero) are returned unchanged. Returns ``(N, 3)`` float64.

    The implied surface blends tangent planes, which lie outside a sphere: on an 80-triangle sphere the
    lifted point ends up to ~5 % of the radius *above* the exact sphere (less than the facet's depth
    below it). Only shadow-ray origins move, so this can at worst let light past an occluder lying within
    that distance of a coarse smooth-shaded mesh.
    """
    lifted = surf.p_lift   # computed with the surface (pyrt.geometry.surface_from_hits), when it was
    if lifted is not None:
        return lifted
    smooth = surf.smooth
    if smooth is not None:
        sm = np.flatnonzero(smooth)
        if sm.size == 0:
            return surf.p
        tv, tn = take_rows(surf.tri_v, sm), take_rows(surf.tri_n, sm)
        out = surf.p.copy()
        out[sm] = terminator_lift(take_rows(surf.p, sm), [tv[:, i] for i in range(3)], [tn[:, i] for i in range(3)],
                                  take_rows(surf.bary, sm))
        return out
    tn = surf.tri_n
    if tn is None:
        return surf.p
    tv = surf.tri_v
    return terminator_lift(surf.p, [tv[:, i] for i in range(3)], [tn[:, i] for i in range(3)], surf.bary)


def terminator_lift(p, v, n, bary, sign=None):
    """The lifted points of :func:`terminator_point`: ``p - sum_i b_i min(0, (p - v_i) . n_i) n_i``.

    ``p`` (K, 3) hit points, ``v`` and ``n`` three (K, 3) arrays each (the triangle's vertices and vertex
    normals), ``bary`` (K, 3); ``sign`` (K,) turns the normals to the side of ng (None: they already are).
    """
    lift = np.zeros_like(p)
    for i in range(3):
        h = dot(p - v[i], n[i])
        if sign is not None:
            h *= sign
        np.minimum(h, 0.0, out=h)          # height above v_i's tangent plane, <= 0 (convex regions only)
        w = bary[:, i] * h
        if sign is not None:
            w *= sign
        lift -= scale_rows(n[i], w)
    return p + lift


def _batch_cached(surf, key, fn):
    """``fn(batch)`` for the whole batch ``surf`` is a lazy subset of, computed once, gathered for ``surf``.

    Lights trace their shadow rays from subsets of the same surface batch; quantities that do not depend
    on the light (terminator lift, offset distances) are cached on the underlying batch.
    """
    base = surf.__dict__.get("_base", surf)
    cache = base.__dict__.setdefault("_offset_cache", {})
    if key not in cache:
        cache[key] = fn(base)
    idx = surf.__dict__.get("_idx")
    val = cache[key]
    if idx is None or base is surf:
        return val
    if isinstance(idx, slice):           # a contiguous view (SurfaceBatch.subset): NumPy views, no gather
        return tuple(v[idx] for v in val) if isinstance(val, tuple) else val[idx]
    return tuple(take_rows(v, idx) for v in val) if isinstance(val, tuple) else take_rows(val, idx)


class _Lifted:
    """A view of a surface batch with the hit point replaced (for offsets from a lifted origin)."""

    def __init__(self, surf, p):
        self._surf = surf
        self.p = p

    @property
    def p_error(self):
        # the lift is computed in float64 from float64 data: its error is covered by widening the
        # magnitude the bounds scale with
        return self._surf.p_error + np.abs(self.p - self._surf.p)

    def __getattr__(self, name):
        return getattr(self._surf, name)


# ---------------------------------------------------------------------------------------- shadow tmax
#: Shadow rays stop this fraction short of the light (pbrt-v4 uses 1 - ShadowEpsilon, 1e-4).
SHADOW_TMAX_SCALE = 1.0 - 1e-4
#: Robust tmax: the light end is also uncertain by the float32 rounding of the geometry around it
#: (a light mounted on a wall: the wall's float32 vertices may put its surface up to ~1 ulp in front of
#: the light). In units of 2^-24 of the largest coordinate magnitude of the ray's ends.
LIGHT_END_REL_ERROR = 16.0


def robust_tmax(origins, wi, end, o_mag=None):
    """``t_end - max((1 - SHADOW_TMAX_SCALE) t_end, LIGHT_END_REL_ERROR 2^-24 max(|o|, |end|))``.

    ``t_end = (end - o) . wi`` is the distance from the (offset) origin to the light's point ``end``
    ((N, 3), or (3,) for one point shared by all rays).
    Never below half of ``t_end`` (a light closer than its own uncertainty is treated as visible
    up to half the way).
    """
    t_end = dot(sub_from_point(end, origins) if end.ndim == 1 else end - origins, wi)
    if o_mag is None:
        o_mag = max_component(np.abs(origins))
    end_mag = np.abs(end).max() if end.ndim == 1 else max_component(np.abs(end))   # (3,): a single light point
    mag = np.maximum(o_mag, end_mag)
    margin = np.maximum((1.0 - SHADOW_TMAX_SCALE) * t_end, LIGHT_END_REL_ERROR * _EPS32 * mag)
    return np.maximum(t_end - margin, 0.5 * t_end)


TMAX_POLICIES = ("exact", "relative", "epsilon", "robust")


@dataclass(frozen=True)
class Strategy:
    """An offset strategy: origins for secondary rays and (origins, tmax) for shadow rays.

    Parameters
    ----------
    name : str
    origin : callable
        ``origin(surf, w) -> (N, 3) float64`` ray origins.
    tmax : {"exact", "relative", "epsilon", "robust"}
        How far short of the light a shadow ray stops (see the module docstring).
    terminator : bool
        Lift shadow-ray origins on faces with interpolated normals (:func:`terminator_point`).
    magnitude : callable, optional
        ``magnitude(surf) -> (N, 1)``: the origin function's offset distance along ``ng`` when it does not
        depend on the direction (e.g. :func:`local_bound_magnitude`); shadow rays then compute it once per
        surface batch for every light and sample. None: the origin function is called per direction.
    """

    name: str
    origin: object
    tmax: str = "relative"
    terminator: bool = False
    magnitude: object = None

    def __post_init__(self):
        if not callable(self.origin):
            raise ValueError(f"Strategy {self.name!r}: origin must be callable(surf, w) -> origins")
        if self.tmax not in TMAX_POLICIES:
            raise ValueError(f"Strategy {self.name!r}: tmax must be one of {TMAX_POLICIES}, got {self.tmax!r}")

    def __call__(self, surf, w):
        """Origins (N, 3) float64 for secondary rays with unit directions ``w`` (N, 3)."""
        return self.origin(surf, w)

    def shadow(self, surf, wi, dist, end=None):
        """Shadow rays toward a light at distance ``dist`` (N,) (``inf``: directional) along unit ``wi``.

        ``end`` (3,), optional: the light's position when all the rays end at one point (punctual lights), or
        (N, 3) each ray's end point (the rays of several lights in one query; a NaN row: ``p + wi dist`` for that
        ray); otherwise the end points are ``p + wi dist``.
        Returns ``(origins (N, 3) float64 or float32, tmax (N,) float64)``, tmax in units of |wi| from the
        origin (float32 origins are exactly the float32 rays Embree will trace).

        The direction-independent parts (the terminator lift, and the offset distance :attr:`magnitude`)
        are computed once per surface batch and shared by every light and sample (:func:`_batch_cached`).
        """
        magnitude = self.magnitude
        o_mag = None
        if magnitude is not None:
            # Direction-independent distance along ng. Shadow rays leave on the viewer's side (light_side
            # lets through ng . wi > 0, and terminator-zone rays are sent from the lifted side too).
            if self.terminator:
                # every shadow ray leaves from the lifted point on the viewer's side: the origin does not
                # depend on the light at all, so it is built once per batch (with its magnitude for tmax)
                def shadow_origin(b):
                    lifted = _batch_cached(b, "terminator_point", terminator_point)
                    off = scale_rows(b.ng, magnitude(_Lifted(b, lifted)))
                    o = _round_away(lifted + off, off, as32=True)
                    return o, converted(max_component(np.abs(o)), np.float64)
                origins, o_mag = _batch_cached(surf, ("shadow_origin", self.origin), shadow_origin)
            else:
                d = _batch_cached(surf, ("magnitude", self.origin), magnitude)
                d = np.where(dot(wi, surf.ng) >= 0, d, -d)
                off = d[:, None] * surf.ng
                origins = _round_away(surf.p + off, off)
        else:
            src, w_side = surf, wi
            if self.terminator:
                cos_g = dot(wi, surf.ng)
                src = _Lifted(surf, _batch_cached(surf, "terminator_point", terminator_point))
                # Terminator-zone rays (ng . wi < 0, let through by an interpolated normal) must start on
                # the lifted side of their own facet: the origin function is given wi mirrored to that side.
                w_side = np.where((cos_g < 0)[:, None], wi - (2.0 * cos_g)[:, None] * surf.ng, wi)
            origins = np.asarray(self.origin(src, w_side), dtype=np.float64)
        dist = np.asarray(dist, dtype=np.float64)
        finite = np.isfinite(dist)
        tmax = np.full(dist.shape, np.inf)
        if np.any(finite):
            f = slice(None) if np.all(finite) else np.flatnonzero(finite)
            if end is None:
                end = surf.p[f] + wi[f] * dist[f, None]       # the light's point (float64)
            else:
                end = np.asarray(end, dtype=np.float64)           # (3,): one point for every ray, or (N, 3)
                if end.ndim == 2:
                    end = end[f]                                  # (a copy: fancy or slice of a fresh array)
                    own = np.flatnonzero(np.isnan(end[:, 0]))     # NaN rows: the light's point p + wi dist
                    if own.size:
                        end = end.copy() if isinstance(f, slice) else end
                        rows = own if isinstance(f, slice) else f[own]
                        end[own] = surf.p[rows] + wi[rows] * dist[rows, None]
            o, w = origins[f], wi[f]
            if self.tmax == "robust":
                tmax[f] = robust_tmax(o, w, end, None if o_mag is None else o_mag[f])
            else:
                t_end = dot(end - o, w)
                if self.tmax == "exact":
                    tmax[f] = t_end
                elif self.tmax == "relative":
                    tmax[f] = t_end * SHADOW_TMAX_SCALE
                else:  # "epsilon"
                    tmax[f] = np.maximum(t_end - RAY_EPSILON, 0.0)
        return origins, tmax


STRATEGIES = {
    "none": Strategy("none", none, tmax="exact"),
    "ray_epsilon": Strategy("ray_epsilon", ray_epsilon, tmax="epsilon"),
    "normal_epsilon": Strategy("normal_epsilon", normal_epsilon),
    "scaled_epsilon": Strategy("scaled_epsilon", scaled_epsilon),
    "wachter_binder_rtg": Strategy("wachter_binder_rtg", wachter_binder_rtg),
    "wachter_binder": Strategy("wachter_binder", wachter_binder),
    "error_bound": Strategy("error_bound", error_bound),
    "local_bound": Strategy("local_bound", local_bound, magnitude=local_bound_magnitude),
    "robust": Strategy("robust", local_bound, tmax="robust", terminator=True, magnitude=local_bound_magnitude),
    # reference switch: the robust offsets without the terminator lift, i.e. shadow rays from the true
    # (flat) triangles as pbrt-v4 and Mitsuba 3 trace them (README conventions table)
    "robust_no_terminator": Strategy("robust_no_terminator", local_bound, tmax="robust", terminator=False,
                                     magnitude=local_bound_magnitude),
}
#: the library's origin functions (passed bare, they need no result check)
_LIBRARY_ORIGINS = frozenset(st.origin for st in STRATEGIES.values())
DEFAULT = "robust"
#: origin functions whose offset distance does not depend on the direction -> that distance
_MAGNITUDES = {local_bound: local_bound_magnitude}


def _checked_origin(fn, name):
    """``fn`` (a user's ``f(surf, w) -> origins``) wrapped so that a result that is not ``(N, 3)`` finite numbers
    for ``N`` directions is a :class:`pyrt.RenderError` naming the function, not a failure deep in the renderer."""
    def origin(surf, w):
        try:
            out = np.asarray(fn(surf, w), dtype=np.float64)
        except (TypeError, ValueError) as exc:
            raise RenderError(f"offset function {name}: its result is not an array of numbers ({exc})") from None
        if out.shape != (len(w), 3):
            raise RenderError(f"offset function {name}: returned an array of shape {out.shape}, expected "
                              f"({len(w)}, 3) (one origin per direction)")
        if not np.isfinite(out).all():
            raise RenderError(f"offset function {name}: returned {int((~np.isfinite(out)).any(axis=1).sum())} "
                              f"non-finite origin(s) out of {len(w)}")
        return out
    origin.__name__ = name
    return origin


def get_strategy(offset):
    """Resolve ``offset`` (a :class:`Strategy`, a name in :data:`STRATEGIES`, a callable or None).

    A plain callable ``f(surf, w) -> origins`` becomes ``Strategy(name, f, tmax="relative")``.
    """
    if isinstance(offset, Strategy):
        return offset
    if callable(offset):
        # the library's origin functions keep their direction-independent fast path when passed bare
        name = getattr(offset, "__name__", "custom")
        if offset in _MAGNITUDES or offset in _LIBRARY_ORIGINS:
            return Strategy(name, offset, magnitude=_MAGNITUDES.get(offset))
        return Strategy(name, _checked_origin(offset, name))
    if offset is None:
        offset = DEFAULT
    try:
        return STRATEGIES[offset]
    except (KeyError, TypeError):
        raise ValueError(f"unknown offset strategy {offset!r}; choose one of {sorted(STRATEGIES)} "
                         "or pass a callable(surf, w) -> origins") from None
