"""Image textures: file loading for textures, lazy MIP pyramids, :class:`ImageTexture`.

Conventions (the kernels in :mod:`pyrt.shaders.textures` document the maths)
----------------------------------------------------------------------------
- **UV orientation**: ``uv = (0, 0)`` is the bottom-left of the image, ``v`` up (OBJ / trimesh);
  image row 0 is the top, so texel row = ``(1 - v) H``. glTF's ``(0, 0)`` is top-left: flip v.
- **Colour**: 8/16-bit PNG/JPEG images are sRGB-encoded and are linearised on load when ``srgb`` is true (the
  default for integer images); EXR and float arrays are linear (default ``srgb=False``). Data textures (roughness,
  metallic, normal maps) must pass ``srgb=False``. ``decode="gamma2.2"`` decodes with the plain power law
  ``x ** 2.2`` of the course notes instead of the exact sRGB curve (``decode`` is one of :data:`DECODINGS`; it
  overrides ``srgb``). Alpha channels are dropped (RGBA -> RGB, grey+alpha -> grey).
- **Storage**: 8/16-bit images keep their codes (uint8 / uint16: a quarter / half of float32) and are decoded
  per tap by a table of the 256 / 65536 decoded values (:func:`decode_table`), the same float32 numbers a
  decoded copy would hold, so level 0 reads exactly what it did; MIP levels >= 1 are float32 linear,
  filtered from the decoded level 0 (built in strips of rows, never a full float copy of level 0).
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

import numpy as np

from pyrt.core.checks import Fixed
from pyrt.core.image_io import ImageFileError, read_image
from pyrt.geometry.memo import row_memo, rows_cached
from pyrt.shaders import color as _color, ewa as _ewa, mip as _mip, textures as _tex
from pyrt.textures import compiled as _compiled, grey as _grey
from pyrt.textures.base import TEXTURES, Texture, TextureError, texcoords


# ----------------------------------------------------------------------------- image loading

def load_image(path, *, integers=False):
    """Read an image file as ``(H, W, C)`` float32 in its stored encoding, and whether it was integer.

    Parameters
    ----------
    path : str or os.PathLike
        PNG/JPEG/TIFF (8 or 16 bit), EXR or Radiance .hdr, read by :func:`pyrt.core.image_io.read_image`.
    integers : bool
        Return 8/16-bit images as their uint8 / uint16 codes (1-bit images as uint8 0 / 255) instead of
        float32 (what :class:`ImageTexture` stores; :func:`decode_table` maps a code to its value).

    Returns
    -------
    image : (H, W) or (H, W, C) float32 ndarray
        Integer images divided by 255 or 65535 (still sRGB-encoded), or their codes with ``integers``; EXR
        as stored (half/float channels R, G, B[, A] or Y, or a single channel).
    is_integer : bool
        True for 8/16-bit (and 1-bit) images: their default is ``srgb=True``.

    Raises
    ------
    TextureError
        Naming the file when it is missing, unreadable (not an image, truncated, corrupt: the message says
        which part), larger than :data:`pyrt.core.image_io.MAX_IMAGE_PIXELS`, or of an unsupported pixel type.
    """
    path = os.fspath(path)
    if not os.path.isfile(path):
        raise TextureError(f"texture file not found: {path!r}")
    try:
        img = read_image(path)
    except ImageFileError as exc:  # names the file and the part: "wood.png: not a readable PNG file (...)"
        raise TextureError(str(exc)) from None
    img = np.asarray(img)
    if integers and img.dtype in (np.uint8, np.uint16):
        return img, True
    if integers and img.dtype == bool:
        return img.astype(np.uint8) * np.uint8(255), True
    if img.dtype == np.uint8:
        return (img.astype(np.float32) / 255.0), True
    if img.dtype == np.uint16:
        return (img.astype(np.float32) / 65535.0), True
    if img.dtype == bool:
        return img.astype(np.float32), True
    if np.issubdtype(img.dtype, np.floating):
        return img.astype(np.float32), False
    raise TextureError(f"texture file {path!r}: unsupported pixel type {img.dtype}")


#: Texel decodings of :class:`ImageTexture` (``decode=``): exact sRGB curve, ``pow(x, 2.2)``, none.
DECODINGS = ("srgb", "gamma2.2", "linear")
#: Integer texel types kept as codes by :class:`ImageTexture` (decoded per tap by :func:`decode_table`).
CODE_TYPES = (np.uint8, np.uint16)


def _decode(img, decode, label):
    if decode == "srgb":
        return _color.srgb_decode(img)
    if decode == "gamma2.2":
        return _color.gamma_decode(img, 2.2)
    if decode != "linear":
        raise TextureError(f"texture {label}: decode must be one of {DECODINGS}, got {decode!r}")
    return img


def decode_table(dtype, decode):
    """The float32 value of every code of an integer texel type: ``table[k] = decode(k / max)``.

    Parameters
    ----------
    dtype : numpy.uint8 or numpy.uint16
    decode : str
        One of :data:`DECODINGS`.

    Returns
    -------
    (256,) or (65536,) float32 ndarray
        ``k / max`` rounded to float32 (the value :func:`load_image` gives) then decoded in float32, exactly
        what decoding a float32 copy of the image would give texel by texel.
    """
    top = np.iinfo(dtype).max
    codes = (np.arange(top + 1, dtype=np.float64) / top).astype(np.float32)
    return _decode(codes, decode, f"<{np.dtype(dtype).name} table>")


def prepare_image(img, *, label, srgb, channels, select, decode=None):
    """Shape to (H, W, C), drop alpha, select/check channels, decode, check finiteness.

    ``decode`` (one of :data:`DECODINGS`) overrides ``srgb`` when given: ``"srgb"`` applies
    :func:`shaders.color.srgb_decode`, ``"gamma2.2"`` :func:`shaders.color.gamma_decode` with
    ``gamma=2.2``, ``"linear"`` nothing.

    Returns
    -------
    (H, W, C) ndarray, C-contiguous: float32 linear values, or for uint8 / uint16 input (:data:`CODE_TYPES`)
    the codes unchanged, to be decoded through :func:`decode_table`.
    """
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
    if decode is None:
        decode = "srgb" if srgb else "linear"
    if img.dtype in CODE_TYPES:
        if decode not in DECODINGS:
            raise TextureError(f"texture {label}: decode must be one of {DECODINGS}, got {decode!r}")
        return np.ascontiguousarray(img)
    img = np.ascontiguousarray(img, dtype=np.float32)
    bad = ~np.isfinite(img)
    if np.any(bad):
        r, col, ch = np.argwhere(bad)[0]
        raise TextureError(f"texture {label}: {int(bad.sum())} non-finite texel value(s), first at row {r}, "
                           f"column {col}, channel {ch} ({img[r, col, ch]})")
    return _decode(img, decode, label)


# ----------------------------------------------------------------------------- MIP pyramid

class MipPyramid:
    """Sequence view of a MIP pyramid whose levels are built on first access.

    ``pyramid[l]`` builds level ``l`` the first time it is indexed, from the nearest finer level
    already built by successive 2x2 box reductions (:func:`pyrt.shaders.mip.reduce_levels`, in the
    dtype of level 0: float32 for textures), and caches it under a lock (render threads share
    textures). Levels in between that no lookup read are not kept. ``built`` lists the levels > 0
    that exist; ``len(pyramid)`` is the full level count; ``nbytes`` the memory of the levels held.
    An integer-coded level 0 (with ``table``) is decoded for its first reduction in strips of
    :attr:`STRIP_ROWS` rows (the same numbers as decoding it whole, without a float copy of level 0), and the
    level 1 it gives is kept even when only coarser levels are read: that decode is the costly step of a build
    (measured on the helmet-like model at 320x240: 13 first reductions, 0.92 s of a 9.8 s render, when level 1 was
    dropped and rebuilt), at a cost of a quarter of level 0 in float32 (12.6 MB for a 2048^2 RGB texture).

    Parameters
    ----------
    base : (H, W, C) ndarray
        Level 0: float, or integer codes with ``table``.
    table : (K,) float ndarray, optional
        The decoded value of every code (:func:`decode_table`); levels >= 1 are in its dtype.
    """

    #: rows of level 0 decoded at a time when it is integer-coded (even: 2x2 cells never straddle strips)
    STRIP_ROWS = 256

    def __init__(self, base, table=None):
        self._levels = [base] + [None] * (_tex.n_mip_levels(base.shape) - 1)
        self.table = table
        self._lock = threading.Lock()  # the renderer shades chunks on several threads
        self._constant = None

    def constant_channels(self):
        """(C,) float64: each channel's value where it is the same in every texel of level 0 (then in every level
        and every filtered lookup: every filter is a weighted mean of texels), NaN where it varies. Computed once
        (a min and a max over level 0) and kept: e.g. the unused channels of packed occlusion-roughness-metallic
        maps, the white RGB of an image that only carries alpha."""
        if self._constant is None:
            base = self._levels[0]
            first = base[0, 0]
            # a strided sample of ~4096 texels first: a channel that varies there varies (most maps: no full pass)
            step = max(1, int(np.sqrt(base.shape[0] * base.shape[1] / 4096)))
            same = (base[::step, ::step] == first).all(axis=(0, 1))
            for c in np.flatnonzero(same):
                same[c] = bool((base[..., c] == first[c]).all())
            vals = (self.table[first] if self.table is not None else first).astype(np.float64)
            self._constant = np.where(same, vals, np.nan)
        return self._constant

    def __len__(self):
        return len(self._levels)

    def __getitem__(self, level):
        level = int(level)
        if level < 0:
            level += len(self._levels)
        if self._levels[level] is None:
            with self._lock:
                if self._levels[level] is None:
                    src = max(i for i in range(level) if self._levels[i] is not None)
                    if src == 0 and self.table is not None:    # the costly step: keep level 1 (module notes)
                        self._levels[1] = first = self._first_reduction()
                        self._levels[level] = _mip.reduce_levels(first, level - 1)
                    else:
                        self._levels[level] = _mip.reduce_levels(self._levels[src], level - src)
        return self._levels[level]

    def _first_reduction(self):
        """Level 1 of a coded level 0: decoded and reduced strip by strip (whole when H is odd)."""
        base, table = self._levels[0], self.table
        h = base.shape[0]
        if h % 2:
            return _mip.reduce_level(table[base])
        out = np.empty(_tex.mip_level_shape(base.shape, 1) + base.shape[2:], dtype=table.dtype)
        step = self.STRIP_ROWS
        if base.dtype == np.uint8:        # row pairs decoded and averaged by one lookup (bit-identical, 3-4x)
            pairs = _mip.pair_table(table)
            for r in range(0, h, step):
                out[r // 2:(r + step) // 2] = _mip.reduce_coded_level(base[r:r + step], table, pairs)
            return out
        for r in range(0, h, step):
            out[r // 2:(r + step) // 2] = _mip.reduce_level(table[base[r:r + step]])
        return out

    def build_all(self):
        """Build every level now, each from the one above (what forked render workers would otherwise each build
        for themselves: built before the fork, the workers share one copy)."""
        for level in range(1, len(self._levels)):
            self[level]

    @property
    def built(self):
        """Indices (> 0) of the levels built so far, ascending."""
        return [i for i, lev in enumerate(self._levels) if i > 0 and lev is not None]

    @property
    def nbytes(self):
        """Bytes held by level 0 and the levels built so far."""
        return sum(lev.nbytes for lev in self._levels if lev is not None)


# ----------------------------------------------------------------------------- image texture

FILTERS = _tex.RECONSTRUCTION_FILTERS + _tex.FOOTPRINT_FILTERS


@TEXTURES.register("image")
class ImageTexture(Texture):
    """Image texture from a file (PNG/JPEG 8/16-bit, EXR) or an array.

    Parameters
    ----------
    source : str, os.PathLike, (H, W[, C]) array or ImageTexture
        File name or image array (row 0 = top). uint8 / uint16 arrays and 8/16-bit files are stored as
        their codes (decoded per tap, module notes); other integer arrays are divided by their dtype max.
        Another :class:`ImageTexture`: share its decoded texels and lazy MIP pyramid (no copy, no
        decode; ``srgb``/``decode`` may only repeat its decoding, ``select`` is refused) with this
        texture's own wrap, filter and UV transform (asset loaders decode each image once).
    srgb : bool, optional
        Decode the sRGB transfer curve on load. Default: True for 8/16-bit images (colour
        textures), False for EXR and float arrays. Pass False for data textures.
    decode : {None, "srgb", "gamma2.2", "linear"}
        Texel decoding; overrides ``srgb`` when given: the exact sRGB curve, the plain power law
        ``x ** 2.2`` (course notes 003/004, LearnOpenGL), or none. ``None`` (default): ``"srgb"`` if
        ``srgb`` else ``"linear"``.
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
    name : str, optional
        Label for messages (arrays have no file name).
    texcoord : int
        The UV set read (0 = the mesh's UVs; k = glTF ``TEXCOORD_k``, :attr:`Texture.texcoord`).
    """

    srgb = Fixed('the texels were decoded with it')
    decode = Fixed('the texels were decoded with it')
    channels = Fixed("it is the decoded image's")
    compiled_scalar = _grey.compiled_scalar     # a grey image: channel 0 of its RGB twin

    def __init__(self, source, *, srgb=None, wrap="repeat", filter="trilinear", scale=(1.0, 1.0),
                 offset=(0.0, 0.0), rotation_deg=0.0, channels=None, select=None, footprint_scale=None,
                 max_anisotropy=8.0, name=None, decode=None, texcoord=0):
        shared = source if isinstance(source, ImageTexture) else None
        if shared is not None:  # same texels (decoded level 0 and lazy pyramid), own sampling options
            self.path = shared.path
            label = repr(self.path) if self.path else (name or shared.name or "<array>")
            if select is not None:
                raise TextureError(f"texture {label}: select= cannot be applied to shared texels")
            want = decode if decode is not None else (None if srgb is None else ("srgb" if srgb else "linear"))
            if want is not None and want != shared.decode:
                raise TextureError(f"texture {label}: shares texels decoded {shared.decode!r}, asked for {want!r}")
            img, is_int, srgb, decode = shared._image, False, None, shared.decode
        elif isinstance(source, (str, os.PathLike)):
            self.path = os.fspath(source)
            label = repr(self.path)
            img, is_int = load_image(self.path, integers=True)
        else:
            self.path = None
            label = name or "<array>"
            img = np.asarray(source)
            is_int = np.issubdtype(img.dtype, np.integer)
            if is_int and img.dtype not in CODE_TYPES:
                img = img.astype(np.float64) / np.iinfo(img.dtype).max
            elif not (is_int or np.issubdtype(img.dtype, np.floating)):
                raise TextureError(f"texture {label}: unsupported array dtype {img.dtype}")
        self.name = name
        if decode is not None:
            if decode not in DECODINGS:
                raise TextureError(f"texture {label}: decode must be one of {DECODINGS}, got {decode!r}")
            if srgb is not None and bool(srgb) != (decode == "srgb"):
                raise TextureError(f"texture {label}: srgb={srgb} contradicts decode={decode!r}; pass one")
        self.srgb = decode == "srgb" if decode is not None else bool(is_int) if srgb is None else bool(srgb)
        #: The texel decoding applied on load (one of :data:`DECODINGS`).
        self.decode = decode if decode is not None else ("srgb" if self.srgb else "linear")
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
        if isinstance(texcoord, bool) or not isinstance(texcoord, (int, np.integer)) or texcoord < 0:
            raise TextureError(f"texture {label}: texcoord must be an integer >= 0 (a UV set), got {texcoord!r}")
        self.texcoord = int(texcoord)
        if shared is not None:
            if channels is not None and shared.channels != channels:
                raise TextureError(f"texture {label}: has {shared.channels} channel(s), expected {channels}")
            self._image, self._pyramid, self._table = shared._image, shared._pyramid, shared._table
        else:
            self._image = prepare_image(img, label=label, srgb=self.srgb, channels=channels, select=select,
                                        decode=self.decode)
            # integer codes: decoded per tap through the table of their values (None: float texels)
            self._table = decode_table(self._image.dtype, self.decode) if self._image.dtype in CODE_TYPES else None
            self._pyramid = MipPyramid(self._image, self._table)
        self.channels = self._image.shape[2]

    def compiled_record(self):
        """:func:`pyrt.textures.compiled.image_record`: an RGB image read with the ``nearest``, ``bilinear`` or
        ``trilinear`` filter from any UV set; None otherwise."""
        return _compiled.image_record(self)

    @classmethod
    def from_dict(cls, params, base_dir=None):
        params = dict(params)
        path = params.pop("path", None)
        if path is None:
            raise TextureError(f"{cls.type_name} texture needs a 'path'")
        if base_dir is not None and not os.path.isabs(path):
            path = os.path.join(base_dir, path)
        return cls(path, **params)

    @classmethod
    def example(cls):
        """A 4 x 4 linear RGB ramp (trilinear, repeat)."""
        ramp = np.linspace(0.0, 1.0, 4 * 4 * 3).reshape(4, 4, 3)
        return cls(ramp, name="example")

    @property
    def image(self):
        """Level 0, linear values, (H, W, C) float32 (read-only; for coded texels a decoded copy per call)."""
        v = self._image.view() if self._table is None else self._table[self._image]
        v.flags.writeable = False
        return v

    @property
    def texels(self):
        """Level 0 as stored, (H, W, C) read-only: float32 linear values, or uint8 / uint16 codes whose
        values are :attr:`table` ``[code]`` (channel views for other textures copy a quarter of the bytes)."""
        v = self._image.view()
        v.flags.writeable = False
        return v

    @property
    def table(self):
        """The decoded value of every code of :attr:`texels` ((256,) or (65536,) float32), None for float texels."""
        return self._table

    @property
    def sampling_key(self):
        """What decides this texture's lookups: its texels and pyramid (with their decoding), its UV set, its
        sampler and UV transform. Textures with equal keys return the same values at the same hits. The pyramid
        itself is in the key (hashed by identity), not its ``id``: a memo keyed by it keeps it alive, so a texture
        freed while a batch's memo remains cannot hand its address, and its cached lookups, to a new one."""
        return (self._pyramid, self.texcoord, self.wrap, self.filter, self.scale, self.offset,
                self.rotation_deg, self.footprint_scale, self.max_anisotropy)

    def constant_channels(self):
        """(C,) float64: each channel's value where it is the same in every texel, NaN where it varies
        (:meth:`MipPyramid.constant_channels`: a lookup of such a channel is that value, whatever the filter)."""
        return self._pyramid.constant_channels()

    def build_mip_levels(self):
        """Build the whole MIP pyramid now if this texture's filter reads one (trilinear, EWA); see
        :meth:`MipPyramid.build_all`."""
        if self.filter not in _tex.RECONSTRUCT:
            self._pyramid.build_all()

    def mip_level(self, level):
        """MIP level ``level >= 1`` ((H_l, W_l, C) float32 linear values), built now if it is not yet, and kept."""
        return self._pyramid[level]

    @property
    def mip_levels_built(self):
        """MIP levels (> 0) built so far: each was read by at least one lookup, but for level 1 of coded texels
        (8/16-bit), kept once any coarser level was built (:class:`MipPyramid`)."""
        return self._pyramid.built

    def _transformed(self, uv, duvdx=None, duvdy=None):
        """Mesh UVs and footprints (None: zeros) as float64 (N, 2), through this texture's UV transform."""
        uv = np.asarray(uv, dtype=np.float64)
        n = len(uv)
        duvdx = np.zeros((n, 2)) if duvdx is None else np.asarray(duvdx, dtype=np.float64)
        duvdy = np.zeros((n, 2)) if duvdy is None else np.asarray(duvdy, dtype=np.float64)
        if self.scale != (1.0, 1.0) or self.offset != (0.0, 0.0) or self.rotation_deg != 0.0:  # identity: exact
            uv, duvdx, duvdy = _tex.transform_uv(uv, duvdx, duvdy, scale=self.scale, offset=self.offset,
                                                 rotation=np.deg2rad(self.rotation_deg))
        return uv, duvdx, duvdy

    def lookup(self, uv, duvdx=None, duvdy=None):
        """Filtered lookup at raw mesh UVs.

        Parameters
        ----------
        uv : (N, 2) float ndarray
            Mesh UVs (before this texture's UV transform).
        duvdx, duvdy : (N, 2) float ndarray, optional
            Footprints (UV change per pixel step); None = zeros (no filtering).

        Returns
        -------
        (N, channels) float64 ndarray
        """
        uv, duvdx, duvdy = self._transformed(uv, duvdx, duvdy)
        if self.filter in _tex.RECONSTRUCT:
            out = _tex.RECONSTRUCT[self.filter](self._image, uv, self.wrap, self._table)
        elif self.filter == "trilinear":
            out = _tex.lookup_trilinear(self._pyramid, uv, duvdx, duvdy, self.wrap, self.footprint_scale,
                                        self._table)
        else:
            out = _ewa.lookup_ewa(self._pyramid, uv, duvdx, duvdy, self.wrap, self.footprint_scale,
                                  self.max_anisotropy, self._table)
        return out.astype(np.float64)

    @property
    def needs_footprint(self):
        """True for the filters that read a footprint (trilinear, EWA); nearest, bilinear and bicubic lookups
        do not."""
        return self.filter not in _tex.RECONSTRUCT

    @property
    def plan_key(self):
        """What decides where (not what) a trilinear lookup reads: level 0's size, the UV set, the sampler and the
        UV transform. Textures with equal keys share one :func:`pyrt.shaders.textures.trilinear_plan` per batch."""
        return (self._image.shape[:2], len(self._pyramid), self.texcoord, self.wrap, self.scale, self.offset,
                self.rotation_deg, self.footprint_scale)

    def evaluate(self, ctx):
        """The filtered lookup at the hits of ``ctx``, each hit of a batch looked up once
        (:func:`pyrt.geometry.memo.row_memo`, keyed by :attr:`sampling_key`: the views of one batch of hits that
        a material's BSDF, light samples, glossy rays and preview lobes are evaluated on gather what another view
        already read). Trilinear lookups reuse the batch's plan for this texture's :attr:`plan_key` on the same
        rows (:func:`pyrt.geometry.memo.rows_cached`, whichever view asks): the MIP levels, taps and weights are
        computed once for all the same-sized maps a material reads at the same UVs (the same numbers as
        :meth:`lookup`)."""
        return row_memo(ctx, ("image", type(self), self.sampling_key), self._evaluate)

    def _evaluate(self, ctx):
        const = self.constant_channels()
        if not np.isnan(const).any():     # every texel the same: the lookup's value, without the lookup
            return np.repeat(const[None, :], ctx.n_hits, axis=0)
        if self.filter != "trilinear":
            return self.lookup(*texcoords(ctx, self.texcoord))
        plan = rows_cached(ctx, ("trilinear plan", self.plan_key), self._plan)
        return _tex.apply_trilinear_plan(self._pyramid, plan, self._table).astype(np.float64)

    def _plan(self, ctx):
        uv, duvdx, duvdy = self._transformed(*texcoords(ctx, self.texcoord))
        return _tex.trilinear_plan(self._image.shape, len(self._pyramid), uv, duvdx, duvdy, self.wrap,
                                   self.footprint_scale)


class ChannelTexture(Texture):
    """One channel of an :class:`ImageTexture`'s lookup, e.g. glTF's metallic (B), roughness (G), occlusion (R).

    No texels of its own: the source's lookup at a batch of hits is made once and kept on the batch
    (``ctx._texture_cache``, keyed by :attr:`ImageTexture.sampling_key`), so the channels of one image read with
    one sampler (the two or three of a packed occlusion-roughness-metallic map) cost one lookup, and the same
    values as a 1-channel copy of the channel would give (every filter works channel by channel).

    Parameters
    ----------
    source : ImageTexture
    channel : int
        ``0 <= channel < source.channels``.
    name : str, optional
        Label for messages.
    """

    channels = 1

    def __init__(self, source, channel, *, name=None):
        if not isinstance(source, ImageTexture):
            raise TextureError(f"ChannelTexture({name or ''}): source must be an ImageTexture, got {type(source).__name__}")
        if not 0 <= int(channel) < source.channels:
            raise TextureError(f"texture {name or source.name or source.path}: channel {channel} but the image has "
                               f"{source.channels} channel(s)")
        self.source, self.channel = source, int(channel)
        self.name = name
        self.texcoord = source.texcoord          # the UV set its source reads

    @classmethod
    def example(cls):
        """The G channel of :meth:`ImageTexture.example`."""
        return cls(ImageTexture.example(), 1, name="example")

    @property
    def needs_footprint(self):
        """The source's (:attr:`Texture.needs_footprint`)."""
        return self.source.needs_footprint

    @property
    def image(self):
        """The channel's level 0, linear values, (H, W, 1) float32 (read-only)."""
        return self.source.image[:, :, self.channel:self.channel + 1]

    def compiled_scalar(self):
        """The source's channel (:meth:`Texture.compiled_scalar`)."""
        return self.source, self.channel, 1.0

    def lookup(self, uv, duvdx=None, duvdy=None):
        """The source's :meth:`ImageTexture.lookup`, this channel: (N, 1) float64."""
        return self.source.lookup(uv, duvdx, duvdy)[:, self.channel:self.channel + 1]

    def evaluate(self, ctx):
        const = self.source.constant_channels()[self.channel]
        if not np.isnan(const):           # the channel is the same in every texel: no lookup
            return np.full((ctx.n_hits, 1), const)
        cache = ctx.__dict__.setdefault("_texture_cache", {})
        key = self.source.sampling_key
        values = cache.get(key)
        if values is None:
            values = cache[key] = self.source.evaluate(ctx)
        return values[:, self.channel:self.channel + 1]

