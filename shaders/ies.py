"""IES LM-63 photometric data (type C): parse, write, interpolate, integrate.

Pure functions over strings and arrays (reading the file is the caller's job, see
:class:`pyrt.lights.IESLight`).

Type C photometry (ANSI/IES LM-63-2002, sec. on photometric types)
-------------------------------------------------------------------
The luminaire's frame has +Z up; the *vertical angle* V is measured from the nadir (V = 0 points
straight down, -Z; V = 90 horizontal; V = 180 straight up) and the *horizontal angle* H around
the Z axis, counter-clockwise seen from above, with H = 0 along the luminaire's +X (its length)
and H = 90 along +Y. Candela values are given on a grid of V (increasing, within [0, 180]) times
H (increasing). The last horizontal angle encodes the symmetry:

- a single H = 0: rotationally symmetric (no H dependence);
- 0 ... 90: symmetric in each quadrant (mirror about the 0-180 and the 90-270 planes);
- 0 ... 180: bilaterally symmetric about the 0-180 plane;
- 90 ... 270: bilaterally symmetric about the 90-270 plane (LM-63-2002);
- 0 ... 360 (or any last angle above 180): full data; a last angle below 360 wraps to H = 0.

Outside the tabulated vertical range (e.g. above V = 90 for a downlight tabulated 0-90) the
intensity is 0. Interpolation is bilinear in (V, H) degrees on the tabulated grid after folding
H by the symmetry; :func:`ies_flux` integrates exactly that interpolant over the sphere.
"""
from __future__ import annotations

from typing import NamedTuple
import re

import numpy as np

from .lights import piecewise_linear_sin_weights


class IESProfile(NamedTuple):
    """Parsed type C photometric data.

    ``candela`` (H, V) float64 already includes the candela multiplier, the ballast factor and the
    ballast-lamp photometric factor. ``lumens_per_lamp`` is -1 for absolute photometry.
    """

    vertical_angles: np.ndarray     # (V,) degrees, increasing, in [0, 180]
    horizontal_angles: np.ndarray   # (H,) degrees, increasing
    candela: np.ndarray             # (H, V) cd
    lumens_per_lamp: float
    n_lamps: int
    keywords: dict
    units: int                      # 1 feet, 2 metres (luminous opening dimensions)
    dimensions: tuple               # (width, length, height)
    input_watts: float


def _numbers(tokens, n, what):
    if len(tokens) < n:
        raise ValueError(f"IES: expected {n} values for {what}, found only {len(tokens)}")
    out = np.array([float(t) for t in tokens[:n]], dtype=np.float64)
    if not np.all(np.isfinite(out)):
        raise ValueError(f"IES: non-finite value in {what}")
    del tokens[:n]
    return out


def parse_ies(text):
    """Parse the text of an IES LM-63 file (1986, 1991, 1995, 2002 variants) with type C photometry.

    Parameters
    ----------
    text : str
        The file's contents.

    Returns
    -------
    IESProfile

    Raises
    ------
    ValueError
        Naming the problem: missing ``TILT=`` line, ``TILT=<file>`` (unsupported), photometric type
        other than C (1), wrong counts, non-increasing angles, vertical angles outside [0, 180],
        negative candela values.
    """
    lines = text.replace("\r\n", "\n").replace("\r", "\n").split("\n")
    keywords = {}
    tilt_at = None
    last_key = None
    for i, line in enumerate(lines):
        s = line.strip()
        if s.upper().startswith("TILT="):
            tilt_at = i
            break
        m = re.match(r"\[([^\]]+)\]\s*(.*)", s)
        if m:
            key = m.group(1).strip().upper()
            if key == "MORE" and last_key is not None:
                keywords[last_key] += "\n" + m.group(2)
            else:
                keywords[key] = m.group(2)
                last_key = key
    if tilt_at is None:
        raise ValueError("IES: no 'TILT=' line found (is this an IES LM-63 file?)")
    tilt = lines[tilt_at].strip()[5:].strip()
    tokens = [t for t in re.split(r"[\s,]+", "\n".join(lines[tilt_at + 1:])) if t]
    if tilt.upper() == "INCLUDE":
        _numbers(tokens, 1, "TILT lamp-to-luminaire geometry")
        n_pairs = int(_numbers(tokens, 1, "TILT pair count")[0])
        _numbers(tokens, 2 * n_pairs, "TILT angles and multipliers")
    elif tilt.upper() != "NONE":
        raise ValueError(f"IES: TILT={tilt} refers to a separate tilt file, which is not supported; "
                         "use TILT=NONE or TILT=INCLUDE")
    (n_lamps, lumens, mult, n_v, n_h, ptype, units, width, length, height) = _numbers(tokens, 10, "the lamp line")
    ballast, ballast_lamp, watts = _numbers(tokens, 3, "the ballast line")
    if int(ptype) != 1:
        kind = {2: "B", 3: "A"}.get(int(ptype), str(int(ptype)))
        raise ValueError(f"IES: photometric type {kind} is not supported (only type C, code 1)")
    n_v, n_h = int(n_v), int(n_h)
    if n_v < 2 or n_h < 1:
        raise ValueError(f"IES: need >= 2 vertical and >= 1 horizontal angles, got {n_v} and {n_h}")
    v = _numbers(tokens, n_v, "the vertical angles")
    h = _numbers(tokens, n_h, "the horizontal angles")
    cd = _numbers(tokens, n_v * n_h, "the candela values").reshape(n_h, n_v)
    if np.any(np.diff(v) <= 0) or np.any(np.diff(h) <= 0):
        raise ValueError("IES: vertical and horizontal angles must be strictly increasing")
    if v[0] < 0 or v[-1] > 180:
        raise ValueError(f"IES: vertical angles must lie in [0, 180] for type C, got {v[0]} ... {v[-1]}")
    if h[0] < 0 or h[-1] > 360:
        raise ValueError(f"IES: horizontal angles must lie in [0, 360], got {h[0]} ... {h[-1]}")
    if np.any(cd < 0):
        raise ValueError("IES: negative candela values")
    scale = mult * ballast * ballast_lamp
    return IESProfile(vertical_angles=v, horizontal_angles=h, candela=cd * scale, lumens_per_lamp=float(lumens),
                      n_lamps=int(n_lamps), keywords=keywords, units=int(units),
                      dimensions=(float(width), float(length), float(height)), input_watts=float(watts))


def _wrap_values(values, per_line=10):
    vals = [f"{x:.9g}" for x in np.asarray(values, dtype=np.float64).ravel()]
    return "\n".join(" ".join(vals[i:i + per_line]) for i in range(0, len(vals), per_line))


def format_ies(vertical_angles, horizontal_angles, candela, *, keywords=None, lumens_per_lamp=-1.0,
               input_watts=0.0):
    """Write type C photometric data as LM-63-2002 text (``TILT=NONE``, one lamp, multiplier 1,
    zero-size opening in metres).

    Parameters
    ----------
    vertical_angles : (V,) float, degrees
    horizontal_angles : (H,) float, degrees
    candela : (H, V) float
    keywords : dict, optional
        ``{"TEST": ..., "MANUFAC": ...}`` written as ``[KEY] value`` lines.
    lumens_per_lamp : float
        -1 for absolute photometry (the default).

    Returns
    -------
    str
    """
    v = np.asarray(vertical_angles, dtype=np.float64)
    h = np.asarray(horizontal_angles, dtype=np.float64)
    cd = np.asarray(candela, dtype=np.float64)
    if cd.shape != (h.size, v.size):
        raise ValueError(f"candela must have shape (H, V) = ({h.size}, {v.size}), got {cd.shape}")
    out = ["IESNA:LM-63-2002"]
    for k, val in (keywords or {}).items():
        out.append(f"[{k}] {val}")
    out.append("TILT=NONE")
    out.append(f"1 {lumens_per_lamp:.9g} 1 {v.size} {h.size} 1 2 0 0 0")
    out.append(f"1 1 {input_watts:.6g}")
    out.append(_wrap_values(v))
    out.append(_wrap_values(h))
    for row in cd:
        out.append(_wrap_values(row))
    return "\n".join(out) + "\n"


def ies_angles(w_local):
    """Type C angles (degrees) of unit directions in the luminaire frame (+z up, +x = H 0, +y = H 90).

    Returns ``(V, H)``: V = arccos(-z) from the nadir, H = atan2(y, x) in [0, 360).
    """
    V = np.degrees(np.arccos(np.clip(-w_local[:, 2], -1.0, 1.0)))
    H = np.mod(np.degrees(np.arctan2(w_local[:, 1], w_local[:, 0])), 360.0)
    return V, H


def _symmetry(h):
    """Symmetry name of a horizontal-angle array (see the module docstring)."""
    if h.size == 1:
        return "rotational"
    if h[0] == 0 and h[-1] == 90:
        return "quadrant"
    if h[0] == 0 and h[-1] == 180:
        return "bilateral"
    if h[0] == 90 and h[-1] == 270:
        return "bilateral_90"
    if h[0] == 0 and h[-1] > 180:
        return "full"
    raise ValueError(f"IES: unsupported horizontal angle range {h[0]} ... {h[-1]} "
                     "(expected 0, 0-90, 0-180, 90-270 or 0-360)")


def _fold_h(h_deg, h):
    """Fold horizontal angles in [0, 360) into the tabulated range; returns the angles and the
    (possibly wrapped) horizontal grid and a column index map for it."""
    sym = _symmetry(h)
    x = np.mod(h_deg, 360.0)
    cols = np.arange(h.size)
    if sym == "quadrant":
        x = np.where(x > 180.0, 360.0 - x, x)
        x = np.where(x > 90.0, 180.0 - x, x)
    elif sym == "bilateral":
        x = np.where(x > 180.0, 360.0 - x, x)
    elif sym == "bilateral_90":
        x = np.where((x < 90.0) | (x > 270.0), np.mod(180.0 - x, 360.0), x)
    elif sym == "full" and h[-1] < 360.0:
        h = np.append(h, 360.0)
        cols = np.append(cols, 0)
    return x, h, cols


def _interp_index(grid, x):
    """Segment index and fraction of ``x`` on an increasing ``grid`` (clamped to the ends)."""
    i = np.clip(np.searchsorted(grid, x, side="right") - 1, 0, grid.size - 2)
    t = np.clip((x - grid[i]) / (grid[i + 1] - grid[i]), 0.0, 1.0)
    return i, t


def ies_candela(profile, V_deg, H_deg):
    """Bilinearly interpolated candela of ``profile`` toward type C angles (degrees).

    Parameters
    ----------
    profile : IESProfile
    V_deg, H_deg : (N,) float ndarray
        Vertical angle from the nadir, horizontal angle (any value; folded by the symmetry).

    Returns
    -------
    (N,) float64 ndarray
        Candela; 0 outside the tabulated vertical range.
    """
    v, h, cd = profile.vertical_angles, profile.horizontal_angles, profile.candela
    V = np.asarray(V_deg, dtype=np.float64)
    iv, tv = _interp_index(v, V)
    inside = (V >= v[0]) & (V <= v[-1])
    if h.size == 1:
        out = (1 - tv) * cd[0, iv] + tv * cd[0, iv + 1]
    else:
        x, hg, cols = _fold_h(np.asarray(H_deg, dtype=np.float64), h)
        ih, th = _interp_index(hg, x)
        c0, c1 = cols[ih], cols[ih + 1]
        out = ((1 - th) * ((1 - tv) * cd[c0, iv] + tv * cd[c0, iv + 1])
               + th * ((1 - tv) * cd[c1, iv] + tv * cd[c1, iv + 1]))
    return np.where(inside, out, 0.0)


def ies_flux(profile):
    """Total luminous flux (lm) of the profile: the exact integral of :func:`ies_candela` over the sphere.

    ``Phi = int_0^{2 pi} int_0^pi I(V, H) sin V dV dH``; the interpolant is linear in V and in H on each
    cell, so V is integrated with :func:`shaders.lights.piecewise_linear_sin_weights` and H with the
    trapezoid rule over the tabulated range, times the number of mirrored copies the symmetry implies.
    """
    v, h, cd = profile.vertical_angles, profile.horizontal_angles, profile.candela
    wv = piecewise_linear_sin_weights(np.radians(v))
    per_h = cd @ wv                                   # (H,) int I sin V dV
    if h.size == 1:
        return float(2 * np.pi * per_h[0])
    sym = _symmetry(h)
    hr = np.radians(h)
    if sym == "full" and h[-1] < 360.0:
        hr = np.append(hr, 2 * np.pi)
        per_h = np.append(per_h, per_h[0])
    seg = np.diff(hr) * 0.5 * (per_h[:-1] + per_h[1:])
    copies = {"quadrant": 4, "bilateral": 2, "bilateral_90": 2, "full": 1}[sym]
    return float(copies * seg.sum())
