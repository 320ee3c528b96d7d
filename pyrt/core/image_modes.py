"""Pillow image modes that :func:`pyrt.core.image_io.read_image` converts itself instead of taking what
``skimage.io.imread`` returns: grey + alpha PNGs came back with scrambled axes ((4, 5, 2) read as (5, 2, 4)), CMYK
as four ink channels that would be taken for RGBA, palettes without their transparency; and the still PNGs and
JPEGs it reads with Pillow alone (:func:`still_frame`, :func:`still_array`: no scikit-image / SciPy import)."""
from __future__ import annotations

import sys

import numpy as np

#: Pillow image modes that ``skio.imread`` returns wrongly (grey+alpha PNGs come back with scrambled axes, CMYK as
#: four ink channels that would be taken for RGBA) or that carry a colour table: converted here (see
#: :func:`converted`)
CONVERTED_MODES = ("LA", "La", "P", "PA", "CMYK", "YCbCr", "LAB", "HSV")


def converted(im):
    """``(H, W, C)`` uint8 of a Pillow image in one of :data:`CONVERTED_MODES`: grey+alpha as (grey, alpha); palette
    images as RGB, or RGBA when the palette has transparency (a ``tRNS`` chunk); CMYK, YCbCr, LAB and HSV as RGB
    (Pillow's conversions; CMYK -> RGB is the uncalibrated ``255 - ink``)."""
    if im.mode in ("LA", "La"):
        return np.asarray(im.convert("LA"))
    if im.mode in ("P", "PA"):
        alpha = im.mode == "PA" or "transparency" in im.info
        return np.asarray(im.convert("RGBA" if alpha else "RGB"))
    return np.asarray(im.convert("RGB"))


def still_frame(im):
    """True for a still PNG or a JPEG (Pillow's formats ``PNG`` not animated, ``JPEG``, ``MPO``: frame 0), which
    :func:`still_array` reads as ``skimage.io.imread`` does (imageio's Pillow plugin: frame 0, no EXIF rotation, no
    gamma); animated PNGs (imageio stacks their frames), GIFs and the other formats still go through ``skimage.io``."""
    if im.format == "PNG":
        return not im.is_animated
    return im.format in ("JPEG", "MPO")


def still_array(im):
    """A still Pillow image as a writeable array, the array ``skimage.io.imread`` returns for it (16-bit grey PNGs,
    Pillow's mode ``"I"``, as uint16 like imageio's plugin)."""
    if im.format == "PNG" and im.mode == "I":
        im = im.convert("I;16" if sys.byteorder == "little" else "I;16B")
    return np.array(im)
