"""Film: per-pixel accumulation (sums, weights, second moment), AOVs, the non-finite policy, float32 output."""
import numpy as np
import pytest

import pyrt
from pyrt.core.film import Film, FilmError
from pyrt.core.rays import RayBatch


def test_block_means_equal_numpy_means_bit_for_bit(rng):
    """One pass of S samples per pixel gives exactly ``L.reshape(n, S, 3).mean(axis=1)`` (what the renderer
    wrote before the Film existed, so images are unchanged)."""
    film = Film(8, 4)
    L = rng.random((32 * 5, 3))
    film.add_block(0, 32, L.copy())
    np.testing.assert_array_equal(film.mean(), L.reshape(32, 5, 3).mean(axis=1))
    img = film.image()
    assert img.dtype == np.float32 and img.shape == (4, 8, 3)


def test_blocks_accumulate_and_second_moment_gives_the_variance_of_the_mean(rng):
    film = Film(4, 4, second_moment=True)
    a, b = rng.normal(size=(16 * 3, 3)), rng.normal(size=(16 * 5, 3))
    film.add_block(0, 16, a.copy())
    film.add_block(0, 16, b.copy())
    allv = np.concatenate([a.reshape(16, 3, 3), b.reshape(16, 5, 3)], axis=1)       # 8 samples per pixel
    np.testing.assert_allclose(film.mean(), allv.mean(axis=1), rtol=1e-12)
    np.testing.assert_allclose(film.variance(), allv.var(axis=1, ddof=1) / 8, rtol=1e-9)
    assert np.all(film.weight == 8)


def test_unsampled_pixels_are_black_and_have_infinite_variance():
    film = Film(2, 2, second_moment=True)
    film.add_block(0, 1, np.ones((4, 3)))
    assert np.all(film.mean()[1:] == 0) and np.all(np.isinf(film.variance()[1:]))


def test_nonfinite_policy_zero_counts_and_raise_raises():
    L = np.ones((6, 3))
    L[1, 0] = np.nan
    L[4, 2] = np.inf
    film = Film(3, 1)
    assert film.add_block(0, 3, L.copy()) == 2 and film.nonfinite_samples == 2
    np.testing.assert_array_equal(film.mean()[:, 0], [0.5, 1.0, 0.5])     # a bad sample is zeroed whole
    with pytest.raises(FilmError):
        Film(3, 1, nonfinite="raise").add_block(0, 3, L.copy())
    with pytest.raises(ValueError):
        Film(3, 1, nonfinite="ignore")


def test_aov_depth_is_the_mean_over_hits_and_inf_without_any():
    film = Film(2, 1, aovs=True)
    aovs = {"depth": np.array([1.0, 3.0, np.inf, np.inf]), "normal": np.tile([0.0, 1.0, 0.0], (4, 1)),
            "albedo": np.full((4, 3), 0.5)}
    film.add_block(0, 2, np.zeros((4, 3)), aovs)
    out = film.aovs()
    np.testing.assert_array_equal(out["depth"][0], [2.0, np.inf])
    assert out["normal"].dtype == np.float32 and np.all(out["albedo"] == 0.5)


def test_render_full_returns_its_film():
    cam = pyrt.Camera(position=(0, 2, 0.01), target=(0, 0, 0), fov=40, width=8, height=6, spp=4)
    scene = pyrt.Scene(cam)
    scene.add_plane((0, 0, 0), 4.0, pyrt.Lambert(albedo=0.5))
    scene.add_light(pyrt.PointLight((0, 2, 0), intensity=3.0))
    res = pyrt.render_full(scene)
    assert np.all(res.film.weight == 4)
    np.testing.assert_array_equal(res.image, res.film.image())


def test_camera_rays_are_a_ray_batch():
    cam = pyrt.Camera(position=(0, 1, 3), target=(0, 0, 0), fov=40, width=4, height=3, spp=2)
    rays = cam.generate_rays(0, 12, np.random.default_rng(0))
    assert isinstance(rays, RayBatch) and rays.size == 24 and rays.depth == 0
    np.testing.assert_array_equal(rays.pixel, np.repeat(np.arange(12), 2))
    np.testing.assert_array_equal(rays.sample, np.arange(24))
    assert np.all(rays.throughput == 1) and len(rays.differentials) == 4
    np.testing.assert_allclose(np.linalg.norm(rays.directions, axis=1), 1.0, rtol=1e-12)


def test_radiance_beyond_float32_is_clipped_with_a_warning_or_raises():
    film = Film(2, 1)
    film.add_block(0, 2, np.array([[1.0, 2.0, 3.0], [1e39, 0.5, 0.0]]))
    with pytest.warns(RuntimeWarning, match="float32 range"):
        img = film.image()
    assert np.isfinite(img).all() and img[0, 1, 0] == np.finfo(np.float32).max and img[0, 0, 2] == 3.0
    strict = Film(2, 1, nonfinite="raise")
    strict.add_block(0, 2, np.array([[1.0, 2.0, 3.0], [1e39, 0.5, 0.0]]))
    with pytest.raises(FilmError):
        strict.image()
