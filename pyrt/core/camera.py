"""Pinhole camera: look-at, vertical field of view, stratified pixel sampling, ray differentials.

Image convention: row 0 is the top of the image, column 0 the left; pixel (row, col) covers
``[col, col+1) x [row, row+1)`` in raster space. Camera space is right-handed with the camera looking
along ``forward = normalize(target - position)``, ``right = normalize(forward x up)``,
``up' = right x forward``. A raster point (x, y) maps to the direction
``normalize(forward + sx * right + sy * up')`` with
``sx = (2 x / W - 1) tan(fov/2) W/H`` and ``sy = (1 - 2 y / H) tan(fov/2)``.
"""
from __future__ import annotations

import math

import numpy as np


from pyrt.core import checks
from pyrt.core.rays import RayBatch
from pyrt.core.sampler import pixel_strata, stratified_samples
from pyrt.core.errors import Error
from pyrt.shaders.vec import cross


class CameraError(Error, ValueError):
    """Invalid camera parameters."""


def _vec3(name, v):
    a = checks.numbers_array("Camera", name, v, CameraError)
    if a.shape != (3,) or not np.all(np.isfinite(a)):
        raise CameraError(f"Camera: {name} must be 3 finite numbers, got {v!r}")
    return a


def _count(name, val):
    """A positive integer as int, else a :class:`CameraError` naming it."""
    try:
        ok = int(val) == val and int(val) >= 1
    except (TypeError, ValueError, OverflowError):
        ok = False
    if not ok:
        raise CameraError(f"Camera: {name} must be a positive integer, got {val!r}")
    return int(val)


class Camera:
    """Pinhole camera.

    Parameters
    ----------
    position, target, up : 3-sequences
        Look-at frame; ``target != position``, ``up`` not parallel to the view direction.
    fov : float
        Vertical field of view in degrees, in (0, 180).
    width, height : int
        Resolution in pixels (any aspect ratio).
    spp : int
        Samples per pixel (stratified: jittered grid when spp is a square, else Latin hypercube).
    jitter : bool
        If False and spp == 1, rays go through pixel centres (useful for exact tests).

    Every parameter may be assigned later (``camera.position = (0, 2, 5)``): position, target and up are checked
    as they are assigned, the frame (:attr:`forward`, :attr:`right`, :attr:`up_ortho`) derives from them whenever
    it is read, and the rest is checked by :meth:`validate` before every render.
    """

    def __init__(self, position=(0, 0, 5), target=(0, 0, 0), up=(0, 1, 0), *, fov=45.0, width=640, height=480,
                 spp=1, jitter=True):
        self.position = position
        self.target = target
        self.up = up
        self.frame()
        self.fov, self.width, self.height, self.spp = fov, width, height, spp
        if not isinstance(jitter, (bool, np.bool_)):
            raise CameraError(f"Camera: jitter must be True or False, got {jitter!r}")
        self.jitter = bool(jitter)
        self.validate()

    # position, target and up are checked when set; the frame derives from them when read, so it never goes stale
    @property
    def position(self):
        """Eye point, float64 (3,); assigning it moves the camera (it keeps looking at :attr:`target`)."""
        return self._position

    @position.setter
    def position(self, value):
        self._position = _vec3("position", value)

    @property
    def target(self):
        """The point looked at, float64 (3,); assigning it turns the camera."""
        return self._target

    @target.setter
    def target(self, value):
        self._target = _vec3("target", value)

    @property
    def up(self):
        """The up hint, float64 (3,) (need not be orthogonal to the view direction)."""
        return self._up

    @up.setter
    def up(self, value):
        self._up = _vec3("up", value)

    def frame(self):
        """``(forward, right, up_ortho)``: the unit frame of the image plane from position, target and up as they are
        now (what :attr:`forward`, :attr:`right` and :attr:`up_ortho` give one at a time); CameraError when
        degenerate."""
        fwd = self._target - self._position
        n = np.linalg.norm(fwd)
        if n == 0:
            raise CameraError("Camera: target equals position (zero-length view direction)")
        forward = fwd / n
        right = cross(forward, self._up)
        if np.linalg.norm(right) < 1e-9 * max(np.linalg.norm(self._up), 1e-300):
            raise CameraError("Camera: up is zero or parallel to the view direction")
        right = right / np.linalg.norm(right)
        return forward, right, cross(right, forward)

    @property
    def forward(self):
        """Unit view direction (derived from position and target; read-only)."""
        return self.frame()[0]

    @property
    def right(self):
        """Unit right vector of the image plane (derived; read-only)."""
        return self.frame()[1]

    @property
    def up_ortho(self):
        """Unit up vector of the image plane, orthogonal to forward and right (derived; read-only)."""
        return self.frame()[2]

    def validate(self):
        """Check the parameters as they are now; :class:`CameraError` otherwise.

        The constructor ends with it and :class:`pyrt.PreparedScene` calls it before every render (so an
        attribute assigned later cannot smuggle in a NaN): position, target and up finite, the frame they
        give not degenerate, ``fov`` in (0, 180) degrees, ``width``, ``height``, ``spp`` positive integers (stored as int).
        """
        for nm, v in (("position", self.position), ("target", self.target), ("up", self.up)):
            _vec3(nm, v)                  # in place changes (camera.position[1] = nan) are caught here
        self.frame()
        try:
            fov = float(self.fov)
        except (TypeError, ValueError):
            fov = math.nan
        if not 0 < fov < 180:
            raise CameraError(f"Camera: fov must be in (0, 180) degrees, got {self.fov!r}")
        self.fov = fov
        self.width, self.height, self.spp = (_count(nm, v) for nm, v in
                                             (("width", self.width), ("height", self.height), ("spp", self.spp)))

    @property
    def tan_half(self):
        """tan of half the vertical field of view."""
        return math.tan(math.radians(self.fov) / 2)

    def directions(self, x, y):
        """Unit world directions through raster points ``x, y`` (N,) (float64)."""
        th = self.tan_half
        sx = (2.0 * x / self.width - 1.0) * th * self.width / self.height
        sy = (1.0 - 2.0 * y / self.height) * th
        # forward, right, up_ortho are orthonormal: |d|^2 = 1 + sx^2 + sy^2, no per-row norm needed;
        # d = [1, sx, sy] / |d| times the basis, one (N, 3) x (3, 3) product
        inv = 1.0 / np.sqrt(1.0 + sx * sx + sy * sy)
        coef = np.empty((inv.shape[0], 3))
        coef[:, 0] = inv
        np.multiply(sx, inv, out=coef[:, 1])
        np.multiply(sy, inv, out=coef[:, 2])
        return coef @ np.stack(self.frame())

    def pixel_samples(self, pixel_lo, pixel_hi, rng, samples=None):
        """Raster positions for the samples of pixels ``[pixel_lo, pixel_hi)`` (row-major index).

        Returns ``(x, y, pixel)`` of length ``(pixel_hi - pixel_lo) * spp``; samples of a pixel are
        contiguous. Stratified: an ``n x n`` jittered grid when ``spp = n^2``, else Latin hypercube
        (each of the ``spp`` rows and columns of the pixel holds one sample).

        ``samples`` (one pixel only, ``pixel_hi = pixel_lo + 1``): draw just these indices of the pixel's set
        of ``spp`` samples, from the equal-area jittered grid of :func:`pyrt.core.sampler.pixel_strata`
        (how a render splits a pixel of more than ``chunk_samples`` samples over several chunks).
        """
        spp = self.spp
        if samples is not None:
            if pixel_hi - pixel_lo != 1:
                raise CameraError("Camera.pixel_samples: samples= needs exactly one pixel")
            u = pixel_strata(rng, spp, samples)
            row, col = divmod(int(pixel_lo), self.width)
            return col + u[:, 0], row + u[:, 1], np.full(u.shape[0], pixel_lo, dtype=np.int64)
        pixels = np.arange(pixel_lo, pixel_hi, dtype=np.int64)
        row, col = np.divmod(pixels, self.width)          # per pixel, then broadcast over its samples
        pix = np.repeat(pixels, spp)
        if spp == 1 and not self.jitter:
            return col + 0.5, row + 0.5, pix
        u = stratified_samples(rng, pixel_hi - pixel_lo, spp)   # (spp, pixels, 2)
        # (pixels, spp) sums, flattened: the samples of a pixel contiguous (the same sums as gathering u first)
        return ((col[:, None] + u[:, :, 0].T).reshape(-1), (row[:, None] + u[:, :, 1].T).reshape(-1), pix)

    def generate_rays(self, pixel_lo, pixel_hi, rng, *, differentials=True, samples=None):
        """Primary rays for the pixels ``[pixel_lo, pixel_hi)`` (row-major), ``spp`` per pixel, contiguous.

        Parameters
        ----------
        pixel_lo, pixel_hi : int
        rng : numpy.random.Generator
            Draws the stratified sample positions.
        differentials : bool
            Also the rays one (scaled) pixel to the right and below, scaled by ``max(1/8, 1/sqrt(spp))``
            as in pbrt-v4 so that supersampled renders filter less.
        samples : int array, optional
            One pixel only: the indices of its ``spp`` samples to generate (see :meth:`pixel_samples`).

        Returns
        -------
        RayBatch
            ``(pixel_hi - pixel_lo) * spp`` rays (``len(samples)`` with ``samples``) at depth 0 with
            ``pixel`` set (and ``differentials``).
        """
        x, y, pix = self.pixel_samples(pixel_lo, pixel_hi, rng, samples)
        d = self.directions(x, y)
        o = np.broadcast_to(self.position, d.shape).copy()
        if not differentials:
            return RayBatch(o, d, pixel=pix)
        scale = max(0.125, 1.0 / math.sqrt(self.spp))
        dx = self.directions(x + scale, y)
        dy = self.directions(x, y + scale)
        return RayBatch(o, d, pixel=pix, differentials=(o, dx, o, dy))

    def rays_at(self, pixels, u, *, differentials=True, spp=None):
        """Primary rays through the points ``u`` ((N, 2) in [0, 1)^2) of the pixels ``pixels`` ((N,) row-major
        indices): the camera rays of an adaptive pass, whose pixels and sample positions the caller chose.

        ``spp`` ((N,) or a number; default the camera's) scales the differentials as in
        :meth:`generate_rays` (``max(1/8, 1/sqrt(spp))``): pass the samples the pixel will have.
        """
        pix = np.asarray(pixels, dtype=np.int64)
        row, col = np.divmod(pix, self.width)
        x, y = col + u[:, 0], row + u[:, 1]
        d = self.directions(x, y)
        o = np.broadcast_to(self.position, d.shape).copy()
        if not differentials:
            return RayBatch(o, d, pixel=pix)
        n = self.spp if spp is None else np.asarray(spp, dtype=np.float64)
        scale = np.maximum(0.125, 1.0 / np.sqrt(n))
        dx = self.directions(x + scale, y)
        dy = self.directions(x, y + scale)
        return RayBatch(o, d, pixel=pix, differentials=(o, dx, o, dy))

    def __repr__(self):
        return (f"Camera(position={self.position.tolist()}, target={self.target.tolist()}, up={self.up.tolist()}, "
                f"fov={self.fov}, width={self.width}, height={self.height}, spp={self.spp})")
