"""Image output: EXR (linear, float32 or half, optional AOVs) and PNG (tone-mapped, sRGB-encoded).

Every file is written through :func:`pyrt.core.atomic.atomic_write`: to a temporary file in the target's folder,
renamed over the target only when complete, so an interrupted or failed write leaves the previous file intact.
"""
from __future__ import annotations

import mmap
import os
import struct
import warnings

import numpy as np

from pyrt.shaders import color
from pyrt.shaders import tonemap

from pyrt.core.errors import Error
from pyrt.core.image_modes import CONVERTED_MODES as _CONVERTED_MODES, converted as _converted, still_array, still_frame
from pyrt.core.image_types import EXR_MAGIC as _EXR_MAGIC, HDR_MAGIC as _HDR_MAGIC, PNG_MAGIC as _PNG_MAGIC
from pyrt.core.image_types import image_kind
from pyrt.core.atomic import ImageWriteError, atomic_write, write_bytes  # noqa: F401 (public here too)


def _check_image(img, name="image"):
    a = np.asarray(img)
    if a.ndim != 3 or a.shape[2] != 3:
        raise ImageWriteError(f"{name} must have shape (H, W, 3), got {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ImageWriteError(f"{name} contains {int((~np.isfinite(a)).sum())} NaN or Inf values; nothing written")
    return a


def write_exr(path, image, *, aovs=None, half=False):
    """Write linear radiance ``image`` (H, W, 3) to an OpenEXR file.

    Channels R, G, B (float32, or half with ``half=True``). ``aovs`` may hold ``depth`` (H, W) -> Z,
    ``normal`` (H, W, 3) -> N.X/N.Y/N.Z, ``albedo`` (H, W, 3) -> albedo.R/G/B; infinite depth (a miss)
    is written as the largest float32. The folder is created; the file is replaced atomically
    (:func:`atomic_write`).
    """
    img = _check_image(image)
    dt = np.float16 if half else np.float32
    ch = {"R": img[..., 0].astype(dt), "G": img[..., 1].astype(dt), "B": img[..., 2].astype(dt)}
    if aovs:
        if "depth" in aovs:
            z = np.asarray(aovs["depth"], dtype=np.float32)
            ch["Z"] = np.where(np.isfinite(z), z, np.finfo(np.float32).max).astype(np.float32)
        for key, prefix, names in (("normal", "N", "XYZ"), ("albedo", "albedo", "RGB")):
            if key in aovs:
                a = np.asarray(aovs[key], dtype=np.float32)
                for i, c in enumerate(names):
                    ch[f"{prefix}.{c}"] = a[..., i].astype(dt)
    ch = {k: np.ascontiguousarray(v) for k, v in ch.items()}
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    import OpenEXR      # here, not at the top: a PNG preview never pays its import (~5 ms with Imath)

    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}

    def put(tmp):
        with OpenEXR.File(header, ch) as f:
            f.write(tmp)

    atomic_write(path, put)


def _exr_float32(pixels):
    """One EXR channel as float32: half and float exactly; UINT through float64 (exact), rounded once."""
    a = np.asarray(pixels)
    if not np.issubdtype(a.dtype, np.floating):
        a = a.astype(np.float64)
    return a.astype(np.float32)


def _exr_stored_channels(chans):
    """Names of the colour channels of an EXR file as stored, or None: R, G, B[, A], Y, or the one channel.

    A file whose channels all sit in one layer (``diffuse.R``, ``diffuse.G``, ``diffuse.B``[, ``.A``]) counts as
    that layer's RGB(A).
    """
    layers = {k.rpartition(".")[0] for k in chans}
    prefix = layers.pop() + "." if len(layers) == 1 and "" not in layers else ""
    rgba = [prefix + c for c in "RGBA"]
    if all(c in chans for c in rgba):
        return rgba
    if all(c in chans for c in rgba[:3]) and (not prefix or len(chans) == 3):
        return rgba[:3]
    if "Y" in chans:
        return ["Y"]
    if len(chans) == 1:
        return list(chans)
    return None


# ----------------------------------------------------------------------------- reading (hostile files refused)

MAX_IMAGE_PIXELS = 1 << 27
"""The largest image :func:`read_image` and :func:`read_exr` decode: 2^27 = 134,217,728 pixels (16384 x 8192, the
largest lat-long environment maps in use). Checked from the header before any pixel memory is allocated: a bigger
file (or a decompression bomb claiming 100000 x 100000) is an :class:`ImageFileError`. Pillow's own bomb limit is
178,956,970 pixels, so Pillow never sees a larger image."""

# EXR scanlines per chunk by compression (OpenEXR's ImfCompression.h: NONE, RLE, ZIPS, ZIP, PIZ, PXR24, B44, B44A,
# DWAA, DWAB)
_EXR_LINES_PER_CHUNK = {0: 1, 1: 1, 2: 1, 3: 16, 4: 32, 5: 16, 6: 32, 7: 32, 8: 32, 9: 256}


class ImageFileError(Error, OSError):
    """An image file is missing, corrupt, truncated, of an unknown type or too large; the message names the file."""


class ImageNotFoundError(ImageFileError, FileNotFoundError):
    """The image file does not exist (also a :class:`FileNotFoundError`)."""


def _check_pixel_count(path, kind, width, height, channels=1):
    if width < 1 or height < 1:
        raise ImageFileError(f"{path}: {kind} header says {width} x {height} pixels (empty image)")
    if width * height > MAX_IMAGE_PIXELS or width * height * channels > 4 * MAX_IMAGE_PIXELS:
        raise ImageFileError(f"{path}: {kind} header says {width} x {height} pixels"
                             f"{f' x {channels} channels' if channels > 4 else ''}; the limit is "
                             f"{MAX_IMAGE_PIXELS} pixels (pyrt.core.image_io.MAX_IMAGE_PIXELS) — refused before "
                             "decoding (corrupt header or decompression bomb?)")


def _exr_header(path, data):
    """Parse the header of a single-part EXR file (``data``: its bytes) far enough to refuse it safely.

    Returns (width, height, channel count). Raises :class:`ImageFileError` for a truncated or malformed header,
    an absurd size, or (scanline files) a line-offset table pointing past the end of the file.
    """
    size = len(data)
    if size < 8:
        raise ImageFileError(f"{path}: not a readable EXR file (truncated at byte {size}: no header)")
    flags = struct.unpack_from("<I", data, 4)[0]
    off, attrs = 8, {}
    while True:
        if off >= size:
            raise ImageFileError(f"{path}: not a readable EXR file (truncated at byte {size}, inside the header)")
        if data[off] == 0:
            off += 1
            break
        name_end = data.find(b"\0", off, off + 256)
        type_end = data.find(b"\0", name_end + 1, name_end + 257) if name_end >= 0 else -1
        if name_end < 0 or type_end < 0 or type_end + 5 > size:
            raise ImageFileError(f"{path}: not a readable EXR file (malformed or truncated header at byte {off})")
        name = data[off:name_end].decode("latin-1")
        n = struct.unpack_from("<i", data, type_end + 1)[0]
        start = type_end + 5
        if n < 0 or start + n > size:
            raise ImageFileError(f"{path}: not a readable EXR file (truncated at byte {size}: header attribute "
                                 f"{name!r} at byte {off} claims {n} bytes)" if n >= 0 else
                                 f"{path}: not a readable EXR file (header attribute {name!r} has size {n})")
        attrs[name] = data[start:start + n]
        off = start + n
    if "dataWindow" not in attrs or len(attrs["dataWindow"]) != 16 or "channels" not in attrs:
        raise ImageFileError(f"{path}: not a readable EXR file (the header has no dataWindow or channels)")
    x0, y0, x1, y1 = struct.unpack("<4i", attrs["dataWindow"])
    width, height = x1 - x0 + 1, y1 - y0 + 1
    nchan, ch, o = 0, attrs["channels"], 0
    while o < len(ch) and ch[o] != 0:   # chlist: (name\0, 16 bytes of type and sampling)*, \0
        o = ch.find(b"\0", o) + 17
        nchan += 1
        if o <= 16:
            raise ImageFileError(f"{path}: not a readable EXR file (malformed channel list)")
    _check_pixel_count(path, "EXR", width, height, nchan)
    tiled, multipart = bool(flags & 0x200), bool(flags & 0x1000)
    comp = attrs.get("compression", b"\0")[0]
    if not tiled and not multipart and comp in _EXR_LINES_PER_CHUNK:
        nchunks = -(-height // _EXR_LINES_PER_CHUNK[comp])
        if off + 8 * nchunks > size:
            raise ImageFileError(f"{path}: not a readable EXR file (truncated at byte {size}: the line-offset table "
                                 f"needs {off + 8 * nchunks} bytes)")
        last = int(np.frombuffer(data, dtype="<u8", count=nchunks, offset=off).max())
        end = last + 8 + (struct.unpack_from("<i", data, last + 4)[0] if last + 8 <= size else 0)
        if end > size:
            raise ImageFileError(f"{path}: not a readable EXR file (truncated at byte {size}: the pixel data "
                                 f"runs to at least byte {end})")
    return width, height, nchan


def _png_header(path, data):
    """Check a PNG's structure without decoding it: IHDR size against the limit, every chunk inside the file,
    an IEND at the end. Returns (width, height, bit depth, colour type)."""
    size = len(data)
    if size < 33 or data[12:16] != b"IHDR":
        raise ImageFileError(f"{path}: not a readable PNG file (truncated at byte {size}: no complete IHDR header)"
                             if size < 33 else f"{path}: not a readable PNG file (the first chunk is not IHDR)")
    width, height, depth, ctype = struct.unpack_from(">IIBB", data, 16)
    if ctype not in _PNG_CHANNELS:
        raise ImageFileError(f"{path}: not a readable PNG file (IHDR colour type {ctype} does not exist)")
    _check_pixel_count(path, "PNG", width, height, _PNG_CHANNELS[ctype])
    off = 8
    while True:
        if off + 8 > size:
            raise ImageFileError(f"{path}: not a readable PNG file (truncated at byte {size}: no IEND chunk)")
        n, ctag = struct.unpack_from(">I4s", data, off)
        if off + 12 + n > size:
            raise ImageFileError(f"{path}: not a readable PNG file (truncated at byte {size}: chunk "
                                 f"{ctag.decode('latin-1')!r} at byte {off} claims {n} bytes)")
        off += 12 + n
        if ctag == b"IEND":
            return width, height, depth, ctype


_PNG_CHANNELS = {0: 1, 2: 3, 3: 3, 4: 2, 6: 4}


def _file_bytes(path, kind):
    """The file's bytes as a read-only memory map (b"" for an empty file); a missing file is ImageNotFoundError."""
    if not os.path.isfile(path):
        raise ImageNotFoundError(f"{kind} file not found: {path}")
    with open(path, "rb") as fh:
        if os.fstat(fh.fileno()).st_size == 0:
            return b""
        return mmap.mmap(fh.fileno(), 0, access=mmap.ACCESS_READ)


def read_exr(path, *, layout="rgb"):
    """Read an OpenEXR file as float32. Errors name the file.

    Parameters
    ----------
    path : str or os.PathLike
        The file.
    layout : {"rgb", "stored"}
        ``"rgb"`` (default): RGB, a luminance-only (``Y``) file repeated to grey. ``"stored"``: the colour
        channels as stored (image textures): R, G, B and A if all four exist, else R, G, B, else ``Y``, else
        the file's only channel whatever its name; a file whose channels all sit in one layer
        (``diffuse.R`` ...) counts as that layer's RGB(A).

    Returns
    -------
    (H, W, 3) float32 ndarray, or with ``layout="stored"`` (H, W, 4), (H, W, 3) or (H, W) float32 ndarray
        Half and float channels exactly; UINT channels rounded to float32.

    Raises
    ------
    ImageNotFoundError
        No such file (also a ``FileNotFoundError``).
    ImageFileError
        Not an EXR file, a truncated or corrupt one, one larger than :data:`MAX_IMAGE_PIXELS` (refused from
        the header, before the pixels are read), or one without the channels ``layout`` asks for.
    """
    if layout not in ("rgb", "stored"):
        raise ValueError(f"read_exr: layout must be 'rgb' or 'stored', got {layout!r}")
    path = os.fspath(path)
    data = _file_bytes(path, "EXR")
    try:
        if data[:4] != _EXR_MAGIC:
            raise ImageFileError(f"{path}: not an EXR file (the first bytes are {bytes(data[:8])!r}, expected "
                                 f"{_EXR_MAGIC!r})" if len(data) else f"{path}: not an EXR file (the file is empty)")
        _exr_header(path, data)
        size = len(data)
    finally:
        if isinstance(data, mmap.mmap):
            data.close()
    import OpenEXR      # (as in write_exr: only where an EXR is read)

    try:
        with OpenEXR.File(str(path), separate_channels=True) as f:
            chans = {name: ch.pixels for name, ch in f.channels().items()}  # the File clears its dict on exit
    except (OSError, RuntimeError, ValueError) as e:
        raise ImageFileError(f"{path}: not a readable EXR file (corrupt or truncated; the file has {size} bytes): "
                             f"OpenEXR: {e}") from None
    if layout == "stored":
        names = _exr_stored_channels(chans)
        if names is None:
            raise ImageFileError(f"{path}: EXR channels {sorted(chans)} are not RGB(A), Y or a single channel")
        if len(names) == 1:
            return _exr_float32(chans[names[0]])
        return np.stack([_exr_float32(chans[c]) for c in names], axis=-1)
    if all(c in chans for c in "RGB"):
        return np.stack([_exr_float32(chans[c]) for c in "RGB"], axis=-1)
    if "Y" in chans:
        y = _exr_float32(chans["Y"])
        return np.repeat(y[..., None], 3, axis=-1)
    raise ImageFileError(f"{path}: no R, G, B (or Y) channels; found {sorted(chans)}")


HDR_EXTRA = "pip install 'pyrt-embree[hdr]' (OpenCV: opencv-python-headless)"


def _hdr_header(path, data):
    """Check a Radiance header (magic, ``FORMAT=32-bit_rle_rgbe``, ``-Y H +X W``) before OpenCV sees the file."""
    end = data.find(b"\n\n", 0, 1 << 16)
    line_end = data.find(b"\n", end + 2, end + 2 + 256) if end >= 0 else -1
    if line_end < 0:
        raise ImageFileError(f"{path}: not a readable Radiance .hdr file (no end of header or no resolution line)")
    head = bytes(data[:end]).decode("latin-1").splitlines()
    fmt = next((h[7:].strip() for h in head if h.startswith("FORMAT=")), None)
    if fmt != "32-bit_rle_rgbe":
        raise ImageFileError(f"{path}: Radiance .hdr FORMAT is {fmt!r}; only '32-bit_rle_rgbe' is read (XYZE, or a "
                             "file without a FORMAT line, is refused by OpenCV's reader): convert it to OpenEXR")
    res = bytes(data[end + 2:line_end]).decode("latin-1").split()
    if len(res) != 4 or res[0] != "-Y" or res[2] != "+X" or not (res[1].isdigit() and res[3].isdigit()):
        raise ImageFileError(f"{path}: Radiance .hdr resolution line {' '.join(res)!r}: only the standard "
                             "orientation '-Y H +X W' (rows top to bottom) is read")
    _check_pixel_count(path, "Radiance .hdr", int(res[3]), int(res[1]), 3)


def read_hdr(path):
    """Read a Radiance RGBE (``.hdr``) image as linear RGB float32, with OpenCV (the optional ``[hdr]`` extra).

    OpenCV (``cv2.imread(path, IMREAD_ANYDEPTH | IMREAD_COLOR)``, Greg Ward's reference decoder) turns a pixel
    (m_r, m_g, m_b, e) into ``m / 256 * 2^(e - 128)`` per channel (no half-step offset; e = 0 is black) and returns
    BGR, which is flipped to RGB here. Flat and run-length-encoded scanlines are read; header lines such as
    ``EXPOSURE=`` are ignored (values as stored, as OpenCV and stb_image read them).

    Raises
    ------
    ImageNotFoundError
        No such file.
    ImageFileError
        OpenCV is not installed (the message names the file and the extra), not a Radiance file, an XYZE or
        other-orientation file, one larger than :data:`MAX_IMAGE_PIXELS`, or data OpenCV cannot decode.
    """
    path = os.fspath(path)
    data = _file_bytes(path, "Radiance .hdr")
    try:
        if not any(data[:len(m)] == m for m in _HDR_MAGIC):
            raise ImageFileError(f"{path}: not a Radiance .hdr file (the first bytes are {bytes(data[:10])!r}, "
                                 "expected '#?RADIANCE' or '#?RGBE')")
        _hdr_header(path, data)
    finally:
        if isinstance(data, mmap.mmap):
            data.close()
    try:
        import cv2
    except ImportError:
        raise ImageFileError(f"{path}: reading Radiance .hdr files needs OpenCV: {HDR_EXTRA}") from None
    level = cv2.utils.logging.getLogLevel()
    cv2.utils.logging.setLogLevel(cv2.utils.logging.LOG_LEVEL_SILENT)   # the failure is reported below, once
    try:
        img = cv2.imread(path, cv2.IMREAD_ANYDEPTH | cv2.IMREAD_COLOR)
    finally:
        cv2.utils.logging.setLogLevel(level)
    if img is None or img.ndim != 3 or img.shape[2] != 3:
        raise ImageFileError(f"{path}: not a readable Radiance .hdr file (OpenCV could not decode the pixel data: "
                             "truncated or corrupt scanlines?)")
    return np.ascontiguousarray(img[..., ::-1], dtype=np.float32)


def read_image(path):
    """Read an image file in its stored encoding (no colour decoding, no scaling).

    The type is taken from the file's first bytes, not its name. The structure is checked before anything is
    decoded: a PNG's chunks must lie inside the file, an EXR's header and line-offset table must be complete,
    and no image may claim more than :data:`MAX_IMAGE_PIXELS` pixels.

    Parameters
    ----------
    path : str or os.PathLike
        EXR (:func:`read_exr` with ``layout="stored"``), Radiance ``.hdr`` (:func:`read_hdr`, needs OpenCV); PNG,
        JPEG, TIFF, BMP, GIF, WebP and AVIF (Pillow's own codecs; AVIF decoded to 8 bits) through ``skimage.io``,
        except 16-bit colour PNGs, which Pillow (behind ``skimage.io``)
        truncates to 8 bits: those are read exactly with pypng (pure Python, ~1 s per megapixel).

    Returns
    -------
    (H, W) or (H, W, C) ndarray
        float32 for EXR and .hdr; the decoder's dtype otherwise (uint8, uint16, bool or float).

    Raises
    ------
    ImageNotFoundError
        No such file.
    ImageFileError
        An unknown file type, a truncated or corrupt file, or one too large; the message names the file and
        the part (``"wood.png: not a readable PNG file (truncated at byte 1234: chunk 'IDAT' at byte 57 claims
        8192 bytes)"``).
    """
    path = os.fspath(path)
    data = _file_bytes(path, "image")
    try:
        size = len(data)
        if data[:4] == _EXR_MAGIC:
            kind = "EXR"
        elif any(data[:len(m)] == m for m in _HDR_MAGIC):
            kind = "HDR"
        elif data[:8] == _PNG_MAGIC:
            kind = "PNG"
            png16 = _png_header(path, data)[2:] in ((16, 2), (16, 4), (16, 6))
        else:
            kind = image_kind(bytes(data[:16]))
            if kind is None:
                raise ImageFileError(f"{path}: not a readable image (the file is empty)" if not size else
                                     f"{path}: not a readable image: the first bytes {bytes(data[:8])!r} are not "
                                     "those of a PNG, JPEG, TIFF, BMP, GIF, WebP, AVIF, OpenEXR or Radiance .hdr "
                                     "file")
    finally:
        if isinstance(data, mmap.mmap):
            data.close()
    if kind == "EXR":
        return read_exr(path, layout="stored")
    if kind == "HDR":
        return read_hdr(path)
    try:
        if kind == "PNG" and png16:
            return _read_png16(path)
        from PIL import Image

        with warnings.catch_warnings():  # imageio's plugin probing warns on undecodable files; the size is checked
            warnings.simplefilter("ignore", DeprecationWarning)
            warnings.simplefilter("ignore", Image.DecompressionBombWarning)
            with Image.open(path) as im:
                if kind != "PNG":
                    _check_pixel_count(path, kind, *im.size)
                if im.mode in _CONVERTED_MODES:
                    return _converted(im)
                if still_frame(im):
                    return still_array(im)
            from skimage import io as skio     # ~0.3 s to import (scipy): animated and other files only

            return np.asarray(skio.imread(path))
    except ImageFileError:
        raise
    except Exception as exc:  # any decoder failure (Pillow, imageio, pypng raise many types): name the file
        msg = str(exc).split("\n")[0]  # imageio appends "pip install imageio[pyav]" hints on further lines
        raise ImageFileError(f"{path}: not a readable {kind} file (corrupt or truncated image data; the file has "
                             f"{size} bytes): {type(exc).__name__}: {msg}") from None


def _read_png16(path):
    """A 16-bit colour PNG as (H, W, C) uint16, exactly, with pypng."""
    import png

    width, height, rows, info = png.Reader(filename=path).asDirect()
    planes = info["planes"]
    img = np.vstack([np.asarray(row, dtype=np.uint16) for row in rows])
    return img.reshape(height, width, planes)


#: Names of the tone-mapping operators (:data:`pyrt.shaders.tonemap.OPERATORS`), for command-line choices.
TONEMAPS = tuple(tonemap.OPERATORS)


def tonemap_to_display(image, *, tonemap_op="reinhard", exposure=0.0, L_white=None):
    """Linear radiance -> display-linear [0, 1] with the named operator (one of :data:`TONEMAPS`).

    ``reinhard`` maps luminance (hue kept), ``reinhard_rgb`` maps each channel ``L / (1 + L)``,
    ``pbr_neutral`` is Khronos PBR Neutral (the glTF Sample Viewer's default), ``aces`` Filament's ACES
    (see :mod:`pyrt.shaders.tonemap`).
    """
    img = _check_image(image)
    try:
        op = tonemap.OPERATORS[tonemap_op]
    except KeyError:
        raise ValueError(f"unknown tone-mapping operator {tonemap_op!r}; choose one of {sorted(tonemap.OPERATORS)}") \
            from None
    if tonemap_op == "reinhard":
        return op(img.astype(np.float64), exposure=exposure, L_white=L_white)
    if L_white is not None:
        raise ValueError(f"L_white applies to the reinhard operator only, not {tonemap_op!r}")
    return op(img.astype(np.float64), exposure=exposure)


#: zlib level of the 8-bit PNGs :func:`encode_png` writes: 1 rather than Pillow's default 6, ~2.8x faster on rendered
#: images for files ~2 % larger (a 640x480 helmet preview: 13.1 against 36.5 ms of CPU, 250 against 246 kB)
PNG_COMPRESS_LEVEL = 1


def encode_png(pixels):
    """Encode display-ready pixels as PNG file bytes; the one PNG encoder (files and in-memory previews).

    Parameters
    ----------
    pixels : (H, W, 3) uint8 or uint16 ndarray
        sRGB-encoded (or any display-ready) values, row 0 at the top. uint8 is written as an 8-bit
        PNG (Pillow at zlib level :data:`PNG_COMPRESS_LEVEL`: deterministic for a given array), uint16 as a
        16-bit PNG (pypng; Pillow has no 16-bit RGB mode).

    Returns
    -------
    bytes
        The PNG file.
    """
    a = np.asarray(pixels)
    if a.ndim != 3 or a.shape[2] != 3:
        raise ValueError(f"pixels must have shape (H, W, 3), got {a.shape}")
    import io

    buf = io.BytesIO()
    if a.dtype == np.uint8:
        from PIL import Image

        Image.fromarray(np.ascontiguousarray(a)).save(buf, format="PNG", compress_level=PNG_COMPRESS_LEVEL)
    elif a.dtype == np.uint16:
        import png

        h, w, _ = a.shape
        png.Writer(w, h, greyscale=False, bitdepth=16).write(buf, a.reshape(h, w * 3))
    else:
        raise ValueError(f"pixels must be uint8 or uint16, got {a.dtype}")
    return buf.getvalue()


def write_png(path, image, *, tonemap="reinhard", exposure=0.0, L_white=None, bits=8, encoding="srgb",
              gamma=2.2):
    """Tone-map (exposure in stops, then ``tonemap``), encode and write an 8- or 16-bit PNG atomically.

    Parameters
    ----------
    path : str or os.PathLike
        Output file (its folder is created).
    image : (H, W, 3) float ndarray
        Linear radiance.
    tonemap : {"linear", "film", "reinhard", "reinhard_rgb", "pbr_neutral", "aces"}
        ``reinhard`` on luminance, ``reinhard_rgb`` per channel ``L / (1 + L)``, ``pbr_neutral`` Khronos
        PBR Neutral, ``aces`` Filament's ACES (:mod:`pyrt.shaders.tonemap`).
    exposure : float
        Stops applied before the operator.
    L_white : float, optional
        The extended Reinhard white point (``tonemap="reinhard"`` only).
    bits : {8, 16}
        Bits per channel (quantised with rounding; encoded by :func:`encode_png`).
    encoding : {"srgb", "gamma"}
        Display transfer curve: the exact piecewise sRGB curve (IEC 61966-2-1, default) or the plain
        power law ``x ** (1 / gamma)`` of the course notes.
    gamma : float
        Exponent of ``encoding="gamma"`` (> 0; default 2.2).
    """
    if encoding == "srgb":
        encode = color.srgb_encode
    elif encoding == "gamma":
        if not (np.isfinite(gamma) and gamma > 0):
            raise ValueError(f"gamma must be a finite number > 0, got {gamma!r}")
        encode = lambda x: color.gamma_encode(x, gamma)  # noqa: E731
    else:
        raise ValueError(f"unknown encoding {encoding!r}; choose one of {sorted(color.ENCODINGS)}")
    data = png_bytes(image, tonemap=tonemap, exposure=exposure, L_white=L_white, bits=bits, encode=encode)
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    write_bytes(path, data)


def png_bytes(image, *, tonemap="reinhard", exposure=0.0, L_white=None, bits=8, encode=color.srgb_encode):
    """The PNG file bytes :func:`write_png` writes for ``image`` (linear radiance, (H, W, 3)): exposure, tone map,
    ``encode`` (display-linear -> code values in [0, 1], default the exact sRGB curve), quantisation to ``bits``.
    What notebooks show (:class:`pyrt.render.result.RenderResult`, :func:`pyrt.core.display.show`)."""
    disp = tonemap_to_display(image, tonemap_op=tonemap, exposure=exposure, L_white=L_white)
    enc = encode(disp)
    if bits == 8:
        out = np.round(enc * 255).astype(np.uint8)
    elif bits == 16:
        out = np.round(enc * 65535).astype(np.uint16)
    else:
        raise ValueError(f"bits must be 8 or 16, got {bits}")
    return encode_png(out)
