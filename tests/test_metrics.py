"""relMSE: the closed form on hand-made images."""
import numpy as np
import pytest

from pyrt.core.metrics import RELMSE_EPS, estimated_relmse, relmse, relmse_per_pixel


def test_relmse_closed_form():
    ref = np.full((2, 2, 3), 0.5)
    img = ref + 0.1
    assert relmse(img, ref) == pytest.approx(0.01 / (0.25 + RELMSE_EPS))
    assert relmse(ref, ref) == 0.0


def test_relmse_shape_mismatch_is_an_error():
    with pytest.raises(ValueError, match="shape"):
        relmse(np.zeros((2, 2, 3)), np.zeros((2, 3, 3)))


def test_estimated_relmse_matches_true_error_of_gaussian_noise():
    rng = np.random.default_rng(1)
    ref = rng.uniform(0.1, 2.0, (20000, 3))
    var = (0.05 * ref) ** 2
    img = ref + rng.normal(size=ref.shape) * np.sqrt(var)
    est = estimated_relmse(var, ref)
    assert relmse(img, ref) == pytest.approx(est, rel=0.03)   # 60000 squared normals: rel. s.e. 0.6 %


def test_relmse_per_pixel_is_the_channel_mean_of_variance_over_mean_squared():
    """``relmse_per_pixel`` equals ``mean_c v / (m^2 + eps)`` for (N, 3) and (H, W, 3) arrays and channel-major views
    (the adaptive passes' buffers), to the last bits of the channel sums."""
    rng = np.random.default_rng(4)
    for shape in ((1000, 3), (4, 5, 3)):
        v, m = rng.random(shape), rng.random(shape) - 0.5
        np.testing.assert_allclose(relmse_per_pixel(v, m), np.mean(v / (m * m + RELMSE_EPS), axis=-1), rtol=1e-15)
    v, m = rng.random((3, 200)).T, rng.random((3, 200)).T
    np.testing.assert_allclose(relmse_per_pixel(v, m, eps=0.5), np.mean(v / (m * m + 0.5), axis=-1), rtol=1e-15)
