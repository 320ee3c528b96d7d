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
``"smooth_range"`` (UE4/Filament window, needs ``range``), ``"gltf_range"`` (needs ``range``)) and
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
import numbers
import os

import numpy as np

from pyrt.shaders import color as _colour
from pyrt.shaders import ies as _ies
from pyrt.shaders import lights as kernels
from pyrt.shaders.vec import max_component, mul_rgb, put_rows, scale_rows, take_rows

from pyrt.core import checks
from pyrt.core.sampler import stratified_samples
from pyrt.core.errors import Error


class LightError(Error, ValueError):
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
    return checks.rgb(owner, "color", v, LightError)


class Light:
    """Base class: ``n_samples`` shadow rays per hit and a :meth:`sample` method."""

    #: True when every sample of the light is the point ``self.position`` (punctual lights): shadow rays
    #: then end at that point exactly.
    fixed_position = False
    n_samples = 1
    #: True for lights at a single point / direction (no randomness).
    delta = True
    name = None

    def sample(self, p, u):
        raise NotImplementedError

    def sample_scalar(self, p, u):
        """Optional fast form of :meth:`sample` for lights of one colour: ``(wi, dist, s, rgb)`` with
        ``E = s[:, None] * rgb`` (``s`` (N,) or None for 1 everywhere, ``rgb`` (3,)); None when the
        light's colour varies over directions (then :meth:`sample` is used)."""
        return None

    def radiant_power(self):
        """Total emitted power (W) per RGB channel, (3,) float64."""
        raise NotImplementedError(f"{type(self).__name__} has no finite total power")

    def luminous_power(self):
        """Total luminous flux (lm): ``683 * luminance(radiant_power())``."""
        return float(LUMINOUS_EFFICACY * _colour.luminance(self.radiant_power()))

    def estimate(self, surf, bsdf, visible, rng):
        """Direct-light estimate at every hit of ``surf``: (N, 3) radiance toward ``surf.wo``.

        ``bsdf.f_cos(idx, wi)`` evaluates the hits' BSDFs (world directions); ``visible(idx, wi, dist)``
        traces shadow rays for the hits ``idx`` and returns a bool array.
        """
        n = surf.n_hits
        L = np.zeros((n, 3))
        ns = self.n_samples
        # delta lights ignore u; others get stratified samples (jittered grid or Latin hypercube)
        us = np.zeros((ns, n, 2)) if self.delta else stratified_samples(rng, n, ns)
        for s in range(ns):
            u = us[s]
            scalar = self.sample_scalar(surf.p, u)
            if scalar is not None:   # E = s * rgb: no (N, 3) irradiance array
                wi, dist, E_s, rgb = scalar
                if not np.max(rgb) > 0:
                    continue
                active = surf.light_side(wi)
                if E_s is not None:
                    active &= E_s > 0
            else:
                wi, dist, E = self.sample(surf.p, u)
                active = surf.light_side(wi) & (max_component(E) > 0)
            # ng . wi > 0, or the interpolated vertex normal faces the light (shadow terminator, pyrt.geometry.offsets)
            idx = np.flatnonzero(active)
            if idx.size == 0:
                continue
            wi_a = take_rows(wi, idx)
            f = bsdf.f_cos(idx, wi_a)
            nonzero = max_component(f) > 0
            if not nonzero.all():                  # (np.flatnonzero keeps the GIL: only when needed)
                keep = np.flatnonzero(nonzero)
                if keep.size == 0:
                    continue
                idx, f, wi_a = idx[keep], take_rows(f, keep), take_rows(wi_a, keep)
            vis = np.flatnonzero(visible(idx, wi_a, np.take(dist, idx), self.position if self.fixed_position else None))
            idx, f = idx[vis], take_rows(f, vis)
            if scalar is None:
                f *= take_rows(E, idx)
            else:
                mul_rgb(f, rgb, out=f)
                if E_s is not None:
                    scale_rows(f, np.take(E_s, idx), out=f)
            put_rows(L, idx, take_rows(L, idx) + f)
        return L / ns


LUMINOUS_EFFICACY = _colour.LUMINOUS_EFFICACY


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


class _PunctualLight(Light):
    """Shared parts of lights at a point: colour, distance falloff and range.

    Subclasses define :meth:`radiant_intensity`; :meth:`sample` is then ``E = I(-wi) f(r)``.
    """

    fixed_position = True

    def _init_falloff(self, owner, falloff, epsilon, light_range):
        if falloff not in kernels.DISTANCE_FALLOFFS:
            raise LightError(f"{owner}: falloff must be one of {list(kernels.DISTANCE_FALLOFFS)}, got {falloff!r}")
        self.falloff = falloff
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

    @property
    def _physical(self):
        """Plain inverse-square falloff with no range: the original kernels apply unchanged."""
        return self.falloff == "inverse_square" and self.range is None

    def distance_falloff(self, dist):
        """The falloff factor f(r) (m^-2) of this light at distances ``dist`` (N,)."""
        return kernels.distance_falloff(dist, self.falloff, eps=self.epsilon or 0.0,
                                        light_range=np.inf if self.range is None else self.range)

    def radiant_intensity(self, w):
        """Radiant intensity (W/sr) per RGB channel toward unit world directions ``w`` (N, 3) from the light."""
        raise NotImplementedError

    def sample(self, p, u):
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


class PointLight(_PunctualLight):
    """Isotropic point light.

    Give exactly one of ``intensity`` I (W/sr), ``power`` phi (W) = 4 pi I, ``candela`` (cd) or
    ``power_lm`` (lm); ``color`` (RGB filter) or ``temperature`` (kelvin). ``falloff``, ``epsilon``
    and ``range`` as in the module docstring.
    """

    def __init__(self, position, intensity=None, *, power=None, candela=None, power_lm=None, color=None,
                 temperature=None, falloff="inverse_square", epsilon=None, range=None, name=None):  # noqa: A002
        owner = f"PointLight({name or ''})"
        self.name = name
        self.position = _vec3(owner, "position", position)
        self.intensity = _intensity(owner, solid_angle=4 * math.pi, intensity=intensity, power=power,
                                    candela=candela, power_lm=power_lm)
        self.color = _resolve_color(owner, color, temperature)
        self._init_falloff(owner, falloff, epsilon, range)

    @property
    def I(self):
        """RGB radiant intensity (W/sr)."""
        return self.intensity * self.color

    @property
    def power(self):
        return 4 * math.pi * self.intensity

    def radiant_intensity(self, w):
        return np.broadcast_to(self.I, (w.shape[0], 3)).copy()

    def radiant_power(self):
        return 4 * math.pi * self.I

    def sample(self, p, u):
        if self._physical:
            return kernels.point_light(p, self.position, self.I)
        return super().sample(p, u)

    def sample_scalar(self, p, u):
        if not (self._physical and type(self) is PointLight):   # a subclass may override sample()
            return None
        wi, dist, s = kernels.point_light_scalar(p, self.position)
        return wi, dist, s, self.I


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


class SpotLight(_PunctualLight):
    """Spot light at ``position`` pointing along ``direction`` (or toward ``target``).

    ``inner_angle``/``outer_angle`` are cone half-angles in degrees, ``0 <= inner <= outer <= 180``.
    Full intensity inside the inner cone, zero outside the outer cone, and between them
    ``spot_falloff``: ``"smoothstep"`` in cos(theta) (pbrt-v4, the default), ``"gltf"`` (squared
    linear in cos theta) or ``"linear_angle"`` (Mitsuba 3). Give exactly one of ``intensity`` (on-axis,
    W/sr), ``candela``, ``power`` (W) or ``power_lm`` (lm); power and intensity are related by the
    closed-form cone integral :func:`shaders.lights.spot_cone_solid_angle` of the chosen falloff.
    """

    def __init__(self, position, direction=None, *, target=None, intensity=None, power=None, candela=None,
                 power_lm=None, inner_angle=20.0, outer_angle=30.0, spot_falloff="smoothstep", color=None,
                 temperature=None, falloff="inverse_square", epsilon=None, range=None, name=None):  # noqa: A002
        owner = f"{type(self).__name__}({name or ''})"
        self.name = name
        self.position = _vec3(owner, "position", position)
        self.direction = _axis(owner, self.position, direction, target)
        self._init_cone(owner, inner_angle, outer_angle, spot_falloff)
        self.intensity = _intensity(owner, solid_angle=self.cone_solid_angle, intensity=intensity, power=power,
                                    candela=candela, power_lm=power_lm)
        self.color = _resolve_color(owner, color, temperature)
        self._init_falloff(owner, falloff, epsilon, range)

    def _init_cone(self, owner, inner_angle, outer_angle, spot_falloff, max_outer=180.0):
        self.inner_angle, self.outer_angle = _cone(owner, inner_angle, outer_angle, max_outer=max_outer)
        self.cos_inner = math.cos(math.radians(self.inner_angle))
        self.cos_outer = math.cos(math.radians(self.outer_angle))
        if spot_falloff not in kernels.SPOT_FALLOFFS:
            raise LightError(f"{owner}: spot_falloff must be one of {sorted(kernels.SPOT_FALLOFFS)}, "
                             f"got {spot_falloff!r}")
        self.spot_falloff = spot_falloff

    @property
    def cone_solid_angle(self):
        """``int g(w) dw`` (sr) of the cone falloff: power = intensity * this."""
        return float(kernels.spot_cone_solid_angle(self.spot_falloff, self.cos_inner, self.cos_outer))

    @property
    def I(self):
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

    def radiant_power(self):
        return self.I * self.cone_solid_angle

    def sample(self, p, u):
        if self._physical and type(self) is SpotLight:
            return kernels.spot_light(p, self.position, self.direction, self.I, self.cos_inner, self.cos_outer,
                                      falloff=kernels.SPOT_FALLOFFS[self.spot_falloff])
        return super().sample(p, u)

    def sample_scalar(self, p, u):
        if not (self._physical and type(self) is SpotLight):
            return None
        wi, dist, s = kernels.spot_light_scalar(p, self.position, self.direction, self.cos_inner, self.cos_outer,
                                                falloff=kernels.SPOT_FALLOFFS[self.spot_falloff])
        return wi, dist, s, self.I


class DirectionalLight(Light):
    """Light from infinitely far away travelling along ``direction``.

    Give exactly one of ``irradiance`` E (W/m^2 on a surface perpendicular to the light) or ``lux``
    (illuminance, lm/m^2; E = lux / 683 per channel times ``color``); ``color`` or ``temperature``.
    """

    def __init__(self, direction, irradiance=None, *, lux=None, color=None, temperature=None, name=None):
        owner = f"DirectionalLight({name or ''})"
        self.name = name
        self.direction = _vec3(owner, "direction", direction, unit=True)
        if (irradiance is None) == (lux is None):
            raise LightError(f"{owner}: give exactly one of irradiance (W/m^2) or lux")
        self.irradiance = (_nonneg(owner, "irradiance", irradiance) if lux is None
                           else _nonneg(owner, "lux", lux) / LUMINOUS_EFFICACY)
        self.color = _resolve_color(owner, color, temperature)

    @property
    def E(self):
        return self.irradiance * self.color

    @property
    def lux(self):
        """Illuminance (lm/m^2) on a perpendicular surface: 683 luminance(E)."""
        return float(LUMINOUS_EFFICACY * _colour.luminance(self.E))

    def sample(self, p, u):
        return kernels.directional_light(p, self.direction, self.E)

    def sample_scalar(self, p, u):
        if type(self) is not DirectionalLight:
            return None
        n = p.shape[0]
        return np.broadcast_to(-self.direction, (n, 3)), np.full(n, np.inf), None, self.E


# ----------------------------------------------------------------------------- textured lights

def _image_texture(owner, image, wrap, srgb):
    """An :class:`pyrt.textures.ImageTexture` (bilinear, no MIP) from a path, an array or a texture."""
    from pyrt.textures import ImageTexture, TextureError

    if isinstance(image, ImageTexture):
        return image
    try:
        return ImageTexture(image, srgb=srgb, wrap=wrap, filter="bilinear", name=owner)
    except TextureError as exc:
        raise LightError(f"{owner}: image: {exc}") from None


def _rgb_lookup(tex, uv):
    out = tex.lookup(uv)
    return np.repeat(out[:, :1], 3, axis=1) if out.shape[1] == 1 else out[:, :3]


class ProjectorLight(SpotLight):
    """Slide projector / gobo: a spot light whose intensity is multiplied by an image.

    ``I(w) = intensity * color * g(cos theta) * image(uv(w))``: the image covers the square
    ``[-tan(outer), tan(outer)]^2`` on the plane one unit along ``direction``, so the outer cone is
    the disc inscribed in it; image ``+u`` (right) lies along ``cross(direction, up)`` and ``+v``
    (up) along ``up`` projected perpendicular to ``direction`` (default ``up``: +y, or -z when the
    projector points straight up or down). A white image gives exactly the
    plain :class:`SpotLight`. ``image`` is a file path, an ``(H, W[, C])`` array or an
    :class:`pyrt.textures.ImageTexture`; it is looked up bilinearly with clamped edges; 8/16-bit
    files are sRGB-decoded unless ``srgb=False``. ``outer_angle < 90``. The default
    ``inner_angle = outer_angle`` gives a hard-edged cone. Give ``intensity`` (W/sr) or
    ``candela`` (scale of a white texel on the axis).
    """

    def __init__(self, position, direction=None, *, image, target=None, up=None, intensity=None,
                 candela=None, inner_angle=None, outer_angle=30.0, spot_falloff="smoothstep", srgb=None,
                 color=None, temperature=None, falloff="inverse_square", epsilon=None, range=None,  # noqa: A002
                 name=None):
        owner = f"ProjectorLight({name or ''})"
        self.name = name
        self.position = _vec3(owner, "position", position)
        self.direction = _axis(owner, self.position, direction, target)
        inner_angle = outer_angle if inner_angle is None else inner_angle
        self._init_cone(owner, inner_angle, outer_angle, spot_falloff, max_outer=89.0)
        self.intensity = _intensity(owner, solid_angle=None, intensity=intensity, candela=candela)
        self.color = _resolve_color(owner, color, temperature)
        self._init_falloff(owner, falloff, epsilon, range)
        # image frame: x = right, y = up, z = direction (components only; handedness irrelevant)
        if up is None:  # world +y, or -z for a projector pointing (nearly) straight up or down
            up = (0.0, 0.0, -1.0) if abs(self.direction[1]) > 0.999 else (0.0, 1.0, 0.0)
        y, _, z = _frame(owner, self.direction, up, "up")
        self.frame = (np.cross(z, y), y, z)
        self.tan_half = math.tan(math.radians(self.outer_angle))
        self.texture = _image_texture(owner, image, "clamp", srgb)

    def image_factor(self, w):
        """Image value (N, 3) toward world directions ``w`` from the light (0 behind the projector)."""
        wl = kernels.to_light_frame(w, *self.frame)
        uv, front = kernels.projector_uv(wl, self.tan_half)
        return np.where(front[:, None], _rgb_lookup(self.texture, uv), 0.0)

    def radiant_intensity(self, w):
        out = np.zeros((w.shape[0], 3))
        g = self.cone_factor(w)
        idx = np.flatnonzero(g > 0)
        if idx.size:
            out[idx] = self.I * g[idx, None] * self.image_factor(w[idx])
        return out

    def radiant_power(self, n_theta=64, n_phi=256):
        """Power (W, RGB) by Gauss-Legendre quadrature in cos(theta) on the inner cone and on the
        falloff band (``n_theta`` nodes each) times a midpoint rule in phi (the image makes it a
        table, not a closed form). For a constant image it reproduces the spot's closed form to
        ~1e-12; for a detailed image its accuracy is that of the grid (test: 2e-4)."""
        x, wx = np.polynomial.legendre.leggauss(n_theta)
        c, wc = [], []
        for lo, hi in ((self.cos_outer, self.cos_inner), (self.cos_inner, 1.0)):
            c.append(lo + (hi - lo) * (x + 1) / 2)
            wc.append(wx * (hi - lo) / 2)
        c, wc = np.concatenate(c), np.concatenate(wc)
        n_theta = c.size
        phi = (np.arange(n_phi) + 0.5) * 2 * np.pi / n_phi
        C, P = np.meshgrid(c, phi, indexing="ij")
        s = np.sqrt(np.maximum(0.0, 1 - C * C))
        fx, fy, fz = self.frame
        w = ((s * np.cos(P)).reshape(-1, 1) * fx + (s * np.sin(P)).reshape(-1, 1) * fy
             + C.reshape(-1, 1) * fz)
        I = self.radiant_intensity(w).reshape(n_theta, n_phi, 3)
        return np.einsum("tpc,t->c", I, wc) * (2 * np.pi / n_phi)

    def sample(self, p, u):
        return _PunctualLight.sample(self, p, u)


class GoniometricLight(_PunctualLight):
    """Point light whose intensity varies with direction as a lat-long image.

    ``I(w) = intensity * color * image(theta, phi)``: ``theta`` from ``up`` (image top row) to
    ``-up`` (bottom row), ``phi`` around ``up`` from ``reference`` (column 0, increasing toward
    ``cross(up, reference)``) - :func:`shaders.lights.latlong_uv`. Bilinear lookup, repeating in phi
    and clamped at the poles. ``image`` is a path, an array or an ImageTexture (8/16-bit files are
    sRGB-decoded unless ``srgb=False``; give measured data as float arrays or EXR). Give
    ``intensity`` (W/sr per unit texel) or ``candela``.
    """

    def __init__(self, position, image, *, up=(0.0, 1.0, 0.0), reference=(1.0, 0.0, 0.0), intensity=None,
                 candela=None, srgb=None, color=None, temperature=None, falloff="inverse_square", epsilon=None,
                 range=None, name=None):  # noqa: A002
        owner = f"GoniometricLight({name or ''})"
        self.name = name
        self.position = _vec3(owner, "position", position)
        if intensity is None and candela is None:
            intensity = 1.0
        self.intensity = _intensity(owner, solid_angle=None, intensity=intensity, candela=candela)
        self.color = _resolve_color(owner, color, temperature)
        self._init_falloff(owner, falloff, epsilon, range)
        self.up = _vec3(owner, "up", up, unit=True)
        self.frame = _frame(owner, self.up, reference, "reference")
        self.texture = _image_texture(owner, image, ("repeat", "clamp"), srgb)

    def radiant_intensity(self, w):
        uv = kernels.latlong_uv(kernels.to_light_frame(w, *self.frame))
        return (self.intensity * self.color)[None, :] * _rgb_lookup(self.texture, uv)

    def radiant_power(self):
        """Exact integral of the bilinear lat-long interpolant: ``sum_i w_i mean_j image_ij`` (W, RGB)."""
        img = np.asarray(self.texture.image, dtype=np.float64)
        img = np.repeat(img[:, :, :1], 3, axis=2) if img.shape[2] == 1 else img[:, :, :3]
        w = kernels.latlong_bilinear_solid_angle_weights(img.shape[0])
        return self.intensity * self.color * (w @ img.mean(axis=1))


class IESLight(_PunctualLight):
    """Point light with a measured IES LM-63 (type C) intensity distribution.

    ``profile`` is a path to a ``.ies`` file or a :class:`shaders.ies.IESProfile`. The luminaire's
    nadir (vertical angle 0) points along ``direction`` (default straight down, -y); horizontal angle
    0 lies along ``reference`` projected perpendicular to it (default +x, or +z if ``direction`` is
    along x) and 90 degrees along ``cross(-direction, reference)`` (the type C convention seen from
    above). ``I(w) = scale * candela(V, H) / 683 * color`` (W/sr); the candela values are bilinearly
    interpolated (:func:`shaders.ies.ies_candela`). A spot-shaped profile is a spot light.
    """

    def __init__(self, position, profile, *, direction=(0.0, -1.0, 0.0), reference=None, scale=1.0, color=None,
                 temperature=None, falloff="inverse_square", epsilon=None, range=None, name=None):  # noqa: A002
        owner = f"IESLight({name or ''})"
        self.name = name
        self.position = _vec3(owner, "position", position)
        if isinstance(profile, _ies.IESProfile):
            self.path, self.profile = None, profile
        elif isinstance(profile, (str, os.PathLike)):
            self.path = os.fspath(profile)
            if not os.path.isfile(self.path):
                raise LightError(f"{owner}: IES file not found: {self.path!r}")
            with open(self.path, encoding="latin-1") as f:
                text = f.read()
            try:
                self.profile = _ies.parse_ies(text)
            except ValueError as exc:
                raise LightError(f"{owner}: {self.path!r}: {exc}") from None
        else:
            raise LightError(f"{owner}: profile must be a path or an IESProfile, got {type(profile).__name__}")
        try:
            _ies.ies_candela(self.profile, np.zeros(1), np.zeros(1))
        except ValueError as exc:
            raise LightError(f"{owner}: {exc}") from None
        self.scale = _nonneg(owner, "scale", scale)
        self.intensity = self.scale / LUMINOUS_EFFICACY
        self.color = _resolve_color(owner, color, temperature)
        self._init_falloff(owner, falloff, epsilon, range)
        self.direction = _vec3(owner, "direction", direction, unit=True)
        z = -self.direction
        if reference is None:
            reference = (0.0, 0.0, 1.0) if abs(z[0]) > 0.9 else (1.0, 0.0, 0.0)
        self.frame = _frame(owner, z, reference, "reference")

    def radiant_intensity(self, w):
        V, H = _ies.ies_angles(kernels.to_light_frame(w, *self.frame))
        cd = _ies.ies_candela(self.profile, V, H)
        return (self.intensity * self.color)[None, :] * cd[:, None]

    def radiant_power(self):
        """``scale * flux / 683 * color`` (W, RGB); the flux is the exact integral of the interpolant."""
        return self.intensity * self.color * _ies.ies_flux(self.profile)

    @property
    def candela(self):
        """Peak luminous intensity (cd) of the scaled profile times luminance(color)."""
        return float(self.scale * self.profile.candela.max() * _colour.luminance(self.color))


REGISTRY = {"point": PointLight, "spot": SpotLight, "directional": DirectionalLight, "projector": ProjectorLight,
            "goniometric": GoniometricLight, "ies": IESLight}
#: light keyword arguments that are file paths (resolved relative to a scene file by the loader)
PATH_ARGUMENTS = ("image", "profile")
