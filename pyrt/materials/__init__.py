"""The material family: the declared interface, the registry and every reflection model."""
from pyrt.materials.library import (REGISTRY, BlinnPhong, BlinnPhongClassic, CookTorrance, DeltaLobe, Glass, Lambert,
                                    Material, MaterialError, MetallicRoughness, Mirror, Phong, PhongClassic, Ward,
                                    register)

__all__ = ["REGISTRY", "BlinnPhong", "BlinnPhongClassic", "CookTorrance", "DeltaLobe", "Glass", "Lambert", "Material",
           "MaterialError", "MetallicRoughness", "Mirror", "Phong", "PhongClassic", "Ward", "register"]
