"""Materials: user-facing parameter holders that call the kernels in :mod:`shaders`.

The material interface (every model implements it; the integrator knows nothing else)
-------------------------------------------------------------------------------------
All directions are in the *local shading frame* of the hit (z = shading normal, turned toward
the viewer), unit length, ``wo`` toward the viewer and ``wi`` toward the light.

``f_cos(wo, wi, ctx) -> (N, 3)``
    BRDF times cos(theta_i) of the non-delta lobes (zero for a pure mirror or glass).
``delta_lobes(wo, ctx) -> list[DeltaLobe]``
    Perfectly specular lobes (mirror reflection, glass reflection and refraction): the
    direction ``wi`` (local frame) and the weight (N, 3) the traced radiance is multiplied by.
``sample(wo, u, ctx) -> (wi, weight, pdf)``
    Sample a direction of the non-delta lobes from ``u`` (N, 2) in [0, 1)^2; ``weight`` is
    ``f_cos / pdf``. The base implementation samples the cosine-weighted hemisphere, which is
    unbiased for any BRDF; models override it with better strategies.
``pdf(wo, wi, ctx) -> (N,)``
    Solid-angle density of :meth:`sample`.
``albedo(ctx) -> (N, 3)``
    Diffuse-like reflectance used by the constant ambient term and the albedo AOV.
``emission(ctx) -> (N, 3)``
    Emitted radiance (W/m^2/sr), zero by default.

``ctx`` is a :class:`pyrt.geometry.SurfaceBatch` restricted to the hits that use this material
(``ctx.uv``, ``ctx.p``, ``ctx.front``, ...). A parameter may be a constant or a texture (any
object with ``evaluate(ctx) -> (N, C)``); :meth:`Material.param` resolves either to an array.

Flags the integrator reads to model no more than the scene needs: ``has_diffuse`` (receives direct
and ambient light), ``has_delta`` (spawns specular rays), ``is_dielectric`` (spawns refraction).
"""
from __future__ import annotations

from dataclasses import dataclass
import numbers

import numpy as np

from shaders import brdfs, fresnel, sampling
from shaders.vec import reflect, refract


class MaterialError(ValueError):
    """A material parameter is missing, unknown or out of range."""


@dataclass
class DeltaLobe:
    """One perfectly specular lobe: local direction ``wi`` (N, 3) and radiance weight (N, 3)."""

    wi: np.ndarray
    weight: np.ndarray
    kind: str  # "reflect" or "refract"
    eta: np.ndarray | None = None  # (N,) eta_t / eta_i for "refract" lobes (ray differentials)


def _is_texture(v):
    return hasattr(v, "evaluate")


def check_color(name, value, owner, *, lo=0.0, hi=None):
    """Validate an RGB triple (or scalar grey) or a texture; return a float64 (3,) array or the texture."""
    if _is_texture(value):
        return value
    arr = np.asarray(value, dtype=np.float64)
    if arr.ndim == 0:
        arr = np.repeat(arr, 3)
    if arr.shape != (3,):
        raise MaterialError(f"{owner}: {name} must be a scalar or an RGB triple, got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise MaterialError(f"{owner}: {name} must be finite, got {arr.tolist()}")
    if np.any(arr < lo) or (hi is not None and np.any(arr > hi)):
        rng = f"[{lo}, {hi}]" if hi is not None else f">= {lo}"
        raise MaterialError(f"{owner}: {name} must be in {rng}, got {arr.tolist()}")
    return arr


def check_scalar(name, value, owner, *, lo=None, hi=None, lo_open=False):
    """Validate a real scalar (or a texture) with an optional range."""
    if _is_texture(value):
        return value
    if not isinstance(value, numbers.Real) or isinstance(value, bool) or not np.isfinite(value):
        raise MaterialError(f"{owner}: {name} must be a finite number, got {value!r}")
    v = float(value)
    if lo is not None and (v < lo or (lo_open and v == lo)):
        raise MaterialError(f"{owner}: {name} must be {'>' if lo_open else '>='} {lo}, got {v}")
    if hi is not None and v > hi:
        raise MaterialError(f"{owner}: {name} must be <= {hi}, got {v}")
    return v


class Material:
    """Base class. Subclasses set the flags and override the methods they need."""

    has_diffuse = True
    has_delta = False
    is_dielectric = False
    #: registry name used by scene files: ``{"type": "lambert", ...}``
    type_name = None
    #: parameters accepted by the scene file loader (name -> kind) filled by subclasses
    name = None

    def param(self, value, ctx, channels=3):
        """Resolve a constant or a texture to an ``(N, channels)`` array (``(N,)`` if channels == 1)."""
        n = ctx.n_hits
        if _is_texture(value):
            out = np.asarray(value.evaluate(ctx), dtype=np.float64)
            if channels == 1:
                return out.reshape(n, -1)[:, 0]
            if out.ndim == 1 or out.shape[1] == 1:
                return np.repeat(out.reshape(n, 1), 3, axis=1)
            return out[:, :3]
        arr = np.asarray(value, dtype=np.float64)
        if channels == 1:
            return np.full(n, float(arr))
        return np.broadcast_to(arr, (n, 3))

    def f_cos(self, wo, wi, ctx):
        return np.zeros_like(wi)

    def delta_lobes(self, wo, ctx):
        return []

    def sample(self, wo, u, ctx):
        wi = sampling.square_to_cosine_hemisphere(u)
        pdf = sampling.cosine_hemisphere_pdf(wi)
        f = self.f_cos(wo, wi, ctx)
        weight = f / np.where(pdf > 0, pdf, 1.0)[:, None]
        return wi, weight, pdf

    def pdf(self, wo, wi, ctx):
        return sampling.cosine_hemisphere_pdf(wi)

    def albedo(self, ctx):
        return np.zeros((ctx.n_hits, 3))

    def emission(self, ctx):
        return np.zeros((ctx.n_hits, 3))

    def __repr__(self):
        fields = ", ".join(f"{k}={v!r}" for k, v in vars(self).items())
        return f"{type(self).__name__}({fields})"


class Lambert(Material):
    """Lambertian diffuse: BRDF ``albedo / pi``; optional emitted radiance ``emission`` (W/m^2/sr)."""

    type_name = "lambert"

    def __init__(self, albedo=0.8, *, emission=0.0, name=None):
        self.name = name
        owner = f"Lambert({name or ''})"
        self.albedo_value = check_color("albedo", albedo, owner, lo=0.0, hi=1.0)
        self.emission_value = check_color("emission", emission, owner, lo=0.0)

    def f_cos(self, wo, wi, ctx):
        return brdfs.lambert_f_cos(wo, wi, self.param(self.albedo_value, ctx))

    def sample(self, wo, u, ctx):
        wi = sampling.square_to_cosine_hemisphere(u)
        pdf = sampling.cosine_hemisphere_pdf(wi)
        active = (wo[:, 2] > 0) & (pdf > 0)
        weight = np.where(active[:, None], self.param(self.albedo_value, ctx), 0.0)
        return wi, weight, pdf

    def albedo(self, ctx):
        return np.array(self.param(self.albedo_value, ctx))

    def emission(self, ctx):
        return np.array(self.param(self.emission_value, ctx))


class BlinnPhong(Material):
    """Energy-normalised Blinn-Phong: ``kd/pi + ks (n+8)/(8 pi) (n.h)^n`` (reciprocal).

    ``kd + ks <= 1`` per channel is required so that the model conserves energy.
    """

    type_name = "blinn_phong"

    def __init__(self, kd=0.5, ks=0.04, exponent=64.0, *, name=None):
        self.name = name
        owner = f"BlinnPhong({name or ''})"
        self.kd = check_color("kd", kd, owner, lo=0.0, hi=1.0)
        self.ks = check_color("ks", ks, owner, lo=0.0, hi=1.0)
        self.exponent = check_scalar("exponent", exponent, owner, lo=0.0)
        if not _is_texture(self.kd) and not _is_texture(self.ks) and np.any(self.kd + self.ks > 1.0 + 1e-12):
            raise MaterialError(f"{owner}: kd + ks must be <= 1 per channel, got {(self.kd + self.ks).tolist()}")

    def f_cos(self, wo, wi, ctx):
        return brdfs.blinn_phong_normalized_f_cos(
            wo, wi, self.param(self.kd, ctx), self.param(self.ks, ctx), self.param(self.exponent, ctx, 1))

    def albedo(self, ctx):
        return np.array(self.param(self.kd, ctx))


class Mirror(Material):
    """Perfect mirror with reflectance ``reflectance`` (RGB): ``L = reflectance * L(reflect(wo))``."""

    type_name = "mirror"
    has_diffuse = False
    has_delta = True

    def __init__(self, reflectance=1.0, *, name=None):
        self.name = name
        self.reflectance = check_color("reflectance", reflectance, f"Mirror({name or ''})", lo=0.0, hi=1.0)

    def delta_lobes(self, wo, ctx):
        n = np.zeros_like(wo)
        n[:, 2] = 1.0
        return [DeltaLobe(reflect(wo, n), np.array(self.param(self.reflectance, ctx)), "reflect")]


class Glass(Material):
    """Smooth dielectric with index of refraction ``ior`` (relative to the surrounding medium, vacuum = 1).

    Exact unpolarised Fresnel reflectance R splits the ray: reflection weighted R, refraction
    weighted 1 - R (``tint`` multiplies both); total internal reflection gives R = 1. Radiance is
    *not* scaled by 1/eta^2 on refraction (pbrt's "importance" convention is not needed for a
    camera-only Whitted tracer: we trace radiance and the eta^2 factors cancel on a round trip
    through a closed object; the choice is documented and tested with R + T = 1).
    """

    type_name = "glass"
    has_diffuse = False
    has_delta = True
    is_dielectric = True

    def __init__(self, ior=1.5, *, tint=1.0, name=None):
        self.name = name
        owner = f"Glass({name or ''})"
        self.ior = check_scalar("ior", ior, owner, lo=0.0, lo_open=True)
        self.tint = check_color("tint", tint, owner, lo=0.0, hi=1.0)

    def delta_lobes(self, wo, ctx):
        eta = np.where(ctx.front, self.ior, 1.0 / self.ior)  # eta_t / eta_i
        cos_o = wo[:, 2]
        R = fresnel.fr_dielectric(cos_o, eta)
        nz = np.zeros_like(wo)
        nz[:, 2] = 1.0
        tint = np.array(self.param(self.tint, ctx))
        wr = reflect(wo, nz)
        wt, tir = refract(wo, nz, eta)
        R = np.where(tir, 1.0, R)
        lobes = [DeltaLobe(wr, tint * R[:, None], "reflect")]
        T = 1.0 - R
        if np.any(T > 0):
            lobes.append(DeltaLobe(wt, tint * T[:, None], "refract", eta))
        return lobes


#: scene-file ``type`` -> class
REGISTRY = {cls.type_name: cls for cls in (Lambert, BlinnPhong, Mirror, Glass)}


def register(cls):
    """Register a material class under its ``type_name`` for scene files; returns ``cls``."""
    REGISTRY[cls.type_name] = cls
    return cls
