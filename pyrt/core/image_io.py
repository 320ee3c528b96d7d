"""Image output: EXR (linear, float32 or half, optional AOVs) and PNG (tone-mapped, sRGB-encoded).

Every file is written through :func:`atomic_write`: to a temporary file in the target's folder, renamed
over the target only when complete, so an interrupted or failed write leaves the previous file intact.
"""
from __future__ import annotations

import os
import secrets
import warnings

import numpy as np
import OpenEXR

from pyrt.shaders import color
from pyrt.shaders import tonemap


def atomic_write(path, write):
    """Create or replace the file ``path`` all at once: ``write(tmp)`` writes a temporary file, renamed over it.

    Parameters
    ----------
    path : str or os.PathLike
        The target. Its folder must exist.
    write : callable
        ``write(tmp_path)`` writes the whole file at ``tmp_path`` (a new, empty file named
        ``.NAME.XXXXXXXX.tmp`` in the target's folder, so the rename never crosses file systems).

    The temporary file is flushed to disk and ``os.replace``-d over ``path`` (atomic on POSIX and
    Windows). If ``write`` raises -- any exception, ``KeyboardInterrupt`` included -- the temporary file
    is removed, the previous ``path`` (if any) is left as it was, and the exception propagates. The new
    file gets the permissions of the file it replaces, or the usual ones (``0o666`` minus the umask).
    """
    path = os.fspath(path)
    folder, base = os.path.split(os.path.abspath(path))
    try:
        mode = os.stat(path).st_mode & 0o7777
    except OSError:
        mode = 0o666
    tmp = os.path.join(folder, f".{base}.{secrets.token_hex(4)}.tmp")
    os.close(os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, mode))
    try:
        write(tmp)
        fd = os.open(tmp, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)
        os.replace(tmp, path)
    except BaseException:
        try:
            os.remove(tmp)
        except OSError:
            pass
        raise


def write_bytes(path, data):
    """Write ``data`` (bytes, or str as UTF-8) to ``path`` through :func:`atomic_write`."""
    blob = data.encode("utf-8") if isinstance(data, str) else bytes(data)

    def put(tmp):
        with open(tmp, "wb") as fh:
            fh.write(blob)

    atomic_write(path, put)


def _check_image(img, name="image"):
    a = np.asarray(img)
    if a.ndim != 3 or a.shape[2] != 3:
        raise ValueError(f"{name} must have shape (H, W, 3), got {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name} contains NaN or Inf values")
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
    FileNotFoundError
        No such file.
    OSError
        OpenEXR cannot read the file.
    ValueError
        The file has none of the channels ``layout`` asks for.
    """
    if layout not in ("rgb", "stored"):
        raise ValueError(f"read_exr: layout must be 'rgb' or 'stored', got {layout!r}")
    if not os.path.exists(path):
        raise FileNotFoundError(f"EXR file not found: {path}")
    try:
        with OpenEXR.File(str(path), separate_channels=True) as f:
            chans = f.channels()
            if layout == "stored":
                names = _exr_stored_channels(chans)
                if names is None:
                    raise ValueError(f"{path}: EXR channels {sorted(chans)} are not RGB(A), Y or a single channel")
                if len(names) == 1:
                    return _exr_float32(chans[names[0]].pixels)
                return np.stack([_exr_float32(chans[c].pixels) for c in names], axis=-1)
            if all(c in chans for c in "RGB"):
                return np.stack([_exr_float32(chans[c].pixels) for c in "RGB"], axis=-1)
            if "Y" in chans:
                y = _exr_float32(chans["Y"].pixels)
                return np.repeat(y[..., None], 3, axis=-1)
            raise ValueError(f"{path}: no R, G, B (or Y) channels; found {sorted(chans)}")
    except (OSError, RuntimeError) as e:
        raise OSError(f"cannot read EXR file {path}: {e}") from e


def read_image(path):
    """Read an image file in its stored encoding (no colour decoding, no scaling).

    Parameters
    ----------
    path : str or os.PathLike
        EXR (:func:`read_exr` with ``layout="stored"``); PNG, JPEG, TIFF, ... through ``skimage.io``, except
        16-bit colour PNGs, which Pillow (behind ``skimage.io``) truncates to 8 bits: those are read exactly
        with pypng (pure Python, ~1 s per megapixel).

    Returns
    -------
    (H, W) or (H, W, C) ndarray
        float32 for EXR; the decoder's dtype otherwise (uint8, uint16, bool or float).

    Raises
    ------
    Exception
        Whatever the decoder raises for a missing or unreadable file (callers name the file).
    """
    path = os.fspath(path)
    ext = os.path.splitext(path)[1].lower()
    if ext == ".exr":
        return read_exr(path, layout="stored")
    if ext == ".png" and _png_is_16bit_colour(path):
        return _read_png16(path)
    from skimage import io as skio

    with warnings.catch_warnings():  # imageio's plugin probing warns on undecodable files
        warnings.simplefilter("ignore", DeprecationWarning)
        return np.asarray(skio.imread(path))


def _png_is_16bit_colour(path):
    """True for a 16-bit PNG with colour or alpha (IHDR bit depth 16, colour type 2, 4 or 6); 16-bit grey is fine."""
    with open(path, "rb") as f:
        head = f.read(26)
    return len(head) == 26 and head[:8] == b"\x89PNG\r\n\x1a\n" and head[24] == 16 and head[25] in (2, 4, 6)


def _read_png16(path):
    """A 16-bit colour PNG as (H, W, C) uint16, exactly, with pypng."""
    import png

    width, height, rows, info = png.Reader(filename=path).asDirect()
    planes = info["planes"]
    img = np.vstack([np.asarray(row, dtype=np.uint16) for row in rows])
    return img.reshape(height, width, planes)


def tonemap_to_display(image, *, tonemap_op="reinhard", exposure=0.0, L_white=None):
    """Linear radiance -> display-linear [0, 1] with the named operator (linear, film, reinhard)."""
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


def encode_png(pixels):
    """Encode display-ready pixels as PNG file bytes; the one PNG encoder (files and in-memory previews).

    Parameters
    ----------
    pixels : (H, W, 3) uint8 or uint16 ndarray
        sRGB-encoded (or any display-ready) values, row 0 at the top. uint8 is written as an 8-bit
        PNG (Pillow, default settings: deterministic for a given array), uint16 as a 16-bit PNG
        (pypng; Pillow has no 16-bit RGB mode).

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

        Image.fromarray(np.ascontiguousarray(a)).save(buf, format="PNG")
    elif a.dtype == np.uint16:
        import png

        h, w, _ = a.shape
        png.Writer(w, h, greyscale=False, bitdepth=16).write(buf, a.reshape(h, w * 3))
    else:
        raise ValueError(f"pixels must be uint8 or uint16, got {a.dtype}")
    return buf.getvalue()


def write_png(path, image, *, tonemap="reinhard", exposure=0.0, L_white=None, bits=8):
    """Tone-map (exposure in stops, then ``tonemap``), sRGB-encode and write an 8- or 16-bit PNG atomically.

    Parameters
    ----------
    path : str or os.PathLike
        Output file (its folder is created).
    image : (H, W, 3) float ndarray
        Linear radiance.
    tonemap : {"linear", "film", "reinhard"}
    exposure : float
        Stops applied before the operator.
    L_white : float, optional
        The extended Reinhard white point (``tonemap="reinhard"`` only).
    bits : {8, 16}
        Bits per channel (quantised with rounding; encoded by :func:`encode_png`).
    """
    disp = tonemap_to_display(image, tonemap_op=tonemap, exposure=exposure, L_white=L_white)
    enc = color.srgb_encode(disp)
    if bits == 8:
        out = np.round(enc * 255).astype(np.uint8)
    elif bits == 16:
        out = np.round(enc * 65535).astype(np.uint16)
    else:
        raise ValueError(f"bits must be 8 or 16, got {bits}")
    data = encode_png(out)
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    write_bytes(path, data)
