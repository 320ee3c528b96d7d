"""Grey (1-channel) image textures on the compiled path: the kernel's texture table holds RGB images, so a grey image
is read there as channel 0 of its RGB twin (each texel's value in the three channels, the same sampling), made once
per texture (:meth:`pyrt.ImageTexture.compiled_scalar`; an alpha mask's opacity, a glTF scalar slot)."""
from __future__ import annotations

import weakref

import numpy as np

_TWINS = weakref.WeakKeyDictionary()


def rgb_twin(tex):
    """The RGB twin of the grey :class:`pyrt.ImageTexture` ``tex`` (made on the first call, then kept with it)."""
    twin = _TWINS.get(tex)
    if twin is None:
        twin = type(tex)(np.repeat(np.asarray(tex.image, dtype=np.float32), 3, axis=2), srgb=False, wrap=tex.wrap,
                         filter=tex.filter, scale=tex.scale, offset=tex.offset, rotation_deg=tex.rotation_deg,
                         footprint_scale=tex.footprint_scale, max_anisotropy=tex.max_anisotropy, name=tex.name,
                         texcoord=tex.texcoord)
        _TWINS[tex] = twin
    return twin


def compiled_scalar(tex):
    """:meth:`pyrt.textures.Texture.compiled_scalar` of an :class:`pyrt.ImageTexture`: a grey image as channel 0 of
    its RGB twin (:func:`rgb_twin`); None for the others."""
    return (rgb_twin(tex), 0, 1.0) if tex.channels == 1 else None
