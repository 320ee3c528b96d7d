"""Film: where radiance samples become pixels.

A :class:`Film` accumulates weighted radiance samples per pixel in float64 (the sum of weights, of
weighted radiance and, when asked, of weighted squared radiance: the per-pixel statistics adaptive
sampling reads), averages the first-hit AOVs (depth, normal, albedo), applies the non-finite policy
and gives the image as float32.
"""
from __future__ import annotations

import warnings

import numpy as np

from pyrt.core.errors import Error
from pyrt.shaders.vec import to_float32

#: what a film does with a sample whose radiance is NaN or infinite
NONFINITE_POLICIES = ("zero", "raise")


class FilmError(Error, ArithmeticError):
    """A non-finite radiance sample reached a film whose policy is ``"raise"``."""


class Film:
    """Per-pixel accumulation of radiance samples.

    Parameters
    ----------
    width, height : int
        Image size in pixels.
    aovs : bool
        Also average the first-hit depth, shading normal and albedo of the samples.
    nonfinite : {"zero", "raise"}
        A sample with non-finite radiance is set to 0 and counted (:attr:`nonfinite_samples`), or raises
        :class:`FilmError`.
    second_moment : bool
        Also accumulate the weighted squared radiance, so :meth:`variance` can estimate the variance of
        each pixel's mean (costs one more (H*W, 3) float64 buffer).
    """

    def __init__(self, width, height, *, aovs=False, nonfinite="zero", second_moment=False):
        if nonfinite not in NONFINITE_POLICIES:
            raise ValueError(f"Film: nonfinite must be one of {NONFINITE_POLICIES}, got {nonfinite!r}")
        self.width, self.height = int(width), int(height)
        n = self.width * self.height
        self.nonfinite = nonfinite
        self.weight = np.zeros(n)                 # sum of sample weights per pixel
        self.sum = np.zeros((n, 3))               # sum of weighted radiance
        self.sum_sq = np.zeros((n, 3)) if second_moment else None
        self.nonfinite_samples = 0
        self._aov = None
        if aovs:
            self._aov = {"depth": np.zeros(n), "depth_weight": np.zeros(n), "normal": np.zeros((n, 3)),
                         "albedo": np.zeros((n, 3))}

    @property
    def n_pixels(self):
        """H * W."""
        return self.weight.shape[0]

    def add_block(self, lo, hi, L, aovs=None):
        """Add the samples of the pixels ``[lo, hi)`` (row-major): ``L`` (n * S, 3), the S samples of a pixel
        contiguous, each of weight 1. Returns the number of non-finite samples (set to 0).

        ``aovs``: the samples' first-hit ``depth`` (n*S,), ``normal`` and ``albedo`` (n*S, 3) (depth ``inf``
        for a miss; the pixel's depth is the mean over the samples that hit, ``inf`` if none did).
        """
        n = hi - lo
        S = L.shape[0] // n if n else 1
        bad = 0
        if not np.isfinite(L).all():          # one flat pass; per-sample only when something is wrong
            if self.nonfinite == "raise":
                raise FilmError(f"Film: non-finite radiance in pixels [{lo}, {hi})")
            rows = ~np.all(np.isfinite(L), axis=1)
            bad = int(rows.sum())
            L[rows] = 0.0
            self.nonfinite_samples += bad
        # a pixel's S samples summed in order: einsum gives the same bits as .sum(axis=1) (a one-off timing of
        # 512 pixels x 64 samples: 0.14 ms against 0.56 ms)
        block = L if S == 1 else np.einsum("psc->pc", L.reshape(n, S, 3))
        self.sum[lo:hi] += block
        self.weight[lo:hi] += S
        if self.sum_sq is not None:
            self.sum_sq[lo:hi] += (L * L) if S == 1 else np.einsum("psc->pc", (L * L).reshape(n, S, 3))
        if aovs is not None and self._aov is not None:
            a = self._aov
            dep = aovs["depth"].reshape(n, S)
            hitm = np.isfinite(dep)
            a["depth"][lo:hi] += np.where(hitm, dep, 0).sum(1)
            a["depth_weight"][lo:hi] += hitm.sum(axis=1)
            a["normal"][lo:hi] += aovs["normal"].reshape(n, S, 3).sum(axis=1)
            a["albedo"][lo:hi] += aovs["albedo"].reshape(n, S, 3).sum(axis=1)
        return bad

    def add_film(self, other, lo=0):
        """Add the sums and weights of the film ``other`` to the pixels ``[lo, lo + other.n_pixels)``.

        How a render merges the pieces of a pixel whose samples are split over several chunks: each piece
        goes into a small film of its own, and the pieces are added in chunk order (deterministic bits
        whatever the thread that rendered them). Non-finite samples counted in ``other`` are counted here too.
        """
        hi = lo + other.n_pixels
        self.sum[lo:hi] += other.sum
        self.weight[lo:hi] += other.weight
        if self.sum_sq is not None and other.sum_sq is not None:
            self.sum_sq[lo:hi] += other.sum_sq
        if self._aov is not None and other._aov is not None:
            for k, v in other._aov.items():
                self._aov[k][lo:hi] += v
        self.nonfinite_samples += other.nonfinite_samples

    def add_pixel_sums(self, pixels, sums):
        """Add a :class:`PixelSums` (the reduced samples of some pixels, from :func:`pixel_sums`) to the
        pixels ``pixels`` (unique row-major indices, the order of ``sums``): how an adaptive pass, whose
        chunks hold scattered pixels, adds a chunk to the film. A run of consecutive pixels in order (an adaptive
        render's base pass) is added as a slice (fancy indexing copies: several times slower)."""
        pixels = np.asarray(pixels)
        if pixels.size > 1 and pixels[-1] - pixels[0] + 1 == pixels.size and np.all(np.diff(pixels) == 1):
            pixels = slice(int(pixels[0]), int(pixels[-1]) + 1)
        self.sum[pixels] += sums.sum
        self.weight[pixels] += sums.weight
        if self.sum_sq is not None and sums.sum_sq is not None:
            self.sum_sq[pixels] += sums.sum_sq
        if self._aov is not None and sums.aov is not None:
            for k, v in sums.aov.items():
                self._aov[k][pixels] += v
        self.nonfinite_samples += sums.nonfinite

    def _mean(self, acc):
        """``acc / weight`` per pixel (0 where a pixel has no sample). Uniform weights (every pixel with the
        same number of samples, the usual case) divide by one scalar, which gives the same bits as the
        per-pixel division; otherwise column by column (NumPy broadcasts over a 3-wide axis 3 elements
        at a time: several times slower)."""
        w = self.weight
        lo, hi = w.min(initial=1.0), w.max(initial=1.0)
        if lo > 0 and lo == hi:
            return acc / lo
        if acc.ndim == 1:
            return np.divide(acc, w, out=np.zeros_like(acc), where=w > 0)
        out = np.zeros_like(acc)
        for c in range(acc.shape[1]):
            np.divide(acc[:, c], w, out=out[:, c], where=w > 0)
        return out

    def mean(self):
        """Per-pixel mean radiance (H*W, 3) float64 (0 where no sample was added)."""
        return self._mean(self.sum)

    def variance(self):
        """Estimated variance (H*W, 3) of each pixel's mean: ``(E[L^2] - E[L]^2) / (n - 1)`` (needs
        ``second_moment=True``; inf where a pixel has fewer than two samples)."""
        if self.sum_sq is None:
            raise ValueError("Film.variance needs second_moment=True")
        w = self.weight[:, None]
        m = self.mean()
        var = np.maximum(self._mean(self.sum_sq) - m * m, 0.0) * w / np.maximum(w - 1, 1)
        return np.where(w > 1, var / np.maximum(w, 1), np.inf)

    def image(self):
        """The image (H, W, 3) float32: linear radiance (the float64 mean rounded once to float32).

        Radiance beyond the float32 range (> 3.4e38, e.g. an absurdly bright background) would become inf:
        with the ``"zero"`` policy such values are clipped to the largest float32 and a ``RuntimeWarning``
        says how many; with ``"raise"`` it is a :class:`FilmError`.
        """
        w = self.weight
        lo, hi = w.min(initial=1.0), w.max(initial=1.0)
        if lo > 0 and lo == hi:     # uniform weights: divide straight into the float32 image, no float64 temporary
            out = np.empty((self.n_pixels, 3), dtype=np.float32)
            with np.errstate(over="ignore"):
                np.divide(self.sum, lo, out=out, casting="same_kind")
        else:
            with np.errstate(over="ignore"):
                out = to_float32(self.mean())
        if not np.isfinite(out).all():      # only float32 overflow can get here: the sums are finite
            n_over = int((~np.isfinite(out)).any(axis=1).sum())
            if self.nonfinite == "raise":
                raise FilmError(f"Film: radiance beyond the float32 range in {n_over} pixels")
            warnings.warn(f"Film: radiance beyond the float32 range (3.4e38) in {n_over} pixels was clipped "
                          "to the largest float32 value", RuntimeWarning, stacklevel=2)
            big = np.finfo(np.float32).max
            np.clip(out, -big, big, out=out, where=~np.isfinite(out))
        return out.reshape(self.height, self.width, 3)

    def aovs(self):
        """The AOV images as float32: ``depth`` (H, W), ``normal`` and ``albedo`` (H, W, 3); None without AOVs."""
        if self._aov is None:
            return None
        a = self._aov
        H, W = self.height, self.width
        cnt = a["depth_weight"]
        depth = np.where(cnt > 0, a["depth"] / np.maximum(cnt, 1), np.inf)
        return {"depth": depth.reshape(H, W).astype(np.float32),
                "normal": self._mean(a["normal"]).reshape(H, W, 3).astype(np.float32),
                "albedo": self._mean(a["albedo"]).reshape(H, W, 3).astype(np.float32)}


class PixelSums:
    """The samples of some pixels reduced to per-pixel sums (what a chunk hands the film): ``weight`` (k,),
    ``sum`` (k, 3), optionally ``sum_sq`` (k, 3) and ``aov`` (the AOV sums, keyed as in :class:`Film`),
    ``nonfinite`` (samples zeroed)."""

    __slots__ = ("weight", "sum", "sum_sq", "aov", "nonfinite")

    def __init__(self, weight, sum, sum_sq=None, aov=None, nonfinite=0):
        self.weight, self.sum, self.sum_sq, self.aov, self.nonfinite = weight, sum, sum_sq, aov, nonfinite


def pixel_sums(L, counts, aovs=None, *, nonfinite="zero", second_moment=False):
    """Reduce samples to per-pixel sums: ``L`` (sum(counts), 3), the ``counts[i]`` (> 0) samples of pixel
    ``i`` contiguous, weight 1 each. Non-finite samples are zeroed and counted (``nonfinite="zero"``; in
    place in ``L``) or raise :class:`FilmError`. ``aovs`` as in :meth:`Film.add_block`. Returns
    :class:`PixelSums`."""
    counts = np.asarray(counts, dtype=np.int64)
    bad = 0
    if not np.isfinite(L).all():
        if nonfinite == "raise":
            raise FilmError("Film: non-finite radiance in an adaptive pass")
        rows = ~np.all(np.isfinite(L), axis=1)
        bad = int(rows.sum())
        L[rows] = 0.0
    starts = np.zeros(counts.shape[0], dtype=np.int64)
    np.cumsum(counts[:-1], out=starts[1:])
    red = lambda a: np.add.reduceat(a, starts, axis=0)   # noqa: E731  (sums over each pixel's run)
    aov = None
    if aovs is not None:
        dep = aovs["depth"]
        hitm = np.isfinite(dep)
        aov = {"depth": red(np.where(hitm, dep, 0.0)), "depth_weight": red(hitm.astype(np.float64)),
               "normal": red(aovs["normal"]), "albedo": red(aovs["albedo"])}
    return PixelSums(counts.astype(np.float64), red(L), red(L * L) if second_moment else None, aov, bad)
