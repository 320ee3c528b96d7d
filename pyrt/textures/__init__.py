"""The texture family: constant, image (MIP-mapped) and procedural textures, normal maps."""
from pyrt.textures.texture import (CheckerTexture, ConstantTexture, FbmTexture, ImageTexture, NoiseTexture, NormalMap,
                                   PerlinTexture, Texture, TextureError, VoronoiTexture, apply_normal_maps,
                                   load_image, perturb_normal, texture_from_dict)

__all__ = ["CheckerTexture", "ConstantTexture", "FbmTexture", "ImageTexture", "NoiseTexture", "NormalMap",
           "PerlinTexture", "Texture", "TextureError", "VoronoiTexture", "apply_normal_maps", "load_image",
           "perturb_normal", "texture_from_dict"]
