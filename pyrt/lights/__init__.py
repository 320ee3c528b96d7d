"""The light family: the declared interface (:mod:`.base`), punctual, textured, area and environment lights.

- :mod:`pyrt.lights.base`: :class:`Light`, :class:`LightSample`, the registry :data:`LIGHTS`;
- :mod:`pyrt.lights.punctual`: point, spot, directional;
- :mod:`pyrt.lights.textured`: projector (gobo), goniometric, IES;
- :mod:`pyrt.lights.area`: rectangle, disk, sphere (and the :class:`AreaEmitter` material of their meshes);
- :mod:`pyrt.lights.mesh`: :class:`EmissiveMeshLight`, the scene's emissive triangles sampled as a light;
- :mod:`pyrt.lights.environment`: constant, lat-long and cube-map environments (:data:`ENVIRONMENTS`);
- :mod:`pyrt.lights.environment_light`: :class:`EnvironmentLight` (estimator parameters) and :func:`set_environment`;
- :mod:`pyrt.lights.probes`: angular-map and mirror-ball light probes (registered in :data:`ENVIRONMENTS`).
"""
from pyrt.lights.base import LIGHTS, LUMINOUS_EFFICACY, PATH_ARGUMENTS, Light, LightError, LightSample
from pyrt.lights.punctual import DirectionalLight, PointLight, SpotLight
from pyrt.lights.textured import GoniometricLight, IESLight, ProjectorLight
from pyrt.lights.area import AreaEmitter, AreaLight, DiskLight, RectLight, SphereLight
from pyrt.lights.mesh import EmissiveMeshLight
from pyrt.lights.environment import (ENVIRONMENTS, ConstantEnvironment, CubeMapEnvironment, Environment,
                                     EnvironmentMapError, LatLongEnvironment, procedural_sky)
from pyrt.lights.environment_light import EnvironmentLight, set_environment
from pyrt.lights.probes import AngularMapEnvironment, MirrorBallEnvironment

#: the light registry under its older name
REGISTRY = LIGHTS

__all__ = ["LIGHTS", "REGISTRY", "LUMINOUS_EFFICACY", "PATH_ARGUMENTS", "Light", "LightError", "LightSample",
           "DirectionalLight", "PointLight", "SpotLight", "GoniometricLight", "IESLight", "ProjectorLight",
           "AreaEmitter", "AreaLight", "DiskLight", "RectLight", "SphereLight", "EmissiveMeshLight",
           "ENVIRONMENTS", "ConstantEnvironment",
           "CubeMapEnvironment", "Environment", "EnvironmentLight", "EnvironmentMapError", "LatLongEnvironment",
           "procedural_sky", "set_environment", "AngularMapEnvironment", "MirrorBallEnvironment"]
