"""Lights whose intensity varies with direction: projector (gobo), goniometric (lat-long image), IES LM-63.

All three are point lights (:class:`pyrt.lights.punctual._PunctualLight`): ``E = I(-wi) f(r)``.
"""
from __future__ import annotations

import math
import os

import numpy as np

from pyrt.core.checks import Fixed
from pyrt.lights.base import LIGHTS, LUMINOUS_EFFICACY, LightError, _intensity, _nonneg, _resolve_color, _vec3
from pyrt.lights.punctual import SpotLight, _PunctualLight, _axis, _frame
from pyrt.shaders import color as _colour
from pyrt.shaders import ies as _ies
from pyrt.shaders import lights as kernels
from pyrt.textures import ImageTexture, TextureError


def _image_texture(owner, image, wrap, srgb):
    """An :class:`pyrt.textures.ImageTexture` (bilinear, no MIP) from a path, an array or a texture."""
    if isinstance(image, ImageTexture):
        return image
    try:
        return ImageTexture(image, srgb=srgb, wrap=wrap, filter="bilinear", name=owner)
    except TextureError as exc:
        raise LightError(f"{owner}: image: {exc}") from None


def _rgb_lookup(tex, uv):
    out = tex.lookup(uv)
    return np.repeat(out[:, :1], 3, axis=1) if out.shape[1] == 1 else out[:, :3]


@LIGHTS.register("projector")
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

    direction = Fixed('the projection frame derives from it')
    outer_angle = Fixed("the projection's tan_half derives from it")
    frame = Fixed('it derives from direction and up')
    tan_half = Fixed('it derives from outer_angle')

    @classmethod
    def example(cls):
        """A projector at (0, 2, 0) pointing down with an 8x8 gradient slide and a soft 20-40 degree edge."""
        img = np.linspace(0.2, 1.0, 8)[:, None, None] * np.ones((8, 8, 3))
        return cls((0.0, 2.0, 0.0), (0.0, -1.0, 0.0), image=img, intensity=10.0, inner_angle=20.0,
                   outer_angle=40.0, srgb=False)

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
        self.validate()

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


@LIGHTS.register("goniometric")
class GoniometricLight(_PunctualLight):
    """Point light whose intensity varies with direction as a lat-long image.

    ``I(w) = intensity * color * image(theta, phi)``: ``theta`` from ``up`` (image top row) to
    ``-up`` (bottom row), ``phi`` around ``up`` from ``reference`` (column 0, increasing toward
    ``cross(up, reference)``) - :func:`shaders.lights.latlong_uv`. Bilinear lookup, repeating in phi
    and clamped at the poles. ``image`` is a path, an array or an ImageTexture (8/16-bit files are
    sRGB-decoded unless ``srgb=False``; give measured data as float arrays or EXR). Give
    ``intensity`` (W/sr per unit texel) or ``candela``.
    """

    up = Fixed("the light's frame derives from it")
    frame = Fixed('it derives from up and reference')

    @classmethod
    def example(cls):
        """A goniometric light at (0, 2, 0) brighter toward its up axis."""
        img = np.linspace(1.0, 0.1, 8)[:, None, None] * np.ones((8, 16, 3))
        return cls((0.0, 2.0, 0.0), img, intensity=5.0, srgb=False)

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
        self.validate()

    def radiant_intensity(self, w):
        uv = kernels.latlong_uv(kernels.to_light_frame(w, *self.frame))
        return (self.intensity * self.color)[None, :] * _rgb_lookup(self.texture, uv)

    def radiant_power(self):
        """Exact integral of the bilinear lat-long interpolant: ``sum_i w_i mean_j image_ij`` (W, RGB)."""
        img = np.asarray(self.texture.image, dtype=np.float64)
        img = np.repeat(img[:, :, :1], 3, axis=2) if img.shape[2] == 1 else img[:, :, :3]
        w = kernels.latlong_bilinear_solid_angle_weights(img.shape[0])
        return self.intensity * self.color * (w @ img.mean(axis=1))


@LIGHTS.register("ies")
class IESLight(_PunctualLight):
    """Point light with a measured IES LM-63 (type C) intensity distribution.

    ``profile`` is a path to a ``.ies`` file or a :class:`shaders.ies.IESProfile`. The luminaire's
    nadir (vertical angle 0) points along ``direction`` (default straight down, -y); horizontal angle
    0 lies along ``reference`` projected perpendicular to it (default +x, or +z if ``direction`` is
    along x) and 90 degrees along ``cross(-direction, reference)`` (the type C convention seen from
    above). ``I(w) = scale * candela(V, H) / 683 * color`` (W/sr); the candela values are bilinearly
    interpolated (:func:`shaders.ies.ies_candela`). A spot-shaped profile is a spot light.
    """

    scale = Fixed('intensity derives from it')
    intensity = Fixed('it derives from scale')
    direction = Fixed("the light's frame derives from it")
    frame = Fixed('it derives from direction and reference')

    @classmethod
    def example(cls):
        """A downlight at (0, 2, 0): a rotationally symmetric profile, 1000 cd at nadir falling to 0 at 90 degrees."""
        v = np.linspace(0.0, 180.0, 19)
        cd = np.where(v <= 90.0, 1000.0 * np.cos(np.radians(np.minimum(v, 90.0))) ** 2, 0.0)
        profile = _ies.IESProfile(vertical_angles=v, horizontal_angles=np.array([0.0]), candela=cd[None, :],
                                  lumens_per_lamp=-1.0, n_lamps=1, keywords={}, units=2, dimensions=(0.0, 0.0, 0.0),
                                  input_watts=0.0)
        return cls((0.0, 2.0, 0.0), profile)

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
        self.validate()

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
