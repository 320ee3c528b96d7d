"""Tone mapping operators: scene-linear radiance -> display-linear [0, 1].

All operators first multiply by ``2**exposure`` (exposure in stops). They return display-linear
values; apply :func:`shaders.color.srgb_encode` afterwards for an 8-bit PNG.
"""
import numpy as np

from .color import luminance


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


OPERATORS = {"linear": linear, "film": film, "reinhard": reinhard, "reinhard_rgb": reinhard_rgb}
