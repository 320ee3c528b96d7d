"""The light family: punctual, textured (projector, goniometric, IES), area and environment lights."""
from pyrt.lights.punctual import (LUMINOUS_EFFICACY, REGISTRY, DirectionalLight, GoniometricLight, IESLight, Light,
                                  LightError, PointLight, ProjectorLight, SpotLight)
from pyrt.lights.area import AreaEmitter, DiskLight, RectLight, SphereLight
from pyrt.lights.environment import (ConstantEnvironment, CubeMapEnvironment, Environment, EnvironmentLight,
                                     EnvironmentMapError, LatLongEnvironment, procedural_sky, set_environment)

__all__ = ["LUMINOUS_EFFICACY", "REGISTRY", "DirectionalLight", "GoniometricLight", "IESLight", "Light", "LightError",
           "PointLight", "ProjectorLight", "SpotLight", "AreaEmitter", "DiskLight", "RectLight", "SphereLight",
           "ConstantEnvironment", "CubeMapEnvironment", "Environment", "EnvironmentLight", "EnvironmentMapError",
           "LatLongEnvironment", "procedural_sky", "set_environment"]
