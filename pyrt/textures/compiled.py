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
    """Texture ``t`` of the table ``(tags, pars)`` at uv ``(u, v)``: an RGB tuple. ``pars`` is the record table's
    flat data (:func:`pyrt.core.unmanaged.pointer`: row ``t`` at ``t * RECORD``; a pointer binds no array, so the
    per-sample code pays no reference counting). Branch-free but for the tag: the cell parity without ``%``."""
    b = t * RECORD
    if tags[t] == CHECKER_UV:
        cells = math.floor(u * pars[b + 6]) + math.floor(v * pars[b + 7])
        odd = cells - 2.0 * math.floor(0.5 * cells)
        return (pars[b] + (pars[b + 3] - pars[b]) * odd, pars[b + 1] + (pars[b + 4] - pars[b + 1]) * odd,
                pars[b + 2] + (pars[b + 5] - pars[b + 2]) * odd)
    return 0.0, 0.0, 0.0
