"""Tone mapping operators: scene-linear radiance -> display-linear [0, 1].

All operators first multiply by ``2**exposure`` (exposure in stops). They return display-linear
values; apply :func:`shaders.color.srgb_encode` afterwards for an 8-bit PNG.
"""
import numpy as np

from .color import luminance, xyz_from_rgb_matrix


def linear(L, exposure=0.0):
    """Scale by ``2**exposure`` and clamp to [0, 1]."""
    return np.clip(L * (2.0 ** exposure), 0.0, 1.0)


def film(L, exposure=0.0):
    """Exponential "film" curve ``1 - exp(-L * 2**exposure)`` per channel."""
    return 1.0 - np.exp(-np.maximum(L, 0.0) * (2.0 ** exposure))


def reinhard(L, exposure=0.0, L_white=None):
    """Extended Reinhard on luminance: ``Ld = Y (1 + Y / L_white^2) / (1 + Y)``, colour scaled by Ld / Y.

    ``L_white`` is the smallest luminance mapped to white (default: infinity, i.e. ``Y / (1 + Y)``).
    Reinhard et al. 2002, "Photographic Tone Reproduction for Digital Images", eq. 4.
    """
    L = np.maximum(L, 0.0) * (2.0 ** exposure)
    Y = luminance(L)
    if L_white is None:
        Yd = Y / (1.0 + Y)
    else:
        Yd = Y * (1.0 + Y / (L_white * L_white)) / (1.0 + Y)
    scale = np.divide(Yd, Y, out=np.zeros_like(Y), where=Y > 0)
    return np.clip(L * scale[..., None], 0.0, 1.0)


def reinhard_rgb(L, exposure=0.0):
    """Per-channel Reinhard ``L / (1 + L)`` on each of R, G, B independently (course note 003).

    Unlike :func:`reinhard` (luminance form, hue preserved) each channel saturates on its own, so bright
    colours drift toward white. Reinhard et al. 2002, eq. 3, applied per channel as in LearnOpenGL's
    "HDR" chapter (``mapped = hdrColor / (hdrColor + vec3(1.0))``).
    """
    L = np.maximum(L, 0.0) * (2.0 ** exposure)
    return L / (1.0 + L)


# ----------------------------------------------------------------------------- Khronos PBR Neutral

#: PBR Neutral's constants: F90 = 0.04 (Fresnel at normal incidence of IOR 1.5), the start of highlight
#: compression K_s = 0.8 - F90 and the desaturation speed K_d.
PBR_NEUTRAL_F90 = 0.04
PBR_NEUTRAL_KS = 0.8 - PBR_NEUTRAL_F90
PBR_NEUTRAL_KD = 0.15


def pbr_neutral(L, exposure=0.0):
    """Khronos PBR Neutral tone mapper (the glTF Sample Viewer's and model-viewer's default).

    With ``c = max(L, 0) * 2**exposure``, ``x = min(R, G, B)``, ``f = x - x^2 / (4 F90)`` for
    ``x <= 2 F90`` else ``F90``, ``p = max(c - f)``: the output is ``c - f`` while ``p <= K_s``, else
    ``(c - f) p_n / p g + p_n (1 - g)`` with ``p_n = 1 - (1 - K_s)^2 / (p + 1 - 2 K_s)`` and
    ``g = 1 / (K_d (p - p_n) + 1)``. Base colours with every channel in [0.08, 0.8] come out as
    ``c - 0.04`` exactly (a shiny dielectric facing the camera under unit white light reproduces its
    base colour); no hue shift; brighter colours compress toward white, which is reached only in the
    limit. Specification: KhronosGroup/ToneMapping, ``PBR_Neutral/README.md``.

    Parameters
    ----------
    L : (..., 3) float ndarray
        Linear Rec. 709 radiance.
    exposure : float
        Stops applied first.

    Returns
    -------
    (..., 3) ndarray
        Display-linear values in [0, 1]; dtype preserved.
    """
    c = np.maximum(L, 0.0) * (2.0 ** exposure)
    # min / max of the three channels pairwise (exact, as the axis reductions, which are slow over an axis of 3)
    x = np.minimum(np.minimum(c[..., 0:1], c[..., 1:2]), c[..., 2:3])
    f = np.where(x <= 2 * PBR_NEUTRAL_F90, x - x * x / (4 * PBR_NEUTRAL_F90), PBR_NEUTRAL_F90)
    c = c - f
    p = np.maximum(np.maximum(c[..., 0:1], c[..., 1:2]), c[..., 2:3])
    # the highlight compression only where it applies (p > K_s, NaN included): the same operations on those pixels
    hi = ~(p[..., 0] <= PBR_NEUTRAL_KS)
    if np.any(hi):
        ch, ph = c[hi], p[hi]
        d = 1.0 - PBR_NEUTRAL_KS
        pn = 1.0 - d * d / (ph + d - PBR_NEUTRAL_KS)
        g = 1.0 / (PBR_NEUTRAL_KD * (ph - pn) + 1.0)
        ratio = np.divide(pn, ph, out=np.ones_like(ph), where=ph > 0)
        c[hi] = ch * ratio * g + pn * (1.0 - g)
    return np.clip(c, 0.0, 1.0, out=c)


# ----------------------------------------------------------------------------- ACES (Filament's)
#
# Filament's ``ACESToneMapper`` (google/filament, ``filament/src/ToneMapper.cpp``, ``aces::ACES``): the
# ACES 1.0 reference rendering transform's glow, red-modifier and desaturation steps in AP0/AP1, then a
# rational fit of RRT + ODT (RGB monitor, 100 nits, dim surround; colour-science's colour-unity fit),
# the dim-surround gamma and the ODT desaturation. Filament feeds it Rec. 2020; the input here is
# Rec. 709, so the in and out matrices go Rec. 709 -> XYZ -> AP1 -> AP0 and AP1 -> XYZ -> Rec. 709 (the
# Rec. 2020 leg cancels). Matrices are built from the primaries (:func:`shaders.color.xyz_from_rgb_matrix`)
# and, as in Filament, without chromatic adaptation between D65 and the ACES white.

_XYZ_FROM_709 = xyz_from_rgb_matrix("rec709")
_XYZ_FROM_AP1 = xyz_from_rgb_matrix("ap1")
_AP1_FROM_XYZ = np.linalg.inv(_XYZ_FROM_AP1)
_AP0_FROM_709 = np.linalg.inv(xyz_from_rgb_matrix("ap0")) @ _XYZ_FROM_709
_AP1_FROM_AP0 = _AP1_FROM_XYZ @ xyz_from_rgb_matrix("ap0")
_709_FROM_AP1 = np.linalg.inv(_XYZ_FROM_709) @ _XYZ_FROM_AP1
_LUMINANCE_AP1 = _XYZ_FROM_AP1[1]
_HALF_MAX = 65504.0                     # Filament clamps to the largest half float

#: The RRT + ODT rational fit ``x (a x + b) / (x (c x + d) + e)`` Filament uses.
ACES_FIT = (2.785085, 0.107772, 2.936045, 0.887122, 0.806889)


def _smoothstep(e0, e1, x):
    t = np.clip((x - e0) / (e1 - e0), 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


def aces(L, exposure=0.0, brightness=1.0):
    """Filament's ACES tone mapper (``ACESToneMapper``; ``brightness=1/0.6`` is its ``ACESLegacyToneMapper``).

    In AP0: glow (+5 % at most for saturated dark colours), red modifier (hue 0 +- 67.5 degrees, scale
    0.82, pivot 0.03); in AP1, clamped to [0, 65504]: desaturation to 96 %, ``* brightness``, the fit
    :data:`ACES_FIT`, the dim-surround gamma 0.9811 on Y in xyY, desaturation to 93 %; back to
    Rec. 709 and clipped to [0, 1] (Filament clips later in its pipeline). Grey 0.18 maps to about
    (0.106, 0.108, 0.111) display-linear, grey 1 to (0.65, 0.63, 0.60). The fit saturates at
    2.785085 / 2.936045 = 0.949 per AP1 channel, i.e. at the ACES white (~D60) and not at D65: as in
    Filament (no chromatic adaptation), bright greys go warm, toward (0.994, 0.944, 0.869), and pure
    white is never reached. A deliberate fidelity to Filament; use ``pbr_neutral`` for neutral whites.

    Parameters
    ----------
    L : (..., 3) float ndarray
        Linear Rec. 709 radiance.
    exposure : float
        Stops applied first.
    brightness : float
        Multiplier in AP1 before the fit (Filament's legacy look: 1 / 0.6).

    Returns
    -------
    (..., 3) ndarray
        Display-linear Rec. 709 in [0, 1]; dtype preserved.
    """
    dt = np.result_type(L, np.float32)
    c = np.maximum(L, 0.0) * (2.0 ** exposure)
    ap0 = c @ _AP0_FROM_709.T.astype(dt)
    r, g, b = ap0[..., 0], ap0[..., 1], ap0[..., 2]
    mi, ma = np.min(ap0, axis=-1), np.max(ap0, axis=-1)
    saturation = (np.maximum(ma, 1e-5) - np.maximum(mi, 1e-5)) / np.maximum(ma, 1e-2)
    chroma = np.sqrt(np.maximum(b * (b - g) + g * (g - r) + r * (r - b), 0.0))
    yc = (r + g + b + 1.75 * chroma) / 3.0
    # glow: sigmoid_shaper((saturation - 0.4) / 0.2), gain 0.05, mid 0.08
    xs = (saturation - 0.4) / 0.2
    t = np.maximum(1.0 - np.abs(xs / 2.0), 0.0)
    s = (1.0 + np.sign(xs) * (1.0 - t * t)) / 2.0
    gain, mid = 0.05 * s, 0.08
    glow = np.where(yc <= 2.0 / 3.0 * mid, gain,
                    np.where(yc >= 2.0 * mid, 0.0, gain * (mid / np.maximum(yc, 1e-30) - 0.5)))
    ap0 = ap0 * (1.0 + glow)[..., None]
    # red modifier: hue in degrees (0 for neutrals), centred on 0, width 135
    r, g, b = ap0[..., 0], ap0[..., 1], ap0[..., 2]
    neutral = (r == g) & (g == b)
    hue = np.where(neutral, 0.0, np.degrees(np.arctan2(np.sqrt(3.0) * (g - b), 2.0 * r - g - b)))
    hue = np.where(hue < 0.0, hue + 360.0, hue)
    centred = np.where(hue > 180.0, hue - 360.0, hue)
    w = _smoothstep(0.0, 1.0, 1.0 - np.abs(2.0 * centred / 135.0)) ** 2
    ap0[..., 0] = r + w * saturation * (0.03 - r) * (1.0 - 0.82)
    ap1 = np.clip(ap0 @ _AP1_FROM_AP0.T.astype(dt), 0.0, _HALF_MAX)
    lum = (ap1 @ _LUMINANCE_AP1.astype(dt))[..., None]
    ap1 = (lum + 0.96 * (ap1 - lum)) * brightness
    a_, b_, c_, d_, e_ = ACES_FIT
    post = ap1 * (a_ * ap1 + b_) / (ap1 * (c_ * ap1 + d_) + e_)
    # dark -> dim surround: Y ** 0.9811 in xyY
    XYZ = post @ _XYZ_FROM_AP1.T.astype(dt)
    ssum = np.maximum(XYZ.sum(axis=-1), 1e-5)
    x, y = XYZ[..., 0] / ssum, XYZ[..., 1] / ssum
    Y = np.clip(XYZ[..., 1], 0.0, _HALF_MAX) ** 0.9811
    k = Y / np.maximum(y, 1e-5)
    XYZ = np.stack([x * k, Y, (1.0 - x - y) * k], axis=-1)
    lin = XYZ @ _AP1_FROM_XYZ.T.astype(dt)
    lum = (lin @ _LUMINANCE_AP1.astype(dt))[..., None]
    lin = lum + 0.93 * (lin - lum)
    return np.clip(lin @ _709_FROM_AP1.T.astype(dt), 0.0, 1.0).astype(dt, copy=False)


#: Operators by name (``write_png(tonemap=...)``, ``pyrt render --tonemap``, ``pyrt-preview --tonemap``).
OPERATORS = {"linear": linear, "film": film, "reinhard": reinhard, "reinhard_rgb": reinhard_rgb,
             "pbr_neutral": pbr_neutral, "aces": aces}
