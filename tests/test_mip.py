"""Tests for shaders/mip.py (the 2x2 cascade) and the lazy float32 pyramid of ImageTexture.

Ground truths: a float64 reference cascade of exact box (area) averages (``build_mip_level``'s filter
applied level by level, and for power-of-two sizes the area average of level 0 itself); the image
mean, which every exact box step preserves; the byte count of a 4/3 pyramid.
"""
import numpy as np
import pytest

from pyrt.shaders import mip as M
from pyrt.shaders import textures as K
from pyrt import textures as T


@pytest.fixture
def rng():
    return np.random.default_rng(2024)


def _reference_cascade(img, n_levels):
    """float64 levels: each the exact area average of the previous one (``build_mip_level`` one step)."""
    levels = [np.asarray(img, dtype=np.float64)]
    for _ in range(1, n_levels):
        prev = levels[-1]
        h, w = max(1, prev.shape[0] // 2), max(1, prev.shape[1] // 2)
        levels.append(K._box_resample_axis(K._box_resample_axis(prev, h, 0), w, 1))
    return levels


@pytest.mark.parametrize("shape", [(64, 64), (37, 53), (1, 17), (5, 1), (100, 3), (3, 3), (7, 2)])
def test_float32_cascade_equals_float64_reference_to_rounding(shape, rng):
    img = rng.random(shape + (3,), dtype=np.float32)
    n = K.n_mip_levels(img.shape)
    ref = _reference_cascade(img, n)
    tex = T.ImageTexture(img, srgb=False)
    pyr = tex._pyramid
    for lev in range(n):
        got = pyr[lev]
        assert got.dtype == np.float32
        assert got.shape[:2] == K.mip_level_shape(img.shape, lev)
        np.testing.assert_allclose(got, ref[lev], rtol=4e-6 * (1 + lev), atol=1e-7)
        np.testing.assert_allclose(got.mean(axis=(0, 1)), img.astype(np.float64).mean(axis=(0, 1)), rtol=1e-5)


def test_power_of_two_cascade_is_the_area_average_of_level_0(rng):
    img = rng.random((32, 16, 2))
    for lev in range(K.n_mip_levels(img.shape)):
        np.testing.assert_allclose(M.reduce_levels(img, lev), K.build_mip_level(img, lev), atol=1e-14)


def test_odd_axis_is_the_exact_area_average_of_the_previous_level():
    # 5 -> 2: cells [0, 2.5), [2.5, 5); 2 -> 1: the pair mean. 3 -> 1: the plain mean.
    img = np.array([[[1.0], [2.0], [6.0], [3.0], [5.0]]])
    lev1 = M.reduce_level(img)
    np.testing.assert_allclose(lev1[0, :, 0], [(1 + 2 + 0.5 * 6) / 2.5, (0.5 * 6 + 3 + 5) / 2.5])
    np.testing.assert_allclose(M.reduce_level(lev1)[0, :, 0], [17 / 5])
    np.testing.assert_allclose(M.reduce_axis(np.array([1.0, 2.0, 6.0]), 0), [3.0])
    # 7 -> 3: cells of width 7/3, four taps for the middle one.
    a = np.arange(7, dtype=np.float64) ** 2
    r = 7 / 3
    cum = lambda x: np.sum(a[:int(np.floor(x))]) + (x - np.floor(x)) * a[min(int(np.floor(x)), 6)]
    want = [(cum((k + 1) * r) - cum(k * r)) / r for k in range(3)]
    np.testing.assert_allclose(M.reduce_axis(a, 0), want, rtol=1e-14)


def test_dtype_kept_and_integers_promoted():
    assert M.reduce_level(np.zeros((4, 4, 3), np.float32)).dtype == np.float32
    assert M.reduce_level(np.zeros((4, 4, 3), np.float64)).dtype == np.float64
    assert M.reduce_level(np.zeros((4, 4), np.uint8)).dtype == np.float64
    with pytest.raises(ValueError, match="steps"):
        M.reduce_levels(np.zeros((4, 4)), -1)


def test_levels_are_the_same_whatever_order_they_are_built_in(rng):
    img = rng.random((45, 30, 3), dtype=np.float32)
    a = T.ImageTexture(img, srgb=False)._pyramid
    b = T.ImageTexture(img, srgb=False)._pyramid
    n = len(a)
    for lev in range(1, n):
        a[lev]
    for lev in (4, 2, n - 1, 1, 3):
        np.testing.assert_array_equal(b[lev], a[lev])


def test_pyramid_memory_of_a_2048_rgb_texture():
    img = np.zeros((2048, 2048, 3), dtype=np.float32)
    tex = T.ImageTexture(img, srgb=False)
    pyr = tex._pyramid
    for lev in range(1, len(pyr)):
        assert pyr[lev].dtype == np.float32
    assert pyr.built == list(range(1, 12))
    assert pyr.nbytes < 1.4 * 2048 * 2048 * 3 * 4


def test_lazy_level_skips_unread_levels(rng):
    tex = T.ImageTexture(rng.random((64, 64, 1)), filter="trilinear")
    ref = _reference_cascade(tex.image, 5)
    np.testing.assert_allclose(tex._pyramid[4], ref[4], rtol=2e-5)
    assert tex.mip_levels_built == [4]
    tex._pyramid[5]  # from level 4, not from level 0
    assert tex.mip_levels_built == [4, 5]
