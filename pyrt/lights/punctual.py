"""Lights in physical units.

The interface is :class:`pyrt.lights.base.Light` (lights only sample; the estimator that turns samples
into radiance lives in :mod:`pyrt.integrators.direct`).

Units and conventions
---------------------
- :class:`PointLight`: radiant intensity ``I`` in W/sr (or power ``phi = 4 pi I`` in W), times ``color``.
- :class:`SpotLight`: intensity ``I`` (W/sr) on the axis; falloff between the inner and outer cone
  half-angles is ``smoothstep(cos theta; cos outer, cos inner)`` (pbrt-v4). ``power`` is not accepted
  because it depends on the falloff; give the on-axis intensity.
- :class:`DirectionalLight`: irradiance ``E`` in W/m^2 on a surface perpendicular to the light,
  ``direction`` is the direction the light *travels* (from the light toward the scene).
- :class:`ProjectorLight` (gobo / slide projector), :class:`GoniometricLight` (lat-long intensity
  image) and :class:`IESLight` (measured IES LM-63 type C profile) are point lights whose intensity
  varies with direction.

Photometric units
-----------------
Every light also accepts photometric values: ``candela=`` (luminous intensity, cd = lm/sr) or
``power_lm=`` (luminous flux, lm) for point and spot lights, ``lux=`` (illuminance, lm/m^2) for a
directional light. Conversion: a radiometric RGB quantity ``Q`` (W, W/sr, W/m^2 per channel) has the
photometric value ``683 lm/W * luminance(Q)`` with the Rec. 709 weights
``luminance = 0.2126 R + 0.7152 G + 0.0722 B`` (:data:`shaders.color.LUMINANCE_WEIGHTS`); 683 lm/W is
the luminous efficacy of 555 nm light (the SI definition of the candela). So ``candela=c`` sets the
intensity to ``c / 683`` W/sr per channel, times ``color``: the light's luminous intensity is
``c * luminance(color)``, exactly ``c`` for white or for a ``temperature=`` colour (which has unit
luminance). This is the glTF KHR_lights_punctual reading (``color`` filters a light of the given
photometric value; Blender's importer uses the same 683 lm/W).

Colour temperature: ``temperature=T`` (kelvin) instead of ``color`` gives the black-body colour
normalised to unit luminance (:func:`shaders.color.kelvin_to_srgb`).

Distance falloff and range
--------------------------
Point-like lights take ``falloff=`` one of :data:`shaders.lights.DISTANCE_FALLOFFS`
(``"inverse_square"`` (default, physical), ``"inverse_square_eps"`` (with ``epsilon``),
``"smooth_range"`` (UE4/Filament window, needs ``range``), ``"gltf_range"`` (needs ``range``),
``"clq"`` (``1 / (Kc + Kl r + Kq r^2)`` with ``clq=(Kc, Kl, Kq)``, point and spot lights)) and
an optional ``range`` (m): beyond it E = 0, so the integrator traces no shadow ray there. Spot-like
lights take ``spot_falloff=`` one of ``"smoothstep"`` (pbrt-v4, default), ``"gltf"``,
``"linear_angle"`` (Mitsuba).

Total power
-----------
``radiant_power()`` returns the RGB power (W) from the closed form of each light's profile and
``luminous_power()`` the flux in lm (683 * luminance). Point: ``4 pi I``; spot:
``I * spot_cone_solid_angle``; goniometric and IES: exact integrals of the interpolated data;
projector: a fixed quadrature over the cone.
"""
from __future__ import annotations

import math

import numpy as np

from pyrt.lights.base import (LIGHTS, LUMINOUS_EFFICACY, Light, LightError, LightSample, _color, _intensity,
                              _nonneg, _resolve_color, _vec3)
from pyrt.lights import compiled as _compiled
from pyrt.shaders import color as _colour
from pyrt.shaders import jit as _jit
from pyrt.shaders import lights as kernels


class _PunctualLight(Light):
    """Shared parts of lights at a point: colour, distance falloff and range.

    Subclasses define :meth:`radiant_intensity`; :meth:`sample` is then ``E = I(-wi) f(r)``.
    """

    fixed_position = True

    def __init_subclass__(cls, **kwargs):
        # Fast paths by construction: a subclass that changes what the light emits (sample or
        # radiant_intensity) but not sample_li gets the general sample_li, built from its own sample().
        super().__init_subclass__(**kwargs)
        if "sample_li" not in cls.__dict__ and ("sample" in cls.__dict__ or "radiant_intensity" in cls.__dict__):
            cls.sample_li = Light.sample_li
        # ... and is not compiled unless it says how (the compiled records hold the parents' profiles)
        if "compiled_record" not in cls.__dict__ and ("sample" in cls.__dict__ or "radiant_intensity" in cls.__dict__
                                                      or "sample_li" in cls.__dict__):
            cls.compiled_record = Light.compiled_record

    def _init_falloff(self, owner, falloff, epsilon, light_range, clq=None):
        if falloff not in kernels.DISTANCE_FALLOFFS:
            raise LightError(f"{owner}: falloff must be one of {list(kernels.DISTANCE_FALLOFFS)}, got {falloff!r}")
        self.falloff = falloff
        if falloff == "clq":
            if clq is None:
                raise LightError(f"{owner}: falloff 'clq' needs clq=(Kc, Kl, Kq)")
            clq = self._check_clq(owner, clq)
        elif clq is not None:
            raise LightError(f"{owner}: clq is only used by falloff 'clq'")
        self.clq = clq
        if light_range is not None:
            light_range = _nonneg(owner, "range", light_range)
            if light_range == 0:
                raise LightError(f"{owner}: range must be > 0 (or None for no range)")
        if falloff in ("smooth_range", "gltf_range") and light_range is None:
            raise LightError(f"{owner}: falloff {falloff!r} needs a range (m)")
        self.range = light_range
        if falloff == "inverse_square_eps":
            if epsilon is None:
                raise LightError(f"{owner}: falloff 'inverse_square_eps' needs epsilon (m) > 0")
            epsilon = _nonneg(owner, "epsilon", epsilon)
        elif epsilon is not None:
            raise LightError(f"{owner}: epsilon is only used by falloff 'inverse_square_eps'")
        self.epsilon = epsilon

    def validate(self):
        """The base checks, then ``position`` (3 finite numbers), ``intensity`` >= 0, ``color`` >= 0 and the
        distance falloff's ``range`` (> 0 or None) and ``epsilon``."""
        super().validate()
        owner = self.label
        _vec3(owner, "position", self.position)
        _nonneg(owner, "intensity", self.intensity)
        _color(owner, self.color)
        if self.range is not None and not _nonneg(owner, "range", self.range) > 0:
            raise LightError(f"{owner}: range must be > 0 (or None for no range)")
        if self.epsilon is not None:
            _nonneg(owner, "epsilon", self.epsilon)
        if self.clq is not None:
            self._check_clq(owner, self.clq)

    @staticmethod
    def _check_clq(owner, clq):
        """``(Kc, Kl, Kq)``: three finite numbers >= 0, not all zero; returned as a tuple of floats."""
        k = np.asarray(clq, dtype=np.float64)
        if k.shape != (3,) or not np.all(np.isfinite(k)) or np.any(k < 0) or not np.any(k > 0):
            raise LightError(f"{owner}: clq must be three finite numbers (Kc, Kl, Kq) >= 0, not all 0, got {clq!r}")
        return tuple(float(x) for x in k)

    @property
    def _physical(self):
        """Plain inverse-square falloff with no range: the original kernels apply unchanged."""
        return self.falloff == "inverse_square" and self.range is None

    def distance_falloff(self, dist):
        """The falloff factor f(r) (m^-2) of this light at distances ``dist`` (N,)."""
        return kernels.distance_falloff(dist, self.falloff, eps=self.epsilon or 0.0,
                                        light_range=np.inf if self.range is None else self.range,
                                        clq=self.clq or (0.0, 0.0, 1.0))

    def radiant_intensity(self, w):
        """Radiant intensity (W/sr) per RGB channel toward unit world directions ``w`` (N, 3) from the light."""
        raise NotImplementedError

    def sample(self, p, u):
        """``E = I(-wi) f(r)``: intensity toward the point times the distance falloff (0 beyond the range)."""
        wi, dist = kernels.light_direction(p, self.position)
        f = self.distance_falloff(dist)
        E = np.zeros((p.shape[0], 3))
        lit = np.flatnonzero(f > 0)   # beyond the range: no intensity lookup, E = 0, no shadow ray
        if lit.size:
            E[lit] = self.radiant_intensity(-wi[lit]) * f[lit, None]
        return wi, dist, E

    @property
    def candela(self):
        """Peak (on-axis for spots, scale for profiles) luminous intensity (cd) = 683 luminance(I)."""
        return float(LUMINOUS_EFFICACY * _colour.luminance(self.intensity * self.color))


@LIGHTS.register("point")
class PointLight(_PunctualLight):
    """Isotropic point light.

    Give exactly one of ``intensity`` I (W/sr), ``power`` phi (W) = 4 pi I, ``candela`` (cd) or
    ``power_lm`` (lm); ``color`` (RGB filter) or ``temperature`` (kelvin). ``falloff``, ``epsilon``,
    ``range`` and ``clq`` as in the module docstring.
    """

    @classmethod
    def example(cls):
        """A 10 W/sr light at (0, 2, 0)."""
        return cls((0.0, 2.0, 0.0), intensity=10.0, color=(1.0, 0.8, 0.6))

    def __init__(self, position, intensity=None, *, power=None, candela=None, power_lm=None, color=None,
                 temperature=None, falloff="inverse_square", epsilon=None, range=None, clq=None,  # noqa: A002
                 name=None):
        owner = f"PointLight({name or ''})"
        self.name = name
        self.position = _vec3(owner, "position", position)
        self.intensity = _intensity(owner, solid_angle=4 * math.pi, intensity=intensity, power=power,
                                    candela=candela, power_lm=power_lm)
        self.color = _resolve_color(owner, color, temperature)
        self._init_falloff(owner, falloff, epsilon, range, clq)
        self.validate()

    @property
    def I(self):
        """RGB radiant intensity (W/sr)."""
        return self.intensity * self.color

    @property
    def power(self):
        """Radiant power (W) of the scalar intensity, ``4 pi I`` (times ``color`` per channel)."""
        return 4 * math.pi * self.intensity

    def radiant_intensity(self, w):
        return np.broadcast_to(self.I, (w.shape[0], 3)).copy()

    def compiled_record(self):
        """:data:`pyrt.lights.compiled.POINT`."""
        return _compiled.punctual_record(self, _compiled.POINT)

    def radiant_power(self):
        return 4 * math.pi * self.I

    def sample(self, p, u):
        """``(wi, dist, E)`` with ``E = I / r^2`` (or the chosen falloff)."""
        if self._physical:
            return kernels.point_light(p, self.position, self.I)
        return super().sample(p, u)

    def sample_li(self, p, u):
        """Factored ``E = (1 / r^2) * I`` for the physical falloff; the general form otherwise."""
        if not self._physical:
            return Light.sample_li(self, p, u)
        wi, dist, s = kernels.point_light_scalar(p, self.position)
        return LightSample(wi, dist, scale=s, rgb=self.I)


def _cone(owner, inner_angle, outer_angle, *, max_outer=180.0):
    inner = _nonneg(owner, "inner_angle", inner_angle)
    outer = _nonneg(owner, "outer_angle", outer_angle)
    if not inner <= outer <= max_outer:
        raise LightError(f"{owner}: need 0 <= inner_angle <= outer_angle <= {max_outer:g} degrees, got {inner}, {outer}")
    return inner, outer


def _axis(owner, position, direction, target):
    if (direction is None) == (target is None):
        raise LightError(f"{owner}: give exactly one of direction or target")
    if target is not None:
        direction = _vec3(owner, "target", target) - position
    return _vec3(owner, "direction", direction, unit=True)


def _frame(owner, z, ref, ref_name):
    """Orthonormal (x, y, z) with x along ``ref`` projected perpendicular to ``z`` (y = z x x)."""
    ref = _vec3(owner, ref_name, ref)
    x = ref - np.dot(ref, z) * z
    n = np.linalg.norm(x)
    if n < 1e-9 * max(1.0, np.linalg.norm(ref)):
        raise LightError(f"{owner}: {ref_name} {ref.tolist()} is parallel to the light's axis {z.tolist()}")
    x = x / n
    return x, np.cross(z, x), z


@LIGHTS.register("spot")
class SpotLight(_PunctualLight):
    """Spot light at ``position`` pointing along ``direction`` (or toward ``target``).

    ``inner_angle``/``outer_angle`` are cone half-angles in degrees, ``0 <= inner <= outer <= 180``.
    Full intensity inside the inner cone, zero outside the outer cone, and between them
    ``spot_falloff``: ``"smoothstep"`` in cos(theta) (pbrt-v4, the default), ``"gltf"`` (squared
    linear in cos theta) or ``"linear_angle"`` (Mitsuba 3). Give exactly one of ``intensity`` (on-axis,
    W/sr), ``candela``, ``power`` (W) or ``power_lm`` (lm); power and intensity are related by the
    closed-form cone integral :func:`shaders.lights.spot_cone_solid_angle` of the chosen falloff.
    """

    @classmethod
    def example(cls):
        """A spot at (0, 2, 0) pointing down, 20-40 degree cone."""
        return cls((0.0, 2.0, 0.0), (0.0, -1.0, 0.0), intensity=10.0, inner_angle=20.0, outer_angle=40.0)

    def __init__(self, position, direction=None, *, target=None, intensity=None, power=None, candela=None,
                 power_lm=None, inner_angle=20.0, outer_angle=30.0, spot_falloff="smoothstep", color=None,
                 temperature=None, falloff="inverse_square", epsilon=None, range=None, clq=None,  # noqa: A002
                 name=None):
        owner = f"{type(self).__name__}({name or ''})"
        self.name = name
        self.position = _vec3(owner, "position", position)
        self.direction = _axis(owner, self.position, direction, target)
        self._init_cone(owner, inner_angle, outer_angle, spot_falloff)
        self.intensity = _intensity(owner, solid_angle=self.cone_solid_angle, intensity=intensity, power=power,
                                    candela=candela, power_lm=power_lm)
        self.color = _resolve_color(owner, color, temperature)
        self._init_falloff(owner, falloff, epsilon, range, clq)
        self.validate()

    def validate(self):
        """The punctual checks, then a finite non-zero ``direction`` and the cone angles."""
        super().validate()
        _vec3(self.label, "direction", self.direction, unit=True)
        _cone(self.label, self.inner_angle, self.outer_angle)

    def _init_cone(self, owner, inner_angle, outer_angle, spot_falloff, max_outer=180.0):
        self.inner_angle, self.outer_angle = _cone(owner, inner_angle, outer_angle, max_outer=max_outer)
        if spot_falloff not in kernels.SPOT_FALLOFFS:
            raise LightError(f"{owner}: spot_falloff must be one of {sorted(kernels.SPOT_FALLOFFS)}, "
                             f"got {spot_falloff!r}")
        self.spot_falloff = spot_falloff

    @property
    def cos_inner(self):
        """cos of the inner cone half-angle (derived from :attr:`inner_angle`, so it never goes stale)."""
        return math.cos(math.radians(self.inner_angle))

    @property
    def cos_outer(self):
        """cos of the outer cone half-angle (derived from :attr:`outer_angle`)."""
        return math.cos(math.radians(self.outer_angle))

    @property
    def cone_solid_angle(self):
        """``int g(w) dw`` (sr) of the cone falloff: power = intensity * this."""
        return float(kernels.spot_cone_solid_angle(self.spot_falloff, self.cos_inner, self.cos_outer))

    @property
    def I(self):
        """RGB on-axis radiant intensity (W/sr): ``intensity * color``."""
        return self.intensity * self.color

    @property
    def power(self):
        """Radiant power (W) of the scalar intensity (times ``color`` for RGB, see :meth:`radiant_power`)."""
        return self.intensity * self.cone_solid_angle

    def cone_factor(self, w):
        """Spot falloff g toward world directions ``w`` (N, 3) from the light."""
        g = kernels.SPOT_FALLOFFS[self.spot_falloff]
        return g(w @ self.direction, self.cos_inner, self.cos_outer)

    def radiant_intensity(self, w):
        return self.I[None, :] * self.cone_factor(w)[:, None]

    def compiled_record(self):
        """:data:`pyrt.lights.compiled.SPOT`."""
        tag, rec = _compiled.punctual_record(self, _compiled.SPOT)
        rec[3:6] = self.direction
        rec[9], rec[10] = self.cos_inner, self.cos_outer
        rec[11] = _jit.SPOT_KINDS.index(self.spot_falloff)
        return tag, rec

    def radiant_power(self):
        return self.I * self.cone_solid_angle

    def sample(self, p, u):
        """``(wi, dist, E)`` with ``E = I g(cos theta) / r^2`` (or the chosen distance falloff)."""
        if self._physical:
            return kernels.spot_light(p, self.position, self.direction, self.I, self.cos_inner, self.cos_outer,
                                      falloff=kernels.SPOT_FALLOFFS[self.spot_falloff])
        return super().sample(p, u)

    def sample_li(self, p, u):
        """Factored ``E = (g / r^2) * I`` for the physical falloff; the general form otherwise."""
        if not self._physical:
            return Light.sample_li(self, p, u)
        wi, dist, s = kernels.spot_light_scalar(p, self.position, self.direction, self.cos_inner, self.cos_outer,
                                                falloff=kernels.SPOT_FALLOFFS[self.spot_falloff])
        return LightSample(wi, dist, scale=s, rgb=self.I)


@LIGHTS.register("directional")
class DirectionalLight(Light):
    """Light from infinitely far away travelling along ``direction``.

    Give exactly one of ``irradiance`` E (W/m^2 on a surface perpendicular to the light) or ``lux``
    (illuminance, lm/m^2; E = lux / 683 per channel times ``color``); ``color`` or ``temperature``.
    """

    @classmethod
    def example(cls):
        """2 W/m^2 travelling down and sideways."""
        return cls((0.3, -1.0, -0.2), 2.0)

    def __init__(self, direction, irradiance=None, *, lux=None, color=None, temperature=None, name=None):
        owner = f"DirectionalLight({name or ''})"
        self.name = name
        self.direction = _vec3(owner, "direction", direction, unit=True)
        if (irradiance is None) == (lux is None):
            raise LightError(f"{owner}: give exactly one of irradiance (W/m^2) or lux")
        self.irradiance = (_nonneg(owner, "irradiance", irradiance) if lux is None
                           else _nonneg(owner, "lux", lux) / LUMINOUS_EFFICACY)
        self.color = _resolve_color(owner, color, temperature)
        self.validate()

    def validate(self):
        """The base checks, then a finite non-zero ``direction``, ``irradiance`` >= 0 and ``color`` >= 0."""
        super().validate()
        _vec3(self.label, "direction", self.direction, unit=True)
        _nonneg(self.label, "irradiance", self.irradiance)
        _color(self.label, self.color)

    @property
    def E(self):
        """RGB irradiance (W/m^2) on a surface perpendicular to the light: ``irradiance * color``."""
        return self.irradiance * self.color

    @property
    def lux(self):
        """Illuminance (lm/m^2) on a perpendicular surface: 683 luminance(E)."""
        return float(LUMINOUS_EFFICACY * _colour.luminance(self.E))

    def __init_subclass__(cls, **kwargs):
        super().__init_subclass__(**kwargs)      # a subclass overriding sample() gets the general sample_li
        if "sample_li" not in cls.__dict__ and "sample" in cls.__dict__:
            cls.sample_li = Light.sample_li
        if "compiled_record" not in cls.__dict__ and ("sample" in cls.__dict__ or "sample_li" in cls.__dict__):
            cls.compiled_record = Light.compiled_record

    def compiled_record(self):
        """:data:`pyrt.lights.compiled.DIRECTIONAL`."""
        rec = np.zeros(_compiled.RECORD)
        rec[3:6] = self.direction
        rec[6:9] = self.E
        return _compiled.DIRECTIONAL, rec

    def sample(self, p, u):
        """``(wi, dist, E)``: ``wi = -direction``, ``dist = inf``, ``E`` the irradiance everywhere."""
        return kernels.directional_light(p, self.direction, self.E)

    def sample_li(self, p, u):
        """Factored: ``E = 1 * E_rgb`` everywhere, ``dist = inf``."""
        n = p.shape[0]
        return LightSample(np.broadcast_to(-self.direction, (n, 3)), np.full(n, np.inf), rgb=self.E)
