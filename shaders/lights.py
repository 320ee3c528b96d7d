"""Punctual light kernels (radiometric units).

Each kernel returns, for shading points ``p`` (N, 3):
``wi`` unit direction toward the light, ``dist`` distance to the light (``inf`` for directional)
and ``E`` (N, 3): the irradiance the light delivers on a surface *perpendicular* to ``wi``
(W/m^2). The caller multiplies by ``f * cos(theta_i)``; a Lambertian surface of albedo rho
then has outgoing radiance ``rho / pi * E * cos(theta_i)``.

Units
-----
- point light: radiant intensity ``I`` (W/sr) per RGB channel; E = I / r^2.
- spot light: intensity ``I`` on the axis; E = I * falloff(cos theta) / r^2, where theta is
  the angle between the spot axis and the direction from the light to ``p``.
- directional light: irradiance ``E`` (W/m^2) on a surface perpendicular to the light.
"""
import numpy as np

from . import vec as _vec


def smoothstep(x, edge0, edge1):
    """Hermite smoothstep: 0 below ``edge0``, 1 above ``edge1``, ``3t^2 - 2t^3`` between."""
    denom = edge1 - edge0
    t = np.clip(np.divide(x - edge0, denom, out=np.where(x >= edge1, 1.0, 0.0).astype(np.result_type(x, 1.0)),
                          where=denom != 0), 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


def spot_falloff_smoothstep(cos_theta, cos_inner, cos_outer):
    """pbrt-v4 spot falloff: ``smoothstep(cos_theta; cos_outer, cos_inner)``.

    1 inside the inner cone, 0 outside the outer cone, monotone in between (in cos theta).
    """
    return smoothstep(cos_theta, cos_outer, cos_inner)


def point_light_scalar(p, light_pos):
    """Direction and distance to a point light at ``light_pos`` (3,) and its falloff ``1/r^2`` (N,).

    The irradiance of a point light of intensity ``I`` is ``E = I / r^2``: one colour times a
    per-point scalar, which is all :func:`point_light` and :func:`spot_light` multiply out.
    Returns ``wi, dist, s`` with ``E = I * s``.
    """
    d = _vec.sub_from_point(np.asarray(light_pos, dtype=np.float64), p)
    dist = np.sqrt(_vec.dot(d, d))
    inv = np.divide(1.0, dist, out=np.zeros_like(dist), where=dist > 0)
    wi = _vec.scale_rows(d, inv, out=d)
    return wi, dist, inv * inv


def spot_light_scalar(p, light_pos, axis, cos_inner, cos_outer, falloff=spot_falloff_smoothstep):
    """:func:`point_light_scalar` times the cone falloff: ``E = I * s``, ``I`` the on-axis intensity."""
    wi, dist, s = point_light_scalar(p, light_pos)
    cos_theta = -_vec.dot(wi, np.asarray(axis, dtype=np.float64))
    return wi, dist, s * falloff(cos_theta, cos_inner, cos_outer)


def point_light(p, light_pos, I):
    """Point light of intensity ``I`` (3,) W/sr at ``light_pos`` (3,).

    Returns ``wi, dist, E`` as described in the module docstring.
    """
    wi, dist, s = point_light_scalar(p, light_pos)
    return wi, dist, _vec.outer_rgb(s, np.asarray(I, dtype=np.float64))


def spot_light(p, light_pos, axis, I, cos_inner, cos_outer, falloff=spot_falloff_smoothstep):
    """Spot light at ``light_pos`` pointing along unit ``axis``, on-axis intensity ``I`` (W/sr).

    ``falloff(cos_theta, cos_inner, cos_outer)`` shapes the cone (default: pbrt smoothstep).
    """
    wi, dist, s = spot_light_scalar(p, light_pos, axis, cos_inner, cos_outer, falloff)
    return wi, dist, _vec.outer_rgb(s, np.asarray(I, dtype=np.float64))


def directional_light(p, direction, E):
    """Directional light travelling along unit ``direction`` with perpendicular irradiance ``E``."""
    n = p.shape[0]
    wi = np.broadcast_to(-np.asarray(direction, dtype=np.float64), (n, 3)).copy()
    return wi, np.full(n, np.inf), np.broadcast_to(np.asarray(E, dtype=np.float64), (n, 3)).copy()


# ----------------------------------------------------------------------------- falloff variants
#
# Distance falloff ``f(r)`` multiplies the intensity: E = I(w) f(r). Names (used by pyrt.lights):
#   "inverse_square"      1 / r^2                               physical, the default
#   "inverse_square_eps"  1 / (r + eps)^2                       finite as r -> 0 (course notes, lecture 8)
#   "smooth_range"        clamp(1 - (r/R)^4, 0, 1)^2 / r^2      UE4 (Karis 2013, "Real Shading in Unreal
#                                                               Engine 4", eq. 9 without its +1) and Filament's
#                                                               getSquareFalloffAttenuation: C1, exactly 0 at R
#   "gltf_range"          clamp(1 - (r/R)^4, 0, 1) / r^2        the formula recommended by the glTF
#                                                               KHR_lights_punctual README for ``range``
#   "clq"                 1 / (Kc + Kl r + Kq r^2)              constant-linear-quadratic attenuation (course
#                                                               notes 003; OpenGL fixed-function
#                                                               GL_*_ATTENUATION, LearnOpenGL "Light casters");
#                                                               (Kc, Kl, Kq) = (0, 0, 1) is "inverse_square"
# Spot (cone) falloff ``g(cos theta)`` with cone half-angles inner <= outer:
#   "smoothstep"    pbrt-v4 SpotLight: smoothstep(cos theta; cos outer, cos inner)   the default
#   "gltf"          KHR_lights_punctual: clamp((cos theta - cos outer)/(cos inner - cos outer), 0, 1)^2
#   "linear_angle"  Mitsuba 3 spot: clamp((outer - theta)/(outer - inner), 0, 1), linear in the angle

DISTANCE_FALLOFFS = ("inverse_square", "inverse_square_eps", "smooth_range", "gltf_range", "clq")


def distance_falloff(dist, kind="inverse_square", *, eps=0.0, light_range=np.inf, clq=(0.0, 0.0, 1.0)):
    """Distance falloff factor ``f(r)`` (m^-2) of a punctual light; see the table above for ``kind``.

    Parameters
    ----------
    dist : (N,) float ndarray
        Distance r from the light (m).
    kind : str
        One of :data:`DISTANCE_FALLOFFS`.
    eps : float
        ``inverse_square_eps`` only: the epsilon (m) added to r.
    light_range : float
        Range R (m): every kind returns exactly 0 for ``r >= R`` (a hard cut for the inverse-square
        kinds, the smooth window reaches 0 there by itself); ``inf`` for no range. Required (finite)
        for the two ``*_range`` windows.
    clq : (3,) float
        ``clq`` only: the constant, linear (m^-1) and quadratic (m^-2) coefficients ``(Kc, Kl, Kq)`` >= 0.

    Returns
    -------
    (N,) ndarray, dtype of ``dist``; 0 where r = 0 for the kinds that diverge there (no Inf/NaN).
    """
    r = np.asarray(dist)
    dt = np.result_type(r, np.float32)
    r = r.astype(dt, copy=False)
    if kind == "inverse_square_eps":
        re = r + dt.type(eps)
        f = np.divide(1.0, re * re, out=np.zeros_like(r), where=re > 0)
    elif kind == "clq":
        kc, kl, kq = (dt.type(k) for k in clq)
        den = kc + r * (kl + kq * r)
        f = np.divide(1.0, den, out=np.zeros_like(r), where=den > 0)
    else:
        r2 = r * r
        f = np.divide(1.0, r2, out=np.zeros_like(r), where=r2 > 0)
        if kind in ("smooth_range", "gltf_range"):
            if not np.isfinite(light_range):
                raise ValueError(f"distance falloff {kind!r} needs a finite range")
            q = r / dt.type(light_range)
            q2 = q * q
            w = np.clip(1.0 - q2 * q2, 0.0, 1.0)
            f = f * (w * w if kind == "smooth_range" else w)
        elif kind != "inverse_square":
            raise ValueError(f"distance falloff must be one of {DISTANCE_FALLOFFS}, got {kind!r}")
    if np.isfinite(light_range):
        f = np.where(r < light_range, f, 0.0)
    return f.astype(dt, copy=False)


def spot_falloff_gltf(cos_theta, cos_inner, cos_outer):
    """glTF KHR_lights_punctual spot falloff: ``clamp((cos theta - cos outer) / (cos inner - cos outer), 0, 1)^2``.

    A hard edge (step at cos outer) when ``cos_inner == cos_outer``.
    """
    denom = cos_inner - cos_outer
    x = np.asarray(cos_theta)
    t = np.clip(np.divide(x - cos_outer, denom, out=np.where(x >= cos_outer, 1.0, 0.0).astype(
        np.result_type(x, 1.0)), where=denom != 0), 0.0, 1.0)
    return t * t


def spot_falloff_linear_angle(cos_theta, cos_inner, cos_outer):
    """Mitsuba 3 spot falloff: linear in the angle, ``clamp((outer - theta) / (outer - inner), 0, 1)``.

    The angles are recovered as ``arccos`` of the cosines; a hard edge when inner == outer.
    """
    x = np.clip(np.asarray(cos_theta), -1.0, 1.0)
    theta = np.arccos(x)
    inner, outer = np.arccos(np.clip(cos_inner, -1, 1)), np.arccos(np.clip(cos_outer, -1, 1))
    denom = outer - inner
    t = np.divide(outer - theta, denom, out=np.where(theta <= outer, 1.0, 0.0).astype(theta.dtype),
                  where=denom != 0)
    return np.clip(t, 0.0, 1.0).astype(np.result_type(cos_theta, np.float32), copy=False)


#: name -> spot falloff kernel ``g(cos_theta, cos_inner, cos_outer)``; the default is "smoothstep".
SPOT_FALLOFFS = {"smoothstep": spot_falloff_smoothstep, "gltf": spot_falloff_gltf,
                 "linear_angle": spot_falloff_linear_angle}


def spot_cone_solid_angle(kind, cos_inner, cos_outer):
    """Integral of the spot falloff over the sphere, ``int g dw`` (sr): power = I * this.

    Closed forms, with ``ci = cos inner``, ``co = cos outer`` and the band between them:
    ``2 pi [(1 - ci) + (ci - co) c]`` where ``c = int_0^1 g dt`` over ``t`` linear in cos theta:
    1/2 for "smoothstep" (pbrt-v4 ``SpotLight::Phi``), 1/3 for "gltf". For "linear_angle",
    ``int_inner^outer (outer - theta)/(outer - inner) sin theta dtheta = ci - (sin outer - sin inner)/(outer - inner)``.
    """
    ci, co = float(cos_inner), float(cos_outer)
    if kind == "smoothstep":
        band = 0.5 * (ci - co)
    elif kind == "gltf":
        band = (ci - co) / 3.0
    elif kind == "linear_angle":
        ti, to = np.arccos(np.clip(ci, -1, 1)), np.arccos(np.clip(co, -1, 1))
        band = 0.0 if to - ti <= 0 else ci - (np.sin(to) - np.sin(ti)) / (to - ti)
    else:
        raise ValueError(f"spot falloff must be one of {sorted(SPOT_FALLOFFS)}, got {kind!r}")
    return 2.0 * np.pi * ((1.0 - ci) + band)


def light_direction(p, light_pos):
    """Unit directions ``wi`` (N, 3) from shading points ``p`` toward a light at ``light_pos`` and the
    distances (N,); ``wi = 0`` where ``p`` is at the light (no NaN). The intensity toward ``-wi`` times a
    :func:`distance_falloff` gives ``E`` (see the module docstring).
    """
    d = np.asarray(light_pos, dtype=np.float64) - p
    dist = np.sqrt(np.einsum("ij,ij->i", d, d))
    inv = np.divide(1.0, dist, out=np.zeros_like(dist), where=dist > 0)
    return d * inv[:, None], dist


def to_light_frame(w, axis_x, axis_y, axis_z):
    """Directions ``w`` (N, 3) expressed in a light's orthonormal frame -> (N, 3) (z = ``axis_z``)."""
    return np.stack([w @ np.asarray(axis_x, dtype=np.float64), w @ np.asarray(axis_y, dtype=np.float64),
                     w @ np.asarray(axis_z, dtype=np.float64)], axis=1)


def projector_uv(w_local, tan_half):
    """Slide-projector mapping: light-frame direction -> image UV on the plane z = 1.

    The image covers ``[-tan_half, tan_half]^2`` of the plane z = 1 (``tan_half`` = tan of the cone's
    outer half-angle, so the cone is the disc inscribed in the image); ``u`` along +x, ``v`` along +y
    (``uv = (0, 0)`` bottom-left, :mod:`shaders.textures` convention).

    Returns
    -------
    uv : (N, 2) float64 ndarray
    front : (N,) bool
        False for directions with z <= 0 (behind the projector; uv is then 0).
    """
    z = w_local[:, 2]
    front = z > 0
    inv = np.divide(1.0, z * tan_half, out=np.zeros_like(z), where=front)
    uv = 0.5 + 0.5 * w_local[:, :2] * inv[:, None]
    return np.where(front[:, None], uv, 0.0), front


def projector_texel_solid_angles(shape, tan_half):
    """Exact solid angle (sr) of each texel of a projector image ``shape = (H, W, ...)``.

    A rectangle ``[x0, x1] x [y0, y1]`` on the plane z = 1 subtends
    ``F(x1, y1) - F(x0, y1) - F(x1, y0) + F(x0, y0)`` with ``F(x, y) = atan(x y / sqrt(1 + x^2 + y^2))``.
    Returns (H, W) float64 with row 0 at the top (largest y).
    """
    h, w = shape[0], shape[1]
    xs = np.linspace(-tan_half, tan_half, w + 1)
    ys = np.linspace(tan_half, -tan_half, h + 1)
    X, Y = np.meshgrid(xs, ys)
    F = np.arctan(X * Y / np.sqrt(1.0 + X * X + Y * Y))
    return -(F[1:, 1:] - F[1:, :-1] - F[:-1, 1:] + F[:-1, :-1])


def latlong_uv(w_local):
    """Goniometric lat-long mapping: light-frame direction -> UV.

    ``theta`` = angle from the frame's +z axis (the light's "up"): image rows from the top (theta = 0)
    to the bottom (theta = pi), ``v = 1 - theta / pi``; ``phi = atan2(y, x)`` in [0, 2 pi) along the
    columns, ``u = phi / (2 pi)``. Use with wrap ("repeat", "clamp").
    """
    z = np.clip(w_local[:, 2], -1.0, 1.0)
    theta = np.arccos(z)
    phi = np.mod(np.arctan2(w_local[:, 1], w_local[:, 0]), 2 * np.pi)
    return np.stack([phi / (2 * np.pi), 1.0 - theta / np.pi], axis=1)


def piecewise_linear_sin_weights(theta):
    """Weights ``w_i`` with ``int_{theta_0}^{theta_K} f(theta) sin(theta) dtheta = sum_i w_i f(theta_i)``.

    Exact for ``f`` linear between the increasing nodes ``theta`` (K+1,) in radians. On a segment
    [a, b]: ``int (1 - s) sin = A - B/(b - a)`` and ``int s sin = B/(b - a)`` with ``s = (theta - a)/(b - a)``,
    ``A = cos a - cos b``, ``B = sin b - sin a - (b - a) cos b``. Zero-length segments contribute 0.
    """
    th = np.asarray(theta, dtype=np.float64)
    a, b = th[:-1], th[1:]
    L = b - a
    A = np.cos(a) - np.cos(b)
    B = np.sin(b) - np.sin(a) - L * np.cos(b)
    wb = np.divide(B, L, out=np.zeros_like(L), where=L > 0)
    wa = np.where(L > 0, A - wb, 0.0)
    w = np.zeros_like(th)
    w[:-1] += wa
    w[1:] += wb
    return w


def latlong_bilinear_solid_angle_weights(height):
    """Row weights (sr per unit value per row mean) for the integral over the sphere of a bilinearly
    interpolated lat-long image of ``height`` rows (texel centres at ``theta_i = (i + 1/2) pi / H``,
    clamped beyond the first/last centre, repeating in phi): ``int I dw = sum_i w_i mean_j I_ij``.

    The phi integral of a periodic linear interpolant is exactly 2 pi times the row mean; the theta
    integral is :func:`piecewise_linear_sin_weights` with the constant pole caps added.
    """
    th = (np.arange(height) + 0.5) * np.pi / height
    nodes = np.concatenate([[0.0], th, [np.pi]])
    w = piecewise_linear_sin_weights(nodes)
    rows = w[1:-1].copy()
    rows[0] += w[0]
    rows[-1] += w[-1]
    return 2.0 * np.pi * rows
