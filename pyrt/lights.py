"""Lights in physical units.

Interface
---------
``Light.sample(p, u) -> (wi, dist, E)``: for shading points ``p`` (N, 3) and random numbers ``u``
(N, 2), the unit direction toward the light, the distance to it (``inf`` for directional light),
and ``E`` (N, 3), the contribution with the sampling pdf divided out: for a point light the
irradiance on a surface perpendicular to ``wi``. The integrator adds ``f_cos(wo, wi) * E * V``
averaged over ``n_samples`` samples. A light that cannot contribute at a point returns ``E = 0``
there and costs no shadow ray. A light may override :meth:`Light.estimate` to use its own
estimator (e.g. multiple importance sampling with the BSDF).

Units and conventions
---------------------
- :class:`PointLight`: radiant intensity ``I`` in W/sr (or power ``phi = 4 pi I`` in W), times ``color``.
- :class:`SpotLight`: intensity ``I`` (W/sr) on the axis; falloff between the inner and outer cone
  half-angles is ``smoothstep(cos theta; cos outer, cos inner)`` (pbrt-v4). ``power`` is not accepted
  because it depends on the falloff; give the on-axis intensity.
- :class:`DirectionalLight`: irradiance ``E`` in W/m^2 on a surface perpendicular to the light,
  ``direction`` is the direction the light *travels* (from the light toward the scene).
"""
from __future__ import annotations

import math
import numbers

import numpy as np

from shaders import lights as kernels


class LightError(ValueError):
    """Invalid light parameters."""


def _vec3(owner, name, v, *, unit=False):
    a = np.asarray(v, dtype=np.float64)
    if a.shape != (3,) or not np.all(np.isfinite(a)):
        raise LightError(f"{owner}: {name} must be 3 finite numbers, got {v!r}")
    if unit:
        n = np.linalg.norm(a)
        if n == 0:
            raise LightError(f"{owner}: {name} is a zero-length direction")
        a = a / n
    return a


def _nonneg(owner, name, v):
    if not isinstance(v, numbers.Real) or isinstance(v, bool) or not math.isfinite(v):
        raise LightError(f"{owner}: {name} must be a finite number, got {v!r}")
    if v < 0:
        raise LightError(f"{owner}: {name} must be >= 0, got {v}")
    return float(v)


def _color(owner, v):
    a = np.asarray(v, dtype=np.float64)
    if a.ndim == 0:
        a = np.repeat(a, 3)
    if a.shape != (3,) or not np.all(np.isfinite(a)) or np.any(a < 0):
        raise LightError(f"{owner}: color must be a non-negative finite RGB triple, got {v!r}")
    return a


class Light:
    """Base class: ``n_samples`` shadow rays per hit and a :meth:`sample` method."""

    n_samples = 1
    #: True for lights at a single point / direction (no randomness).
    delta = True
    name = None

    def sample(self, p, u):
        raise NotImplementedError

    def estimate(self, surf, bsdf, visible, rng):
        """Direct-light estimate at every hit of ``surf``: (N, 3) radiance toward ``surf.wo``.

        ``bsdf.f_cos(idx, wi)`` evaluates the hits' BSDFs (world directions); ``visible(idx, wi, dist)``
        traces shadow rays for the hits ``idx`` and returns a bool array.
        """
        n = surf.n_hits
        L = np.zeros((n, 3))
        ns = self.n_samples
        for s in range(ns):
            if self.delta:
                u = np.zeros((n, 2))
            else:
                # stratify the samples of this light along the first dimension
                u = rng.random((n, 2))
                u[:, 0] = (s + u[:, 0]) / ns
            wi, dist, E = self.sample(surf.p, u)
            cos_g = np.einsum("ij,ij->i", wi, surf.ng)
            active = (cos_g > 0) & (E.max(axis=1) > 0)
            idx = np.flatnonzero(active)
            if idx.size == 0:
                continue
            f = bsdf.f_cos(idx, wi[idx])
            keep = f.max(axis=1) > 0
            idx, f = idx[keep], f[keep]
            if idx.size == 0:
                continue
            vis = visible(idx, wi[idx], dist[idx])
            L[idx] += np.where(vis[:, None], f * E[idx], 0.0)
        return L / ns


class PointLight(Light):
    """Isotropic point light. Give ``intensity`` I (W/sr) or ``power`` phi (W) = 4 pi I, times ``color``."""

    def __init__(self, position, intensity=None, *, power=None, color=(1.0, 1.0, 1.0), name=None):
        owner = f"PointLight({name or ''})"
        self.name = name
        self.position = _vec3(owner, "position", position)
        if (intensity is None) == (power is None):
            raise LightError(f"{owner}: give exactly one of intensity (W/sr) or power (W)")
        if power is not None:
            intensity = _nonneg(owner, "power", power) / (4 * math.pi)
        self.intensity = _nonneg(owner, "intensity", intensity)
        self.color = _color(owner, color)

    @property
    def I(self):
        """RGB radiant intensity (W/sr)."""
        return self.intensity * self.color

    @property
    def power(self):
        return 4 * math.pi * self.intensity

    def sample(self, p, u):
        return kernels.point_light(p, self.position, self.I)


class SpotLight(Light):
    """Spot light at ``position`` pointing along ``direction`` (or toward ``target``).

    ``inner_angle``/``outer_angle`` are cone half-angles in degrees, ``0 <= inner <= outer <= 180``.
    Full intensity inside the inner cone, zero outside the outer cone, pbrt-v4 smoothstep in
    cos(theta) between.
    """

    def __init__(self, position, direction=None, *, target=None, intensity, inner_angle=20.0, outer_angle=30.0,
                 color=(1.0, 1.0, 1.0), name=None):
        owner = f"SpotLight({name or ''})"
        self.name = name
        self.position = _vec3(owner, "position", position)
        if (direction is None) == (target is None):
            raise LightError(f"{owner}: give exactly one of direction or target")
        if target is not None:
            direction = _vec3(owner, "target", target) - self.position
        self.direction = _vec3(owner, "direction", direction, unit=True)
        self.intensity = _nonneg(owner, "intensity", intensity)
        inner = _nonneg(owner, "inner_angle", inner_angle)
        outer = _nonneg(owner, "outer_angle", outer_angle)
        if not inner <= outer <= 180:
            raise LightError(f"{owner}: need 0 <= inner_angle <= outer_angle <= 180 degrees, got {inner}, {outer}")
        self.inner_angle, self.outer_angle = inner, outer
        self.cos_inner = math.cos(math.radians(inner))
        self.cos_outer = math.cos(math.radians(outer))
        self.color = _color(owner, color)

    @property
    def I(self):
        return self.intensity * self.color

    def sample(self, p, u):
        return kernels.spot_light(p, self.position, self.direction, self.I, self.cos_inner, self.cos_outer)


class DirectionalLight(Light):
    """Light from infinitely far away travelling along ``direction``, irradiance ``E`` (W/m^2) perpendicular."""

    def __init__(self, direction, irradiance, *, color=(1.0, 1.0, 1.0), name=None):
        owner = f"DirectionalLight({name or ''})"
        self.name = name
        self.direction = _vec3(owner, "direction", direction, unit=True)
        self.irradiance = _nonneg(owner, "irradiance", irradiance)
        self.color = _color(owner, color)

    @property
    def E(self):
        return self.irradiance * self.color

    def sample(self, p, u):
        return kernels.directional_light(p, self.direction, self.E)


REGISTRY = {"point": PointLight, "spot": SpotLight, "directional": DirectionalLight}
