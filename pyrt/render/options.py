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

import warnings

import numpy as np

from pyrt.core import checks
from pyrt.core.errors import RenderError

#: the microfacet alpha (roughness^2) at or below which a lobe counts as mirror-like for :func:`warn_smooth_lobes`
SMOOTH_ALPHA = 0.01


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
                      SmoothLobeWarning, stacklevel=3)
