"""Checks of the render options that hold whatever path renders (fixed or adaptive, NumPy or compiled, Whitted or
glossy), so that an option the chosen path happens not to read is still an error when it is wrong, and the warning
about what a Whitted render silently drops.

:func:`check_options` checks ``seed`` (an integer >= 0: NumPy would say "unrecognized seed string") and the glossy
options (``glossy_samples`` >= 1, ``glossy_depth`` >= 0, ``glossy_threshold`` >= 0, ``glossy_clamp`` >= 0 or None)
even for ``integrator="whitted"``, which does not use them.

:func:`warn_smooth_lobes`: the Whitted integrator traces only delta lobes (mirrors, glass) and lights a glossy
lobe by light sampling alone. A microfacet lobe of alpha at most :data:`SMOOTH_ALPHA` (roughness 0.1) is almost a
mirror: under Whitted it shows the lights' highlights on black, not the scene it should reflect. Such a material
is named in a warning, with the integrator that traces it (``integrator="glossy"``) and the delta materials
(``Conductor``, ``Mirror``, ``Glass``) that are exactly smooth.
"""
from __future__ import annotations

import os
import re
import warnings

import numpy as np

from pyrt.core import checks
from pyrt.core.errors import RenderError

#: the microfacet alpha (roughness^2) at or below which a lobe counts as mirror-like for :func:`warn_smooth_lobes`
SMOOTH_ALPHA = 0.01


#: bytes per pixel a render holds besides the scene: the film's float64 weight and RGB sums (32), the float64
#: resolve temporaries and the float32 image (24 + 12); per AOV film 64 more; an adaptive render has two films
FILM_BYTES, AOV_BYTES, IMAGE_BYTES = 32, 64, 36


class SmoothLobeWarning(UserWarning):
    """A mirror-like microfacet material is rendered by an integrator that does not trace its reflection."""


def check_options(*, seed, glossy_samples, glossy_depth, glossy_threshold, glossy_clamp):
    """The validated ``seed`` (int); RenderError naming the option otherwise (module docstring)."""
    checks.integer("render", "glossy_samples", glossy_samples, RenderError, lo=1)
    checks.integer("render", "glossy_depth", glossy_depth, RenderError, lo=0)
    checks.finite_number("render", "glossy_threshold", glossy_threshold, RenderError, lo=0.0)
    if glossy_clamp is not None:
        checks.finite_number("render", "glossy_clamp", glossy_clamp, RenderError, lo=0.0)
    return checks.integer("render", "seed", seed, RenderError, lo=0)


class _OneHit:
    """The smallest shading context a material with constant parameters evaluates ``glossy_alpha`` on."""
    n_hits = 1


def _constant_alpha(material):
    """The material's ``glossy_alpha`` when its parameters are constants, else None (textured: varies per hit)."""
    if material.uses_textures:
        return None
    try:
        alpha = material.glossy_alpha(_OneHit())
    except AttributeError:          # its alpha reads the hits' geometry (a tangent frame): not a constant
        return None
    return None if alpha is None else float(np.min(alpha))


def warn_smooth_lobes(scene, integrator):
    """Warn (:class:`SmoothLobeWarning`) once per render about each material of ``scene`` whose constant microfacet
    alpha is at most :data:`SMOOTH_ALPHA` when ``integrator`` is ``"whitted"`` (module docstring)."""
    if integrator != "whitted":
        return
    smooth = []
    for m in scene.materials:
        alpha = _constant_alpha(m)
        if alpha is not None and alpha <= SMOOTH_ALPHA and all(m is not s for s in smooth):
            smooth.append(m)
    for m in smooth:
        warnings.warn(f"render: material {m.label} is a mirror-like microfacet lobe (alpha {_constant_alpha(m):.2g} <= "
                      f"{SMOOTH_ALPHA}): integrator='whitted' traces no rays along it, so it shows the lights' "
                      "highlights on black; render with integrator='glossy' (--integrator glossy, [render] "
                      "integrator = \"glossy\"), or use a Conductor, Mirror or Glass for an exactly smooth surface",
                      SmoothLobeWarning, stacklevel=5)


#: the two lines of /proc/meminfo that :func:`available_memory` reads (kB)
_MEMINFO = re.compile(rb"^(MemAvailable|SwapFree):\s+(\d+)", re.M)


def available_memory():
    """Bytes of memory a new allocation can use now: Linux's ``MemAvailable`` plus free swap; elsewhere the free
    physical pages; None when neither can be read (then nothing is checked)."""
    try:
        with open("/proc/meminfo", "rb") as fh:
            info = dict(_MEMINFO.findall(fh.read()))
        return (int(info[b"MemAvailable"]) + int(info.get(b"SwapFree", 0))) * 1024
    except (OSError, KeyError, ValueError, IndexError):
        pass
    try:
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):
        return None


def check_image_memory(width, height, *, aovs=False, films=1):
    """RenderError naming ``width`` x ``height`` when the image's film and output (:data:`FILM_BYTES` ... per
    pixel, ``films`` films) need more memory than :func:`available_memory` says there is, before anything of that
    size is allocated (NumPy would fail later, with a traceback and no word of the image size)."""
    need = int(width) * int(height) * (films * FILM_BYTES + (AOV_BYTES if aovs else 0) + IMAGE_BYTES)
    avail = available_memory()
    if avail is not None and need > avail:
        raise RenderError(f"render: a {width}x{height} image needs about {need / (1 << 30):.1f} GiB of memory for "
                          f"its film and output, more than the {avail / (1 << 30):.1f} GiB available: lower width "
                          "and height")
