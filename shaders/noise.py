"""Procedural texture kernels: lattice noises, fractal sums, cellular noise and checkerboards.

Pure functions of NumPy arrays. Points ``p`` are ``(N, 2)`` (texture space, e.g. UV times a
frequency) or ``(N, 3)`` (object space); every kernel dispatches on ``p.shape[1]``.

Determinism
-----------
Randomness comes only from a permutation table ``perm`` built by :func:`permutation_table` from an
integer seed (a splitmix64 hash of ``(seed, i)`` sorted with a stable sort: bit-identical across
NumPy versions and platforms) and *passed in*; nothing here draws random numbers or keeps state.
Lattice noises repeat with period 256 along each axis.

Kernels
-------
- :func:`value_noise`: random values in [-1, 1] at lattice points, quintic-smoothed interpolation.
- :func:`perlin`: Perlin's improved gradient noise (Perlin 2002: quintic fade
  ``6t^5 - 15t^4 + 10t^3``, 12 edge gradients in 3D; 8 unit gradients in 2D scaled by sqrt(2)).
  Zero at every lattice point, C2-continuous, approximately in [-1, 1].
- :func:`fbm`: fractal sum ``sum_i a_i perlin(f_i p)`` with ``a_i = gain^i``, ``f_i = lacunarity^i``
  (or explicit arrays); optional per-point footprint fades out octaves above the Nyquist rate
  (``f_i * footprint > 1/2``), like pbrt-v4's ``FBm`` octave clamp.
- :func:`voronoi`: Worley cellular noise: distances to the nearest and second-nearest feature point
  (one jittered point per unit cell, 3^d neighbour search) and a per-cell id in [0, 1).
- :func:`checker` and :func:`checker_box_filtered`: the unit checkerboard, point-sampled and
  analytically box-filtered (exact area fraction of the box covered by odd cells).
"""
import numpy as np

_MASK64 = np.uint64(0xFFFFFFFFFFFFFFFF)

#: 2D gradients: 8 unit directions.
GRAD2 = np.stack([np.cos(np.arange(8) * np.pi / 4), np.sin(np.arange(8) * np.pi / 4)], axis=1)
#: 3D gradients of improved Perlin noise: the 12 cube-edge midpoints padded to 16.
GRAD3 = np.array([[1, 1, 0], [-1, 1, 0], [1, -1, 0], [-1, -1, 0],
                  [1, 0, 1], [-1, 0, 1], [1, 0, -1], [-1, 0, -1],
                  [0, 1, 1], [0, -1, 1], [0, 1, -1], [0, -1, -1],
                  [1, 1, 0], [0, -1, 1], [-1, 1, 0], [0, -1, -1]], dtype=np.float64)


def _splitmix64(x):
    """splitmix64 finaliser on uint64 arrays (wrapping arithmetic)."""
    x = (x + np.uint64(0x9E3779B97F4A7C15)) & _MASK64
    x = ((x ^ (x >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)) & _MASK64
    x = ((x ^ (x >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)) & _MASK64
    return x ^ (x >> np.uint64(31))


def permutation_table(seed):
    """Permutation of 0..255 derived from ``seed``, doubled to length 512 (int64).

    Parameters
    ----------
    seed : int
        Any Python integer (reduced modulo 2^64).

    Returns
    -------
    (512,) int64 ndarray
        ``perm[i] == perm[i + 256]``; ``perm[:256]`` is a permutation of ``range(256)``.
    """
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)):
        raise TypeError(f"seed must be an integer, got {seed!r}")
    s = np.uint64(int(seed) % (1 << 64))
    with np.errstate(over="ignore"):
        keys = _splitmix64(_splitmix64(np.full(256, s, dtype=np.uint64)) ^ np.arange(256, dtype=np.uint64))
    p = np.argsort(keys, kind="stable").astype(np.int64)
    return np.concatenate([p, p])


def _check_p(p):
    p = np.asarray(p)
    if p.ndim != 2 or p.shape[1] not in (2, 3):
        raise ValueError(f"p must be (N, 2) or (N, 3), got shape {p.shape}")
    return p


def _check_perm(perm):
    perm = np.asarray(perm)
    if perm.shape != (512,):
        raise ValueError(f"perm must be a (512,) table from permutation_table(seed), got shape {perm.shape}")
    return perm


def fade(t):
    """Perlin's quintic fade ``6t^5 - 15t^4 + 10t^3`` (C2, zero slope and curvature at 0 and 1)."""
    return t * t * t * (t * (t * 6.0 - 15.0) + 10.0)


def _lattice(p):
    """Integer cell (wrapped to 0..255, int64) and fractional position (float64) of each point."""
    pf = np.floor(p.astype(np.float64))
    return pf.astype(np.int64) & 255, p.astype(np.float64) - pf


def _hash(perm, cells):
    """Nested permutation hash of integer lattice coordinates ``cells`` (list of (N,) arrays in 0..255)."""
    h = perm[cells[0]]
    for c in cells[1:]:
        h = perm[h + c]
    return h


def _corners(d):
    """Offsets of the 2^d cell corners, as tuples of 0/1."""
    return [tuple((k >> a) & 1 for a in range(d)) for k in range(1 << d)]


def _interpolate(values, f):
    """Multilinear blend of corner ``values`` (dict corner -> (N,)) with weights ``fade(f)``."""
    d = f.shape[1]
    w = fade(f)
    out = 0.0
    for corner, v in values.items():
        wt = 1.0
        for a in range(d):
            wt = wt * (w[:, a] if corner[a] else 1.0 - w[:, a])
        out = out + wt * v
    return out


def value_noise(p, perm):
    """Value noise: hashed values in [-1, 1] at lattice points, quintic interpolation between.

    Parameters
    ----------
    p : (N, 2) or (N, 3) float ndarray
    perm : (512,) int ndarray
        From :func:`permutation_table`.

    Returns
    -------
    (N,) ndarray in [-1, 1], dtype of ``p`` (float64 for integer input).
    """
    p = _check_p(p)
    perm = _check_perm(perm)
    cell, f = _lattice(p)
    vals = {}
    for corner in _corners(p.shape[1]):
        h = _hash(perm, [(cell[:, a] + corner[a]) & 255 for a in range(p.shape[1])])
        vals[corner] = h / 127.5 - 1.0
    return _interpolate(vals, f).astype(np.result_type(p, np.float32), copy=False)


def perlin(p, perm):
    """Perlin improved gradient noise in 2D or 3D.

    Parameters
    ----------
    p : (N, 2) or (N, 3) float ndarray
    perm : (512,) int ndarray
        From :func:`permutation_table`.

    Returns
    -------
    (N,) ndarray, dtype of ``p`` (float64 for integer input)
        Exactly zero at integer lattice points; C2-continuous; approximately in [-1, 1]
        (3D: Perlin 2002 edge gradients; 2D: unit gradients, result scaled by sqrt(2)).
    """
    p = _check_p(p)
    perm = _check_perm(perm)
    d = p.shape[1]
    cell, f = _lattice(p)
    grads = GRAD2 if d == 2 else GRAD3
    vals = {}
    for corner in _corners(d):
        h = _hash(perm, [(cell[:, a] + corner[a]) & 255 for a in range(d)])
        g = grads[h & (len(grads) - 1)]
        vals[corner] = np.einsum("ij,ij->i", g, f - np.asarray(corner, dtype=np.float64))
    out = _interpolate(vals, f)
    if d == 2:
        out = out * np.sqrt(2.0)
    return out.astype(np.result_type(p, np.float32), copy=False)


def fbm(p, perm, octaves=5, *, lacunarity=2.0, gain=0.5, amplitudes=None, frequencies=None,
        footprint=None, basis=None):
    """Fractal sum ``sum_i a_i basis(f_i p)`` (fractional Brownian motion).

    Parameters
    ----------
    p : (N, 2) or (N, 3) float ndarray
    perm : (512,) int ndarray
    octaves : int
        Number of terms (ignored when ``amplitudes`` is given).
    lacunarity, gain : float
        ``f_i = lacunarity^i``, ``a_i = gain^i`` unless given explicitly.
    amplitudes, frequencies : sequence of float, optional
        Explicit ``a_i`` and ``f_i`` (same length).
    footprint : (N,) float ndarray, optional
        Filter width in units of ``p`` (e.g. the length of ``dp/dx``). Octave ``i`` is weighted by
        ``1 - smoothstep(f_i * footprint; 1/4, 1/2)``: zero (its mean) above the Nyquist rate.
    basis : callable, optional
        ``basis(p, perm) -> (N,)``; default :func:`perlin`.

    Returns
    -------
    (N,) ndarray, dtype of ``p``.
    """
    p = _check_p(p)
    basis = perlin if basis is None else basis
    if amplitudes is None:
        if not isinstance(octaves, (int, np.integer)) or octaves < 1:
            raise ValueError(f"octaves must be a positive integer, got {octaves!r}")
        amplitudes = gain ** np.arange(octaves, dtype=np.float64)
        if frequencies is None:
            frequencies = lacunarity ** np.arange(octaves, dtype=np.float64)
    amplitudes = np.asarray(amplitudes, dtype=np.float64)
    frequencies = np.asarray(frequencies if frequencies is not None else 2.0 ** np.arange(len(amplitudes)),
                             dtype=np.float64)
    if amplitudes.shape != frequencies.shape or amplitudes.ndim != 1:
        raise ValueError("amplitudes and frequencies must be 1-D sequences of the same length")
    out = np.zeros(len(p), dtype=np.float64)
    for a, fr in zip(amplitudes, frequencies):
        w = a
        if footprint is not None:
            x = np.clip((fr * np.asarray(footprint, dtype=np.float64) - 0.25) / 0.25, 0.0, 1.0)
            w = a * (1.0 - x * x * (3.0 - 2.0 * x))
            if np.all(w == 0):
                continue
        out += w * basis(p.astype(np.float64) * fr, perm)
    return out.astype(np.result_type(p, np.float32), copy=False)


def voronoi(p, perm, jitter=1.0):
    """Worley cellular noise.

    One feature point per unit cell at ``cell + 0.5 + jitter * (r - 0.5)`` with ``r`` in [0, 1)^d
    hashed from the cell; the nearest two are searched in the 3^d cells around ``p``.

    Parameters
    ----------
    p : (N, 2) or (N, 3) float ndarray
    perm : (512,) int ndarray
    jitter : float in [0, 1]
        0 gives a regular grid of points at cell centres.

    Returns
    -------
    f1, f2 : (N,) float64
        Euclidean distance to the nearest and second-nearest feature point. ``f1`` is exact and
        1-Lipschitz whenever the nearest point lies in the 3^d neighbourhood (always for
        ``jitter <= 0.5``, and in practice for 1); ``f2`` may be overestimated rarely.
    cell_id : (N,) float64 in [0, 1)
        A per-cell random value of the nearest feature point (for per-cell colours).
    """
    p = _check_p(p)
    perm = _check_perm(perm)
    if not 0.0 <= jitter <= 1.0:
        raise ValueError(f"jitter must be in [0, 1], got {jitter!r}")
    d = p.shape[1]
    pf = np.floor(p.astype(np.float64))
    fpos = p.astype(np.float64) - pf
    cell = pf.astype(np.int64)
    n = len(p)
    f1 = np.full(n, np.inf)
    f2 = np.full(n, np.inf)
    ident = np.zeros(n)
    offsets = np.stack(np.meshgrid(*([np.arange(-1, 2)] * d), indexing="ij"), axis=-1).reshape(-1, d)
    for off in offsets:
        c = (cell + off) & 255
        h = _hash(perm, [c[:, a] for a in range(d)])
        r = []
        hk = h
        for _ in range(d):
            hk = perm[hk + 17]  # walk the table for d values per cell
            r.append(hk / 256.0)
        r = np.stack(r, axis=1)
        feature = off + 0.5 + jitter * (r - 0.5)
        dist = np.sqrt(np.sum((feature - fpos) ** 2, axis=1))
        closer = dist < f1
        f2 = np.where(closer, f1, np.minimum(f2, dist))
        ident = np.where(closer, (perm[(h + 101) & 511] * 256 + perm[(hk + 37) & 511]) / 65536.0, ident)
        f1 = np.where(closer, dist, f1)
    return f1, f2, ident


# ----------------------------------------------------------------------------- checkerboard

def checker(p):
    """Unit checkerboard: 1 where ``sum(floor(p_i))`` is odd, else 0. ``(N, d)`` -> ``(N,)`` float64."""
    p = _check_p(p)
    return (np.sum(np.floor(p.astype(np.float64)), axis=1) % 2.0).astype(np.float64)


def _odd_integral(x):
    """Integral over [0, x] of the 1-D indicator ``floor(t) mod 2 == 1`` (pbrt-v4 ``bumpInt``)."""
    h = np.floor(x / 2.0)
    return h + np.maximum(x - 2.0 * h - 1.0, 0.0)


def checker_box_filtered(p, half_width):
    """Checkerboard averaged over the axis-aligned box ``p +- half_width`` (exact).

    Parameters
    ----------
    p : (N, d) float ndarray, d in {2, 3}
    half_width : (N, d) float ndarray
        Box half-widths per axis (>= 0), in units of ``p``.

    Returns
    -------
    (N,) float64 in [0, 1]
        The fraction of the box covered by odd cells. With the square wave ``s = 1 - 2 [odd]``,
        ``[odd cell] = (1 - prod_i s(p_i)) / 2`` and a box average factorises over axes, so the
        result is ``(1 - prod_i mean_i(s)) / 2`` with each 1-D mean from the triangle-wave integral
        :func:`_odd_integral`. Axes with a half-width below 1e-9 (cell units) are point-sampled.

    Notes
    -----
    Coordinates are first reduced modulo 2 (the period) to avoid cancellation far from the origin.
    """
    p = _check_p(p).astype(np.float64)
    hw = np.abs(np.asarray(half_width, dtype=np.float64))
    if hw.shape != p.shape:
        raise ValueError(f"half_width must have the shape of p {p.shape}, got {hw.shape}")
    c = p - 2.0 * np.floor(p / 2.0)  # in [0, 2)
    tiny = hw < 1e-9  # relative to a cell of size 1: below this the box is a point
    hw_safe = np.where(tiny, 1.0, hw)
    mean_odd = (_odd_integral(c + hw_safe) - _odd_integral(c - hw_safe)) / (2.0 * hw_safe)
    point_odd = np.floor(c) % 2.0
    s = 1.0 - 2.0 * np.where(tiny, point_odd, mean_odd)
    return np.clip((1.0 - np.prod(s, axis=1)) / 2.0, 0.0, 1.0)
