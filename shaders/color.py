"""Colour: sRGB transfer curve and luminance.

Linear values are linear sRGB / Rec. 709 primaries, D65 white.
"""
import numpy as np

#: Rec. 709 / sRGB luminance weights (Y row of the linear sRGB -> XYZ matrix, IEC 61966-2-1).
LUMINANCE_WEIGHTS = np.array([0.2126, 0.7152, 0.0722])


def luminance(rgb):
    """Relative luminance Y of linear sRGB ``(..., 3)`` -> ``(...)``."""
    return rgb @ LUMINANCE_WEIGHTS.astype(np.result_type(rgb, np.float32))


def srgb_encode(linear):
    """Linear [0, 1] -> sRGB-encoded (IEC 61966-2-1 piecewise curve). Input is clipped to [0, 1]."""
    x = np.clip(linear, 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1.0 / 2.4) - 0.055).astype(x.dtype, copy=False)


def srgb_decode(encoded):
    """sRGB-encoded [0, 1] -> linear (inverse of :func:`srgb_encode`)."""
    x = np.clip(encoded, 0.0, 1.0)
    return np.where(x <= 0.04045, x / 12.92, np.power((x + 0.055) / 1.055, 2.4)).astype(x.dtype, copy=False)


def gamma_encode(linear, gamma=2.2):
    """Linear [0, 1] -> plain power-law encoding ``x ** (1 / gamma)`` (course notes 003/004).

    The simple display curve (LearnOpenGL "Gamma correction": ``pow(color, vec3(1.0 / 2.2))``), beside
    the exact piecewise sRGB curve :func:`srgb_encode`; with ``gamma=2.2`` the two differ by at most
    ~0.035 (near black, where sRGB is linear). Input is clipped to [0, 1]; dtype preserved.
    """
    x = np.clip(linear, 0.0, 1.0)
    return np.power(x, 1.0 / gamma).astype(x.dtype, copy=False)


def gamma_decode(encoded, gamma=2.2):
    """Power-law encoded [0, 1] -> linear ``x ** gamma`` (inverse of :func:`gamma_encode`).

    With ``gamma=2.2`` this is the ``pow(texel, 2.2)`` texture decoding of the course notes and of
    LearnOpenGL, beside the exact :func:`srgb_decode`. Input is clipped to [0, 1]; dtype preserved.
    """
    x = np.clip(encoded, 0.0, 1.0)
    return np.power(x, gamma).astype(x.dtype, copy=False)


#: Display encodings by name: ``name -> (encode, decode)``; ``"gamma"`` takes a ``gamma`` keyword.
ENCODINGS = {"srgb": (srgb_encode, srgb_decode), "gamma": (gamma_encode, gamma_decode)}


# ----------------------------------------------------------------------------- colorimetry
#
# CIE 1931 2-degree standard observer. No installed package ships the tabulated CIE data (numpy,
# scipy, scikit-image, matplotlib, trimesh do not; ``colour-science`` is not a dependency), so the
# colour-matching functions come from the analytic multi-lobe piecewise-Gaussian fit of
# Wyman, Sloan & Shirley, "Simple Analytic Approximations to the CIE XYZ Color Matching Functions",
# JCGT 2(2), 2013, eq. (2) (the "multi-lobe" fit). Measured against the CIE 1931 table
# (tests/test_color_temperature.py): |error| <= 0.011 at 450/500/555/600/650 nm (peak values
# 1.0-1.8), and the black-body chromaticities agree with published values to ~1e-3 in xy.

#: Lobes of the Wyman-Sloan-Shirley multi-lobe fit: (weight, mean nm, sigma below mean, sigma above mean).
_CMF_LOBES = (
    ((1.056, 599.8, 37.9, 31.0), (0.362, 442.0, 16.0, 26.7), (-0.065, 501.1, 20.4, 26.2)),  # x-bar
    ((0.821, 568.8, 46.9, 40.5), (0.286, 530.9, 16.3, 31.1)),                             # y-bar
    ((1.217, 437.0, 11.8, 36.0), (0.681, 459.0, 26.0, 13.8)),                             # z-bar
)

#: Maximum luminous efficacy of photopic vision (lm/W at 555 nm, i.e. 540 THz; SI definition of the candela).
LUMINOUS_EFFICACY = 683.0

#: linear sRGB -> CIE XYZ (IEC 61966-2-1:1999, D65 white; its Y row is :data:`LUMINANCE_WEIGHTS`).
XYZ_FROM_SRGB = np.array([[0.4124, 0.3576, 0.1805],
                          [0.2126, 0.7152, 0.0722],
                          [0.0193, 0.1192, 0.9505]])

#: CIE XYZ -> linear sRGB (IEC 61966-2-1:1999, the inverse as printed in the standard, 4 decimals).
SRGB_FROM_XYZ = np.array([[3.2406, -1.5372, -0.4986],
                          [-0.9689, 1.8758, 0.0415],
                          [0.0557, -0.2040, 1.0570]])

#: Wavelength grid (nm) for spectral integrals: the CIE tabulation range 360-830 nm at 1 nm.
WAVELENGTHS_NM = np.arange(360.0, 831.0, 1.0)

# CODATA 2018 exact constants (SI).
_H = 6.62607015e-34    # Planck constant, J s
_C = 299792458.0       # speed of light, m/s
_KB = 1.380649e-23     # Boltzmann constant, J/K


def cie1931_cmf(wavelength_nm):
    """CIE 1931 2-degree colour-matching functions (x-bar, y-bar, z-bar), analytic fit.

    Wyman, Sloan & Shirley 2013 (JCGT 2(2)), multi-lobe fit: each function is a sum of
    piecewise Gaussians ``w exp(-((lambda - mu) / sigma)^2 / 2)`` with ``sigma`` chosen by the side of
    ``mu``. Their paper reports it closer to the table than the 1-lobe fit; measured here
    (tests/test_color_temperature.py) within 0.011 absolute of the CIE table at 450-650 nm.

    Parameters
    ----------
    wavelength_nm : (N,) float ndarray
        Wavelengths in nanometres.

    Returns
    -------
    (N, 3) ndarray
        x-bar, y-bar, z-bar (dimensionless, y-bar peaks at ~1 near 555 nm); dtype of the input.
    """
    lam = np.asarray(wavelength_nm)
    dt = np.result_type(lam, np.float32)
    lam = lam.astype(dt, copy=False)
    out = np.zeros(lam.shape + (3,), dtype=dt)
    for c, lobes in enumerate(_CMF_LOBES):
        for w, mu, s_lo, s_hi in lobes:
            t = (lam - mu) / np.where(lam < mu, s_lo, s_hi).astype(dt, copy=False)
            out[..., c] += dt.type(w) * np.exp(dt.type(-0.5) * t * t)
    return out


def planck(wavelength_nm, temperature):
    """Black-body spectral radiance (Planck's law) per nanometre.

    ``B(lambda, T) = 2 h c^2 / lambda^5 / (exp(h c / (lambda k T)) - 1)``, evaluated with ``expm1``.

    Parameters
    ----------
    wavelength_nm : (N,) float ndarray
        Wavelengths in nm.
    temperature : float or (M, 1) float ndarray
        Temperature in kelvin (> 0); broadcasts against ``wavelength_nm``.

    Returns
    -------
    ndarray
        Spectral radiance in W m^-2 sr^-1 nm^-1 (float64, broadcast shape).
    """
    lam = np.asarray(wavelength_nm, dtype=np.float64) * 1e-9
    T = np.asarray(temperature, dtype=np.float64)
    x = (_H * _C / _KB) / (lam * T)
    # exp overflows for x > ~709: the radiance there is 0 to double precision.
    return np.where(x < 700.0, 2.0 * _H * _C ** 2 / lam ** 5 / np.expm1(np.minimum(x, 700.0)), 0.0) * 1e-9


def spectrum_to_xyz(wavelength_nm, spectrum):
    """CIE XYZ of a sampled spectrum: ``sum_lambda S(lambda) cmf(lambda) d lambda`` (trapezoid rule).

    Parameters
    ----------
    wavelength_nm : (K,) float ndarray
        Increasing wavelengths in nm.
    spectrum : (..., K) float ndarray
        Spectral values on that grid.

    Returns
    -------
    (..., 3) float64 ndarray
        X, Y, Z in the spectrum's units times nm (no 683 factor: multiply Y by
        :data:`LUMINOUS_EFFICACY` for photometric units when the spectrum is in W/nm).
    """
    lam = np.asarray(wavelength_nm, dtype=np.float64)
    cmf = cie1931_cmf(lam)
    w = np.zeros_like(lam)
    d = np.diff(lam)
    w[:-1] += d / 2
    w[1:] += d / 2
    return np.asarray(spectrum, dtype=np.float64) @ (cmf * w[:, None])


def xyz_to_xy(xyz):
    """Chromaticity ``(x, y) = (X, Y) / (X + Y + Z)`` of ``(..., 3)`` -> ``(..., 2)`` (0 where X+Y+Z = 0)."""
    xyz = np.asarray(xyz)
    s = xyz.sum(axis=-1, keepdims=True)
    return np.divide(xyz[..., :2], s, out=np.zeros_like(xyz[..., :2]), where=s != 0)


def xyz_to_srgb(xyz):
    """CIE XYZ ``(..., 3)`` -> linear sRGB ``(..., 3)`` (IEC 61966-2-1 matrix); dtype preserved."""
    xyz = np.asarray(xyz)
    return xyz @ SRGB_FROM_XYZ.T.astype(np.result_type(xyz, np.float32))


def srgb_to_xyz(rgb):
    """Linear sRGB ``(..., 3)`` -> CIE XYZ ``(..., 3)`` (IEC 61966-2-1 matrix); dtype preserved."""
    rgb = np.asarray(rgb)
    return rgb @ XYZ_FROM_SRGB.T.astype(np.result_type(rgb, np.float32))


def blackbody_xyz(temperature):
    """CIE XYZ of a black body at ``temperature`` kelvin, scaled to ``Y = 1``.

    Parameters
    ----------
    temperature : float or (M,) float ndarray
        Kelvin, > 0.

    Returns
    -------
    (3,) or (M, 3) float64 ndarray
    """
    T = np.asarray(temperature, dtype=np.float64)
    xyz = spectrum_to_xyz(WAVELENGTHS_NM, planck(WAVELENGTHS_NM, T.reshape(-1, 1)))
    xyz = xyz / xyz[:, 1:2]
    return xyz.reshape(T.shape + (3,))


def kelvin_to_srgb(temperature):
    """Colour of a black body at ``temperature`` kelvin as linear sRGB with unit luminance.

    Planck's spectrum is integrated against the CIE 1931 colour-matching functions
    (:func:`blackbody_xyz`), converted with the IEC 61966-2-1 matrix, negative components
    (out-of-gamut: below ~1900 K the blue channel goes negative) are clipped to 0, and the
    result is scaled so that ``luminance(rgb) == 1`` (Rec. 709 weights). A light given as
    ``temperature=T`` therefore keeps its photometric value exactly.

    Parameters
    ----------
    temperature : float or (M,) float ndarray
        Kelvin, > 0.

    Returns
    -------
    (3,) or (M, 3) float64 ndarray

    Notes
    -----
    D65 (the sRGB white) has a correlated colour temperature of ~6504 K but lies ~0.003 above the
    Planckian locus in uv, so ``kelvin_to_srgb(6504)`` is close to, not exactly, (1, 1, 1).
    """
    rgb = np.maximum(xyz_to_srgb(blackbody_xyz(temperature)), 0.0)
    Y = luminance(rgb)
    return rgb / np.where(Y > 0, Y, 1.0)[..., None]


# ----------------------------------------------------------------------------- RGB spaces from primaries

#: Chromaticities (x, y) of the red, green and blue primaries and of the white point of the RGB spaces
#: the tone mappers work in: Rec. 709 / sRGB (ITU-R BT.709, D65), ACES AP0 and AP1 (SMPTE ST 2065-1 and
#: the ACEScg specification S-2014-004, white point "ACES" ~D60).
PRIMARIES = {
    "rec709": ((0.64, 0.33), (0.30, 0.60), (0.15, 0.06), (0.3127, 0.3290)),
    "ap0": ((0.7347, 0.2653), (0.0, 1.0), (0.0001, -0.0770), (0.32168, 0.33767)),
    "ap1": ((0.713, 0.293), (0.165, 0.830), (0.128, 0.044), (0.32168, 0.33767)),
}


def xyz_from_rgb_matrix(space):
    """The 3x3 linear-RGB -> CIE XYZ matrix of ``space`` (a key of :data:`PRIMARIES`), float64.

    The standard construction (SMPTE RP 177): the primaries' XYZ columns ``(x/y, 1, (1-x-y)/y)``
    scaled so that RGB (1, 1, 1) maps to the white point with Y = 1. No chromatic adaptation.
    """
    (xr, yr), (xg, yg), (xb, yb), (xw, yw) = PRIMARIES[space]
    P = np.array([[x / y, 1.0, (1.0 - x - y) / y] for x, y in ((xr, yr), (xg, yg), (xb, yb))]).T
    W = np.array([xw / yw, 1.0, (1.0 - xw - yw) / yw])
    return P * np.linalg.solve(P, W)
