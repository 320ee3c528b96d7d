"""Image output: EXR (linear, float32 or half, optional AOVs) and PNG (tone-mapped, sRGB-encoded)."""
from __future__ import annotations

import os

import numpy as np
import OpenEXR

from pyrt.shaders import color
from pyrt.shaders import tonemap


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
    is written as the largest float32.
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
    with OpenEXR.File(header, ch) as f:
        f.write(str(path))


def read_exr(path):
    """Read an EXR file; returns ``(H, W, 3) float32`` RGB (plus nothing else). Errors name the file."""
    if not os.path.exists(path):
        raise FileNotFoundError(f"EXR file not found: {path}")
    try:
        with OpenEXR.File(str(path), separate_channels=True) as f:
            chans = f.channels()
            if all(c in chans for c in "RGB"):
                return np.stack([np.asarray(chans[c].pixels, dtype=np.float32) for c in "RGB"], axis=-1)
            if "Y" in chans:
                y = np.asarray(chans["Y"].pixels, dtype=np.float32)
                return np.repeat(y[..., None], 3, axis=-1)
            raise ValueError(f"{path}: no R, G, B (or Y) channels; found {sorted(chans)}")
    except (OSError, RuntimeError) as e:
        raise OSError(f"cannot read EXR file {path}: {e}") from e


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
    """Tone-map (exposure in stops, then ``tonemap``), sRGB-encode and write an 8- or 16-bit PNG.

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
    with open(path, "wb") as fh:
        fh.write(data)
