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
