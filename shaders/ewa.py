"""Anisotropic EWA texture lookups (pbrt-v4 ``MIPMap::EWA``) over a MIP pyramid.

Pure functions of NumPy arrays (no pyrt, no I/O, no module state). The conventions (UV orientation,
footprints, wrap modes, level shapes, integer-stored level 0 with a decode ``table``) are those of
:mod:`pyrt.shaders.textures`, whose helpers this module uses: ellipse half-axes
``footprint_scale / 2 * duv``, the minor axis stretched so that major/minor <= ``max_anisotropy`` (8),
level from the minor half-axis, Gaussian weights ``exp(-2 r^2) - exp(-2)`` inside ``r^2 < 1`` of the
ellipse ``Sigma = M M^T + I`` (texel units, the ``+I`` guarantees at least one texel), blended between
two levels.
"""
import numpy as np

from .textures import (_dtype, _gather, check_wrap, footprint_to_texels, levels_needed, lookup_bilinear, trilinear_levels,
                       uv_to_texel)

#: pbrt-v4 EWA Gaussian falloff exp(-alpha r^2) - exp(-alpha).
EWA_ALPHA = 2.0


def ewa_axes(duvdx, duvdy, shape, footprint_scale=1.5, max_anisotropy=8.0):
    """Ellipse half-axes in level-0 texels and the continuous EWA level (pbrt-v4 ``MIPMap::Filter``).

    Returns
    -------
    major, minor : (N, 2) float64
        Half-axes ``footprint_scale / 2 * duv`` in level-0 texels, ``|major| >= |minor|``, the
        minor axis lengthened so that ``|major| / |minor| <= max_anisotropy``. A zero minor
        axis with a non-zero major axis is replaced by the perpendicular of length
        ``|major| / max_anisotropy``.
    lam : (N,) float64
        ``log2(|minor|)`` (``-inf`` for a zero footprint).
    """
    a = 0.5 * footprint_scale * footprint_to_texels(duvdx, shape)
    b = 0.5 * footprint_scale * footprint_to_texels(duvdy, shape)
    la, lb = np.hypot(a[:, 0], a[:, 1]), np.hypot(b[:, 0], b[:, 1])
    swap = la < lb
    major = np.where(swap[:, None], b, a)
    minor = np.where(swap[:, None], a, b)
    lmaj, lmin = np.maximum(la, lb), np.minimum(la, lb)
    # A degenerate (zero) minor axis: use the perpendicular of the major axis.
    perp = np.stack([-major[:, 1], major[:, 0]], axis=1)
    lmin_safe = np.where(lmin > 0, lmin, 1.0)
    unit_minor = np.where((lmin > 0)[:, None], minor / lmin_safe[:, None],
                          perp / np.where(lmaj > 0, lmaj, 1.0)[:, None])
    new_lmin = np.maximum(lmin, lmaj / max_anisotropy)
    minor = unit_minor * new_lmin[:, None]
    with np.errstate(divide="ignore"):
        lam = np.where(new_lmin > 0, np.log2(np.where(new_lmin > 0, new_lmin, 1.0)), -np.inf)
    return major, minor, lam


def _ewa_level(image, uv, major, minor, wrap, max_taps=2_000_000, table=None):
    """EWA-filter ``image`` (one level) at ``uv`` with half-axes given in *this level's* texels.

    Ragged gather over the texels inside each ellipse: for every lookup and texel row the exact
    x-interval where ``r^2 < 1`` is solved (a quadratic in x), so no tap outside the ellipse is
    visited; all taps of all lookups are flattened into one array (``np.repeat``) and reduced with
    ``np.bincount``. Processed in chunks of at most ``max_taps`` taps. ``table`` decodes integer texels.
    """
    n = len(uv)
    c = image.shape[2]
    out = np.zeros((n, c), dtype=np.float64)
    if n == 0:
        return out
    x, y = uv_to_texel(uv, image.shape)
    # Covariance Sigma = M M^T + I (texels^2); r^2 = d^T Sigma^-1 d.
    sxx = major[:, 0] ** 2 + minor[:, 0] ** 2 + 1.0
    syy = major[:, 1] ** 2 + minor[:, 1] ** 2 + 1.0
    sxy = major[:, 0] * major[:, 1] + minor[:, 0] * minor[:, 1]
    det = sxx * syy - sxy * sxy  # >= 1 since Sigma >= I
    ia, ib, ic = syy / det, -2.0 * sxy / det, sxx / det  # r^2 = ia dx^2 + ib dx dy + ic dy^2
    ey = np.sqrt(syy)  # row half extent of r^2 < 1
    y0 = np.ceil(y - ey).astype(np.int64)
    ny = np.maximum(np.floor(y + ey).astype(np.int64) - y0 + 1, 0)
    # One entry per (lookup, row): the x-interval of the ellipse on that row.
    row_owner = np.repeat(np.arange(n), ny)
    row_k = np.arange(len(row_owner)) - np.repeat(np.cumsum(ny) - ny, ny)
    iy_r = y0[row_owner] + row_k
    dy_r = iy_r - y[row_owner]
    a_r, b_r = ia[row_owner], ib[row_owner] * dy_r
    disc = b_r * b_r - 4.0 * a_r * (ic[row_owner] * dy_r * dy_r - 1.0)
    half = np.sqrt(np.maximum(disc, 0.0)) / (2.0 * a_r)
    mid = x[row_owner] - b_r / (2.0 * a_r)
    ix0_r = np.ceil(mid - half).astype(np.int64)
    nx_r = np.where(disc > 0, np.maximum(np.floor(mid + half).astype(np.int64) - ix0_r + 1, 0), 0)
    taps = np.bincount(row_owner, weights=nx_r, minlength=n).astype(np.int64)
    tap_csum = np.cumsum(taps)
    row_start = np.concatenate([[0], np.cumsum(ny)])
    cut = -np.exp(-EWA_ALPHA)
    start = 0
    while start < n:
        base = tap_csum[start - 1] if start > 0 else 0
        stop = max(int(np.searchsorted(tap_csum, base + max_taps, side="right")), start + 1)
        rs = slice(row_start[start], row_start[stop])
        cnt = nx_r[rs]
        r_idx = np.repeat(np.arange(rs.start, rs.stop), cnt)
        kx = np.arange(len(r_idx)) - np.repeat(np.cumsum(cnt) - cnt, cnt)
        owner = row_owner[r_idx]
        ix = ix0_r[r_idx] + kx
        dx = ix - x[owner]
        dy = dy_r[r_idx]
        r2 = ia[owner] * dx * dx + ib[owner] * dx * dy + ic[owner] * dy * dy
        w = np.where(r2 < 1.0, np.exp(-EWA_ALPHA * np.minimum(r2, 1.0)) + cut, 0.0)
        texels = _gather(image, ix, iy_r[r_idx], wrap, table)
        local = owner - start
        m = stop - start
        wsum = np.bincount(local, weights=w, minlength=m)
        for ch in range(c):
            out[start:stop, ch] = np.bincount(local, weights=w * texels[:, ch], minlength=m)
        out[start:stop] /= np.where(wsum > 0, wsum, 1.0)[:, None]
        start = stop
    return out


def lookup_ewa(levels, uv, duvdx, duvdy, wrap="repeat", footprint_scale=1.5, max_anisotropy=8.0, table=None):
    """Anisotropic EWA lookup (pbrt-v4 style), blended between two MIP levels.

    Parameters
    ----------
    levels : sequence of (H_l, W_l, C) ndarrays
        Lazily indexed pyramid, as in :func:`lookup_trilinear`.
    uv, duvdx, duvdy : (N, 2) float ndarray
    wrap : str or (str, str)
    footprint_scale : float
        Filter width in pixel steps (ellipse half-axes ``footprint_scale / 2 * duv``); default 1.5,
        see :data:`DEFAULT_FOOTPRINT_SCALE`.
    max_anisotropy : float
        Largest allowed major/minor ratio (pbrt-v4: 8).
    table : (K,) float ndarray, optional
        Decode table of an integer-stored level 0 (levels >= 1 are float).

    Returns
    -------
    (N, C) ndarray, dtype of ``levels[0]`` (of ``table`` when given).

    Notes
    -----
    Level ``lambda = log2 |minor|`` (level-0 texels), split as in :func:`trilinear_levels`; at each
    level the half-axes are rescaled by the level's resolution. Lookups with a zero footprint use
    bilinear on level 0 (pbrt does the same); lookups at or beyond the coarsest level use bilinear
    on the coarsest level. Work per lookup is bounded: at level ``floor(lambda)`` the minor
    half-axis is 1-2 texels and the major at most ``2 max_anisotropy``.
    """
    wrap = check_wrap(wrap)
    base = levels[0]
    n_lev = len(levels)
    major, minor, lam = ewa_axes(duvdx, duvdy, base.shape, footprint_scale, max_anisotropy)
    l0, l1, w1 = trilinear_levels(lam, n_lev)
    zero = ~np.isfinite(lam)
    coarsest = lam >= n_lev - 1
    out = np.zeros((len(uv), base.shape[2]), dtype=np.float64)
    idx = np.flatnonzero(zero)
    if len(idx):
        out[idx] = lookup_bilinear(base, uv[idx], wrap, table)
    idx = np.flatnonzero(coarsest)
    if len(idx):
        out[idx] = lookup_bilinear(levels[n_lev - 1], uv[idx], wrap, table if n_lev == 1 else None)
    filt = ~zero & ~coarsest
    for lev in levels_needed(l0[filt], l1[filt], w1[filt]):
        w = np.where(filt & (l0 == lev), 1.0 - w1, 0.0) + np.where(filt & (l1 == lev) & (l1 != l0), w1, 0.0)
        idx = np.flatnonzero(w > 0)
        img = levels[lev]
        sx = img.shape[1] / base.shape[1]
        sy = img.shape[0] / base.shape[0]
        s = np.array([sx, sy])
        out[idx] += w[idx, None] * _ewa_level(img, uv[idx], major[idx] * s, minor[idx] * s, wrap,
                                              table=table if lev == 0 else None)
    return out.astype(_dtype(base, table), copy=False)
