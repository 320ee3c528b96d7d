"""Images in Jupyter: :func:`show` wraps a linear-radiance image in a :class:`Picture`, which a notebook displays
as the PNG :func:`pyrt.write_png` would write (exposure, tone map, sRGB). :class:`pyrt.RenderResult` displays itself
the same way, with the defaults."""
from __future__ import annotations

import numpy as np

from pyrt.core.image_io import TONEMAPS, png_bytes


class Picture:
    """A linear-radiance image with its display settings; Jupyter shows it through :meth:`_repr_png_`.

    Parameters
    ----------
    image : (H, W, 3) float ndarray
        Linear radiance (what :func:`pyrt.render` returns). Not copied.
    tonemap : str
        One of :data:`pyrt.core.image_io.TONEMAPS` (default ``"reinhard"``, :func:`pyrt.write_png`'s).
    exposure : float
        Stops applied before the tone map.
    L_white : float, optional
        The extended Reinhard white point.
    """

    def __init__(self, image, *, tonemap="reinhard", exposure=0.0, L_white=None):
        image = np.asarray(image)
        if image.ndim != 3 or image.shape[2] != 3 or not np.issubdtype(image.dtype, np.floating):
            raise ValueError(f"show: image must be an (H, W, 3) float array, got {image.dtype} {image.shape}")
        if tonemap not in TONEMAPS:
            raise ValueError(f"show: tonemap must be one of {list(TONEMAPS)}, got {tonemap!r}")
        self.image, self.tonemap, self.exposure, self.L_white = image, tonemap, float(exposure), L_white

    def _repr_png_(self):
        """The 8-bit sRGB PNG bytes of the image (IPython's display protocol)."""
        return png_bytes(self.image, tonemap=self.tonemap, exposure=self.exposure, L_white=self.L_white)

    def __repr__(self):
        h, w = self.image.shape[:2]
        return f"Picture({w}x{h}, tonemap={self.tonemap!r}, exposure={self.exposure:g})"


def show(image, *, tonemap="reinhard", exposure=0.0, L_white=None):
    """``image`` as a :class:`Picture`: the last expression of a notebook cell, it displays as a PNG
    (``pyrt.show(pyrt.render(scene), exposure=1)``)."""
    return Picture(image, tonemap=tonemap, exposure=exposure, L_white=L_white)
