"""Image-texture kernels: wrapping, reconstruction, MIP pyramids and footprint-filtered lookups.

Pure functions of NumPy arrays (no pyrt, no Embree, no I/O, no module state). Texture *objects*
(file loading, lazy pyramids, material plumbing) live in :mod:`pyrt.textures`.

Conventions
-----------
UV orientation
    ``uv = (0, 0)`` is the **bottom-left** corner of the image and ``v`` grows **upward**, as in
    OBJ files and trimesh (glTF uses the opposite, ``(0, 0)`` = top-left; its loader must flip v).
    Images are stored ``(H, W, C)`` with row 0 at the top, so the continuous texel coordinates of
    ``uv`` are::

        x = u * W - 0.5          (column; texel centres at integers)
        y = (1 - v) * H - 0.5    (row)

    and a UV footprint ``(du, dv)`` is ``(du * W, -dv * H)`` in texels.
UV transform
    :func:`transform_uv` maps ``uv' = R(rotation) @ (scale * uv) + offset`` (scale first, then a
    counter-clockwise rotation in radians about the UV origin, then the offset), applied before
    wrapping; footprints go through the linear part only.
Wrap modes (per axis)
    ``"repeat"`` (period 1), ``"mirror"`` (period 2, reflected every other tile), ``"clamp"``
    (edge texels extend). Wrapping acts on integer texel indices, so bilinear/bicubic taps that
    straddle the border follow the same rule.
MIP pyramid
    Level ``l`` has shape ``(max(1, H >> l), max(1, W >> l))``; there are
    ``1 + floor(log2(max(H, W)))`` levels. Each level is the **exact box (area) average** of level 0
    over its texel's footprint, computed from prefix sums, so non-power-of-two sizes are handled
    without resampling and the mean of every level equals the mean of the image (for power-of-two
    sizes this is the classic 2x2 box cascade). A level can be built alone, which lets callers build
    only the levels a render reads.
Footprints and level selection
    ``duvdx, duvdy`` (N, 2) are the UV changes per pixel step (from ray differentials). The filter
    *width* of one lookup is ``footprint_scale * |duv|``: ``footprint_scale = 1`` matches a box
    pixel filter of one pixel; pbrt-v4 uses 2 (its ellipses have half-axes ``dst0, dst1``).
    Defaults: 1 for trilinear, 1.5 for EWA (:data:`DEFAULT_FOOTPRINT_SCALE`).
    Isotropic level (OpenGL spec / Heckbert): ``lambda = log2(footprint_scale * max(|dx|, |dy|))``
    with ``dx, dy`` the footprints in level-0 texels (Euclidean lengths, so rotation invariant).
    EWA (pbrt-v4 ``MIPMap::EWA``): ellipse half-axes ``footprint_scale / 2 * duv``, the minor
    axis stretched so that major/minor <= ``max_anisotropy`` (8), level from the minor half-axis,
    Gaussian weights ``exp(-2 r^2) - exp(-2)`` inside ``r^2 < 1`` of the ellipse ``Sigma = M M^T + I``
    (texel units, the ``+I`` guarantees at least one texel), blended between two levels.

Integer-stored level 0
    8/16-bit images are kept as their codes (uint8 / uint16, 1 or 2 bytes per channel instead of 4) and
    decoded per tap through ``table`` (a float array indexed by the code: ``value = table[code]``, e.g.
    the 256 sRGB -> linear values), so level 0 reads exactly what a decoded float copy would hold.
    ``table`` applies to level 0 only; levels >= 1 are float (filtered in linear space).

Precision: lookups preserve the image's float dtype (the table's for integer storage); index arithmetic is
done in float64.
"""
import numpy as np

from .vec import coordinate_frame, cross, dot, normalize, reject

#: Accepted wrap-mode names.
WRAP_MODES = ("repeat", "mirror", "clamp")
#: Reconstruction filters that ignore the footprint / footprint-aware filters.
RECONSTRUCTION_FILTERS = ("nearest", "bilinear", "bicubic")
FOOTPRINT_FILTERS = ("trilinear", "anisotropic")
#: Default filter width in pixel steps per footprint filter. Trilinear: a one-pixel box (pbrt-v4
#: uses 2, which over-blurs since the isotropic level already takes the larger axis). EWA: 1.5
#: (pbrt-v4: 2); on the grazing-plane test against a 256-spp box-filtered reference the RMS error
#: was lowest near 1.5-1.75 for both a checkerboard and white noise (measured, see tests).
DEFAULT_FOOTPRINT_SCALE = {"trilinear": 1.0, "anisotropic": 1.5}


# ----------------------------------------------------------------------------- wrapping

def check_wrap(wrap):
    """Normalise ``wrap`` (a name or a pair of names) to a ``(wrap_x, wrap_y)`` tuple; raise on bad names."""
    pair = (wrap, wrap) if isinstance(wrap, str) else tuple(wrap)
    if len(pair) != 2 or any(w not in WRAP_MODES for w in pair):
        raise ValueError(f"wrap must be one of {WRAP_MODES} or a pair of them, got {wrap!r}")
    return pair


def wrap_index(i, n, mode):
    """Map integer texel indices ``i`` onto ``[0, n)`` with wrap ``mode``.

    Parameters
    ----------
    i : int ndarray
        Texel indices, any shape, may be negative or >= n.
    n : int
        Number of texels along the axis (>= 1).
    mode : {"repeat", "mirror", "clamp"}

    Returns
    -------
    int64 ndarray
        Same shape as ``i``. ``mirror`` has period ``2 n``: ``..., 1, 0, 0, 1, ..., n-1, n-1, ...``.
    """
    i = np.asarray(i, dtype=np.int64)
    if mode == "repeat":
        # a power of two: the low bits (two's complement: the same as the modulo for negative i, ~10x cheaper)
        return i & (n - 1) if n & (n - 1) == 0 else np.mod(i, n)
    if mode == "clamp":
        return np.clip(i, 0, n - 1)
    if mode == "mirror":
        j = np.mod(i, 2 * n)
        return np.where(j >= n, 2 * n - 1 - j, j)
    raise ValueError(f"wrap mode must be one of {WRAP_MODES}, got {mode!r}")


def _gather(image, ix, iy, wrap, table=None):
    """``image[wrap(iy), wrap(ix)]`` -> ``(..., C)``, decoded by ``table[code]`` when given."""
    h, w = image.shape[:2]
    taps = image[wrap_index(iy, h, wrap[1]), wrap_index(ix, w, wrap[0])]
    return taps if table is None else table.take(taps)


def _dtype(image, table):
    """The float dtype of a lookup's result: the table's for integer storage, else the image's."""
    return image.dtype if table is None else table.dtype


# ----------------------------------------------------------------------------- coordinates

def transform_uv(uv, duvdx=None, duvdy=None, *, scale=(1.0, 1.0), offset=(0.0, 0.0), rotation=0.0):
    """Apply the UV transform ``uv' = R(rotation) @ (scale * uv) + offset``.

    Parameters
    ----------
    uv : (N, 2) float ndarray
    duvdx, duvdy : (N, 2) float ndarray or None
        Footprints; transformed by the linear part (scale, rotation) only.
    scale, offset : (2,) float
        Per-axis scale (tiling) and offset in UV units.
    rotation : float
        Counter-clockwise rotation in radians about the UV origin.

    Returns
    -------
    uv, duvdx, duvdy : (N, 2) ndarrays (``None`` stays ``None``), dtype of ``uv``.
    """
    c, s = np.cos(rotation), np.sin(rotation)
    sx, sy = float(scale[0]), float(scale[1])
    # Linear map L = R @ diag(scale); applied to row vectors as x @ L.T.
    lin_t = np.array([[c * sx, s * sx], [-s * sy, c * sy]], dtype=np.float64)
    dt = np.result_type(uv, np.float32)

    def lin(a):
        return None if a is None else (np.asarray(a, dtype=np.float64) @ lin_t).astype(dt, copy=False)

    uv_t = lin(uv) + np.asarray(offset, dtype=np.float64).astype(dt)
    return uv_t, lin(duvdx), lin(duvdy)


def uv_to_texel(uv, shape):
    """Continuous texel coordinates ``(x, y)`` of ``uv`` on an image of ``shape = (H, W, ...)``.

    ``x = u W - 0.5``, ``y = (1 - v) H - 0.5`` (texel centres at integers, row 0 at the top).
    Returned as float64 (N,) arrays.
    """
    h, w = shape[0], shape[1]
    uv = np.asarray(uv, dtype=np.float64)
    return uv[:, 0] * w - 0.5, (1.0 - uv[:, 1]) * h - 0.5


def footprint_to_texels(duv, shape):
    """UV footprint (N, 2) -> texel footprint (N, 2) float64 on an image of ``shape`` (``(du W, -dv H)``)."""
    duv = np.asarray(duv, dtype=np.float64)
    return np.stack([duv[:, 0] * shape[1], -duv[:, 1] * shape[0]], axis=1)


# ----------------------------------------------------------------------------- reconstruction

def lookup_nearest(image, uv, wrap="repeat", table=None):
    """Nearest-texel lookup.

    Parameters
    ----------
    image : (H, W, C) float ndarray, or integer codes with ``table``
    uv : (N, 2) float ndarray
        Texture coordinates (see module docstring for the orientation).
    wrap : str or (str, str)
    table : (K,) float ndarray, optional
        Decode table of integer-stored texels (module docstring).

    Returns
    -------
    (N, C) ndarray, dtype of ``image`` (of ``table`` when given).
    """
    wrap = check_wrap(wrap)
    x, y = uv_to_texel(uv, image.shape)
    return _gather(image, np.floor(x + 0.5), np.floor(y + 0.5), wrap, table)


def bilinear_taps(shape, uv, wrap):
    """Where and how much a bilinear lookup reads on an image of ``shape = (H, W, ...)``, whatever its texels:
    ``(flat, weights)``, four (N,) int64 flat texel indices ``row * W + col`` (wrapped) of the taps (y0, x0),
    (y0, x1), (y1, x0), (y1, x1) and their four (N, 1) float64 weights. :func:`bilinear_combine` applies them."""
    wrap = check_wrap(wrap)
    x, y = uv_to_texel(uv, shape)
    x0, y0 = np.floor(x), np.floor(y)
    fx, fy = (x - x0)[:, None], (y - y0)[:, None]
    h, w = shape[0], shape[1]
    # the four taps' wrapped rows and columns once each, gathered by flat index from the (H*W, C) view of a
    # contiguous image (cheaper than four 2-D fancy indexings; the same texels, the same sums)
    ix0, iy0 = np.asarray(x0, dtype=np.int64), np.asarray(y0, dtype=np.int64)
    cx0, cx1 = wrap_index(ix0, w, wrap[0]), wrap_index(ix0 + 1, w, wrap[0])
    ry0, ry1 = wrap_index(iy0, h, wrap[1]) * w, wrap_index(iy0 + 1, h, wrap[1]) * w
    flat = (ry0 + cx0, ry0 + cx1, ry1 + cx0, ry1 + cx1)
    weights = ((1 - fx) * (1 - fy), fx * (1 - fy), (1 - fx) * fy, fx * fy)
    return flat, weights


def bilinear_channels(image, flat, weights, table=None):
    """:func:`bilinear_combine` channel by channel: the lookup as a ``(C, N)`` array (row ``c`` = channel ``c``),
    the same numbers.

    The four taps of every lookup are one gather (a contiguous image's texels viewed as one opaque item each, so
    the gather copies whole texels, 2-4x faster than ``take(axis=0)`` of (N, C) rows), and the weighted sum runs on
    1-D rows: NumPy broadcasting (N, 1) weights over the 3-wide channel axis runs 3 elements at a time. Each
    channel is decoded by ``table`` and summed ``w0 t0 + w1 t1 + w2 t2 + w3 t3`` in float64, then cast, as
    :func:`bilinear_combine` does."""
    h, w = image.shape[:2]
    c = image.shape[2] if image.ndim == 3 else 1
    n = flat[0].shape[0]
    dt = _dtype(image, table)
    if not image.flags.c_contiguous:
        return np.ascontiguousarray(bilinear_combine(image, flat, weights, table).reshape(n, c).T)
    texel = np.dtype((np.void, c * image.dtype.itemsize))
    items = image.reshape(-1).view(texel)                               # (H*W,) one item per texel
    taps = items.take(np.concatenate(flat)).view(image.dtype).reshape(4 * n, c)
    w0, w1, w2, w3 = (np.asarray(x).reshape(-1) for x in weights)
    out = np.empty((c, n), dtype=dt)
    for ch in range(c):
        col = taps[:, ch]
        v = (col if table is None else table.take(col)).reshape(4, n)
        out[ch] = w0 * v[0] + w1 * v[1] + w2 * v[2] + w3 * v[3]
    return out


def bilinear_combine(image, flat, weights, table=None):
    """The bilinear lookup of :func:`bilinear_taps`' ``(flat, weights)`` on ``image`` (H, W, C): ``sum_k
    weights[k] * image[flat[k]]`` (decoded by ``table``), cast to the image's (the table's) dtype."""
    h, w = image.shape[:2]
    if image.flags.c_contiguous:
        out = bilinear_channels(image, flat, weights, table)
        return np.ascontiguousarray(out.T).reshape((flat[0].shape[0],) + image.shape[2:])

    def tap(i):
        return image[i // w, i % w] if table is None else table[image[i // w, i % w]]
    out = (weights[0] * tap(flat[0]) + weights[1] * tap(flat[1]) + weights[2] * tap(flat[2])
           + weights[3] * tap(flat[3]))
    return out.astype(_dtype(image, table), copy=False)


def lookup_bilinear(image, uv, wrap="repeat", table=None):
    """Bilinear interpolation between the four nearest texel centres.

    Same parameters and return as :func:`lookup_nearest`. Weights are computed in float64 and the
    result cast to the image dtype (the table's).
    """
    return bilinear_combine(image, *bilinear_taps(image.shape, uv, wrap), table)


def catmull_rom_weights(f):
    """Catmull-Rom (Keys a = -1/2) weights for the taps at offsets -1, 0, 1, 2 of fraction ``f``.

    Returns ``(N, 4)``; rows sum to 1 and the kernel interpolates (weights (0, 1, 0, 0) at f = 0).
    """
    f = np.asarray(f, dtype=np.float64)
    f2, f3 = f * f, f * f * f
    return np.stack([(-f3 + 2 * f2 - f) / 2,
                     (3 * f3 - 5 * f2 + 2) / 2,
                     (-3 * f3 + 4 * f2 + f) / 2,
                     (f3 - f2) / 2], axis=1)


def lookup_bicubic(image, uv, wrap="repeat", table=None):
    """Bicubic (Catmull-Rom) interpolation over the 4x4 neighbourhood.

    Interpolating and C1. Catmull-Rom overshoots at sharp edges; the result is clamped to the
    min/max of the 16 taps so no new extremes (e.g. negative albedo) appear.
    Same parameters and return as :func:`lookup_nearest`.
    """
    wrap = check_wrap(wrap)
    x, y = uv_to_texel(uv, image.shape)
    x0, y0 = np.floor(x), np.floor(y)
    wx, wy = catmull_rom_weights(x - x0), catmull_rom_weights(y - y0)
    acc = 0.0
    lo = hi = None
    for j in range(4):
        for i in range(4):
            tap = _gather(image, x0 + (i - 1), y0 + (j - 1), wrap, table)
            acc = acc + (wx[:, i] * wy[:, j])[:, None] * tap
            lo = tap if lo is None else np.minimum(lo, tap)
            hi = tap if hi is None else np.maximum(hi, tap)
    return np.clip(acc, lo, hi).astype(_dtype(image, table), copy=False)


RECONSTRUCT = {"nearest": lookup_nearest, "bilinear": lookup_bilinear, "bicubic": lookup_bicubic}


# ----------------------------------------------------------------------------- MIP pyramid

def n_mip_levels(shape):
    """Number of MIP levels of an image of ``shape = (H, W, ...)``: ``1 + floor(log2(max(H, W)))``."""
    return 1 + int(np.floor(np.log2(max(int(shape[0]), int(shape[1])))))


def mip_level_shape(shape, level):
    """``(H_l, W_l) = (max(1, H >> l), max(1, W >> l))``."""
    return max(1, int(shape[0]) >> level), max(1, int(shape[1]) >> level)


def _box_resample_axis(a, n_out, axis):
    """Exact box (area) average of piecewise-constant ``a`` onto ``n_out`` equal cells along ``axis``.

    Output cell ``k`` averages the input over ``[k r, (k + 1) r)`` with ``r = n_in / n_out``,
    using the prefix integral ``P(x) = sum_{i < floor x} a_i + frac(x) a_floor(x)`` (float64).
    """
    a = np.moveaxis(np.asarray(a, dtype=np.float64), axis, 0)
    n_in = a.shape[0]
    if n_out == n_in:
        return np.moveaxis(a, 0, axis)
    cum = np.concatenate([np.zeros((1,) + a.shape[1:]), np.cumsum(a, axis=0)], axis=0)
    edges = np.arange(n_out + 1, dtype=np.float64) * (n_in / n_out)
    i = np.minimum(np.floor(edges).astype(np.int64), n_in - 1)
    frac = (edges - i).reshape((-1,) + (1,) * (a.ndim - 1))
    prefix = cum[i] + frac * a[i]
    out = (prefix[1:] - prefix[:-1]) * (n_out / n_in)
    return np.moveaxis(out, 0, axis)


def build_mip_level(base, level):
    """MIP level ``level`` of ``base`` (H, W, C) by an exact box average of level 0.

    Parameters
    ----------
    base : (H, W, C) float ndarray
        Level 0 (linear values: filter *after* sRGB decoding).
    level : int
        ``0 <= level < n_mip_levels(base.shape)``.

    Returns
    -------
    (H_l, W_l, C) ndarray, dtype of ``base``.

    Notes
    -----
    Every texel of level ``l`` is the mean of the level-0 area it covers (cell edges at multiples
    of ``H / H_l`` and ``W / W_l``), so each level's mean equals the image mean exactly (up to
    rounding) and power-of-two images give the 2x2 box cascade. Cost O(H W C) per level.
    """
    if not 0 <= level < n_mip_levels(base.shape):
        raise ValueError(f"level must be in [0, {n_mip_levels(base.shape)}), got {level}")
    if level == 0:
        return base
    h_l, w_l = mip_level_shape(base.shape, level)
    out = _box_resample_axis(_box_resample_axis(base, h_l, 0), w_l, 1)
    return out.astype(base.dtype, copy=False)


# ----------------------------------------------------------------------------- level selection

def mip_level_isotropic(duvdx, duvdy, shape, footprint_scale=1.0):
    """Continuous MIP level of a footprint (OpenGL / Heckbert isotropic rule).

    Parameters
    ----------
    duvdx, duvdy : (N, 2) float ndarray
        UV change per pixel step in x and y.
    shape : tuple
        Level-0 image shape ``(H, W, ...)``.
    footprint_scale : float
        Filter width in pixel steps (1 = box pixel filter, 2 = pbrt-v4).

    Returns
    -------
    (N,) float64
        ``log2(footprint_scale * max(|dx|, |dy|))`` with ``dx, dy`` in level-0 texels; ``-inf``
        for a zero footprint (pure magnification: bilinear on level 0).
    """
    tx = footprint_to_texels(duvdx, shape)
    ty = footprint_to_texels(duvdy, shape)
    width = footprint_scale * np.maximum(np.hypot(tx[:, 0], tx[:, 1]), np.hypot(ty[:, 0], ty[:, 1]))
    with np.errstate(divide="ignore"):
        return np.where(width > 0, np.log2(np.where(width > 0, width, 1.0)), -np.inf)


def trilinear_levels(lam, n_levels):
    """Split continuous levels into ``(l0, l1, w1)``: blend ``(1 - w1) level[l0] + w1 level[l1]``.

    ``lam <= 0`` -> level 0 only (``w1 = 0``); ``lam >= n_levels - 1`` -> the coarsest level only.
    ``l1 = min(l0 + 1, n_levels - 1)``. All (N,) arrays (int64, int64, float64).
    """
    lam = np.clip(np.asarray(lam, dtype=np.float64), 0.0, n_levels - 1)
    l0 = np.floor(lam).astype(np.int64)
    l1 = np.minimum(l0 + 1, n_levels - 1)
    w1 = np.where(l1 > l0, lam - l0, 0.0)
    return l0, l1, w1


def levels_needed(l0, l1, w1):
    """Sorted list of the MIP levels a trilinear blend actually reads (weight > 0)."""
    used = np.concatenate([l0[w1 < 1.0], l1[w1 > 0.0]])
    return sorted(int(v) for v in np.unique(used))


def lookup_trilinear(levels, uv, duvdx, duvdy, wrap="repeat", footprint_scale=1.0, table=None):
    """Trilinear MIP lookup: bilinear on the two levels around the footprint's level, blended.

    Parameters
    ----------
    levels : sequence of (H_l, W_l, C) ndarrays
        The pyramid; ``levels[l]`` is only indexed for the levels with a non-zero weight, so a
        lazy sequence builds no level that is never read. ``len(levels)`` = number of levels.
    uv, duvdx, duvdy : (N, 2) float ndarray
    wrap : str or (str, str)
    footprint_scale : float
        See :func:`mip_level_isotropic`.
    table : (K,) float ndarray, optional
        Decode table of an integer-stored level 0 (levels >= 1 are float).

    Returns
    -------
    (N, C) ndarray, dtype of ``levels[0]`` (of ``table`` when given).

    Notes
    -----
    The lookups are ordered by their finer level ``l0`` once (a stable counting sort), so each level's
    readers -- those with ``l0 = l`` (weight ``1 - w1``) and those with ``l0 = l - 1`` and ``w1 > 0`` --
    are two contiguous runs of that order: one bilinear call per level read, no per-level mask over all
    lookups. Each lookup gets its ``l0`` term, then its ``l1`` term, as a loop over levels would.
    """
    plan = trilinear_plan(levels[0].shape, len(levels), uv, duvdx, duvdy, wrap, footprint_scale)
    return apply_trilinear_plan(levels, plan, table)


def trilinear_plan(shape, n_levels, uv, duvdx, duvdy, wrap="repeat", footprint_scale=1.0):
    """What :func:`lookup_trilinear` reads on a pyramid of ``n_levels`` over a level 0 of ``shape``, whatever its
    texels: the same for every texture of that shape read at the same UVs with the same wrap and footprint scale
    (a glTF material's base colour, normal, metallic-roughness, occlusion and emissive maps usually are), so it
    is computed once and applied to each (:func:`apply_trilinear_plan`, the same numbers as
    :func:`lookup_trilinear`).

    Returns a tuple ``(n, steps)``: ``n`` lookups and, per MIP level read, ``(level, idx, w, flat, weights)``:
    the lookups ``idx`` (k,) that read it with weight ``w`` (k, 1) and their bilinear taps on that level
    (:func:`bilinear_taps`).
    """
    if len(uv) and not np.any(duvdx) and not np.any(duvdy):
        # no footprint anywhere (shadow-ray crossings, coverage tests, hits without differentials): every lookup is
        # level 0 with weight 1, the plan the general path builds for it (the same arrays), without its sort
        n = len(uv)
        return n, [(0, np.arange(n), np.ones((n, 1))) + bilinear_taps(shape, np.asarray(uv)[np.arange(n)], wrap)]
    lam = mip_level_isotropic(duvdx, duvdy, shape, footprint_scale)
    l0, l1, w1 = trilinear_levels(lam, n_levels)
    order = np.argsort(l0.astype(np.int16), kind="stable")     # levels < 64: a radix sort
    start = np.concatenate([[0], np.cumsum(np.bincount(l0, minlength=n_levels))])
    steps = []
    for lev in range(n_levels):
        own = order[start[lev]:start[lev + 1]]
        up = order[start[lev - 1]:start[lev]] if lev > 0 else own[:0]
        up = up[w1[up] > 0]
        if own.size + up.size == 0:
            continue
        idx = np.concatenate([own, up])
        w = np.concatenate([1.0 - w1[own], w1[up]])[:, None]
        steps.append((lev, idx, w) + bilinear_taps(mip_level_shape(shape, lev), uv[idx], wrap))
    return len(uv), steps


def apply_trilinear_plan(levels, plan, table=None):
    """:func:`lookup_trilinear` of the pyramid ``levels`` from its :func:`trilinear_plan` ((N, C), dtype of level 0,
    of ``table`` when given); only the levels the plan reads are indexed (a lazy pyramid builds no other)."""
    n, steps = plan
    base = levels[0]
    out = np.zeros((base.shape[2], n), dtype=np.float64)     # channel rows (bilinear_channels)
    for lev, idx, w, flat, weights in steps:
        bil = bilinear_channels(levels[lev], flat, weights, table if lev == 0 else None)
        wk = w.reshape(-1)
        for row, b in zip(out, bil):
            row[idx] += wk * b
    return out.T.astype(_dtype(base, table), order="C")


# ----------------------------------------------------------------------------- normal maps

def tangent_frame(ns, dpdu, dpdv):
    """Orthonormal tangent frame ``(t, b)`` around shading normals from the UV derivatives.

    ``t`` is ``dpdu`` made orthogonal to ``ns`` (Gram-Schmidt) and normalised; ``b = ns x t``,
    flipped if needed so that ``b . dpdv >= 0`` (so +v of the texture is +b even on mirrored UVs
    and on back faces whose ``ns`` was turned toward the viewer). Where ``dpdu`` is zero or
    parallel to ``ns`` (no UVs, degenerate triangles) the frame of
    :func:`shaders.vec.coordinate_frame` is used. ``(N, 3)`` arrays, dtype of ``ns``.
    """
    t = normalize(reject(dpdu, ns))
    bad = dot(t, t) < 0.5
    if np.any(bad):
        s_fb, _ = coordinate_frame(ns)
        t = np.where(bad[:, None], s_fb, t)
    b = cross(ns, t)
    flip = dot(b, dpdv) < 0
    b = np.where(flip[:, None], -b, b)
    return t.astype(ns.dtype, copy=False), b.astype(ns.dtype, copy=False)


def decode_normal_map(rgb, strength=1.0, flip_green=False):
    """Tangent-space normal from normal-map texels: ``n = 2 rgb - 1`` (not normalised).

    ``strength`` scales the x and y components (0 gives the flat normal); ``flip_green`` negates
    y for DirectX-style maps (pyrt's convention is OpenGL-style: green = +v = +b).
    """
    n = 2.0 * np.asarray(rgb, dtype=np.float64)[:, :3] - 1.0
    sy = -strength if flip_green else strength
    return n * np.array([strength, sy, 1.0])


def apply_tangent_normal(n_ts, ns, t, b):
    """World shading normal ``normalize(x t + y b + z ns)`` from tangent-space ``n_ts`` (N, 3).

    Exactly ``ns`` where the map is flat (``x = y = 0``, ``z > 0``) and where the result would be
    degenerate (zero length or ``z <= 0``, i.e. a normal in or below the tangent plane).
    """
    n = normalize(n_ts[:, 0:1] * t + n_ts[:, 1:2] * b + n_ts[:, 2:3] * ns)
    keep = ((n_ts[:, 0] == 0) & (n_ts[:, 1] == 0)) | (n_ts[:, 2] <= 0)
    return np.where(keep[:, None], ns, n).astype(ns.dtype, copy=False)
