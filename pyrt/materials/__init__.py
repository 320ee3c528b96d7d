"""The material family: the declared interface (:mod:`.base`), the registry and every reflection model.

- :mod:`pyrt.materials.base`: :class:`Material`, :class:`IsotropicMaterial`, :class:`DeltaLobe`, the
  queries, parameter checks and the registry :data:`MATERIALS`;
- :mod:`pyrt.materials.basic`: Lambert, Blinn-Phong, mirror, glass;
- :mod:`pyrt.materials.library`: the rest of the course's models (Phong, classic models, Ward,
  Cook-Torrance, glTF metallic-roughness);
- :mod:`pyrt.materials.extra`: smooth conductor, Oren-Nayar, LearnOpenGL's PBR model;
- :mod:`pyrt.materials.rough_dielectric`: frosted glass (GGX reflection and transmission, Walter 2007);
- :mod:`pyrt.materials.gltf_pbr`: glTF's material extensions (specular / ior / transmission / volume, anisotropy);
- :mod:`pyrt.materials.gltf_layers`: glTF's clear coat and unlit materials;
- :mod:`pyrt.materials.sheen`: sheen over a base (``KHR_materials_sheen``; its kernels: :mod:`pyrt.shaders.sheen`);
- :mod:`pyrt.materials.layering`: what a layer over a base material (clear coat, sheen) shares;
- :mod:`pyrt.materials.dispatch`: :class:`BSDFBatch`, the per-material-type dispatch of a batch of hits.
"""
from pyrt.materials.base import (MATERIALS, CosineQuery, DeltaLobe, IsotropicMaterial, LocalCosineQuery, Material,
                                 MaterialError, check_color, check_scalar, is_texture, register)
from pyrt.materials.basic import BlinnPhong, Glass, Lambert, Mirror
from pyrt.materials.library import BlinnPhongClassic, CookTorrance, MetallicRoughness, Phong, PhongClassic, Ward
from pyrt.materials.extra import Conductor, LearnOpenGLPBR, OrenNayar
from pyrt.materials.rough_dielectric import RoughDielectric
from pyrt.materials.gltf_pbr import GltfPBR
from pyrt.materials.gltf_layers import Clearcoat, Unlit
from pyrt.materials.sheen import Sheen

#: the material registry under its older name
REGISTRY = MATERIALS

__all__ = ["MATERIALS", "REGISTRY", "CosineQuery", "DeltaLobe", "IsotropicMaterial", "LocalCosineQuery", "Material",
           "MaterialError", "check_color", "check_scalar", "is_texture", "register", "BlinnPhong", "Glass", "Lambert",
           "Mirror", "BlinnPhongClassic", "CookTorrance", "MetallicRoughness", "Phong", "PhongClassic", "Ward",
           "Conductor", "LearnOpenGLPBR", "OrenNayar", "RoughDielectric", "Clearcoat", "GltfPBR", "Unlit", "Sheen"]
