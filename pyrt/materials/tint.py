"""The colour a transmitting :class:`pyrt.materials.GltfPBR` filters light by per interface (its ``tint``), derived
from its parameters whenever it is read, so that a ``base_color``, ``metallic`` or textured ``transmission`` assigned
after construction is what transparent shadows (:mod:`pyrt.integrators.shadows`) multiply by."""
from __future__ import annotations

import numpy as np

from pyrt.textures import Texture, footprinted, is_texture


class TransmittedTint(Texture):
    """``base_color x transmission x (1 - metallic)`` of a material, per hit, read from the material's parameters as
    they are when a hit is shaded: the tint where one of them is a texture."""

    channels = 3

    def __init__(self, material):
        self._material = material       # private: the texture's repr does not print the material (a cycle)

    @property
    def needs_footprint(self):
        return footprinted(self._material.metallic, self._material.transmission, self._material.base_color)

    def evaluate(self, ctx):
        """The tint (N, 3)."""
        m = self._material
        w = (1.0 - m.param(m.metallic, ctx, 1)) * m.param(m.transmission, ctx, 1)
        return np.asarray(m.param(m.base_color, ctx)) * w[:, None]


def transmitted_tint(material, texture):
    """``material``'s tint from its current ``base_color``, ``metallic`` and ``transmission``: their product when all
    three are constants, ``base_color`` itself when only it is a texture and the surface transmits fully, else
    ``texture`` (the material's :class:`TransmittedTint`)."""
    b, m, t = material.base_color, material.metallic, material.transmission
    if not any(is_texture(v) for v in (b, m, t)):
        return np.asarray(b, dtype=np.float64) * (1.0 - m) * t
    if not is_texture(m) and not is_texture(t) and m == 0.0 and t == 1.0:
        return b
    return texture
