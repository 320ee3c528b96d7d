"""The light interface: a light only samples; the integrators own the estimator.

``Light.sample_li(p, u) -> LightSample``: for shading points ``p`` (N, 3) and random numbers ``u``
(N, 2) in [0, 1)^2, the unit direction ``wi`` toward the light, the distance to it (``inf`` for
directional and environment light) and the contribution ``E`` (W/m^2 per RGB channel) with the
sampling pdf divided out: for a point light the irradiance on a surface perpendicular to ``wi``.
:class:`LightSample` carries ``E`` either as an (N, 3) array or factored as a per-point scalar times
one RGB colour (lights of one colour: no (N, 3) array, no per-light max or gather). A light that
cannot contribute at a point returns ``E = 0`` there and costs no shadow ray.
``Light.pdf_li(p, wi)`` is the solid-angle density of ``sample_li`` (0 for delta lights), what
multiple importance sampling needs. :mod:`pyrt.integrators.direct` adds ``f_cos(wo, wi) * E * V``
averaged over ``n_samples`` samples per hit.

A new light is one kernel in :mod:`pyrt.shaders.lights` and one class here registered with
``@LIGHTS.register("name")``; tests/test_light_contracts.py checks it.
"""
from __future__ import annotations

import math
import numbers

import numpy as np

from pyrt.core import checks
from pyrt.core.errors import Error
from pyrt.core.registry import Registry
from pyrt.shaders import color as _colour
from pyrt.shaders.vec import mul_rgb, scale_rows, take_rows


class LightError(Error, ValueError):
    """Invalid light parameters."""


def _vec3(owner, name, v, *, unit=False):
    a = checks.numbers_array(owner, name, v, LightError)
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
    return checks.rgb(owner, "color", v, LightError)



class LightSample:
    """Samples of a light at N shading points.

    Attributes
    ----------
    wi : (N, 3) float64 ndarray
        Unit directions toward the light.
    dist : (N,) float64 ndarray
        Distance to the sampled point (``inf`` for lights at infinity).
    E : (N, 3) float64 ndarray or None
        Contribution with the pdf divided out (W/m^2 per channel), when not factored.
    scale : (N,) float64 ndarray or None
        Factored form ``E = scale[:, None] * rgb`` (None: scale 1 everywhere).
    rgb : (3,) float64 ndarray or None
        The light's colour in the factored form (None when ``E`` is given).
    pdf : (N,) float64 ndarray or None
        The solid-angle density of each sample, when the light knows it better than :meth:`Light.pdf_li` of the
        direction would (a sampled point on one of several emitter triangles: the MIS weights use it); None:
        ``pdf_li(p, wi)``.
    """

    __slots__ = ("wi", "dist", "E", "scale", "rgb", "pdf")

    def __init__(self, wi, dist, E=None, *, scale=None, rgb=None, pdf=None):
        if (E is None) == (rgb is None):
            raise ValueError("LightSample: give E or rgb (with an optional scale), not both")
        self.wi, self.dist, self.E, self.scale, self.rgb = wi, dist, E, scale, rgb
        self.pdf = pdf

    @property
    def factored(self):
        """True when ``E = scale * rgb`` (:attr:`rgb` set)."""
        return self.rgb is not None

    def active(self):
        """(N,) bool: where the sample can contribute (E > 0 in some channel)."""
        if self.rgb is None:
            return self.E.max(axis=1) > 0 if self.E.size else np.zeros(0, dtype=bool)
        if not np.max(self.rgb) > 0:
            return np.zeros(self.wi.shape[0], dtype=bool)
        return np.ones(self.wi.shape[0], dtype=bool) if self.scale is None else self.scale > 0

    def irradiance(self):
        """``E`` as an (N, 3) array."""
        if self.rgb is None:
            return self.E
        n = self.wi.shape[0]
        rgb = np.broadcast_to(self.rgb, (n, 3))
        return np.array(rgb) if self.scale is None else self.scale[:, None] * rgb

    def weight(self, f, idx):
        """``f * E[idx]`` in place for f (k, 3) at the sample rows ``idx`` (k,); returns ``f``."""
        if self.rgb is None:
            f *= take_rows(self.E, idx)
        else:
            mul_rgb(f, self.rgb, out=f)
            if self.scale is not None:
                scale_rows(f, np.take(self.scale, idx), out=f)
        return f


class Light:
    """Base class of every light: a light only samples, the integrators estimate.

    Subclasses implement :meth:`sample` (``wi, dist, E`` arrays) or :meth:`sample_li` (a
    :class:`LightSample`); the other is derived. Non-delta lights also implement :meth:`pdf_li`.

    Methods
    -------
    sample_li(p, u) -> LightSample
        ``p`` (N, 3) float64 shading points (m), ``u`` (N, 2) float64 in [0, 1)^2 (ignored by delta lights).
    pdf_li(p, wi) -> (N,) float64
        Solid-angle density (sr^-1) of :meth:`sample_li`; 0 for delta lights.
    radiant_power() -> (3,) float64
        Total emitted power (W per RGB channel), where finite.
    example() -> Light
        A typical instance (classmethod) for the contract tests.
    """

    #: True when every sample of the light is the point :attr:`position` (punctual lights): shadow rays
    #: then end at that point exactly.
    fixed_position = False
    #: the light's position (punctual lights), else None
    position = None
    #: the light's axis (spot, projector, IES) or travel direction (directional), unit (3,); else None
    direction = None
    #: shadow rays per hit (stratified when > 1)
    n_samples = 1
    #: BSDF samples per hit MIS-combined with the light samples (area lights with :meth:`ray_distance`; 0: none)
    bsdf_samples = 0
    #: True for lights at a single point / direction (no randomness: ``u`` is ignored)
    delta = True
    #: True for lights that can add a visible emitter mesh to a scene (:meth:`add_to`)
    has_mesh = False
    #: True for lights that sample triangles of the scene's own meshes (:class:`pyrt.lights.mesh.EmissiveMeshLight`):
    #: a ray that hits them reaches the light, and :meth:`pdf_hit` gives the light's density there
    scene_emitter = False
    #: the :class:`pyrt.lights.environment.Environment` an environment light samples, else None; the
    #: integrators then use the environment estimator (strategies, MIS) with the light's settings
    environment = None
    #: the user's name for the light
    name = None
    #: registry name used by scene files (set by :meth:`Registry.register`)
    type_name = None

    @classmethod
    def example(cls):
        """A typical instance for the contract tests (tests/test_light_contracts.py); every light defines one."""
        raise NotImplementedError(f"{cls.__name__} defines no example()")

    @property
    def label(self):
        """The light as messages name it: ``"PointLight(key)"``."""
        return f"{type(self).__name__}({self.name or ''})"

    def validate(self):
        """Check the light's parameters as they are now; raise :class:`LightError` naming the light.

        Constructors end with it and :class:`pyrt.PreparedScene` calls it again before every render, so
        a parameter assigned after construction (``light.intensity = float("nan")``) is an error rather
        than a light that silently contributes nothing. The base checks that every public numeric
        attribute is finite (:func:`pyrt.core.checks.finite_attributes`) and that ``n_samples`` is a
        positive integer; subclasses add their ranges and call ``super().validate()``.
        """
        checks.finite_attributes(self.label, self, LightError)
        n = self.n_samples
        if not isinstance(n, numbers.Integral) or isinstance(n, bool) or n < 1:
            raise LightError(f"{self.label}: n_samples must be a positive integer, got {n!r}")
        nb = self.bsdf_samples
        if not isinstance(nb, numbers.Integral) or isinstance(nb, bool) or nb < 0:
            raise LightError(f"{self.label}: bsdf_samples must be an integer >= 0, got {nb!r}")

    def sample(self, p, u):
        """``(wi, dist, E)`` arrays at shading points ``p`` (N, 3) for random numbers ``u`` (N, 2)."""
        s = self.sample_li(p, u)
        return s.wi, s.dist, s.irradiance()

    def compiled_record(self):
        """``(tag, record)``: this light as a row of the compiled kernel's light table (:mod:`pyrt.lights.compiled`),
        or ``(tag, record, data)`` for a light with tables of its own (a float64 array the compiled scene appends after
        the records, :mod:`pyrt.lights.compiled_mesh`), or None when the compiled kernel cannot sample it (the render
        then takes the NumPy path). Default None."""
        return None

    def sample_li(self, p, u):
        """A :class:`LightSample` at shading points ``p`` (N, 3) for random numbers ``u`` (N, 2).

        The default wraps :meth:`sample` (the unfactored form).
        """
        wi, dist, E = self.sample(p, u)
        return LightSample(wi, dist, E)

    def pdf_li(self, p, wi):
        """Solid-angle density (N,) of :meth:`sample_li` toward ``wi`` (N, 3) from ``p``; 0 for delta lights."""
        if self.delta:
            return np.zeros(wi.shape[0])
        raise NotImplementedError(f"{type(self).__name__} defines no pdf_li")

    def pdf_hit(self, p, mesh_id, prim_id, dist, cos_l):
        """Solid-angle density (N,) of the light's sampling from the points ``p`` at the points their rays hit
        (scene mesh ``mesh_id``, its triangle ``prim_id``, at distance ``dist``, cosine ``cos_l`` between the ray
        and the triangle's normal): 0 unless the light samples scene triangles (:attr:`scene_emitter`)."""
        return np.zeros(np.asarray(dist).shape[0])

    @property
    def emitter_mesh_name(self):
        """The name of the visible emitter mesh :meth:`add_to` adds for a light with :attr:`has_mesh`
        (``"<name>_emitter"``), else None."""
        return f"{self.name or type(self).__name__}_emitter" if self.has_mesh else None

    def built_for(self, meshes):
        """True when the light may light a scene with these ``meshes`` (every light but a :attr:`scene_emitter`,
        which must find its own meshes there)."""
        return True

    def ray_distance(self, p, wi):
        """Distance (N,) from ``p`` along ``wi`` to the light's emitting surface, ``inf`` where the ray misses it
        (the lights that BSDF sampling can reach define it; for the others every ray misses)."""
        return np.full(np.asarray(wi).shape[0], np.inf)

    def radiant_power(self):
        """Total emitted power (W) per RGB channel, (3,) float64."""
        raise NotImplementedError(f"{type(self).__name__} has no finite total power")

    def luminous_power(self):
        """Total luminous flux (lm): ``683 * luminance(radiant_power())``."""
        return float(LUMINOUS_EFFICACY * _colour.luminance(self.radiant_power()))

    def add_to(self, scene, *, visible=True):
        """Add the light to ``scene`` (lights with a mesh also add their emitter when ``visible``); returns it."""
        scene.add_light(self)
        return self


LUMINOUS_EFFICACY = _colour.LUMINOUS_EFFICACY

#: scene-file ``type`` -> light class
LIGHTS = Registry("light", Light)
#: light keyword arguments that are file paths (resolved relative to a scene file by the loader)
PATH_ARGUMENTS = ("image", "profile")

def _resolve_color(owner, color, temperature):
    """RGB colour from ``color`` or ``temperature`` (kelvin, unit-luminance black body); default white."""
    if temperature is not None:
        if color is not None:
            raise LightError(f"{owner}: give either color or temperature (kelvin), not both")
        if (not isinstance(temperature, numbers.Real) or isinstance(temperature, bool)
                or not math.isfinite(temperature) or not 100.0 <= temperature <= 1e6):
            raise LightError(f"{owner}: temperature must be a number of kelvin in [100, 1e6], got {temperature!r}")
        return _colour.kelvin_to_srgb(float(temperature))
    return _color(owner, (1.0, 1.0, 1.0) if color is None else color)


def _intensity(owner, *, solid_angle, intensity=None, power=None, candela=None, power_lm=None):
    """Radiant intensity scale (W/sr) from exactly one of intensity (W/sr), power (W), candela, power_lm (lm).

    ``solid_angle`` (sr) converts power to intensity (``None``: power not accepted).
    """
    given = {k: v for k, v in dict(intensity=intensity, power=power, candela=candela, power_lm=power_lm).items()
             if v is not None}
    allowed = ["intensity (W/sr)", "candela"] + (["power (W)", "power_lm (lm)"] if solid_angle is not None else [])
    if len(given) != 1:
        raise LightError(f"{owner}: give exactly one of {', '.join(allowed)}; got {sorted(given) or 'none'}")
    (k, v), = given.items()
    if solid_angle is None and k in ("power", "power_lm"):
        raise LightError(f"{owner}: {k} is not accepted here; give one of {', '.join(allowed)}")
    v = _nonneg(owner, k, v)
    if k == "intensity":
        return v
    if k == "candela":
        return v / LUMINOUS_EFFICACY
    if solid_angle <= 0:
        raise LightError(f"{owner}: the light emits into a zero solid angle; {k} cannot set its intensity")
    if k == "power":
        return v / solid_angle
    return v / (LUMINOUS_EFFICACY * solid_angle)

