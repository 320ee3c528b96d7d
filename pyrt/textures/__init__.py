"""The texture family: constant, image (MIP-mapped) and procedural textures, normal maps.

- :mod:`pyrt.textures.base`: the :class:`Texture` interface, :func:`is_texture`, the registry
  :data:`TEXTURES`, :class:`ConstantTexture`, :func:`texture_from_dict`.
- :mod:`pyrt.textures.image`: :func:`load_image`, :class:`MipPyramid`, :class:`ImageTexture`.
- :mod:`pyrt.textures.procedural`: checker, value noise, Perlin, fBm, Voronoi.
- :mod:`pyrt.textures.normal_map`: :class:`NormalMap`, :func:`perturb_normal`, :func:`apply_normal_maps`.
"""
from pyrt.textures.base import (TEXTURES, ConstantTexture, Texture, TextureError, footprinted, is_texture,
                                texture_from_dict)
from pyrt.textures.image import FILTERS, ChannelTexture, ImageTexture, MipPyramid, load_image
from pyrt.textures.normal_map import NormalMap, apply_normal_maps, flat_normal_map, perturb_normal
from pyrt.textures.procedural import CheckerTexture, FbmTexture, NoiseTexture, PerlinTexture, VoronoiTexture

__all__ = ["FILTERS", "TEXTURES", "ChannelTexture", "CheckerTexture", "ConstantTexture", "FbmTexture", "ImageTexture", "MipPyramid",
           "NoiseTexture", "NormalMap", "PerlinTexture", "Texture", "TextureError", "VoronoiTexture",
           "apply_normal_maps", "flat_normal_map", "footprinted", "is_texture", "load_image", "perturb_normal",
           "texture_from_dict"]
