"""The texture family's compiled form: type tags, parameter records and the lookup switch.

A texture the compiled kernel can read packs itself into one row of the texture table
(:meth:`pyrt.textures.Texture.compiled_record`: a tag and :data:`RECORD` float64 parameters). Layouts:

=============  ==============================================================================
CHECKER_UV     0-2 colour0, 3-5 colour1 (constant RGB), 6-7 scale (u, v): the unfiltered checker
               (:func:`pyrt.shaders.noise.checker`) in UV space
=============  ==============================================================================
"""
from __future__ import annotations

import math

from numba.extending import register_jitable

#: parameters per texture record
RECORD = 8
#: type tags (0 is no texture)
CHECKER_UV = 1


@register_jitable(inline="always")
def texture_rgb(tags, pars, t, u, v):
    """Texture ``t`` of the table ``(tags, pars)`` at uv ``(u, v)``: an RGB tuple (tables are indexed, never sliced: a
    view in a per-sample loop costs two atomic reference-count updates)."""
    if tags[t] == CHECKER_UV:
        odd = (math.floor(u * pars[t, 6]) + math.floor(v * pars[t, 7])) % 2.0
        return (pars[t, 0] + (pars[t, 3] - pars[t, 0]) * odd, pars[t, 1] + (pars[t, 4] - pars[t, 1]) * odd,
                pars[t, 2] + (pars[t, 5] - pars[t, 2]) * odd)
    return 0.0, 0.0, 0.0
