"""The material family's compiled form: type tags, parameter records and the per-hit switch over them.

A material that the compiled tile kernel (:mod:`pyrt.integrators.compiled`) can shade packs itself into one row
of the material table (:meth:`pyrt.materials.Material.compiled_record`): a type tag (:data:`LAMBERT`, ...) and a
float64 parameter record of :data:`RECORD` entries. Colours that may come from a texture are a *colour slot*:
``[texture index or -1, r, g, b]`` (the constant used when the index is -1; textures are rows of the texture
table, :mod:`pyrt.textures.compiled`). A material that returns None from ``compiled_record`` renders through the
NumPy path (the whole render falls back; ``result.stats.backend`` says which path ran).

Record layouts (offsets into the record):

============  ===================================================================================
LAMBERT       0-3 albedo slot, 4-6 emission (constant RGB)
BLINN_PHONG   0-3 kd slot, 4-6 ks (constant RGB), 7 exponent
MIRROR        0-2 reflectance (constant RGB)
GLASS         0 ior, 1-3 tint (constant RGB)
============  ===================================================================================

The kernel reads the record table through its flat data (:func:`pyrt.core.unmanaged.pointer`: material ``m``'s
record at ``pars[m * RECORD:]``; a pointer binds no array, so the per-sample code pays no reference counting).
The formulas are the scalar twins in :mod:`pyrt.shaders.jit` of the NumPy kernels the materials use.
"""
from __future__ import annotations

import math

import numpy as np
from numba.extending import register_jitable

from pyrt.shaders import jit as J
from pyrt.textures.compiled import texture_rgb

#: parameters per material record
RECORD = 8
#: type tags (0 is no material)
LAMBERT, BLINN_PHONG, MIRROR, GLASS = 1, 2, 3, 4


@register_jitable(inline="always")
def color_slot(pars, m, k, tex_tag, tex_par, u, v):
    """The colour (an RGB tuple) of the slot at ``k`` of material ``m``'s record at uv ``(u, v)``."""
    b = m * RECORD + k
    t = int(pars[b])
    if t < 0:
        return pars[b + 1], pars[b + 2], pars[b + 3]
    return texture_rgb(tex_tag, tex_par, t, u, v)


@register_jitable(inline="always")
def has_diffuse(tag):
    """True for materials lit by the lights (a non-delta lobe)."""
    return tag == LAMBERT or tag == BLINN_PHONG


@register_jitable(inline="always")
def has_delta(tag):
    """True for materials that spawn specular rays."""
    return tag == MIRROR or tag == GLASS


@register_jitable(inline="always")
def mirror_weight(tag, pars, m, cos_o):
    """The RGB weight of the one reflection lobe of a mirror-like material ``m`` (not GLASS, whose two lobes the
    kernel's ``spawn`` computes) at ``cos_o = n.wo``: MIRROR's constant reflectance."""
    b = m * RECORD
    return pars[b], pars[b + 1], pars[b + 2]


@register_jitable(inline="always")
def f_cos(tag, pars, m, albedo, cos_o, cos_i, cos_io):
    """BRDF times cos(theta_i) (an RGB tuple) of material ``m`` (tag ``tag``) for the cosines
    ``n.wo``, ``n.wi``, ``wo.wi`` (shading normal); ``albedo`` (RGB tuple) is the material's diffuse colour at the
    hit (:func:`albedo_at`). Zero below either horizon.

    LAMBERT: :func:`pyrt.shaders.brdfs.lambert_f_cos_cosines`; BLINN_PHONG:
    :func:`pyrt.shaders.brdfs.blinn_phong_normalized_f_cos_cosines`."""
    c = J.upper_cos(cos_o, cos_i)
    if c == 0.0:
        return 0.0, 0.0, 0.0
    if tag == LAMBERT:
        k = c / math.pi
        return albedo[0] * k, albedo[1] * k, albedo[2] * k
    b = m * RECORD
    spec = J.blinn_phong_spec(cos_o, cos_i, cos_io, pars[b + 7])
    return ((albedo[0] / math.pi + pars[b + 4] * spec) * c, (albedo[1] / math.pi + pars[b + 5] * spec) * c,
            (albedo[2] / math.pi + pars[b + 6] * spec) * c)


@register_jitable(inline="always")
def albedo_at(tag, pars, m, tex_tag, tex_par, u, v):
    """The diffuse colour (Lambert albedo, Blinn-Phong kd; an RGB tuple) of material ``m`` at uv ``(u, v)``; zeros
    for the others."""
    if tag == LAMBERT or tag == BLINN_PHONG:
        return color_slot(pars, m, 0, tex_tag, tex_par, u, v)
    return 0.0, 0.0, 0.0


def constant_slot(value):
    """A colour slot ``[-1, r, g, b]`` for a constant colour (a grey number or an RGB triple)."""
    rgb = np.broadcast_to(np.asarray(value, dtype=np.float64).reshape(-1), (3,))
    return [-1.0, *rgb.tolist()]


def empty_record():
    """A zero parameter record."""
    return np.zeros(RECORD)
