"""More reflection models: the smooth conductor, Oren-Nayar and LearnOpenGL's PBR model.

Each is a thin holder of validated parameters over kernels of :mod:`pyrt.shaders` (scene-file ``type``
names in brackets):

- :class:`Conductor` [conductor]: a perfectly smooth metal, a mirror lobe weighted by the exact
  conductor Fresnel reflectance :func:`pyrt.shaders.fresnel.fr_conductor`;
- :class:`OrenNayar` [oren_nayar]: rough diffuse, :func:`pyrt.shaders.brdfs.oren_nayar_f_cos_cosines`;
- :class:`LearnOpenGLPBR` [learnopengl]: the metallic-roughness Cook-Torrance model of LearnOpenGL's
  "PBR: Lighting" lesson, i.e. :class:`pyrt.materials.library.MetallicRoughness` with the Schlick-GGX
  geometry term of k = (roughness + 1)^2 / 8.
"""
from __future__ import annotations

import math

import numpy as np

from pyrt.core.checks import Fixed
from pyrt.materials.base import (DeltaLobe, IsotropicMaterial, Material, MaterialError, check_color, check_scalar,
                                 is_texture, register)
from pyrt.materials.library import MetallicRoughness, conductor_eta_k
from pyrt.materials import compiled as _compiled
from pyrt.shaders import brdfs
from pyrt.shaders import fresnel
from pyrt.shaders.vec import reflect


@register("conductor")
class Conductor(Material):
    """Perfectly smooth conductor (metal) [conductor]: ``L = F_c(cos theta_o) L(reflect(wo))`` per RGB channel.

    ``F_c`` is the exact unpolarised Fresnel reflectance of the complex index ``eta + i k``
    (:func:`pyrt.shaders.fresnel.fr_conductor`): ``((eta - 1)^2 + k^2) / ((eta + 1)^2 + k^2)`` at normal
    incidence, 1 at grazing. The limit alpha -> 0 of ``CookTorrance(fresnel="conductor")``.

    Parameters (keyword-only)
    -------------------------
    metal : str
        A name of :data:`pyrt.shaders.metals.METALS` (gold, silver, copper, aluminium, steel); the
        default is gold when neither ``metal`` nor ``eta``/``k`` is given.
    eta, k : RGB
        Real and imaginary parts of the relative complex index per channel (instead of ``metal``).
    name : str, optional
    """

    metal = Fixed('eta and k were looked up from it')

    has_diffuse = False
    has_delta = True
    ranges = {"eta": ("color", 0.0, None, True), "k": ("color", 0.0, None, False)}

    def __init__(self, *, metal=None, eta=None, k=None, name=None):
        self.name = name
        if metal is None and eta is None and k is None:
            metal = "gold"
        self.metal = metal
        self.eta, self.k = conductor_eta_k(self.label, metal, eta, k)

    def reflectance(self, cos_o):
        """Fresnel reflectance (N, 3) at the cosines ``cos_o`` (N,) of the viewing direction."""
        return fresnel.fr_conductor(cos_o, self.eta, self.k)

    def compiled_record(self, pack_texture):
        """:data:`pyrt.materials.compiled.CONDUCTOR`: the exact conductor Fresnel of ``eta``, ``k`` (per channel)."""
        return _compiled.library_record(self, _compiled.CONDUCTOR, [*_compiled.rgb(self.eta), *_compiled.rgb(self.k)])

    def delta_lobes(self, wo, ctx, *, eta=None):
        """The mirror lobe ``reflect(wo)`` weighted by :meth:`reflectance` at ``cos theta_o``."""
        n = np.zeros_like(wo)
        n[:, 2] = 1.0
        return [DeltaLobe(reflect(wo, n), self.reflectance(wo[:, 2]), "reflect")]


@register("oren_nayar")
class OrenNayar(IsotropicMaterial):
    """Qualitative Oren-Nayar rough diffuse BRDF [oren_nayar] (Oren & Nayar 1994, eq. 30).

    ``f = albedo / pi (A + B max(0, cos(phi_i - phi_o)) sin(alpha) tan(beta))`` with
    ``A = 1 - 0.5 s^2 / (s^2 + 0.33)``, ``B = 0.45 s^2 / (s^2 + 0.09)``, ``s = sigma``,
    ``alpha = max(theta_i, theta_o)``, ``beta = min(theta_i, theta_o)``
    (:func:`pyrt.shaders.brdfs.oren_nayar_f_cos_cosines`). Reciprocal; ``sigma = 0`` is Lambert exactly.
    Not exactly energy conserving: with albedo 1 the directional albedo reaches 1.015 at grazing view
    for sigma ~ 11 degrees (below 1 for sigma >= 20 degrees; measured in tests/test_materials_extra.py).

    Parameters
    ----------
    albedo : RGB, float or Texture
        Diffuse reflectance rho in [0, 1].
    sigma : float or scalar Texture, keyword-only
        Standard deviation of the microfacet slope angle **in radians**, in [0, pi/2] (default 0.35,
        about 20 degrees).
    sigma_deg : float, keyword-only
        The same in degrees, instead of ``sigma`` (pbrt's scene files give degrees).
    name : str, optional
    """

    ranges = {"albedo_value": ("color", 0.0, 1.0, False), "sigma": ("scalar", 0.0, math.pi / 2, False)}

    def __init__(self, albedo=0.8, *, sigma=None, sigma_deg=None, name=None):
        self.name = name
        if sigma is not None and sigma_deg is not None:
            raise MaterialError(f"{self.label}: give sigma (radians) or sigma_deg, not both")
        if sigma_deg is not None:
            sigma = math.radians(check_scalar("sigma_deg", sigma_deg, self.label, lo=0.0, hi=90.0))
        self.albedo_value = check_color("albedo", albedo, self.label, lo=0.0, hi=1.0)
        self.sigma = check_scalar("sigma", 0.35 if sigma is None else sigma, self.label, lo=0.0, hi=math.pi / 2)

    def compiled_record(self, pack_texture):
        """:data:`pyrt.materials.compiled.OREN_NAYAR` with a constant albedo and sigma."""
        if is_texture(self.albedo_value) or is_texture(self.sigma):
            return None
        return _compiled.library_record(self, _compiled.OREN_NAYAR, [*_compiled.rgb(self.albedo_value),
                                                                     float(self.sigma)])

    def f_cos_cosines(self, q):
        """:func:`pyrt.shaders.brdfs.oren_nayar_f_cos_cosines` for the query's lanes."""
        return brdfs.oren_nayar_f_cos_cosines(q.cos_o, q.cos_i, q.cos_io(), q.param(self, self.albedo_value),
                                              q.param(self, self.sigma, 1))

    def albedo(self, ctx):
        return np.array(self.param(self.albedo_value, ctx))


@register("learnopengl")
class LearnOpenGLPBR(MetallicRoughness):
    """LearnOpenGL's PBR model [learnopengl] (J. de Vries, learnopengl.com, "PBR: Lighting").

    ``f = kD albedo / pi + D G F / (4 (n.v) (n.l))`` with ``F0 = mix(0.04, albedo, metallic)``,
    ``F = F0 + (1 - F0)(1 - h.v)^5`` (Fresnel-Schlick), ``kD = (1 - F)(1 - metallic)``,
    ``D = a^2 / (pi ((n.h)^2 (a^2 - 1) + 1)^2)`` with ``a = roughness^2`` (GGX) and
    ``G = G1(n.v) G1(n.l)``, ``G1(x) = x / (x (1 - k) + k)``, ``k = (roughness + 1)^2 / 8``
    (Schlick-GGX "direct lighting" remapping). That is :class:`MetallicRoughness` (same kernel,
    :func:`pyrt.shaders.brdfs.gltf_metallic_roughness_f_cos`) with ``geometry="schlick_ue4"``; only
    the shader's ``max(denominator, 0.001)`` guard is not reproduced (pyrt returns 0 below the horizon
    instead). Not energy conserving (k = (r+1)^2/8 over-estimates G for smooth surfaces; the diffuse
    weight ignores the specular albedo), reciprocal.

    Parameters (keyword-only)
    -------------------------
    albedo : RGB or Texture in [0, 1] (the shader's ``albedo``, glTF's ``base_color``)
    metallic, roughness : float or scalar Texture in [0, 1]
    """

    def __init__(self, *, albedo=0.8, metallic=0.0, roughness=0.5, name=None):
        super().__init__(base_color=albedo, metallic=metallic, roughness=roughness, name=name)
        self.geometry = "schlick_ue4"

    def compiled_record(self, pack_texture):
        """:class:`pyrt.materials.MetallicRoughness`'s record (its ``schlick_ue4`` geometry term included)."""
        return MetallicRoughness.compiled_record(self, pack_texture)
