"""Light-probe environments: angular map (Debevec) and mirror ball (sphere map).

Both read a square HDR image whose disc holds the whole sphere of directions; the mappings and their
conventions (image centre = direction -z, +x right, +y up) are in :mod:`shaders.probes`.

Importance sampling (``strategy="map"`` and ``"mis"`` of :class:`pyrt.lights.environment.EnvironmentLight`)
uses a lat-long table resampled from the probe (:func:`shaders.envmap.latlong_sample`): the luminance
at the centres of an ``H x 2H`` lat-long grid (``H`` the power of two nearest ``size / 2``, clipped to [16, 512]), dilated as for a
bilinear lat-long map and given a floor of 1e-3 of the mean so the pdf is positive wherever the
radiance can be (unbiased), times ``sin theta``. ``sample`` and ``pdf`` are the table's, hence exactly
consistent; the table is narrower than the probe only in the sense of resolution. The SH and
prefiltered previews use the same lat-long resampling.
"""
from __future__ import annotations

import numpy as np

from pyrt.core.checks import Fixed
from pyrt.shaders import envmap as K
from pyrt.shaders import probes as P
from pyrt.shaders import textures as _tex
from pyrt.shaders.color import luminance

from pyrt.lights.environment import (ENVIRONMENTS, EnvironmentMapError, LatLongTable, _prefilter_stack,
                                     filtered_image, procedural_sky)

#: floor of the importance weights, relative to their mean luminance (keeps the pdf > 0 everywhere)
TABLE_FLOOR = 1e-3


class _ProbeEnvironment(LatLongTable):
    """Shared parts of the light probes: a square image, its mapping ``kind`` and the resampled tables."""

    kind = None
    image, filter = Fixed("the sampling tables derive from it"), Fixed("the sampling table too")

    def __init__(self, image, *, intensity=1.0, rotate=None, filter="bilinear", hide_background=False,
                 background=0.0, name=None):
        super().__init__(intensity=intensity, rotate=rotate, hide_background=hide_background,
                         background=background, name=name)
        owner = f"{type(self).__name__}({name or ''})"
        self.filter, self.image = filtered_image(owner, image, filter)
        h, w = self.image.shape[:2]
        if h != w or h < 2:
            raise EnvironmentMapError(f"{owner}: a light probe must be a square image of at least 2x2 texels, "
                                      f"got {h}x{w}")
        self._dist = None
        self._latlong = None

    @classmethod
    def example(cls):
        """The small procedural sky resampled into a 48 x 48 probe."""
        return cls(cls.from_latlong_image(procedural_sky(64, 32), 48))

    @classmethod
    def from_latlong_image(cls, latlong, size, filter="bilinear"):
        """Resample a lat-long map (H, W, 3) into a ``size x size`` probe image of this kind (texel centres)."""
        c = (np.arange(size) + 0.5) / size
        uu, vv = np.meshgrid(c, 1.0 - c)
        uv = np.stack([uu.ravel(), vv.ravel()], axis=1)
        d = P.PROBE_MAPPINGS[cls.kind][1](uv)
        out = K.latlong_lookup(np.asarray(latlong, dtype=np.float64), d, filter).reshape(size, size, -1)
        rho = np.hypot(2 * uv[:, 0] - 1, 2 * uv[:, 1] - 1)
        out[(rho > 1.0).reshape(size, size)] = 0.0     # outside the disc: no direction
        return out

    def uv(self, d):
        """Probe texture coordinates (N, 2) of directions ``d`` (N, 3) in the environment frame."""
        return P.PROBE_MAPPINGS[self.kind][0](d)

    def _radiance_local(self, d):
        uv = self.uv(d)
        if self.filter == "nearest":
            return _tex.lookup_nearest(self.image, uv, "clamp")
        return _tex.lookup_bilinear(self.image, uv, "clamp")

    @property
    def radiance_resolution(self):
        """The lat-long texels (H, W) = (S / 2, S) of an S x S probe (about its texel size at the image centre):
        what :meth:`pyrt.lights.environment.Environment.irradiance` refines."""
        s = self.image.shape[0]
        return max(2, s // 2), max(4, s)

    def latlong(self):
        """The probe resampled to a lat-long map ``(H, 2H, 3)`` float64 (built once)."""
        if self._latlong is None:
            # a power of two: cells nest in any finer power-of-two lat-long grid (exact quadratures)
            h = int(np.clip(2 ** round(np.log2(self.image.shape[0] / 2)), 16, 512))
            d = K.latlong_texel_directions(h, 2 * h).reshape(-1, 3)
            self._latlong = np.asarray(self._radiance_local(d), dtype=np.float64).reshape(h, 2 * h, 3)
        return self._latlong

    @property
    def distribution(self):
        """The importance table over the resampled lat-long grid (built on first use, float64)."""
        if self._dist is None:
            ll = self.latlong()
            lum = K.conservative_weights(np.maximum(luminance(ll), 0.0))
            lum = lum + TABLE_FLOOR * max(float(lum.mean()), 1e-300)
            h = ll.shape[0]
            self._dist = K.distribution2d_build(lum * np.sin(np.pi * (np.arange(h) + 0.5) / h)[:, None])
        return self._dist

    def _sh9_local(self):
        return K.sh9_project_latlong(self.latlong())

    def _build_prefiltered(self):
        return _prefilter_stack(self.latlong())


@ENVIRONMENTS.register("angular")
class AngularMapEnvironment(_ProbeEnvironment):
    """Angular-map light probe (Debevec's format): distance from the image centre proportional to the angle.

    Parameters
    ----------
    image : (S, S, 3) array or path to an OpenEXR or Radiance .hdr file
        Linear radiance; the disc inscribed in the square holds every direction: the centre is -z,
        the rim +z, +x right, +y up (:mod:`shaders.probes`; ``r = acos(-z) / (pi sqrt(x^2 + y^2))``).
    filter : {"bilinear", "nearest"}
        Reconstruction of ``radiance()``.
    """

    kind = "angular"


@ENVIRONMENTS.register("mirror_ball")
class MirrorBallEnvironment(_ProbeEnvironment):
    """Mirror-ball light probe (sphere map): the photograph of a mirrored sphere seen along +z.

    Parameters
    ----------
    image : (S, S, 3) array or path to an OpenEXR or Radiance .hdr file
        Linear radiance; the disc inscribed in the square is the ball: its centre reflects -z (back
        toward the camera), its rim +z, +x right, +y up (:mod:`shaders.probes`; OpenGL's sphere map
        with z negated). Directions near +z are squeezed into the rim and are poorly resolved.
    filter : {"bilinear", "nearest"}
        Reconstruction of ``radiance()``.
    """

    kind = "mirror_ball"
