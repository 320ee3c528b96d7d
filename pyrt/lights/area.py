"""Area lights: rectangle, disk and sphere emitters sampled as many point lights (soft shadows).

Units and conventions
---------------------
- Each light emits constant radiance ``L_e`` (W m^-2 sr^-1, times ``color``) from its surface:
  rectangle and disk from their **front side only** (the side ``normal`` points to), the sphere
  outward. Give ``radiance`` or ``power`` (W): a one-sided Lambertian emitter of area ``A`` has
  ``power = pi A L_e``; the sphere ``power = 4 pi^2 r^2 L_e``. The radiant intensity of a small
  rectangle or disk is ``I(theta) = L_e A cos theta = (power / pi) cos theta`` (Lambert's cosine law);
  a small sphere is isotropic, ``I = power / (4 pi)``, like a point light of the same power.
- Direct light at a hit is estimated with ``n_samples`` shadow rays toward points on the light,
  stratified per hit (jittered ``k x k`` grid when ``n_samples = k^2``, otherwise Latin-hypercube
  strata), so partially visible lights give a penumbra and fully hidden ones an umbra. Rectangles
  and disks are sampled uniformly by area (``E = L_e cos theta_l A / r^2`` per sample); spheres
  uniformly inside the cone they subtend (``E = L_e 2 pi (1 - cos theta_max)``), zero for points
  inside the sphere.
- Visible to camera rays: :meth:`AreaLight.add_to` adds the light *and* a mesh with an
  :class:`AreaEmitter` material (one-sided emission, receives no light). Shadow rays toward the
  light stop at ``1 - 1e-4`` of the distance to the sampled point (:data:`pyrt.geometry.offsets.SHADOW_TMAX_SCALE`);
  the sampled point lies on the emitter's plane (rectangle, disk) or on the exact sphere, which
  encloses the inscribed triangle mesh, so a light's own mesh never shadows its samples.
"""
from __future__ import annotations

import math
import numbers

import numpy as np

from pyrt.core.checks import Fixed
from pyrt.shaders import sampling
from pyrt.shaders.vec import coordinate_frame

from pyrt.lights import compiled as _compiled
from pyrt.lights.base import LIGHTS, Light, LightError, _color, _nonneg, _vec3
from pyrt.materials import Material, check_color, register
from pyrt.materials import compiled as mc


#: shadow rays per hit by default: ``tools/estimator_chart.py``'s area scene (160 x 120, equal shadow rays per
#: pixel, 3 interleaved repeats) with padded camera-hit samples: 4 per hit has 0.48x the relMSE x time
#: of 16 (with independent samples a hit's 16 were its only strata)
DEFAULT_SAMPLES = 4


@register
class AreaEmitter(Material):
    """Material of an area light's visible mesh: emits ``radiance`` (RGB, W m^-2 sr^-1) from its front side
    (``two_sided=False``) or both sides, reflects nothing and receives no light (``has_diffuse = False``)."""

    type_name = "area_emitter"
    has_diffuse = False
    has_delta = False

    def __init__(self, radiance=1.0, *, two_sided=False, name=None):
        self.name = name
        self.radiance = radiance
        self.two_sided = bool(two_sided)
        self.validate()

    def validate(self):
        """``radiance``: a non-negative finite RGB triple (normalised to (3,) float64)."""
        self.radiance = check_color("radiance", self.radiance, self.label, lo=0.0)
        super().validate()

    def compiled_record(self, pack_texture):
        """:data:`pyrt.materials.compiled.EMITTER`: the radiance and whether both sides emit."""
        rec = mc.empty_record()
        rec[4:7] = self.radiance
        rec[7] = 1.0 if self.two_sided else 0.0
        return mc.EMITTER, rec

    def emission(self, ctx):
        L = np.broadcast_to(self.radiance, (ctx.n_hits, 3))
        if self.two_sided:
            return np.array(L)
        return np.where(ctx.front[:, None], L, 0.0)


class AreaLight(Light):
    """Base class of the area lights (see the module docstring).

    ``bsdf_samples`` (default 0): BSDF samples per hit combined with the ``n_samples`` light samples by the
    power heuristic with the counts (:func:`pyrt.integrators.direct.area_mis_estimate`); each one that
    reaches the light (:meth:`ray_distance`) traces a shadow ray.
    """

    delta = False
    has_mesh = True

    def __init_subclass__(cls, **kwargs):
        """A subclass that samples differently from its parent is not compiled unless it says how (the compiled
        records hold the three shapes' sampling)."""
        super().__init_subclass__(**kwargs)
        if "compiled_record" not in cls.__dict__ and ("sample" in cls.__dict__ or "sample_li" in cls.__dict__):
            cls.compiled_record = Light.compiled_record

    def _init_common(self, owner, radiance, power, color, n_samples, name, bsdf_samples=0):
        self.name = name
        if (radiance is None) == (power is None):
            raise LightError(f"{owner}: give exactly one of radiance (W m^-2 sr^-1) or power (W)")
        if not isinstance(n_samples, numbers.Integral) or isinstance(n_samples, bool) or n_samples < 1:
            raise LightError(f"{owner}: n_samples must be a positive integer, got {n_samples!r}")
        if not isinstance(bsdf_samples, numbers.Integral) or isinstance(bsdf_samples, bool) or bsdf_samples < 0:
            raise LightError(f"{owner}: bsdf_samples must be an integer >= 0, got {bsdf_samples!r}")
        self.n_samples = int(n_samples)
        self.bsdf_samples = int(bsdf_samples)
        self.color = _color(owner, color)
        if power is not None:
            radiance = _nonneg(owner, "power", power) / self._power_per_radiance()
        self.radiance = _nonneg(owner, "radiance", radiance)
        self.validate()

    def validate(self):
        """The base checks, then ``center`` (3 finite numbers), ``radiance`` >= 0, ``color`` >= 0 and the
        light's size (:meth:`_validate_size`)."""
        super().validate()
        _vec3(self.label, "center", self.center)
        _nonneg(self.label, "radiance", self.radiance)
        _color(self.label, self.color)
        self._validate_size()

    def _validate_size(self):
        """Radius > 0 (disk, sphere); the rectangle overrides it."""
        _radius(self.label, self.radius)

    @property
    def L(self):
        """RGB emitted radiance (W m^-2 sr^-1)."""
        return self.radiance * self.color

    @property
    def power(self):
        """Emitted power (W) per unit of ``color``."""
        return self.radiance * self._power_per_radiance()

    def _power_per_radiance(self):
        raise NotImplementedError

    def mesh(self):
        """The emitter's triangle mesh (world space) with outward/front winding."""
        raise NotImplementedError

    def add_to(self, scene, *, visible=True):
        """Add the light to ``scene`` and, if ``visible``, its emissive mesh (seen by camera and mirror rays)."""
        scene.add_light(self)
        if visible:
            scene.add_mesh(self.mesh(), AreaEmitter(self.L, name=self.name), smooth=self._smooth,
                           name=self.emitter_mesh_name)
        return self

    _smooth = False


def _radius(owner, radius):
    """A finite radius > 0 as a float, else a :class:`LightError` naming ``owner``."""
    if not isinstance(radius, numbers.Real) or isinstance(radius, bool) or not math.isfinite(radius) or radius <= 0:
        raise LightError(f"{owner}: radius must be a finite number > 0, got {radius!r}")
    return float(radius)


def _planar_pdf(p, wi, center, n, inside):
    """Solid-angle pdf (N,) of uniform area sampling of a one-sided planar emitter: ``r^2 / (A cos_l)`` where
    the ray ``p + t wi`` (t > 0) hits the emitter's front (``inside(local x, y) -> bool`` on its plane); the
    area ``A`` is applied by the caller."""
    cos_l = -(wi @ n)
    t = np.divide((center - p) @ n, -cos_l, out=np.full(cos_l.shape, -1.0), where=cos_l > 0)
    hit = (cos_l > 0) & (t > 0)
    x = p + t[:, None] * wi - center
    hit &= inside(x)
    return np.where(hit, np.divide(t * t, cos_l, out=np.zeros_like(t), where=hit), 0.0)


def _planar_distance(p, wi, center, n, inside):
    """Distance (N,) along ``wi`` from ``p`` to the front of a one-sided planar emitter, ``inf`` where the ray
    misses it (the same hit test as :func:`_planar_pdf`)."""
    cos_l = -(wi @ n)
    t = np.divide((center - p) @ n, -cos_l, out=np.full(cos_l.shape, -1.0), where=cos_l > 0)
    hit = (cos_l > 0) & (t > 0)
    hit &= inside(p + np.where(hit, t, 0.0)[:, None] * wi - center)
    return np.where(hit, t, np.inf)


def _planar_sample(p, x, n, L, area):
    """Shared by rectangle and disk: light point ``x`` (N, 3) sampled with pdf 1/area on a plane of normal n."""
    d = x - p
    dist2 = np.einsum("ij,ij->i", d, d)
    dist = np.sqrt(dist2)
    inv = np.divide(1.0, dist, out=np.zeros_like(dist), where=dist > 0)
    wi = d * inv[:, None]
    cos_l = np.maximum(-(wi @ n), 0.0)       # one-sided: front = +normal
    g = cos_l * area * inv * inv
    return wi, dist, L[None, :] * g[:, None]


def _size(owner, size):
    """A rectangle's (width, height) > 0 as float64 (2,) (a number means a square), else a :class:`LightError`."""
    try:
        sz = np.broadcast_to(np.asarray(size, dtype=np.float64), (2,)).copy()
    except (TypeError, ValueError):
        sz = np.full(2, np.nan)
    if not np.all(np.isfinite(sz)) or np.any(sz <= 0):
        raise LightError(f"{owner}: size must be > 0 (a number or [width, height]), got {size!r}")
    return sz


@LIGHTS.register("rect")
class RectLight(AreaLight):
    """Rectangle of ``size = (width, height)`` centred at ``center``, emitting toward ``normal``.

    ``tangent`` (optional) is the direction of the ``width`` side (projected onto the plane);
    by default an arbitrary frame around ``normal``.
    """

    normal = Fixed('the tangent frame derives from it')
    tangent = Fixed('the tangent frame derives from it')
    bitangent = Fixed('it derives from normal and tangent')

    @classmethod
    def example(cls):
        """A 1 x 0.5 rectangle at height 2 facing down, 20 W."""
        return cls((0.0, 2.0, 0.0), size=(1.0, 0.5), power=20.0)

    def __init__(self, center, normal=(0.0, -1.0, 0.0), size=1.0, *, tangent=None, radiance=None, power=None,
                 color=(1.0, 1.0, 1.0), n_samples=DEFAULT_SAMPLES, bsdf_samples=0, name=None):
        owner = f"RectLight({name or ''})"
        self.center = _vec3(owner, "center", center)
        self.normal = _vec3(owner, "normal", normal, unit=True)
        self.size = _size(owner, size)
        if tangent is None:
            t, _ = coordinate_frame(self.normal[None])
            t = t[0]
        else:
            t = _vec3(owner, "tangent", tangent)
            t = t - (t @ self.normal) * self.normal
            if np.linalg.norm(t) < 1e-9:
                raise LightError(f"{owner}: tangent must not be parallel to normal")
            t = t / np.linalg.norm(t)
        self.tangent = t
        self.bitangent = np.cross(self.normal, t)     # (t, b, n) right-handed
        self._init_common(owner, radiance, power, color, n_samples, name, bsdf_samples)

    def _validate_size(self):
        """Width and height > 0."""
        _size(self.label, self.size)

    @property
    def area(self):
        """Emitting area (m^2)."""
        return float(self.size[0] * self.size[1])

    def _power_per_radiance(self):
        return math.pi * self.area

    def compiled_record(self):
        """:data:`pyrt.lights.compiled.RECT`."""
        return _compiled.area_record(self, _compiled.RECT)

    def sample(self, p, u):
        x = (self.center + (u[:, 0:1] - 0.5) * self.size[0] * self.tangent
             + (u[:, 1:2] - 0.5) * self.size[1] * self.bitangent)
        return _planar_sample(p, x, self.normal, self.L, self.area)

    def pdf_li(self, p, wi):
        """Solid-angle density of :meth:`sample` (uniform by area): ``r^2 / (A cos theta_l)`` on the rectangle."""
        hx, hy = 0.5 * self.size
        inside = lambda x: (np.abs(x @ self.tangent) <= hx) & (np.abs(x @ self.bitangent) <= hy)  # noqa: E731
        return _planar_pdf(p, wi, self.center, self.normal, inside) / self.area

    def ray_distance(self, p, wi):
        """Distance (N,) from ``p`` along ``wi`` to the rectangle's front, ``inf`` where the ray misses it."""
        hx, hy = 0.5 * self.size
        inside = lambda x: (np.abs(x @ self.tangent) <= hx) & (np.abs(x @ self.bitangent) <= hy)  # noqa: E731
        return _planar_distance(p, wi, self.center, self.normal, inside)

    def mesh(self):
        import trimesh  # deferred (pyrt.core.transforms)
        hx, hy = 0.5 * self.size
        t, b = self.tangent, self.bitangent
        v = np.array([self.center - hx * t - hy * b, self.center + hx * t - hy * b,
                      self.center + hx * t + hy * b, self.center - hx * t + hy * b])
        return trimesh.Trimesh(vertices=v, faces=[[0, 1, 2], [0, 2, 3]], process=False)   # (t x b) = n winding


@LIGHTS.register("disk")
class DiskLight(AreaLight):
    """Disk of ``radius`` centred at ``center``, emitting toward ``normal`` (one-sided)."""

    normal = Fixed('the tangent frame derives from it')
    tangent = Fixed('it derives from normal')
    bitangent = Fixed('it derives from normal')

    #: polygon segments of the visible mesh (the light itself is sampled on the exact disk)
    segments = 64

    @classmethod
    def example(cls):
        """A disk of radius 0.4 at height 2 facing down, 20 W."""
        return cls((0.0, 2.0, 0.0), radius=0.4, power=20.0)

    def __init__(self, center, normal=(0.0, -1.0, 0.0), radius=0.5, *, radiance=None, power=None,
                 color=(1.0, 1.0, 1.0), n_samples=DEFAULT_SAMPLES, bsdf_samples=0, name=None):
        owner = f"DiskLight({name or ''})"
        self.center = _vec3(owner, "center", center)
        self.normal = _vec3(owner, "normal", normal, unit=True)
        self.radius = _radius(owner, radius)
        t, b = coordinate_frame(self.normal[None])
        self.tangent, self.bitangent = t[0], b[0]
        self._init_common(owner, radiance, power, color, n_samples, name, bsdf_samples)

    @property
    def area(self):
        """Emitting area (m^2)."""
        return math.pi * self.radius ** 2

    def _power_per_radiance(self):
        return math.pi * self.area

    def compiled_record(self):
        """:data:`pyrt.lights.compiled.DISK`."""
        return _compiled.area_record(self, _compiled.DISK)

    def sample(self, p, u):
        q = sampling.square_to_uniform_disk_concentric(u) * self.radius
        x = self.center + q[:, 0:1] * self.tangent + q[:, 1:2] * self.bitangent
        return _planar_sample(p, x, self.normal, self.L, self.area)

    def pdf_li(self, p, wi):
        """Solid-angle density of :meth:`sample` (uniform by area): ``r^2 / (A cos theta_l)`` on the disk."""
        inside = lambda x: np.einsum("ij,ij->i", x, x) <= self.radius ** 2  # noqa: E731
        return _planar_pdf(p, wi, self.center, self.normal, inside) / self.area

    def ray_distance(self, p, wi):
        """Distance (N,) from ``p`` along ``wi`` to the disk's front, ``inf`` where the ray misses it."""
        inside = lambda x: np.einsum("ij,ij->i", x, x) <= self.radius ** 2  # noqa: E731
        return _planar_distance(p, wi, self.center, self.normal, inside)

    def mesh(self):
        import trimesh  # deferred (pyrt.core.transforms)
        a = 2.0 * np.pi * np.arange(self.segments) / self.segments
        ring = (self.center + self.radius * (np.cos(a)[:, None] * self.tangent + np.sin(a)[:, None] * self.bitangent))
        v = np.vstack([self.center, ring])
        i = np.arange(self.segments)
        f = np.stack([np.zeros_like(i), 1 + i, 1 + (i + 1) % self.segments], axis=1)
        return trimesh.Trimesh(vertices=v, faces=f, process=False)


@LIGHTS.register("sphere")
class SphereLight(AreaLight):
    """Sphere of ``radius`` at ``center`` emitting outward; sampled by the cone it subtends."""

    _smooth = True
    #: icosphere subdivisions of the visible mesh (3 -> 1280 triangles)
    subdivisions = 3

    @classmethod
    def example(cls):
        """A sphere of radius 0.3 at height 2, 20 W."""
        return cls((0.0, 2.0, 0.0), radius=0.3, power=20.0)

    def __init__(self, center, radius=0.5, *, radiance=None, power=None, color=(1.0, 1.0, 1.0), n_samples=DEFAULT_SAMPLES,
                 bsdf_samples=0, name=None):
        owner = f"SphereLight({name or ''})"
        self.center = _vec3(owner, "center", center)
        self.radius = _radius(owner, radius)
        self._init_common(owner, radiance, power, color, n_samples, name, bsdf_samples)

    @property
    def area(self):
        """Emitting area (m^2)."""
        return 4.0 * math.pi * self.radius ** 2

    def _power_per_radiance(self):
        return math.pi * self.area

    def compiled_record(self):
        """:data:`pyrt.lights.compiled.SPHERE`."""
        return _compiled.area_record(self, _compiled.SPHERE)

    def sample(self, p, u):
        r = self.radius
        dc = self.center - p
        dist_c = np.sqrt(np.einsum("ij,ij->i", dc, dc))
        outside = dist_c > r * (1.0 + 1e-9)
        inv = np.divide(1.0, dist_c, out=np.zeros_like(dist_c), where=dist_c > 0)
        wc = dc * inv[:, None]
        sin2 = np.clip((r * inv) ** 2, 0.0, 1.0)
        one_minus_cos = np.where(outside, sin2 / (1.0 + np.sqrt(1.0 - sin2)), 0.0)   # no cancellation
        cos_max = 1.0 - one_minus_cos
        wl = sampling.square_to_uniform_cone(u, cos_max)
        s, t = coordinate_frame(np.where(outside[:, None], wc, np.array([0.0, 0.0, 1.0])))
        wi = wl[:, 0:1] * s + wl[:, 1:2] * t + wl[:, 2:3] * wc
        # nearest intersection with the exact sphere: |p + t wi - c|^2 = r^2
        b = np.einsum("ij,ij->i", wi, dc)
        disc = np.maximum(b * b - (dist_c * dist_c - r * r), 0.0)
        dist = np.maximum(b - np.sqrt(disc), 0.0)
        E = self.L[None, :] * 2.0 * np.pi * one_minus_cos[:, None]
        return wi, dist, E

    def pdf_li(self, p, wi):
        """Solid-angle density of :meth:`sample`: uniform in the cone the sphere subtends,
        ``1 / (2 pi (1 - cos theta_max))`` inside it, 0 outside (and for points inside the sphere)."""
        r = self.radius
        dc = self.center - p
        dist_c = np.sqrt(np.einsum("ij,ij->i", dc, dc))
        outside = dist_c > r * (1.0 + 1e-9)
        inv = np.divide(1.0, dist_c, out=np.zeros_like(dist_c), where=dist_c > 0)
        sin2 = np.clip((r * inv) ** 2, 0.0, 1.0)
        one_minus_cos = np.where(outside, sin2 / (1.0 + np.sqrt(1.0 - sin2)), 0.0)
        in_cone = outside & (np.einsum("ij,ij->i", wi, dc) * inv >= 1.0 - one_minus_cos)
        return np.where(in_cone, 1.0 / (2.0 * np.pi * np.where(in_cone, one_minus_cos, 1.0)), 0.0)

    def ray_distance(self, p, wi):
        """Distance (N,) from ``p`` along ``wi`` to the exact sphere (nearest hit in front), ``inf`` where the
        ray misses it or ``p`` is inside (where :meth:`pdf_li` is 0)."""
        dc = self.center - p
        b = np.einsum("ij,ij->i", wi, dc)
        c = np.einsum("ij,ij->i", dc, dc) - self.radius ** 2
        disc = b * b - c
        t = b - np.sqrt(np.maximum(disc, 0.0))
        return np.where((disc >= 0) & (c > 0) & (t > 0), t, np.inf)

    def mesh(self):
        import trimesh  # deferred (pyrt.core.transforms)
        m = trimesh.creation.icosphere(subdivisions=self.subdivisions, radius=self.radius)
        m.apply_translation(self.center)
        return m
