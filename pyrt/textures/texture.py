"""Textures: user-facing objects with ``evaluate(ctx) -> (N, C)`` float64.

Any material parameter may be a texture: :meth:`pyrt.materials.Material.param` calls
``texture.evaluate(ctx)`` on the hits that use the material. ``ctx`` is a
:class:`pyrt.geometry.SurfaceBatch`; textures read ``ctx.uv`` (N, 2), ``ctx.duvdx``/``ctx.duvdy``
(N, 2, UV change per pixel step from ray differentials; zeros = unknown, no filtering),
``ctx.p_object`` (N, 3), ``ctx.dpdu``/``ctx.dpdv``/``ctx.ns`` (N, 3) (normal maps).

Conventions (the kernels in :mod:`shaders.textures` and :mod:`shaders.noise` document the maths)
---------------------------------------------------------------------------------------------
- **UV orientation**: ``uv = (0, 0)`` is the bottom-left of the image, ``v`` up (OBJ / trimesh);
  image row 0 is the top, so texel row = ``(1 - v) H``. glTF's ``(0, 0)`` is top-left: flip v.
- **Colour**: 8/16-bit PNG/JPEG images are sRGB-encoded and are linearised on load when
  ``srgb`` is true (the default for integer images); EXR and float arrays are linear (default
  ``srgb=False``). Data textures (roughness, metallic, normal maps) must pass ``srgb=False``.
  Alpha channels are dropped (RGBA -> RGB, grey+alpha -> grey).
- **Wrap**: ``"repeat" | "mirror" | "clamp"``, one name or a ``(u, v)`` pair.
- **Filters**: ``"nearest" | "bilinear" | "bicubic"`` (reconstruction on the full-resolution
  image, footprint ignored) and ``"trilinear" | "anisotropic"`` (MIP-mapped, level from the ray
  differential footprint; anisotropic = EWA, max anisotropy 8). Default ``"trilinear"``.
- **Lazy MIP maps**: a pyramid level is built the first time a lookup with a non-zero weight on
  it happens, i.e. only for textures that are minified (footprint > 1 texel) and only for the
  levels that are read; ``ImageTexture.mip_levels_built`` lists them.
"""
from __future__ import annotations

import os
import threading
import warnings

import numpy as np

from pyrt.shaders import color as _color
from pyrt.shaders import noise as _noise
from pyrt.shaders import textures as _tex
from pyrt.core.errors import Error


class TextureError(Error, ValueError):
    """A texture file or parameter is missing, unreadable or invalid (the message names it)."""


# ----------------------------------------------------------------------------- ctx helpers

def _footprints(ctx):
    n = ctx.n_hits
    z = np.zeros((n, 2))
    dx = getattr(ctx, "duvdx", None)
    dy = getattr(ctx, "duvdy", None)
    dx = z if dx is None else np.asarray(dx, dtype=np.float64).reshape(n, 2)
    dy = z if dy is None else np.asarray(dy, dtype=np.float64).reshape(n, 2)
    return dx, dy


def _dp_dxy(ctx):
    """World-space position change per pixel step (N, 3) x2: ``dpdu du/dx + dpdv dv/dx``.

    Uses ``ctx.dpdx``/``ctx.dpdy`` when the engine provides them.
    """
    if getattr(ctx, "dpdx", None) is not None and getattr(ctx, "dpdy", None) is not None:
        return np.asarray(ctx.dpdx, dtype=np.float64), np.asarray(ctx.dpdy, dtype=np.float64)
    dx, dy = _footprints(ctx)
    dpdu = np.asarray(ctx.dpdu, dtype=np.float64)
    dpdv = np.asarray(ctx.dpdv, dtype=np.float64)
    return dpdu * dx[:, :1] + dpdv * dx[:, 1:], dpdu * dy[:, :1] + dpdv * dy[:, 1:]


def _as_value(value, owner, name):
    """A constant parameter as a float64 (C,) array (C = 1 or 3), or a texture unchanged."""
    if hasattr(value, "evaluate"):
        return value
    arr = np.atleast_1d(np.asarray(value, dtype=np.float64))
    if arr.ndim != 1 or arr.shape[0] not in (1, 3) or not np.all(np.isfinite(arr)):
        raise TextureError(f"{owner}: {name} must be a finite scalar, an RGB triple or a texture, got {value!r}")
    return arr


def _resolve(value, ctx):
    if hasattr(value, "evaluate"):
        return np.asarray(value.evaluate(ctx), dtype=np.float64).reshape(ctx.n_hits, -1)
    return np.broadcast_to(value, (ctx.n_hits, value.shape[0]))


def _lerp(a, b, t):
    """``a + (b - a) t`` with a, b (N, Ca), (N, Cb) broadcast to a common channel count."""
    c = max(a.shape[1], b.shape[1])
    a = np.broadcast_to(a, (a.shape[0], c)) if a.shape[1] == 1 else a
    b = np.broadcast_to(b, (b.shape[0], c)) if b.shape[1] == 1 else b
    return a + (b - a) * t[:, None]


class Texture:
    """Base class: ``evaluate(ctx) -> (N, C)`` float64, C = ``channels`` (1 or 3)."""

    channels = 3

    def evaluate(self, ctx):  # pragma: no cover - interface
        raise NotImplementedError

    def __repr__(self):
        fields = ", ".join(f"{k}={v!r}" for k, v in vars(self).items() if not k.startswith("_"))
        return f"{type(self).__name__}({fields})"


class ConstantTexture(Texture):
    """The same value everywhere: a scalar (C = 1) or an RGB triple (C = 3)."""

    def __init__(self, value):
        self.value = _as_value(value, "ConstantTexture", "value")
        self.channels = self.value.shape[0]

    def evaluate(self, ctx):
        return np.array(np.broadcast_to(self.value, (ctx.n_hits, self.channels)))


# ----------------------------------------------------------------------------- image loading

def load_image(path):
    """Read an image file as ``(H, W, C)`` float32 in its stored encoding, and whether it was integer.

    PNG/JPEG/TIFF (8 or 16 bit) via ``skimage.io`` (divided by 255 or 65535); EXR via ``OpenEXR``
    (half/float channels R, G, B[, A] or Y, or a single channel). Raises :class:`TextureError`
    naming the file when it is missing, unreadable or of an unsupported pixel type.
    """
    path = os.fspath(path)
    if not os.path.isfile(path):
        raise TextureError(f"texture file not found: {path!r}")
    ext = os.path.splitext(path)[1].lower()
    try:
        if ext == ".exr":
            return _load_exr(path), False
        if ext == ".png" and _png_is_16bit_colour(path):
            img = _load_png16(path)
        else:
            from skimage import io as skio

            with warnings.catch_warnings():  # imageio's plugin probing warns on undecodable files
                warnings.simplefilter("ignore", DeprecationWarning)
                img = skio.imread(path)
    except TextureError:
        raise
    except Exception as exc:  # any decoder failure: say which file
        raise TextureError(f"cannot read texture file {path!r}: {type(exc).__name__}: {exc}") from exc
    img = np.asarray(img)
    if img.dtype == np.uint8:
        return (img.astype(np.float32) / 255.0), True
    if img.dtype == np.uint16:
        return (img.astype(np.float32) / 65535.0), True
    if img.dtype == bool:
        return img.astype(np.float32), True
    if np.issubdtype(img.dtype, np.floating):
        return img.astype(np.float32), False
    raise TextureError(f"texture file {path!r}: unsupported pixel type {img.dtype}")


def _png_is_16bit_colour(path):
    """True for a 16-bit PNG with colour or alpha (IHDR bit depth 16, colour type 2, 4 or 6).

    Pillow (behind ``skimage.io``) silently truncates those to 8 bits; 16-bit grey is fine.
    """
    with open(path, "rb") as f:
        head = f.read(26)
    return len(head) == 26 and head[:8] == b"\x89PNG\r\n\x1a\n" and head[24] == 16 and head[25] in (2, 4, 6)


def _load_png16(path):
    """Read a 16-bit colour PNG with pypng (exact 16-bit values; pure Python, ~1 s per megapixel)."""
    import png

    width, height, rows, info = png.Reader(filename=path).asDirect()
    planes = info["planes"]
    img = np.vstack([np.asarray(row, dtype=np.uint16) for row in rows])
    return img.reshape(height, width, planes)


def _load_exr(path):
    import OpenEXR

    with OpenEXR.File(path) as f:
        ch = f.channels()
        if "RGBA" in ch:
            img = ch["RGBA"].pixels
        elif "RGB" in ch:
            img = ch["RGB"].pixels
        elif all(k in ch for k in "RGB"):
            img = np.stack([ch[k].pixels for k in "RGB"], axis=-1)
        elif "Y" in ch:
            img = ch["Y"].pixels
        elif len(ch) == 1:
            img = next(iter(ch.values())).pixels
        else:
            raise TextureError(f"texture file {path!r}: EXR channels {sorted(ch)} are not RGB(A), Y or a single channel")
        img = np.asarray(img)
    if not np.issubdtype(img.dtype, np.floating):
        img = img.astype(np.float64)
    return img.astype(np.float32)


def _prepare(img, *, label, srgb, channels, select):
    """Shape to (H, W, C), drop alpha, select/check channels, decode sRGB, check finiteness."""
    img = np.asarray(img)
    if img.ndim == 2:
        img = img[:, :, None]
    if img.ndim != 3 or img.shape[0] < 1 or img.shape[1] < 1:
        raise TextureError(f"texture {label}: expected an (H, W) or (H, W, C) image, got shape {img.shape}")
    c = img.shape[2]
    if select is not None:
        if not 0 <= select < c:
            raise TextureError(f"texture {label}: select={select} but the image has {c} channel(s)")
        img = img[:, :, select:select + 1]
    elif c == 2:
        img = img[:, :, :1]
    elif c == 4:
        img = img[:, :, :3]
    elif c not in (1, 3):
        raise TextureError(f"texture {label}: has {c} channels; expected 1 (grey), 2 (grey+alpha), 3 (RGB) or 4 (RGBA)")
    if channels is not None and img.shape[2] != channels:
        hint = "; pass select=k to use one channel" if channels == 1 else ""
        raise TextureError(f"texture {label}: has {img.shape[2]} channel(s), expected {channels}{hint}")
    img = np.ascontiguousarray(img, dtype=np.float32)
    bad = ~np.isfinite(img)
    if np.any(bad):
        r, col, ch = np.argwhere(bad)[0]
        raise TextureError(f"texture {label}: {int(bad.sum())} non-finite texel value(s), first at row {r}, "
                           f"column {col}, channel {ch} ({img[r, col, ch]})")
    if srgb:
        img = _color.srgb_decode(img)
    return img


class MipPyramid:
    """Sequence view of a MIP pyramid whose levels are built on first access.

    ``pyramid[l]`` builds level ``l`` from level 0 (:func:`shaders.textures.build_mip_level`, an
    exact box filter) the first time it is indexed and caches it (under a lock: render threads
    share textures); ``built`` lists the levels > 0 that exist. ``len(pyramid)`` is the full
    level count.
    """

    def __init__(self, base):
        self._levels = [base] + [None] * (_tex.n_mip_levels(base.shape) - 1)
        self._lock = threading.Lock()  # the renderer shades chunks on several threads

    def __len__(self):
        return len(self._levels)

    def __getitem__(self, level):
        level = int(level)
        if level < 0:
            level += len(self._levels)
        if self._levels[level] is None:
            with self._lock:
                if self._levels[level] is None:
                    self._levels[level] = _tex.build_mip_level(self._levels[0], level)
        return self._levels[level]

    @property
    def built(self):
        return [i for i, lev in enumerate(self._levels) if i > 0 and lev is not None]


FILTERS = _tex.RECONSTRUCTION_FILTERS + _tex.FOOTPRINT_FILTERS


class ImageTexture(Texture):
    """Image texture from a file (PNG/JPEG 8/16-bit, EXR) or an array.

    Parameters
    ----------
    source : str, os.PathLike or (H, W[, C]) array
        File name or image array (row 0 = top). Integer arrays are divided by their dtype max.
    srgb : bool, optional
        Decode the sRGB transfer curve on load. Default: True for 8/16-bit images (colour
        textures), False for EXR and float arrays. Pass False for data textures.
    wrap : str or (str, str)
        ``"repeat"``, ``"mirror"`` or ``"clamp"`` (per axis as a ``(u, v)`` pair).
    filter : str
        ``"nearest"``, ``"bilinear"``, ``"bicubic"``, ``"trilinear"`` (default) or ``"anisotropic"``.
    scale, offset : (2,) float
        UV transform ``uv' = R(rotation) (scale * uv) + offset``.
    rotation_deg : float
        Counter-clockwise UV rotation in degrees.
    channels : {None, 1, 3}
        Required channel count after alpha is dropped (error naming the file otherwise).
    select : int, optional
        Use only this channel of the file (e.g. 1 = G of a glTF metallic-roughness map).
    footprint_scale : float, optional
        Filter width in pixel steps for the footprint filters (1 = one-pixel box; pbrt-v4 uses 2).
        Default: 1 for trilinear, 1.5 for anisotropic (``shaders.textures.DEFAULT_FOOTPRINT_SCALE``).
    max_anisotropy : float
        Anisotropic filter: largest major/minor axis ratio (pbrt-v4: 8).
    """

    def __init__(self, source, *, srgb=None, wrap="repeat", filter="trilinear", scale=(1.0, 1.0),
                 offset=(0.0, 0.0), rotation_deg=0.0, channels=None, select=None, footprint_scale=None,
                 max_anisotropy=8.0, name=None):
        if isinstance(source, (str, os.PathLike)):
            self.path = os.fspath(source)
            label = repr(self.path)
            img, is_int = load_image(self.path)
        else:
            self.path = None
            label = name or "<array>"
            img = np.asarray(source)
            is_int = np.issubdtype(img.dtype, np.integer)
            if is_int:
                img = img.astype(np.float64) / np.iinfo(img.dtype).max
            elif not np.issubdtype(img.dtype, np.floating):
                raise TextureError(f"texture {label}: unsupported array dtype {img.dtype}")
        self.name = name
        self.srgb = bool(is_int) if srgb is None else bool(srgb)
        if filter not in FILTERS:
            raise TextureError(f"texture {label}: filter must be one of {FILTERS}, got {filter!r}")
        try:
            self.wrap = _tex.check_wrap(wrap)
        except ValueError as exc:
            raise TextureError(f"texture {label}: {exc}") from None
        self.filter = filter
        self.scale = tuple(float(s) for s in np.broadcast_to(np.asarray(scale, dtype=np.float64), (2,)))
        self.offset = tuple(float(s) for s in np.broadcast_to(np.asarray(offset, dtype=np.float64), (2,)))
        self.rotation_deg = float(rotation_deg)
        if not (np.all(np.isfinite(self.scale)) and np.all(np.isfinite(self.offset)) and np.isfinite(self.rotation_deg)):
            raise TextureError(f"texture {label}: scale, offset and rotation_deg must be finite")
        if footprint_scale is None:
            footprint_scale = _tex.DEFAULT_FOOTPRINT_SCALE.get(filter, 1.0)
        if not footprint_scale > 0 or not max_anisotropy >= 1:
            raise TextureError(f"texture {label}: need footprint_scale > 0 and max_anisotropy >= 1")
        self.footprint_scale = float(footprint_scale)
        self.max_anisotropy = float(max_anisotropy)
        self._image = _prepare(img, label=label, srgb=self.srgb, channels=channels, select=select)
        self.channels = self._image.shape[2]
        self._pyramid = MipPyramid(self._image)

    @property
    def image(self):
        """Level 0, linear values, (H, W, C) float32 (read-only view)."""
        v = self._image.view()
        v.flags.writeable = False
        return v

    @property
    def mip_levels_built(self):
        """MIP levels (> 0) built so far; each was read by at least one lookup."""
        return self._pyramid.built

    def lookup(self, uv, duvdx=None, duvdy=None):
        """Filtered lookup at raw mesh UVs (N, 2) with footprints (N, 2) -> (N, C) float64."""
        uv = np.asarray(uv, dtype=np.float64)
        n = len(uv)
        duvdx = np.zeros((n, 2)) if duvdx is None else np.asarray(duvdx, dtype=np.float64)
        duvdy = np.zeros((n, 2)) if duvdy is None else np.asarray(duvdy, dtype=np.float64)
        uv, duvdx, duvdy = _tex.transform_uv(uv, duvdx, duvdy, scale=self.scale, offset=self.offset,
                                             rotation=np.deg2rad(self.rotation_deg))
        if self.filter in _tex.RECONSTRUCT:
            out = _tex.RECONSTRUCT[self.filter](self._image, uv, self.wrap)
        elif self.filter == "trilinear":
            out = _tex.lookup_trilinear(self._pyramid, uv, duvdx, duvdy, self.wrap, self.footprint_scale)
        else:
            out = _tex.lookup_ewa(self._pyramid, uv, duvdx, duvdy, self.wrap, self.footprint_scale,
                                  self.max_anisotropy)
        return out.astype(np.float64)

    def evaluate(self, ctx):
        dx, dy = _footprints(ctx)
        return self.lookup(ctx.uv, dx, dy)


# ----------------------------------------------------------------------------- procedural

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
            dx, dy = _footprints(ctx)
        else:
            dx, dy = _dp_dxy(ctx)
        return 0.5 * (np.abs(dx) + np.abs(dy)) * np.abs(self.scale)

    def _footprint_len(self, ctx):
        hw = self._half_width(ctx)
        return 2.0 * np.max(hw, axis=1)


class CheckerTexture(_Procedural):
    """Checkerboard of ``color0`` (even cells) and ``color1`` (odd cells).

    ``scale`` cells per unit of UV (2D) or object space (3D, ``space="object"``). With
    ``filtered=True`` (default) each lookup returns the exact average over its pixel footprint's
    bounding box (:func:`shaders.noise.checker_box_filtered`): alias-free under minification.
    ``color0``/``color1`` may be scalars, RGB triples or textures.
    """

    def __init__(self, color0=0.0, color1=1.0, *, scale=8.0, space="uv", filtered=True):
        super().__init__(scale, space, "CheckerTexture")
        self.color0 = _as_value(color0, "CheckerTexture", "color0")
        self.color1 = _as_value(color1, "CheckerTexture", "color1")
        self.filtered = bool(filtered)
        self.channels = max(getattr(c, "channels", None) or c.shape[0] for c in (self.color0, self.color1))

    def evaluate(self, ctx):
        p = self._point(ctx)
        if self.filtered:
            t = _noise.checker_box_filtered(p, self._half_width(ctx))
        else:
            t = _noise.checker(p)
        return _lerp(_resolve(self.color0, ctx), _resolve(self.color1, ctx), t)


class _NoiseBase(_Procedural):
    def __init__(self, scale, space, seed, low, high, owner):
        super().__init__(scale, space, owner)
        self.seed = seed
        try:
            self._perm = _noise.permutation_table(seed)
        except TypeError as exc:
            raise TextureError(f"{owner}: {exc}") from None
        self.low = _as_value(low, owner, "low")
        self.high = _as_value(high, owner, "high")
        self.channels = max(getattr(c, "channels", None) or c.shape[0] for c in (self.low, self.high))

    def _t(self, ctx):  # pragma: no cover - interface
        raise NotImplementedError

    def evaluate(self, ctx):
        t = np.clip(self._t(ctx), 0.0, 1.0)
        return _lerp(_resolve(self.low, ctx), _resolve(self.high, ctx), t)


class NoiseTexture(_NoiseBase):
    """Value noise mapped to ``low + (high - low) (0.5 + 0.5 n)``; ``scale`` = lattice cells per unit."""

    def __init__(self, *, scale=4.0, space="uv", seed=0, low=0.0, high=1.0):
        super().__init__(scale, space, seed, low, high, "NoiseTexture")

    def _t(self, ctx):
        return 0.5 + 0.5 * _noise.value_noise(self._point(ctx), self._perm)


class PerlinTexture(_NoiseBase):
    """Perlin gradient noise mapped to ``low + (high - low) (0.5 + 0.5 n)``."""

    def __init__(self, *, scale=4.0, space="uv", seed=0, low=0.0, high=1.0):
        super().__init__(scale, space, seed, low, high, "PerlinTexture")

    def _t(self, ctx):
        return 0.5 + 0.5 * _noise.perlin(self._point(ctx), self._perm)


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


# ----------------------------------------------------------------------------- normal maps

class NormalMap(ImageTexture):
    """Tangent-space normal map (OpenGL convention: red = +u tangent, green = +v, blue = normal).

    Loaded as linear data (``srgb=False``) with 3 channels. ``strength`` scales the tangential
    components (0 = flat); ``flip_green=True`` reads DirectX-style maps. Default filter
    ``"bilinear"`` (trilinear also works; averaged normals are renormalised). Use with
    :func:`perturb_normal` or a material's ``normal_map=`` parameter.
    """

    def __init__(self, source, *, strength=1.0, flip_green=False, filter="bilinear", **kwargs):
        kwargs.setdefault("srgb", False)
        super().__init__(source, filter=filter, channels=3, **kwargs)
        if not np.isfinite(strength) or strength < 0:
            raise TextureError(f"NormalMap {self.path or self.name or ''}: strength must be finite and >= 0")
        self.strength = float(strength)
        self.flip_green = bool(flip_green)


def flat_normal_map(height=4, width=4):
    """A flat tangent-space normal-map image (every texel (0.5, 0.5, 1)), float32 (H, W, 3)."""
    img = np.empty((height, width, 3), dtype=np.float32)
    img[...] = (0.5, 0.5, 1.0)
    return img


def perturb_normal(ctx, normal_map):
    """Shading normals perturbed by a tangent-space normal map.

    Parameters
    ----------
    ctx : SurfaceBatch
        Uses ``ns`` (unit shading normal, turned toward the viewer), ``dpdu``, ``dpdv`` and what
        the texture reads (``uv``, footprints).
    normal_map : texture
        A :class:`NormalMap` (its ``strength`` and ``flip_green`` apply) or any 3-channel texture
        whose values are ``(n + 1) / 2`` of a tangent-space normal.

    Returns
    -------
    (N, 3) float64
        Unit normals ``normalize(x t + y b + z ns)`` with the tangent frame of
        :func:`shaders.textures.tangent_frame`; exactly ``ctx.ns`` where the map is flat
        (0.5, 0.5, 1) or degenerate, and where the perturbed normal would face away from
        ``ctx.wo`` (when ``ctx`` has ``wo``).
    """
    ns = np.asarray(ctx.ns, dtype=np.float64)
    rgb = np.asarray(normal_map.evaluate(ctx), dtype=np.float64).reshape(ctx.n_hits, -1)
    if rgb.shape[1] != 3:
        raise TextureError(f"normal map {normal_map!r} must have 3 channels, got {rgb.shape[1]}")
    n_ts = _tex.decode_normal_map(rgb, getattr(normal_map, "strength", 1.0), getattr(normal_map, "flip_green", False))
    t, b = _tex.tangent_frame(ns, np.asarray(ctx.dpdu, dtype=np.float64), np.asarray(ctx.dpdv, dtype=np.float64))
    n = _tex.apply_tangent_normal(n_ts, ns, t, b)
    wo = getattr(ctx, "wo", None)
    if wo is not None:
        # A perturbed normal that turns away from the viewer cannot shade anything (every BRDF
        # kernel returns 0 for wo below the horizon): keep the unperturbed normal there, as
        # pyrt.geometry does for interpolated vertex normals.
        away = np.einsum("ij,ij->i", n, np.asarray(wo, dtype=np.float64)) <= 0
        n = np.where(away[:, None], ns, n)
    return n


def apply_normal_maps(surf, materials):
    """Perturb ``surf``'s shading normals for every material with a ``normal_map`` attribute.

    Called by the integrator right after the surface batch is built (before any material or AOV
    reads ``ns``); rebuilds the local frame with ``surf.set_shading_normal``. Materials without
    ``normal_map`` (or with ``None``) are untouched. Returns ``surf``.
    """
    mids = np.asarray(surf.material_id)
    ns = None
    for k in np.unique(mids):
        nm = getattr(materials[int(k)], "normal_map", None)
        if nm is None:
            continue
        sel = np.flatnonzero(mids == k)
        if ns is None:
            ns = np.array(surf.ns, dtype=np.float64, copy=True)
        ns[sel] = perturb_normal(surf.subset(sel), nm)
    if ns is not None:
        surf.set_shading_normal(ns)
    return surf


# ----------------------------------------------------------------------------- scene files

TEXTURE_TYPES = {
    "constant": ConstantTexture, "image": ImageTexture, "checker": CheckerTexture,
    "noise": NoiseTexture, "perlin": PerlinTexture, "fbm": FbmTexture, "voronoi": VoronoiTexture,
    "normal_map": NormalMap,
}


def texture_from_dict(spec, base_dir=None):
    """Build a texture from a scene-file dict ``{"type": name, ...keyword args}``.

    ``"path"`` (image / normal_map) is resolved relative to ``base_dir``. Nested dicts in
    colour parameters become textures too.
    """
    spec = dict(spec)
    kind = spec.pop("type", None)
    if kind not in TEXTURE_TYPES:
        raise TextureError(f"texture type must be one of {sorted(TEXTURE_TYPES)}, got {kind!r}")
    for k, v in list(spec.items()):
        if isinstance(v, dict):
            spec[k] = texture_from_dict(v, base_dir)
    cls = TEXTURE_TYPES[kind]
    if kind in ("image", "normal_map"):
        path = spec.pop("path", None)
        if path is None:
            raise TextureError(f"{kind} texture needs a 'path'")
        if base_dir is not None and not os.path.isabs(path):
            path = os.path.join(base_dir, path)
        return cls(path, **spec)
    if kind == "constant":
        return cls(spec.pop("value"), **spec)
    try:
        return cls(**spec)
    except TypeError as exc:
        raise TextureError(f"{kind} texture: {exc}") from None
