"""Environment-map kernels: direction <-> texel mappings, importance-sampling tables, SH, prefiltering.

Pure functions of NumPy arrays (no pyrt, no I/O, no module state, no RNG: callers pass ``u``).
Directions are world (or environment-local) unit vectors ``(N, 3)``, right-handed, **y up**.
Images are ``(H, W, C)`` with row 0 at the top.

Lat-long (equirectangular) mapping
----------------------------------
For a unit direction ``d = (x, y, z)``::

    u = atan2(x, -z) / (2 pi)   wrapped into [0, 1)        (longitude; u = 0 looks along -z,
                                                            u = 1/4 along +x, u = 1/2 along +z)
    v = acos(y) / pi            in [0, 1]                  (colatitude; v = 0 is +y, the top row)

and back: ``theta = pi v``, ``phi = 2 pi u``, ``d = (sin phi sin theta, cos theta, -cos phi sin theta)``.
This is exactly Mitsuba 3's ``envmap`` emitter (``direction_to_uv`` / ``uv_to_direction`` in
``src/emitters/envmap.cpp``), so an EXR that looks right there looks the same here. Texel
``(row j, column i)`` of an ``H x W`` map covers ``u in [i/W, (i+1)/W)``, ``v in [j/H, (j+1)/H)``
(texel centres at half-integers, the pbrt convention); Mitsuba 3 instead puts pixel centres on
``u = i/W``, ``v = j/(H-1)``, a difference of half a texel.

Importance sampling
-------------------
A piecewise-constant 2D distribution over ``[0, 1)^2`` with one cell per texel and weight
``luminance * sin(theta_centre)`` (:func:`distribution2d_build`, float64 CDFs). A sample ``(u, v)``
with density ``p(u, v)`` maps to a direction with solid-angle density
``p(u, v) / (2 pi^2 sin theta)`` (the Jacobian of ``(u, v) -> d`` is ``2 pi^2 sin theta``).

Cube maps (OpenGL convention)
-----------------------------
Faces in the order ``+x, -x, +y, -y, +z, -z`` (OpenGL ``GL_TEXTURE_CUBE_MAP_POSITIVE_X + i``). The
major axis ``ma`` (largest ``|component|``) picks the face; then, per the OpenGL 4.6 specification
table 8.19::

    face   sc    tc    ma            s = (sc / |ma| + 1) / 2    (column, left to right)
    +x    -z    -y     x             t = (tc / |ma| + 1) / 2    (row, top to bottom: t = 0 is row 0)
    -x    +z    -y     x
    +y    +x    +z     y
    -y    +x    -z     y
    +z    +x    -y     z
    -z    -x    -y     z

Face images are stored as they are usually authored (row 0 = ``t = 0``). Note that this table
is the RenderMan/OpenGL one, which is *left-handed* when viewed from inside with y up (looking at
+z, +x is on the right): a cube map authored for OpenGL shows the world mirrored relative to a
lat-long map of the same scene. :func:`latlong_to_cube` and :func:`cube_to_latlong` convert
consistently in our right-handed world with this table.
Cross images (:func:`split_cross`): horizontal 4x3 ``[., +y, ., . / -x, +z, +x, -z / ., -y, ., .]``
and vertical 3x4 ``[., +y, . / -x, +z, +x / ., -y, . / ., -z, .]`` with the ``-z`` face rotated by
180 degrees in the vertical layout (so that its edges meet ``-y``'s).

Spherical harmonics (Ramamoorthi & Hanrahan 2001)
--------------------------------------------------
Nine real SH basis functions ``Y_00, Y_1-1, Y_10, Y_11, Y_2-2, Y_2-1, Y_20, Y_21, Y_22`` with the
constants of R&H eq. (3), written in the world ``(x, y, z)`` as printed (their polar axis is z;
the irradiance formula only needs an orthonormal basis of the l <= 2 functions, which it is in any
orientation). Irradiance ``E(n) = sum_lm A_l L_lm Y_lm(n)`` with ``A_0 = pi``, ``A_1 = 2 pi / 3``,
``A_2 = pi / 4`` (R&H eq. 8).
"""

import math

import numpy as np

from .distribution import Distribution2D, distribution2d_build, distribution2d_pdf, distribution2d_sample  # noqa: F401 (API)
from . import microfacet as _mf
from . import sampling as _sampling
from . import textures as _tex
from .color import luminance
from .vec import coordinate_frame, dot

_INV_2PI2 = 1.0 / (2.0 * np.pi * np.pi)

# ----------------------------------------------------------------------------- lat-long mapping


def latlong_dir_to_uv(d):
    """Unit directions ``(N, 3)`` -> lat-long ``(u, v)`` ``(N, 2)`` float64 (see module docstring)."""
    d = np.asarray(d, dtype=np.float64)
    u = np.arctan2(d[:, 0], -d[:, 2]) * (0.5 / np.pi)
    u = u - np.floor(u)
    u = np.where(u >= 1.0, 0.0, u)  # -0.0 - floor(-0.0) edge case and rounding up to 1
    v = np.arccos(np.clip(d[:, 1], -1.0, 1.0)) / np.pi
    return np.stack([u, v], axis=1)


def latlong_uv_to_dir(uv):
    """Lat-long ``(u, v)`` ``(N, 2)`` -> unit directions ``(N, 3)`` float64 (inverse of :func:`latlong_dir_to_uv`)."""
    uv = np.asarray(uv, dtype=np.float64)
    theta = np.pi * uv[:, 1]
    phi = 2.0 * np.pi * uv[:, 0]
    st = np.sin(theta)
    return np.stack([np.sin(phi) * st, np.cos(theta), -np.cos(phi) * st], axis=1)


def _env_uv_to_tex_uv(uv):
    """Lat-long (v down) -> :mod:`shaders.textures` UV (v up)."""
    return np.stack([uv[:, 0], 1.0 - uv[:, 1]], axis=1)


def latlong_lookup(image, d, filter="bilinear"):
    """Radiance of a lat-long ``image`` (H, W, C) in directions ``d`` (N, 3).

    ``filter``: ``"nearest"`` (piecewise constant per texel, exactly what the importance table
    assumes) or ``"bilinear"`` (between texel centres; wraps in u, clamps at the poles).
    Returns ``(N, C)`` in the image dtype.
    """
    uv = _env_uv_to_tex_uv(latlong_dir_to_uv(d))
    wrap = ("repeat", "clamp")
    if filter == "nearest":
        return _tex.lookup_nearest(image, uv, wrap)
    if filter == "bilinear":
        return _tex.lookup_bilinear(image, uv, wrap)
    raise ValueError(f"filter must be 'nearest' or 'bilinear', got {filter!r}")


def latlong_texel_directions(height, width):
    """Directions of the texel centres of an ``height x width`` lat-long map, ``(H, W, 3)`` float64."""
    u = (np.arange(width) + 0.5) / width
    v = (np.arange(height) + 0.5) / height
    uu, vv = np.meshgrid(u, v)
    return latlong_uv_to_dir(np.stack([uu.ravel(), vv.ravel()], axis=1)).reshape(height, width, 3)


def latlong_texel_solid_angle(height, width):
    """Exact solid angle of each texel row, ``(H,)`` float64: ``(2 pi / W) (cos theta_j - cos theta_{j+1})``.

    Sums to ``4 pi`` over the map.
    """
    edges = np.cos(np.pi * np.arange(height + 1) / height)
    return (2.0 * np.pi / width) * (edges[:-1] - edges[1:])


def conservative_weights(w):
    """Per-texel weights that are > 0 wherever a *bilinear* lookup can be > 0.

    A bilinear lookup inside texel (j, i) blends it with its 8 neighbours; building the importance
    table from ``(w + max_3x3(w)) / 2`` keeps the pdf positive wherever the radiance is, so that
    sampling stays unbiased, at the price of a slightly wider distribution. Wraps in x, clamps in y.
    """
    w = np.asarray(w, dtype=np.float64)
    p = np.pad(np.pad(w, ((0, 0), (1, 1)), mode="wrap"), ((1, 1), (0, 0)), mode="edge")
    m = _max3x3(p, w.shape)
    return 0.5 * (w + m)


def latlong_sampling_weights(image, filter="nearest"):
    """Importance-table weights ``luminance * sin(theta_centre)`` (H, W) float64 of a lat-long map.

    Negative luminance (possible in odd HDR files) is clamped to 0. For ``filter="bilinear"`` the
    weights go through :func:`conservative_weights`.
    """
    img = np.asarray(image, dtype=np.float64)
    lum = np.maximum(luminance(img[..., :3]), 0.0)
    if filter == "bilinear":
        lum = conservative_weights(lum)
    h = img.shape[0]
    sin_c = np.sin(np.pi * (np.arange(h) + 0.5) / h)
    return lum * sin_c[:, None]


def latlong_sample(dist, u):
    """Sample directions from a lat-long importance table.

    Parameters
    ----------
    dist : Distribution2D
        Built from :func:`latlong_sampling_weights`.
    u : (N, 2) float ndarray in [0, 1)^2

    Returns
    -------
    d : (N, 3) float64 unit directions (environment frame)
    pdf : (N,) float64 solid-angle density ``p(u, v) / (2 pi^2 sin theta)``; 0 at the poles.
    """
    uv, p = distribution2d_sample(dist, u)
    d = latlong_uv_to_dir(uv)
    sin_t = np.sin(np.pi * uv[:, 1])
    pdf = np.divide(p * _INV_2PI2, sin_t, out=np.zeros_like(p), where=sin_t > 0)
    return d, pdf


def latlong_pdf(dist, d):
    """Solid-angle density of :func:`latlong_sample` for directions ``d`` (N, 3)."""
    d = np.asarray(d, dtype=np.float64)
    p = distribution2d_pdf(dist, latlong_dir_to_uv(d))
    sin_t = np.sqrt(np.maximum(0.0, d[:, 0] ** 2 + d[:, 2] ** 2))
    return np.divide(p * _INV_2PI2, sin_t, out=np.zeros_like(p), where=sin_t > 0)


# ----------------------------------------------------------------------------- cube maps

CUBE_FACES = ("+x", "-x", "+y", "-y", "+z", "-z")

# (sc, tc, ma) as (component index, sign) per face, OpenGL 4.6 table 8.19
_CUBE_TABLE = (
    ((2, -1.0), (1, -1.0), 0),   # +x
    ((2, +1.0), (1, -1.0), 0),   # -x
    ((0, +1.0), (2, +1.0), 1),   # +y
    ((0, +1.0), (2, -1.0), 1),   # -y
    ((0, +1.0), (1, -1.0), 2),   # +z
    ((0, -1.0), (1, -1.0), 2),   # -z
)


def cube_dir_to_face_st(d):
    """Directions ``(N, 3)`` -> face index ``(N,)`` int64 and ``(s, t)`` ``(N, 2)`` in [0, 1] (OpenGL table).

    Ties between axes go to x, then y (the first maximal component).
    """
    d = np.asarray(d, dtype=np.float64)
    a = np.abs(d)
    axis = np.argmax(a, axis=1)
    neg = d[np.arange(d.shape[0]), axis] < 0
    face = 2 * axis + neg.astype(np.int64)
    st = np.zeros((d.shape[0], 2))
    for f, ((sc_i, sc_s), (tc_i, tc_s), ma_i) in enumerate(_CUBE_TABLE):
        m = face == f
        if not np.any(m):
            continue
        ma = np.abs(d[m, ma_i])
        ma = np.where(ma > 0, ma, 1.0)
        st[m, 0] = 0.5 * (sc_s * d[m, sc_i] / ma + 1.0)
        st[m, 1] = 0.5 * (tc_s * d[m, tc_i] / ma + 1.0)
    return face, np.clip(st, 0.0, 1.0)


def cube_face_st_to_dir(face, st):
    """Inverse of :func:`cube_dir_to_face_st`: unit directions ``(N, 3)`` float64."""
    face = np.asarray(face, dtype=np.int64)
    st = np.asarray(st, dtype=np.float64)
    sc = 2.0 * st[:, 0] - 1.0
    tc = 2.0 * st[:, 1] - 1.0
    d = np.zeros((face.shape[0], 3))
    for f, ((sc_i, sc_s), (tc_i, tc_s), ma_i) in enumerate(_CUBE_TABLE):
        m = face == f
        if not np.any(m):
            continue
        d[m, sc_i] = sc_s * sc[m]
        d[m, tc_i] = tc_s * tc[m]
        d[m, ma_i] = -1.0 if f % 2 else 1.0
    return d / np.linalg.norm(d, axis=1, keepdims=True)


def cube_lookup(faces, d, filter="bilinear"):
    """Radiance of a cube map ``faces`` (6, S, S, C) in directions ``d`` (N, 3) -> (N, C).

    Bilinear filtering clamps at face edges (no filtering across seams).
    """
    if filter not in ("nearest", "bilinear"):
        raise ValueError(f"filter must be 'nearest' or 'bilinear', got {filter!r}")
    face, st = cube_dir_to_face_st(d)
    out = np.zeros((st.shape[0], faces.shape[-1]), dtype=faces.dtype)
    lookup = _tex.lookup_nearest if filter == "nearest" else _tex.lookup_bilinear
    for f in range(6):
        m = face == f
        if np.any(m):
            out[m] = lookup(faces[f], _env_uv_to_tex_uv(st[m]), "clamp")
    return out


def cube_texel_jacobian(size):
    """``(1 + a^2 + b^2)^(-3/2)`` at the texel centres of an ``S x S`` face, ``(S, S)`` float64.

    ``a = 2 s - 1``, ``b = 2 t - 1``; ``d omega = da db (1 + a^2 + b^2)^(-3/2)``.
    """
    c = 2.0 * (np.arange(size) + 0.5) / size - 1.0
    b, a = np.meshgrid(c, c, indexing="ij")
    return (1.0 + a * a + b * b) ** -1.5


def cube_sampling_weights(faces, filter="nearest"):
    """Importance-table weights for a cube map: faces stacked vertically into a ``(6 S, S)`` table of
    ``luminance * jacobian`` (conservative for bilinear, per face)."""
    f = np.asarray(faces, dtype=np.float64)
    size = f.shape[1]
    lum = np.maximum(luminance(f[..., :3]), 0.0)
    if filter == "bilinear":
        lum = np.stack([_conservative_clamped(lum[i]) for i in range(6)])
    return (lum * cube_texel_jacobian(size)[None]).reshape(6 * size, size)


def _conservative_clamped(w):
    """:func:`conservative_weights` for a cube face (clamped in both axes)."""
    return 0.5 * (w + _max3x3(np.pad(w, 1, mode="edge"), w.shape))


def _max3x3(p, shape):
    """Maximum over the 3x3 neighbourhood, from an array padded by one cell on each side."""
    h, w = shape
    return np.max(np.stack([p[dy:dy + h, dx:dx + w] for dy in range(3) for dx in range(3)]), axis=0)


def cube_sample(dist, u):
    """Sample directions from a cube-map table built by :func:`cube_sampling_weights`.

    Returns ``d`` (N, 3) and the solid-angle pdf ``p(u, v) / 24 * (1 + a^2 + b^2)^(3/2)``
    (``u`` = s, ``v = (face + t) / 6``; ``du dv = da db / 24``).
    """
    uv, p = distribution2d_sample(dist, u)
    face, st = _stacked_to_face(uv)
    d = cube_face_st_to_dir(face, st)
    a, b = 2.0 * st[:, 0] - 1.0, 2.0 * st[:, 1] - 1.0
    return d, p / 24.0 * (1.0 + a * a + b * b) ** 1.5


def _stacked_to_face(uv):
    v6 = uv[:, 1] * 6.0
    face = np.clip(np.floor(v6).astype(np.int64), 0, 5)
    return face, np.stack([uv[:, 0], np.clip(v6 - face, 0.0, 1.0)], axis=1)


def cube_pdf(dist, d):
    """Solid-angle density of :func:`cube_sample` for directions ``d`` (N, 3)."""
    face, st = cube_dir_to_face_st(d)
    size = dist.func.shape[1]
    # keep the point inside its face's cells (t = 1 belongs to the face, not the next one)
    t = np.minimum(st[:, 1], 1.0 - 0.5 / size)
    uv = np.stack([np.minimum(st[:, 0], 1.0 - 0.5 / size), (face + t) / 6.0], axis=1)
    p = distribution2d_pdf(dist, uv)
    a, b = 2.0 * st[:, 0] - 1.0, 2.0 * st[:, 1] - 1.0
    return p / 24.0 * (1.0 + a * a + b * b) ** 1.5


def split_cross(image):
    """Split a cross image into six faces ``(6, S, S, C)`` in the order of :data:`CUBE_FACES`.

    Horizontal cross: width:height = 4:3; vertical cross: 3:4 (``-z`` stored rotated by 180
    degrees). Raises ``ValueError`` for other shapes.
    """
    img = np.asarray(image)
    h, w = img.shape[:2]
    if 3 * w == 4 * h and w % 4 == 0:
        s = w // 4
        cells = {"+y": (0, 1), "-x": (1, 0), "+z": (1, 1), "+x": (1, 2), "-z": (1, 3), "-y": (2, 1)}
        rot = ()
    elif 4 * w == 3 * h and w % 3 == 0:
        s = w // 3
        cells = {"+y": (0, 1), "-x": (1, 0), "+z": (1, 1), "+x": (1, 2), "-y": (2, 1), "-z": (3, 1)}
        rot = ("-z",)
    else:
        raise ValueError(f"a cube-map cross must be 4:3 (horizontal) or 3:4 (vertical) with square faces, "
                         f"got {w}x{h} pixels")
    faces = []
    for name in CUBE_FACES:
        r, c = cells[name]
        f = img[r * s:(r + 1) * s, c * s:(c + 1) * s]
        faces.append(f[::-1, ::-1] if name in rot else f)
    return np.stack(faces)


def assemble_cross(faces, layout="horizontal"):
    """Inverse of :func:`split_cross`: six faces ``(6, S, S, C)`` -> a cross image (unused cells zero)."""
    faces = np.asarray(faces)
    s = faces.shape[1]
    if layout == "horizontal":
        out = np.zeros((3 * s, 4 * s) + faces.shape[3:], dtype=faces.dtype)
        cells = {"+y": (0, 1), "-x": (1, 0), "+z": (1, 1), "+x": (1, 2), "-z": (1, 3), "-y": (2, 1)}
        rot = ()
    elif layout == "vertical":
        out = np.zeros((4 * s, 3 * s) + faces.shape[3:], dtype=faces.dtype)
        cells = {"+y": (0, 1), "-x": (1, 0), "+z": (1, 1), "+x": (1, 2), "-y": (2, 1), "-z": (3, 1)}
        rot = ("-z",)
    else:
        raise ValueError(f"layout must be 'horizontal' or 'vertical', got {layout!r}")
    for i, name in enumerate(CUBE_FACES):
        r, c = cells[name]
        out[r * s:(r + 1) * s, c * s:(c + 1) * s] = faces[i][::-1, ::-1] if name in rot else faces[i]
    return out


def cube_texel_directions(size):
    """Directions of the texel centres of a cube map, ``(6, S, S, 3)`` float64."""
    c = (np.arange(size) + 0.5) / size
    t, s = np.meshgrid(c, c, indexing="ij")
    st = np.stack([s.ravel(), t.ravel()], axis=1)
    return np.stack([cube_face_st_to_dir(np.full(st.shape[0], f), st).reshape(size, size, 3) for f in range(6)])


def cube_texel_solid_angle(size):
    """Solid angle of each texel of one face ``(S, S)`` (exact, from the area-element integral).

    Uses ``Omega(a, b) = atan(a b / sqrt(1 + a^2 + b^2))``, the solid angle of the face rectangle
    ``[0, a] x [0, b]``, differenced over the texel corners. Six faces sum to ``4 pi``.
    """
    e = 2.0 * np.arange(size + 1) / size - 1.0
    b, a = np.meshgrid(e, e, indexing="ij")
    om = np.arctan2(a * b, np.sqrt(1.0 + a * a + b * b))
    return om[1:, 1:] - om[:-1, 1:] - om[1:, :-1] + om[:-1, :-1]


def latlong_to_cube(image, size, filter="bilinear"):
    """Resample a lat-long map to a cube map ``(6, S, S, C)`` (point samples at texel centres)."""
    d = cube_texel_directions(size).reshape(-1, 3)
    return latlong_lookup(image, d, filter).reshape(6, size, size, -1)


def cube_to_latlong(faces, height, width, filter="bilinear"):
    """Resample a cube map to a lat-long map ``(H, W, C)`` (point samples at texel centres)."""
    d = latlong_texel_directions(height, width).reshape(-1, 3)
    return cube_lookup(faces, d, filter).reshape(height, width, -1)


# ----------------------------------------------------------------------------- spherical harmonics

#: R&H 2001 eq. (3) constants, in closed form (R&H print them to 6 digits: 0.282095, 0.488603,
#: 1.092548, 0.315392, 0.546274; the exact values keep the basis orthonormal to 1e-16)
_SH_C0 = 0.5 / np.sqrt(np.pi)
_SH_C1 = np.sqrt(3.0 / (4.0 * np.pi))
_SH_C2 = np.sqrt(15.0 / (4.0 * np.pi))
_SH_C20 = np.sqrt(5.0 / (16.0 * np.pi))
_SH_C22 = np.sqrt(15.0 / (16.0 * np.pi))

#: convolution with the clamped cosine, per coefficient (R&H eq. 8): A_0 = pi, A_1 = 2 pi / 3, A_2 = pi / 4
SH9_COSINE_LOBE = np.array([np.pi] + [2.0 * np.pi / 3.0] * 3 + [np.pi / 4.0] * 5)


def sh9_basis(d):
    """The nine real SH basis functions at unit directions ``d`` (N, 3) -> (N, 9) float64.

    Order: ``Y_00, Y_1-1 (y), Y_10 (z), Y_11 (x), Y_2-2 (xy), Y_2-1 (yz), Y_20 (3z^2 - 1),
    Y_21 (xz), Y_22 (x^2 - y^2)`` (R&H 2001 eq. 3).
    """
    d = np.asarray(d, dtype=np.float64)
    x, y, z = d[:, 0], d[:, 1], d[:, 2]
    b = np.empty((d.shape[0], 9))        # filled column by column in place (4x faster than stacking 9 temporaries)
    b[:, 0] = _SH_C0
    np.multiply(y, _SH_C1, out=b[:, 1])
    np.multiply(z, _SH_C1, out=b[:, 2])
    np.multiply(x, _SH_C1, out=b[:, 3])
    np.multiply(x, y, out=b[:, 4])
    b[:, 4] *= _SH_C2
    np.multiply(y, z, out=b[:, 5])
    b[:, 5] *= _SH_C2
    np.multiply(z, z, out=b[:, 6])
    b[:, 6] *= 3.0 * _SH_C20
    b[:, 6] -= _SH_C20
    np.multiply(x, z, out=b[:, 7])
    b[:, 7] *= _SH_C2
    np.multiply(x, x, out=b[:, 8])
    b[:, 8] -= y * y
    b[:, 8] *= _SH_C22
    return b


def sh9_project(d, L, d_omega):
    """Project radiance samples onto 9 SH coefficients: ``L_lm = sum_k L_k Y_lm(d_k) d_omega_k``.

    Parameters
    ----------
    d : (N, 3) unit directions
    L : (N, C) radiance
    d_omega : (N,) solid angle per sample (sums to 4 pi for a full-sphere quadrature)

    Returns
    -------
    (9, C) float64
    """
    return sh9_basis(d).T @ (np.asarray(L, dtype=np.float64) * np.asarray(d_omega, dtype=np.float64)[:, None])


def sh9_project_latlong(image):
    """9 SH coefficients ``(9, C)`` of a lat-long map (texel-centre quadrature with exact texel solid angles)."""
    h, w = image.shape[:2]
    d = latlong_texel_directions(h, w).reshape(-1, 3)
    dw = np.repeat(latlong_texel_solid_angle(h, w), w)
    return sh9_project(d, np.asarray(image, dtype=np.float64).reshape(h * w, -1), dw)


def sh9_eval(coeffs, d):
    """Band-limited radiance ``sum_lm L_lm Y_lm(d)`` -> (N, C)."""
    return sh9_basis(d) @ coeffs


def sh9_irradiance(coeffs, n):
    """Irradiance ``E(n) = sum_lm A_l L_lm Y_lm(n)`` (W/m^2) at unit normals ``n`` (N, 3) -> (N, C).

    A Lambertian surface of albedo rho reflects ``rho / pi * E``. R&H 2001 report ~1% average error
    for natural lighting (at most ~9% for a single directional light, where the l >= 4 terms the
    9-term form drops are largest).
    """
    return sh9_basis(n) @ (SH9_COSINE_LOBE[:, None] * coeffs)


# ----------------------------------------------------------------------------- prefiltered maps


def ggx_lobe_alpha_for_solid_angle(omega):
    """Equivalent GGX width for a lobe of solid angle ``omega``: ``alpha = sqrt(omega / (4 pi))``.

    With ``n = v = r`` the reflected-direction density of a GGX lobe peaks at ``D(1) / 4 =
    1 / (4 pi alpha^2)``; its reciprocal is the lobe's solid angle.
    """
    return np.sqrt(np.maximum(np.asarray(omega, dtype=np.float64), 0.0) / (4.0 * np.pi))


def prefilter_latlong_ggx(levels, alpha, out_shape, n_samples=128):
    """Prefilter a lat-long map with a GGX lobe (split-sum assumption ``n = v = r``, Karis 2013).

    ``P(r) = sum_k L(l_k) (r . l_k) / sum_k (r . l_k)`` with half vectors ``h_k`` from the GGX NDF
    around ``r`` (Hammersley points, deterministic) and ``l_k = reflect(r, h_k)``. Each sample reads
    the source MIP level whose texel solid angle matches the sample's ``1 / (K pdf(l_k))``
    ("filtered importance sampling", Krivanek & Colbert 2008), which removes the noise of a small K.

    Parameters
    ----------
    levels : list of (H_l, W_l, C) arrays
        MIP pyramid of the source lat-long map (level 0 first; :func:`shaders.textures.build_mip_level`).
    alpha : float
        GGX width (> 0).
    out_shape : (H_o, W_o)
    n_samples : int

    Returns
    -------
    (H_o, W_o, C) float64
    """
    h0, w0 = levels[0].shape[:2]
    ho, wo = out_shape
    r = latlong_texel_directions(ho, wo).reshape(-1, 3)
    s, t = coordinate_frame(r)
    u = _sampling.hammersley(n_samples)
    h_loc = _mf.sample_ggx_ndf(u, alpha)                      # (K, 3) around +z
    cos_h = h_loc[:, 2]
    pdf_l = _mf.ggx_d(cos_h, alpha) / 4.0                      # n = v: D (n.h) / (4 v.h) = D / 4
    omega_s = 1.0 / (n_samples * np.maximum(pdf_l, 1e-300))
    omega_p = 4.0 * np.pi / (h0 * w0)
    lod = np.clip(0.5 * np.log2(omega_s / omega_p) - 1.0, 0.0, len(levels) - 1)
    out = np.zeros((r.shape[0], levels[0].shape[2]))
    wsum = np.zeros(r.shape[0])
    for k in range(n_samples):
        hk = h_loc[k, 0] * s + h_loc[k, 1] * t + h_loc[k, 2] * r
        l = 2.0 * dot(r, hk)[:, None] * hk - r
        w = np.maximum(dot(r, l), 0.0)
        if not np.any(w > 0):
            continue
        l0 = int(np.floor(lod[k]))
        f = lod[k] - l0
        val = latlong_lookup(levels[l0], l, "bilinear").astype(np.float64)
        if f > 0 and l0 + 1 < len(levels):
            val = (1 - f) * val + f * latlong_lookup(levels[l0 + 1], l, "bilinear")
        out += val * w[:, None]
        wsum += w
    out /= np.where(wsum > 0, wsum, 1.0)[:, None]
    return out.reshape(ho, wo, -1)


def prefilter_stack(image, alphas, n_samples=128):
    """Roughness-indexed stack for ``alphas`` (``alphas[0] = 0``): level 0 = the image, then GGX-prefiltered maps.

    Output texels about ``alpha / 2`` wide (``W_o = 2^ceil(log2(4 pi / alpha))``, between 32 and the
    source width), source read through an exact-box MIP pyramid; ``n_samples`` Hammersley samples per texel
    (:func:`prefilter_latlong_ggx`). About 2.5 s for a 256 x 128 source with 128 samples.
    """
    img = np.asarray(image, dtype=np.float64)
    h, w = img.shape[:2]
    levels = [_tex.build_mip_level(img, lv) for lv in range(_tex.n_mip_levels(img.shape))]
    maps = [img]
    for a in alphas[1:]:
        wo = int(min(w, max(32, 2 ** math.ceil(math.log2(4.0 * math.pi / a)))))
        ho = max(16, wo // 2)
        maps.append(prefilter_latlong_ggx(levels, a, (ho, wo), n_samples=n_samples))
    return maps


def roughness_map_lookup(maps, alphas, d, alpha):
    """Look up a roughness-indexed stack of lat-long maps, linear in ``alpha`` between levels.

    Parameters
    ----------
    maps : list of (H_k, W_k, C) arrays
        ``maps[k]`` is the environment prefiltered for width ``alphas[k]`` (``alphas[0] = 0``: the map itself).
    alphas : (K,) increasing
    d : (N, 3) directions; alpha : (N,) widths (clamped to ``[alphas[0], alphas[-1]]``)

    Returns
    -------
    (N, C) float64
    """
    alphas = np.asarray(alphas, dtype=np.float64)
    a = np.clip(np.broadcast_to(np.asarray(alpha, dtype=np.float64), (d.shape[0],)), alphas[0], alphas[-1])
    k = np.clip(np.searchsorted(alphas, a, side="right") - 1, 0, len(alphas) - 2)
    f = (a - alphas[k]) / (alphas[k + 1] - alphas[k])
    out = np.zeros((d.shape[0], maps[0].shape[2]))
    uv = _env_uv_to_tex_uv(latlong_dir_to_uv(d))    # once per direction: both levels read at the same uv
    wrap = ("repeat", "clamp")
    for j in range(len(alphas) - 1):
        m = k == j
        if not np.any(m):
            continue
        uv_m = uv[m]
        lo = _tex.lookup_bilinear(maps[j], uv_m, wrap).astype(np.float64)
        hi = _tex.lookup_bilinear(maps[j + 1], uv_m, wrap).astype(np.float64)
        out[m] = (1.0 - f[m, None]) * lo + f[m, None] * hi
    return out
