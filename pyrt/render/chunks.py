"""One chunk of camera samples, shaded: the unit of work of every render, on a local thread or a Dask worker.

Module-level functions of plain arguments (no closures), so a Dask worker runs exactly what a local thread
runs: the same pixels, sample positions and random streams, hence the same per-pixel sums.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pyrt.core.film import Film, pixel_sums
from pyrt.core.sampler import hash32, sobol_owen_2d


@dataclass(frozen=True)
class ChunkLayout:
    """How a fixed-spp render cuts the image into chunks of at most ``chunk_samples`` samples: whole pixels
    (``px_per_chunk`` per chunk) up to ``chunk_samples`` spp, above it ``pieces`` chunks per pixel (chunk
    ``pixel * pieces + piece``; see :mod:`pyrt.render.fixed`)."""

    spp: int
    n_pix: int
    chunk_samples: int

    @property
    def split(self):
        """True when a pixel's samples are spread over several chunks (pieces)."""
        return self.spp > self.chunk_samples

    @property
    def pieces(self):
        """Chunks per pixel (1 unless :attr:`split`)."""
        return -(-self.spp // self.chunk_samples) if self.split else 1

    @property
    def px_per_chunk(self):
        """Pixels per chunk (1 when split)."""
        return 1 if self.split else max(1, self.chunk_samples // self.spp)

    @property
    def n_chunks(self):
        """Chunks in the image."""
        return self.n_pix * self.pieces if self.split else -(-self.n_pix // self.px_per_chunk)

    def pixels(self, ci):
        """``(lo, hi)``: the pixel range of chunk ``ci``."""
        lo = ci // self.pieces if self.split else ci * self.px_per_chunk
        return lo, min(lo + self.px_per_chunk, self.n_pix)


def _strata(seed, pixel, index, n):
    """:attr:`pyrt.core.rays.RayBatch.strata` of camera rays: sample ``index`` of its pixel's set of ``n``, the
    pixel's seed a hash of the render's seed and the pixel (the same whatever the chunks)."""
    return index, np.broadcast_to(np.int64(n), index.shape), hash32(seed, pixel).astype(np.int64)


def shade_fixed_chunk(ps, cam, make, seed, ci, layout, film, film_lo, aovs, nonfinite):
    """Shade chunk ``ci`` of a fixed-spp render with the stream ``default_rng([seed, ci])``.

    Whole-pixel chunks are added to ``film`` (whose pixel 0 is the image's pixel ``film_lo``) and ``(stats,
    None)`` is returned; a piece of a pixel returns ``(stats, part)``, a one-pixel film the caller adds in
    chunk order."""
    lo, hi = layout.pixels(ci)
    integ = make()
    rng = np.random.default_rng([seed, ci])
    if not layout.split:
        rays = cam.generate_rays(lo, hi, rng, differentials=ps.needs_differentials)
        if integ.pads_camera_hits:
            rays.strata = _strata(seed, rays.pixel, np.tile(np.arange(layout.spp, dtype=np.int64), hi - lo),
                                  layout.spp)
        L, a = integ.render_samples(rays, want_aovs=aovs, rng=rng)
        integ.stats.nonfinite_samples += film.add_block(lo - film_lo, hi - film_lo, L, a)
        return integ.stats, None
    # piece p of the pixel: its samples p, p + pieces, p + 2 pieces, ... of the pixel's stratified set
    samples = np.arange(ci % layout.pieces, layout.spp, layout.pieces, dtype=np.int64)
    rays = cam.generate_rays(lo, hi, rng, differentials=ps.needs_differentials, samples=samples)
    if integ.pads_camera_hits:
        rays.strata = _strata(seed, rays.pixel, samples, layout.spp)
    L, a = integ.render_samples(rays, want_aovs=aovs, rng=rng)
    part = Film(1, 1, aovs=aovs, nonfinite=nonfinite)
    integ.stats.nonfinite_samples += part.add_block(0, 1, L, a)
    return integ.stats, part


def shade_adaptive_chunk(ps, cam, make, seed, index, key, P, C, base, spp_after, aovs, nonfinite):
    """Shade chunk ``key`` of adaptive pass ``index``: pixels ``P`` with ``C`` (even) new samples each, half
    to A and half to B, continuing each half's Owen-scrambled Sobol' sequence at ``base`` (samples per half
    so far, per pixel of ``P``); ``spp_after`` (per pixel of ``P``) scales the ray differentials.
    Returns ``(stats, P, sums of A + B, sums of B)`` (:class:`pyrt.core.film.PixelSums`)."""
    rng = np.random.default_rng([seed, 0xADA, index, key])
    h = C // 2
    off = np.repeat(np.cumsum(C) - C, C)
    j = np.arange(off.shape[0]) - off
    hh = np.repeat(h, C)
    is_b = j >= hh
    which = np.repeat(np.arange(P.shape[0]), C)
    pix = P[which]
    u = sobol_owen_2d(base[which] + j - is_b * hh, hash32(seed, pix, is_b))
    rays = cam.rays_at(pix, u, differentials=ps.needs_differentials, spp=spp_after[which])
    # the light and BSDF samples of a pass's new samples of each half are one padded set (of its size)
    integ = make()
    if integ.pads_camera_hits:      # each half's light and BSDF samples continue a progressive padded set
        rays.strata = (base[which] + j - is_b * hh, None, hash32(seed, pix, is_b, 0x9AD).astype(np.int64))
    L, a = integ.render_samples(rays, want_aovs=aovs, rng=rng)
    both = pixel_sums(L, C, a, nonfinite=nonfinite)
    integ.stats.nonfinite_samples += both.nonfinite
    return integ.stats, P, both, pixel_sums(L[is_b], h)
