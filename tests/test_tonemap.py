"""Tone mappers against their reference implementations: Khronos PBR Neutral (KhronosGroup/ToneMapping,
PBR_Neutral/README.md) and Filament's ACES (google/filament, filament/src/ToneMapper.cpp), plus range,
monotonicity and dtype for every operator."""
import math

import numpy as np
import pytest

import pyrt
from pyrt.shaders import color, tonemap

OPS = sorted(tonemap.OPERATORS)


# ----------------------------------------------------------------------------- every operator

@pytest.mark.parametrize("name", OPS)
def test_operator_range_and_finite(name, rng):
    L = np.concatenate([rng.exponential(2.0, (500, 3)) * rng.choice([1e-3, 1, 1e3], (500, 1)),
                        [[0, 0, 0], [1e30, 1e30, 1e30], [1e30, 0, 0], [-1, 0.5, 2]]])
    out = tonemap.OPERATORS[name](L)
    assert out.shape == L.shape and np.all(np.isfinite(out))
    assert out.min() >= 0.0 and out.max() <= 1.0


@pytest.mark.parametrize("name", OPS)
def test_operator_monotone(name, rng):
    """Greys: every channel non-decreasing in the input; colours scaled up: luminance non-decreasing."""
    k = np.geomspace(1e-4, 1e4, 400)
    grey = tonemap.OPERATORS[name](k[:, None] * np.ones(3))
    assert np.all(np.diff(grey, axis=0) >= -1e-12)
    for c in rng.uniform(0, 1, (20, 3)):
        Y = color.luminance(tonemap.OPERATORS[name](k[:, None] * c))
        assert np.all(np.diff(Y) >= -1e-9), c


@pytest.mark.parametrize("name", OPS)
def test_operator_keeps_float32(name):
    L = np.array([[0.1, 0.5, 2.0]], dtype=np.float32)
    assert tonemap.OPERATORS[name](L).dtype == np.float32


@pytest.mark.parametrize("name", ["pbr_neutral", "aces"])
def test_exposure_is_a_prescale(name, rng):
    L = rng.uniform(0, 4, (50, 3))
    np.testing.assert_allclose(tonemap.OPERATORS[name](L, exposure=1.5), tonemap.OPERATORS[name](L * 2 ** 1.5),
                               rtol=1e-12, atol=1e-15)


# ----------------------------------------------------------------------------- Khronos PBR Neutral

def test_pbr_neutral_identity_below_start_compression(rng):
    """Spec note: c_out = c_in - F90 for every channel in [0.08, 0.8] (the compression starts at 0.8 - 0.04)."""
    c = rng.uniform(0.08, 0.8, (1000, 3))
    np.testing.assert_allclose(tonemap.pbr_neutral(c), c - 0.04, rtol=0, atol=1e-15)
    grey = np.array([[0.8, 0.8, 0.8]])                      # exactly at K_s after the offset
    np.testing.assert_allclose(tonemap.pbr_neutral(grey), 0.76, atol=1e-15)


def test_pbr_neutral_spot_values():
    """Values from the specification's formulas, evaluated by hand.

    Toe: x = 0.02 -> f = 0.02 - 0.02^2 / 0.16 = 0.0175, out = 0.0025. Grey 1: p = 0.96,
    p_n = 1 - 0.24^2 / (0.96 + 1 - 1.52) = 0.869..., out = p_n (neutral: desaturation changes nothing).
    Red (2, 0.5, 0.5): f = 0.04, p = 1.96, p_n = 1 - 0.0576 / 1.44, g = 1 / (0.15 (p - p_n) + 1).
    """
    np.testing.assert_allclose(tonemap.pbr_neutral(np.full((1, 3), 0.02)), 0.0025, atol=1e-15)
    np.testing.assert_allclose(tonemap.pbr_neutral(np.ones((1, 3))), 1 - 0.0576 / 0.44, atol=1e-12)
    p, pn = 1.96, 1 - 0.0576 / 1.44
    g = 1 / (0.15 * (p - pn) + 1)
    want = np.array([1.96, 0.46, 0.46]) * pn / p * g + pn * (1 - g)
    np.testing.assert_allclose(tonemap.pbr_neutral(np.array([[2.0, 0.5, 0.5]]))[0], want, atol=1e-12)


def test_pbr_neutral_white_limit_and_no_hue_shift(rng):
    """Spec: onto [0, 1] (white only in the limit: grey 1e6 -> 1 - ~6e-8, never above), no hue shift (the
    output stays in the plane of the input colour and the white axis)."""
    big = tonemap.pbr_neutral(np.full((1, 3), 1e6))
    assert np.all(big < 1.0) and np.all(big > 1.0 - 1e-6)
    c = rng.uniform(0, 20, (500, 3))
    out = tonemap.pbr_neutral(c)
    white = np.ones(3)
    n = np.cross(c, white)                                  # normal of the plane (c, white)
    np.testing.assert_allclose(np.einsum("ij,ij->i", out, n) / np.linalg.norm(n, axis=1), 0.0, atol=1e-9)


# ----------------------------------------------------------------------------- Filament's ACES

# Filament's matrices as printed in filament/src/ColorSpaceUtils.h (column-major mat3f: each triple is a column).
_F = {k: np.array(v).reshape(3, 3).T for k, v in {
    "sRGB_to_XYZ": (0.4124560, 0.2126730, 0.0193339, 0.3575760, 0.7151520, 0.1191920,
                    0.1804380, 0.0721750, 0.9503040),
    "XYZ_to_sRGB": (3.2404542, -0.9692660, 0.0556434, -1.5371385, 1.8760108, -0.2040259,
                    -0.4985314, 0.0415560, 1.0572252),
    "AP1_to_XYZ": (0.6624541811, 0.2722287168, -0.0055746495, 0.1340042065, 0.6740817658, 0.0040607335,
                   0.1561876870, 0.0536895174, 1.0103391003),
    "XYZ_to_AP1": (1.6410233797, -0.6636628587, 0.0117218943, -0.3248032942, 1.6153315917, -0.0082844420,
                   -0.2364246952, 0.0167563477, 0.9883948585),
    "AP1_to_AP0": (0.6954522414, 0.0447945634, -0.0055258826, 0.1406786965, 0.8596711185, 0.0040252103,
                   0.1638690622, 0.0955343182, 1.0015006723),
    "AP0_to_AP1": (1.4514393161, -0.0765537734, 0.0083161484, -0.2365107469, 1.1762296998, -0.0060324498,
                   -0.2149285693, -0.0996759264, 0.9977163014),
}.items()}
_LUM_AP1 = (0.272229, 0.674082, 0.0536895)


def _filament_aces(rgb, brightness=1.0):
    """A line-by-line scalar transcription of Filament's ``aces::ACES`` (Rec. 709 in and out)."""
    def mul(M, v):
        return [sum(M[i][j] * v[j] for j in range(3)) for i in range(3)]

    def mix(a, b, t):
        return [x + (y - x) * t for x, y in zip(a, b)] if isinstance(a, list) else [a + (y - a) * t for y in b]

    ap0 = mul(_F["AP1_to_AP0"], mul(_F["XYZ_to_AP1"], mul(_F["sRGB_to_XYZ"], rgb)))
    mi, ma = min(ap0), max(ap0)
    saturation = (max(ma, 1e-5) - max(mi, 1e-5)) / max(ma, 1e-2)
    r, g, b = ap0
    yc = (b + g + r + 1.75 * math.sqrt(b * (b - g) + g * (g - r) + r * (r - b))) / 3.0
    x = (saturation - 0.4) / 0.2
    t = max(1.0 - abs(x / 2.0), 0.0)
    s = (1.0 + math.copysign(1.0, x) * (1.0 - t * t)) / 2.0 if x != 0 else 0.5
    gain = 0.05 * s
    if yc <= 2.0 / 3.0 * 0.08:
        glow = gain
    elif yc >= 2.0 * 0.08:
        glow = 0.0
    else:
        glow = gain * (0.08 / yc - 0.5)
    ap0 = [c * (1.0 + glow) for c in ap0]
    hue = 0.0
    if not (ap0[0] == ap0[1] == ap0[2]):
        hue = math.degrees(math.atan2(math.sqrt(3.0) * (ap0[1] - ap0[2]), 2.0 * ap0[0] - ap0[1] - ap0[2]))
    hue = hue + 360.0 if hue < 0 else hue
    ch = hue - 360.0 if hue > 180.0 else hue
    u = min(max(1.0 - abs(2.0 * ch / 135.0), 0.0), 1.0)
    w = (u * u * (3 - 2 * u)) ** 2
    ap0[0] += w * saturation * (0.03 - ap0[0]) * (1.0 - 0.82)
    ap1 = [min(max(c, 0.0), 65504.0) for c in mul(_F["AP0_to_AP1"], ap0)]
    ap1 = mix(sum(l * c for l, c in zip(_LUM_AP1, ap1)), ap1, 0.96)
    ap1 = [c * brightness for c in ap1]
    post = [c * (2.785085 * c + 0.107772) / (c * (2.936045 * c + 0.887122) + 0.806889) for c in ap1]
    X, Y, Z = mul(_F["AP1_to_XYZ"], post)
    sxyz = max(X + Y + Z, 1e-5)
    xx, yy = X / sxyz, Y / sxyz
    Y = min(max(Y, 0.0), 65504.0) ** 0.9811
    a = Y / max(yy, 1e-5)
    lin = mul(_F["XYZ_to_AP1"], [xx * a, Y, (1.0 - xx - yy) * a])
    lin = mix(sum(l * c for l, c in zip(_LUM_AP1, lin)), lin, 0.93)
    return [min(max(c, 0.0), 1.0) for c in mul(_F["XYZ_to_sRGB"], mul(_F["AP1_to_XYZ"], lin))]


def test_aces_matches_filament_transcription(rng):
    """pyrt's vectorised ACES against a scalar transcription of Filament's code with Filament's printed
    matrices. pyrt builds its matrices from the primaries (D65 = (0.3127, 0.3290); Filament's sRGB matrix
    is Lindbloom's, D65 = (0.31271, 0.32902)): they differ by ~1e-4, hence atol 1e-3."""
    colours = np.concatenate([rng.exponential(1.0, (200, 3)) * rng.choice([0.05, 1, 20], (200, 1)),
                              np.eye(3), 10 * np.eye(3), [[0.18] * 3, [1.0] * 3, [0.0] * 3, [1, 0.2, 0.05]]])
    want = np.array([_filament_aces(list(c)) for c in colours])
    np.testing.assert_allclose(tonemap.aces(colours), want, atol=1e-3, rtol=0)
    legacy = np.array([_filament_aces(list(c), 1 / 0.6) for c in colours[:20]])
    np.testing.assert_allclose(tonemap.aces(colours[:20], brightness=1 / 0.6), legacy, atol=1e-3, rtol=0)


def test_aces_spot_values():
    """Grey spot values from the published formula (the transcription above, printed once): 0 -> 0,
    0.18 -> (0.1061, 0.1080, 0.1110), 1 -> (0.6466, 0.6285, 0.5996); very bright greys approach the fit's
    asymptote 2.785085 / 2.936045 in AP1 (~D60 white): warm (0.994, 0.944, 0.869), never white."""
    g = np.array([[0.0] * 3, [0.18] * 3, [1.0] * 3, [1e4] * 3])
    out = tonemap.aces(g)
    np.testing.assert_allclose(out[0], 0.0, atol=1e-12)
    np.testing.assert_allclose(out[1], [0.1061, 0.1080, 0.1110], atol=2e-4)
    np.testing.assert_allclose(out[2], [0.6466, 0.6285, 0.5996], atol=2e-4)
    np.testing.assert_allclose(out[3], [0.994, 0.944, 0.869], atol=2e-3)


# ----------------------------------------------------------------------------- the ways in

@pytest.mark.parametrize("name", ["pbr_neutral", "aces"])
def test_write_png_and_clis_accept_new_operators(name, tmp_path):
    from skimage import io as skio
    from pyrt.apps.cli import _parser
    from pyrt.apps.preview.cli import _parser as preview_parser

    img = np.array([[[0.0, 0.0, 0.0], [0.5, 0.5, 0.5], [1e3, 1e3, 1e3]]], dtype=np.float32)
    pyrt.write_png(tmp_path / "t.png", img, tonemap=name)
    out = skio.imread(tmp_path / "t.png")
    want = np.round(color.srgb_encode(tonemap.OPERATORS[name](img.astype(np.float64))) * 255)
    np.testing.assert_array_equal(out[..., :3], want.astype(np.uint8))
    assert _parser().parse_args(["render", "s.toml", "-o", "x.png", "--tonemap", name]).tonemap == name
    assert preview_parser().parse_args(["m.glb", "--tonemap", name]).tonemap == name


def test_preview_options_reject_unknown_tonemap():
    from pyrt.apps.preview import PreviewError, PreviewOptions

    PreviewOptions(tonemap="pbr_neutral").validate()
    with pytest.raises(PreviewError, match="tonemap must be one of"):
        PreviewOptions(tonemap="agx").validate()
