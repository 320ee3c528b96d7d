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


@register_jitable
def texture_rgb(tag, par, u, v, out):
    """The texture ``(tag, par)`` at uv ``(u, v)`` into ``out`` (3,)."""
    if tag == CHECKER_UV:
        odd = (math.floor(u * par[6]) + math.floor(v * par[7])) % 2.0
        for ch in range(3):
            out[ch] = par[ch] + (par[3 + ch] - par[ch]) * odd
    else:
        out[0] = out[1] = out[2] = 0.0
