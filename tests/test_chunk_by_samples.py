"""Chunks are cut by samples: above ``chunk_samples`` spp a pixel's samples are split over several chunks.

Memory is bounded whatever spp (tracemalloc peak, not a timer), the split pixel is unbiased and stratified
(the pieces' strata tile the pixel once), bit-identical across thread counts, and cancellation / fill still
report what was rendered.
"""
import math
import tracemalloc

import numpy as np
import pytest

import pyrt
from pyrt.core.film import Film
from pyrt.core.sampler import pixel_strata
from pyrt.integrators.whitted import Integrator
from render_helpers import CancelAfter, top_down_scene

RHO, I, LP = 0.6, 7.0, np.array([0.4, 1.2, -0.3])


def _lit_pixel(size=1, fov=60.0):
    """A Lambert plane under a point light seen by a ``size`` x ``size`` camera whose pixels see very
    different radiance across their footprint (wide field of view)."""
    scene = top_down_scene(size=size, fov=fov, albedo=RHO, plane=8.0)
    scene.add_light(pyrt.PointLight(LP, intensity=I))
    return scene


def _closed_form_pixel_mean(cam, n=1024):
    """The mean over the pixel (0, 0) in raster space of rho/pi I cos / r^2 at the plane y = 0 (midpoint rule)."""
    u = (np.arange(n) + 0.5) / n
    x, y = np.meshgrid(u, u)
    d = cam.directions(x.ravel(), y.ravel())
    p = cam.position + (-cam.position[1] / d[:, 1])[:, None] * d
    dl = LP - p
    r2 = (dl ** 2).sum(-1)
    return float(np.mean(RHO / math.pi * I * (dl[:, 1] / np.sqrt(r2)) / r2))


class _Edges:
    """A stand-in generator whose ``random`` returns one constant: the cells' corners (0) and far edges (~1)."""

    def __init__(self, v):
        self.v = v

    def random(self, shape):
        return np.full(shape, self.v)


@pytest.mark.parametrize("spp", [1, 2, 3, 5, 7, 10, 16, 17, 99, 768, 1000])
def test_pixel_strata_tile_the_pixel_once(spp):
    s = np.arange(spp)
    lo = pixel_strata(_Edges(0.0), spp, s)
    hi = pixel_strata(_Edges(1.0), spp, s)
    size = hi - lo
    np.testing.assert_allclose(size.prod(axis=1), 1.0 / spp, rtol=1e-12)    # equal areas
    assert (lo >= 0).all() and (hi <= 1 + 1e-12).all()
    # disjoint: total area 1 inside the unit square, and no two cells overlap (pairwise, small spp)
    if spp <= 120:
        ox = np.minimum(hi[:, None, 0], hi[None, :, 0]) - np.maximum(lo[:, None, 0], lo[None, :, 0])
        oy = np.minimum(hi[:, None, 1], hi[None, :, 1]) - np.maximum(lo[:, None, 1], lo[None, :, 1])
        overlap = np.clip(ox, 0, None) * np.clip(oy, 0, None)
        np.fill_diagonal(overlap, 0)
        assert overlap.max() < 1e-12
    # near-square cells: aspect within a factor of 4 once there are a few samples
    if spp >= 4:
        aspect = size[:, 0] / size[:, 1]
        assert aspect.max() < 4 and aspect.min() > 0.25


def test_pixel_strata_square_spp_is_the_jittered_grid():
    k = 7
    s = np.arange(k * k)
    lo = pixel_strata(_Edges(0.0), k * k, s)
    np.testing.assert_allclose(lo[:, 0], (s % k) / k)
    np.testing.assert_allclose(lo[:, 1], (s // k) / k)


def _peak_bytes(scene, spp, **kw):
    tracemalloc.start()
    try:
        tracemalloc.reset_peak()
        img = pyrt.render(scene, backend="numpy", spp=spp, threads=1, progress=False, **kw)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert np.isfinite(img).all() and img.max() > 0
    return peak


def test_peak_memory_does_not_grow_with_spp():
    scene = _lit_pixel()
    cs = 1 << 12
    with pyrt.PreparedScene(scene) as ps:
        small = _peak_bytes(scene, 1 << 15, chunk_samples=cs, prepared=ps)    # 8 pieces
        big = _peak_bytes(scene, 1 << 18, chunk_samples=cs, prepared=ps)      # 64 pieces
        one_chunk = _peak_bytes(scene, cs, chunk_samples=cs, prepared=ps)     # the usual chunk
    assert big < 1.2 * small, (small, big)
    assert big < 1.5 * one_chunk, (one_chunk, big)
    # one chunk holding all 2^18 samples of the pixel would need > 64x one chunk of 2^12
    assert big < one_chunk * 64 / 10


def test_split_pixel_is_unbiased_against_the_closed_form():
    scene = _lit_pixel()
    ref = _closed_form_pixel_mean(scene.camera)
    cs = 256
    vals = np.array([pyrt.render(scene, backend="numpy", spp=3 * cs, chunk_samples=cs, seed=s, threads=1)[0, 0, 0]
                     for s in range(8)], dtype=np.float64)
    se = vals.std(ddof=1) / math.sqrt(len(vals))
    assert abs(vals.mean() - ref) < 5 * se + 1e-6 * ref, (vals.mean(), ref, se)
    # stratified across the pieces: measured relative standard deviation of the 768-sample mean 1.6e-3
    # (independent uniform samples: 2.4e-2; a Latin hypercube of 768: 9e-3)
    assert vals.std(ddof=1) < 5e-3 * ref


def test_split_square_and_non_square_spp_agree_with_unsplit():
    scene = _lit_pixel()
    ref = _closed_form_pixel_mean(scene.camera)
    for spp in (1024, 1000):
        split = pyrt.render(scene, backend="numpy", spp=spp, chunk_samples=100, threads=1)[0, 0, 0]
        whole = pyrt.render(scene, backend="numpy", spp=spp, threads=1)[0, 0, 0]
        # ~6 standard deviations each (measured: 1.5e-3 relative split, ~9e-3 for the unsplit Latin hypercube)
        assert abs(split - ref) < 1e-2 * ref and abs(whole - ref) < 5e-2 * ref, (spp, split, whole, ref)


def test_split_is_bit_identical_across_thread_counts():
    scene = _lit_pixel(size=3)
    kw = dict(spp=700, chunk_samples=128, aovs=True, progress=False)
    a = pyrt.render_full(scene, backend="numpy", threads=1, **kw)
    b = pyrt.render_full(scene, backend="numpy", threads=2, **kw)
    c = pyrt.render_full(scene, backend="numpy", threads=5, **kw)
    for r in (b, c):
        np.testing.assert_array_equal(a.image, r.image)
        for k in a.aovs:
            np.testing.assert_array_equal(a.aovs[k], r.aovs[k])
    assert a.chunks_total == 9 * 6 and a.complete and a.pixels_done == 9
    np.testing.assert_array_equal(a.film.weight, 700)
    assert a.samples_done == 9 * 700 and a.stats.primary_rays == 9 * 700


def test_unsplit_chunks_unchanged():
    """spp <= chunk_samples: chunks of whole pixels with the streams of before (what same_pixels checks on
    every scene): the pixel range of chunk ci is [ci * (chunk_samples // spp), ...)."""
    scene = _lit_pixel(size=4)
    res = pyrt.render_full(scene, backend="numpy", spp=16, chunk_samples=64, threads=1, progress=False)
    assert res.chunks_total == 4
    film = Film(4, 4)
    cam = pyrt.Camera(position=scene.camera.position, target=scene.camera.target, up=scene.camera.up, fov=60.0,
                      width=4, height=4, spp=16)
    with pyrt.PreparedScene(scene) as ps:
        for ci in range(4):
            integ = Integrator(ps)
            rng = np.random.default_rng([0, ci])
            rays = cam.generate_rays(4 * ci, 4 * ci + 4, rng, differentials=ps.needs_differentials)
            L, _ = integ.render_samples(rays, rng=rng)
            film.add_block(4 * ci, 4 * ci + 4, L)
    np.testing.assert_array_equal(res.image, film.image())


def test_cancel_and_fill_with_split_pixels():
    scene = _lit_pixel(size=2)
    kw = dict(spp=1000, chunk_samples=256, threads=1, progress=False)    # 4 pieces per pixel, 16 chunks
    full = pyrt.render_full(scene, backend="numpy", **kw)
    part = pyrt.render_full(scene, backend="numpy", cancel=CancelAfter(6), **kw)
    assert not part.complete and part.chunks_done == 6 and part.chunks_total == 16
    assert part.pixels_done == 1                        # pixel 0: 4 pieces; pixel 1: 2 of its 4
    assert part.samples_done == 1000 + 250 + 250
    w = part.film.weight
    assert w[0] == 1000 and w[1] == 500 and w[2] == 0 and w[3] == 0
    assert part.image[0, 0, 0] == full.image[0, 0, 0]   # the same pieces, added in the same order
    # the half-rendered pixel: its two pieces are spread over the whole pixel, so close to the full value
    assert abs(part.image[0, 1, 0] - full.image[0, 1, 0]) < 0.02 * full.image[0, 1, 0]
    assert (part.image[1] == 0).all() and part.pixels_filled == 0
    filled = pyrt.render_full(scene, backend="numpy", cancel=CancelAfter(6), fill=True, fill_budget=60.0, **kw)
    assert filled.pixels_filled == 2 and filled.pixels_done == 1
    np.testing.assert_array_equal(filled.film.weight, [1000, 500, 1, 1])
    assert (filled.image[1] > 0).all()
