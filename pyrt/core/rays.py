"""RayBatch: the rays of one wavefront (camera rays, or the specular rays of one bounce).

The integrators trace a whole batch per query (:class:`pyrt.geometry.Accel`), shade the hits and spawn
the next batch (depth + 1). Everything a ray carries lives here, batch-first.
"""
from __future__ import annotations

import numpy as np


class RayBatch:
    """N rays with what they carry.

    Parameters
    ----------
    origins, directions : (N, 3) float64 ndarray
        Ray origins and unit directions (world space).
    sample : (N,) int64 ndarray, optional
        Index of the camera sample each ray's radiance goes to (within the chunk); default ``arange(N)``.
    throughput : (N, 3) float64 ndarray, optional
        Product of the lobe weights along the path so far; default ones.
    depth : int
        Specular bounces so far (0 for camera rays).
    differentials : tuple of four (N, 3) ndarrays, optional
        ``(rx_origin, rx_direction, ry_origin, ry_direction)``: the rays one (scaled) pixel to the right and
        below (pbrt-v4 ray differentials), for texture filtering; None when no texture needs them.
    stack : (N, K) int ndarray, optional
        Nested-dielectric interface stacks (:mod:`pyrt.integrators.media`), only when the scene needs them.
    pixel : (N,) int64 ndarray, optional
        Raster index (row-major) of the pixel each camera ray belongs to.
    tmax : (N,) float64 ndarray, optional
        Parametric end of each ray; None for unbounded rays.
    bsdf_pdf : (N,) float64 ndarray, optional
        For rays spawned by sampling a non-delta lobe (:mod:`pyrt.integrators.glossy`): ``n_samples * pdf``
        of that sample (solid angle), what the emitters and the environment they reach are MIS-weighted
        against; 0 for delta-lobe rays, None when no ray of the batch was sampled so.
    strata : tuple of three (N,) int64 ndarrays, optional
        Camera rays only: ``(index, n, key)``, each ray's sample index in its pixel's set, the set's size (None:
        progressive sets, adaptive passes) and the pixel's seed: the light and BSDF samples at their hits are
        padded over the pixel's samples (:class:`pyrt.core.sampler.PaddedStream`); None: independent random
        numbers.
    """

    __slots__ = ("origins", "directions", "sample", "throughput", "depth", "differentials", "stack", "pixel",
                 "tmax", "bsdf_pdf", "strata")

    def __init__(self, origins, directions, *, sample=None, throughput=None, depth=0, differentials=None,
                 stack=None, pixel=None, tmax=None,
                 bsdf_pdf=None, strata=None):
        n = origins.shape[0]
        self.origins = origins
        self.directions = directions
        self.sample = np.arange(n) if sample is None else sample
        self.throughput = np.ones((n, 3)) if throughput is None else throughput
        self.depth = int(depth)
        self.differentials = differentials
        self.stack = stack
        self.pixel = pixel
        self.tmax = tmax
        self.bsdf_pdf = bsdf_pdf
        self.strata = strata

    @property
    def size(self):
        """Number of rays N."""
        return self.origins.shape[0]

    def __len__(self):
        return self.size

    def __repr__(self):
        return f"RayBatch({self.size} rays, depth {self.depth})"

    def rows(self, lo, hi):
        """The rays ``lo .. hi - 1`` (views of this batch's arrays)."""
        def cut(a):
            return None if a is None else a[lo:hi]
        return RayBatch(self.origins[lo:hi], self.directions[lo:hi], sample=self.sample[lo:hi],
                        throughput=self.throughput[lo:hi], depth=self.depth,
                        differentials=None if self.differentials is None else tuple(x[lo:hi] for x in
                                                                                    self.differentials),
                        stack=cut(self.stack), pixel=cut(self.pixel), tmax=cut(self.tmax), bsdf_pdf=cut(self.bsdf_pdf),
                        strata=None if self.strata is None else tuple(None if x is None else x[lo:hi]
                                                                      for x in self.strata))

    @staticmethod
    def concatenate(batches):
        """One batch of the rays of ``batches`` (of one depth), in order. ``bsdf_pdf`` is 0 (delta-lobe rays) for
        the rays of a batch without one; ``differentials``, ``stack``, ``pixel`` and ``tmax`` are kept when every
        batch has them. Interface stacks of different widths (a slice whose rays entered more volumes) are padded
        with -1 (empty) to the widest."""
        if len(batches) == 1:
            return batches[0]

        def cat(name):
            parts = [getattr(b, name) for b in batches]
            if any(p is None for p in parts):
                return None
            if name == "stack":
                wdt = max(p.shape[1] for p in parts)
                parts = [np.pad(p, ((0, 0), (0, wdt - p.shape[1])), constant_values=-1) for p in parts]
            return np.concatenate(parts)
        pdfs = [b.bsdf_pdf for b in batches]
        bsdf_pdf = None if all(p is None for p in pdfs) else np.concatenate(
            [np.zeros(b.size) if p is None else p for b, p in zip(batches, pdfs)])
        diffs = None
        if all(b.differentials is not None for b in batches):
            diffs = tuple(np.concatenate([b.differentials[k] for b in batches]) for k in range(4))
        strata = None
        if all(b.strata is not None for b in batches):
            strata = tuple(None if batches[0].strata[k] is None else np.concatenate([b.strata[k] for b in batches])
                           for k in range(3))
        return RayBatch(cat("origins"), cat("directions"), sample=cat("sample"), throughput=cat("throughput"),
                        depth=batches[0].depth, differentials=diffs, stack=cat("stack"), pixel=cat("pixel"),
                        tmax=cat("tmax"), bsdf_pdf=bsdf_pdf, strata=strata)
