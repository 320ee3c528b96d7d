"""Procedural textures: checkerboard, value noise, Perlin noise, fBm and Voronoi (Worley) noise.

The kernels are in :mod:`pyrt.shaders.noise` (deterministic for a seed). Every texture here looks up a
point ``p`` in UV (2D, ``space="uv"``) or object space (3D, ``space="object"``) times ``scale``; the
checker and fBm filter over the pixel footprint.
"""
from __future__ import annotations

import numpy as np

from pyrt.core.checks import Fixed
from pyrt.shaders import noise as _noise
from pyrt.textures import compiled as _compiled
from pyrt.textures.base import (TEXTURES, Texture, TextureError, as_value, dp_dxy, footprints, is_texture, lerp,
                                resolve, value_channels)


def _check_space(space, owner):
    if space not in ("uv", "object"):
        raise TextureError(f"{owner}: space must be 'uv' or 'object', got {space!r}")
    return space


class _Procedural(Texture):
    """Shared plumbing: lookup point ``p`` in UV (2D) or object (3D) space times ``scale``."""

    def __init__(self, scale, space, owner):
        self.space = _check_space(space, owner)
        d = 2 if space == "uv" else 3
        sc = np.broadcast_to(np.asarray(scale, dtype=np.float64), (d,)).copy()
        if not np.all(np.isfinite(sc)) or np.any(sc == 0):
            raise TextureError(f"{owner}: scale must be finite and non-zero, got {scale!r}")
        self.scale = sc

    def _point(self, ctx):
        if self.space == "uv":
            return np.asarray(ctx.uv, dtype=np.float64) * self.scale
        return np.asarray(ctx.p_object, dtype=np.float64) * self.scale

    def _half_width(self, ctx):
        """Half-widths (N, d) of the footprint's axis-aligned bounding box in units of ``p``.

        The pixel footprint is the parallelogram ``p + a dp/dx + b dp/dy``, ``a, b`` in
        ``[-1/2, 1/2]`` (a one-pixel box filter); its AABB half-width is
        ``(|dp/dx| + |dp/dy|) / 2`` per axis. In object space the world-space ``dp/dx`` is used
        (exact for meshes whose object-to-world transform is a rigid motion; scaled otherwise).
        """
        if self.space == "uv":
            dx, dy = footprints(ctx)
        else:
            dx, dy = dp_dxy(ctx)
        return 0.5 * (np.abs(dx) + np.abs(dy)) * np.abs(self.scale)

    def _footprint_len(self, ctx):
        hw = self._half_width(ctx)
        return 2.0 * np.max(hw, axis=1)


@TEXTURES.register("checker")
class CheckerTexture(_Procedural):
    """Checkerboard of ``color0`` (even cells) and ``color1`` (odd cells).

    ``scale`` cells per unit of UV (2D) or object space (3D, ``space="object"``). With
    ``filtered=True`` (default) each lookup returns the exact average over its pixel footprint's
    bounding box (:func:`pyrt.shaders.noise.checker_box_filtered`): alias-free under minification.
    ``color0``/``color1`` may be scalars, RGB triples or textures; ``channels`` is the larger of theirs.
    """

    def __init__(self, color0=0.0, color1=1.0, *, scale=8.0, space="uv", filtered=True):
        super().__init__(scale, space, "CheckerTexture")
        self.color0 = as_value(color0, "CheckerTexture", "color0")
        self.color1 = as_value(color1, "CheckerTexture", "color1")
        self.filtered = bool(filtered)

    @property
    def channels(self):
        """The larger channel count of ``color0`` and ``color1`` (derived whenever read: it never goes stale)."""
        return max(value_channels(c) for c in (self.color0, self.color1))

    def compiled_record(self):
        """The unfiltered UV checker with constant colours (:data:`pyrt.textures.compiled.CHECKER_UV`); None for
        the filtered one (it needs ray differentials), object space or textured colours."""
        if self.filtered or self.space != "uv" or self.texcoord != 0 \
                or any(is_texture(c) for c in (self.color0, self.color1)):
            return None
        rec = np.zeros(_compiled.RECORD)
        rec[0:3] = np.broadcast_to(self.color0, (3,))
        rec[3:6] = np.broadcast_to(self.color1, (3,))
        rec[6:8] = self.scale
        return _compiled.CHECKER_UV, rec

    def evaluate(self, ctx):
        p = self._point(ctx)
        if self.filtered:
            t = _noise.checker_box_filtered(p, self._half_width(ctx))
        else:
            t = _noise.checker(p)
        return lerp(resolve(self.color0, ctx), resolve(self.color1, ctx), t)


class _NoiseBase(_Procedural):
    """A scalar noise ``t`` in [0, 1] (:meth:`_t`) mapped to ``low + (high - low) t``."""

    seed = Fixed('the permutation table derives from it')

    def __init__(self, scale, space, seed, low, high, owner):
        super().__init__(scale, space, owner)
        self.seed = seed
        try:
            self._perm = _noise.permutation_table(seed)
        except TypeError as exc:
            raise TextureError(f"{owner}: {exc}") from None
        self.low = as_value(low, owner, "low")
        self.high = as_value(high, owner, "high")

    @property
    def channels(self):
        """The larger channel count of ``low`` and ``high`` (derived whenever read: it never goes stale)."""
        return max(value_channels(c) for c in (self.low, self.high))

    def _t(self, ctx):  # pragma: no cover - interface
        raise NotImplementedError

    def evaluate(self, ctx):
        t = np.clip(self._t(ctx), 0.0, 1.0)
        return lerp(resolve(self.low, ctx), resolve(self.high, ctx), t)


class _LatticeNoise(_NoiseBase):
    """A single-octave lattice noise ``kernel(p, perm)`` in [-1, 1] mapped to ``low + (high - low) (0.5 + 0.5 n)``."""

    #: the noise kernel (a function of points (N, 3) and the permutation table), set by each subclass
    kernel = None

    def __init__(self, *, scale=4.0, space="uv", seed=0, low=0.0, high=1.0):
        super().__init__(scale, space, seed, low, high, type(self).__name__)

    def _t(self, ctx):
        return 0.5 + 0.5 * self.kernel(self._point(ctx), self._perm)


@TEXTURES.register("noise")
class NoiseTexture(_LatticeNoise):
    """Value noise mapped to ``low + (high - low) (0.5 + 0.5 n)``; ``scale`` = lattice cells per unit."""

    kernel = staticmethod(_noise.value_noise)


@TEXTURES.register("perlin")
class PerlinTexture(_LatticeNoise):
    """Perlin gradient noise mapped to ``low + (high - low) (0.5 + 0.5 n)``."""

    kernel = staticmethod(_noise.perlin)


@TEXTURES.register("fbm")
class FbmTexture(_NoiseBase):
    """Fractal Perlin sum ``sum_i gain^i perlin(lacunarity^i p)`` normalised by ``sum_i gain^i``.

    Octaves finer than the pixel footprint are faded out (``filtered=True``), so minified fBm
    converges to its mean instead of aliasing.
    """

    def __init__(self, *, scale=4.0, space="uv", seed=0, octaves=6, lacunarity=2.0, gain=0.5,
                 low=0.0, high=1.0, filtered=True):
        super().__init__(scale, space, seed, low, high, "FbmTexture")
        if not isinstance(octaves, (int, np.integer)) or not 1 <= octaves <= 32:
            raise TextureError(f"FbmTexture: octaves must be an integer in [1, 32], got {octaves!r}")
        self.octaves, self.lacunarity, self.gain = int(octaves), float(lacunarity), float(gain)
        self.filtered = bool(filtered)

    def _t(self, ctx):
        norm = np.sum(self.gain ** np.arange(self.octaves))
        fp = self._footprint_len(ctx) if self.filtered else None
        if fp is not None and not np.any(fp > 0):
            fp = None
        n = _noise.fbm(self._point(ctx), self._perm, self.octaves, lacunarity=self.lacunarity,
                       gain=self.gain, footprint=fp)
        return 0.5 + 0.5 * n / norm


@TEXTURES.register("voronoi")
class VoronoiTexture(_NoiseBase):
    """Worley cellular noise; ``output`` is ``"f1"``, ``"f2"``, ``"f2-f1"`` (cell borders) or ``"cell"``.

    Distances are in cells (``scale`` cells per unit) and clipped to [0, 1]; ``"cell"`` gives a
    random value in [0, 1) per cell.
    """

    OUTPUTS = ("f1", "f2", "f2-f1", "cell")

    def __init__(self, *, scale=8.0, space="uv", seed=0, output="f1", jitter=1.0, low=0.0, high=1.0):
        super().__init__(scale, space, seed, low, high, "VoronoiTexture")
        if output not in self.OUTPUTS:
            raise TextureError(f"VoronoiTexture: output must be one of {self.OUTPUTS}, got {output!r}")
        if not 0.0 <= jitter <= 1.0:
            raise TextureError(f"VoronoiTexture: jitter must be in [0, 1], got {jitter!r}")
        self.output, self.jitter = output, float(jitter)

    def _t(self, ctx):
        f1, f2, cell = _noise.voronoi(self._point(ctx), self._perm, self.jitter)
        return {"f1": f1, "f2": f2, "f2-f1": f2 - f1, "cell": cell}[self.output]
