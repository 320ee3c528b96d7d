"""What a render returns: :class:`RenderResult` (image, AOVs, statistics, film, completeness)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pyrt.core.film import Film
from pyrt.core.image_io import png_bytes
from pyrt.integrators.prepared import RenderStats


@dataclass
class RenderResult:
    """Output of :func:`render_full`.

    Attributes
    ----------
    image : (H, W, 3) float32 ndarray
        Linear scene radiance.
    aovs : dict or None
        ``depth`` (H, W), ``normal`` and ``albedo`` (H, W, 3), float32, when asked for.
    stats : RenderStats
        Rays by kind, times, non-finite samples.
    film : Film
        The film the image was read from (per-pixel sample sums and weights).
    complete : bool
        False when the render was cancelled (``cancel`` set): only the chunks that finished are in the film;
        the other pixels have weight 0 and are black in ``image`` (and 0 / infinite depth in the AOVs).
        Above ``chunk_samples`` spp a pixel can be partly rendered: its weight (``film.weight``) is the
        samples of its pieces done, and its value their mean, an unbiased estimate of the pixel's mean
        over the union of those pieces' strata (each piece is spread evenly over the pixel), noisier.
    chunks_done, chunks_total : int
        Chunks (pixel range x sample range) rendered, and in the whole image.
    pixels_done : int
        Pixels with all their samples (all their chunks finished).
    pixels_filled : int
        Pixels with no sample at all after a cancellation that got one sample each (``fill=True``), so the
        image has no black holes; 0 otherwise.
    samples_done : int
        Camera samples of the finished chunks (the fill's not counted); ``spp * H * W`` when complete.
    passes : int
        Passes rendered (1 at a fixed spp; adaptive renders: the base pass and the adaptive ones).
    estimated_error : float or None
        Adaptive renders: the estimated relMSE of the image (:mod:`pyrt.render.adaptive`); None otherwise.
    stop_reason : str or None
        Adaptive renders: ``"target_error"``, ``"time_budget"``, ``"max_spp"`` or ``"cancelled"``.

    In Jupyter a result displays as its image, tone-mapped as :func:`pyrt.write_png` does by default (Reinhard,
    sRGB); ``pyrt.show(result.image, tonemap=..., exposure=...)`` chooses otherwise.
    """

    image: np.ndarray
    aovs: dict | None
    stats: RenderStats
    film: Film | None = None
    complete: bool = True
    chunks_done: int = 0
    chunks_total: int = 0
    pixels_done: int = 0
    pixels_filled: int = 0
    samples_done: int = 0
    passes: int = 1
    estimated_error: float | None = None
    stop_reason: str | None = None

    def _repr_png_(self):
        """The image as 8-bit sRGB PNG bytes with the default tone map (IPython's display protocol)."""
        return png_bytes(self.image)

    def __repr__(self):
        h, w = self.image.shape[:2]
        return (f"RenderResult({w}x{h}, {self.stats.backend} path, {self.passes} pass(es), "
                f"{'complete' if self.complete else f'{self.fraction_done:.0%} done'})")

    @property
    def spp_map(self):
        """Samples each pixel got, (H, W) float64 (adaptive renders vary it; None without a film)."""
        if self.film is None:
            return None
        return self.film.weight.reshape(self.image.shape[0], self.image.shape[1])

    @property
    def fraction_done(self):
        """Share of the image's pixels rendered, in [0, 1] (1 for a complete render)."""
        n = self.image.shape[0] * self.image.shape[1]
        return self.pixels_done / n if n else 1.0
