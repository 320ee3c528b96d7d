"""The compiled kernel's progressive samples are the NumPy path's, bit for bit (pyrt.shaders.jit_sampling)."""
import numba
import numpy as np
import pytest

from pyrt.core import sampler
from pyrt.shaders import jit_sampling as JS

pytestmark = pytest.mark.filterwarnings("ignore:overflow encountered:RuntimeWarning")


def test_hash32_matches_numpy(rng):
    a, b, c = (rng.integers(0, 2 ** 31, 300) for _ in range(3))
    a[:3] = [0, 1, 2 ** 31 - 1]
    np.testing.assert_array_equal([JS.hash32_2(x, y) for x, y in zip(a, b)], sampler.hash32(a, b))
    np.testing.assert_array_equal([JS.hash32_3(x, y, z) for x, y, z in zip(a, b, c)], sampler.hash32(a, b, c))


@numba.njit
def _points(index, seed):
    out = np.zeros((index.shape[0], 2))
    for k in range(index.shape[0]):
        out[k, 0], out[k, 1] = JS.sobol_owen_2d(index[k], seed[k])
    return out


def test_sobol_owen_matches_numpy_compiled_and_in_python(rng):
    index = np.concatenate([np.arange(300), rng.integers(0, 2 ** 32, 300, dtype=np.int64), [2 ** 32 - 1]])
    seed = sampler.hash32(rng.integers(0, 2 ** 31, index.size), 7).astype(np.int64)
    want = sampler.sobol_owen_2d(index, seed)
    np.testing.assert_array_equal(_points(index, seed), want)
    np.testing.assert_array_equal([JS.sobol_owen_2d(i, s) for i, s in zip(index[:50], seed[:50])], want[:50])


def test_padded_sobol_matches_numpy(rng):
    """The padded points of a fixed-size set (the compiled area-light samples of camera hits), bit for bit."""
    n = rng.integers(1, 70, 200)
    index = rng.integers(0, 1 << 20, 200) % n
    key = rng.integers(0, 1 << 32, 200)
    for dim in (0, 1, 7):
        want = sampler.padded_sobol_2d(index, n, key, dim)
        got = np.array([JS.padded_sobol_2d(i, m, k, dim) for i, m, k in zip(index, n, key)])
        np.testing.assert_array_equal(got, want)
        # a progressive set (adaptive passes: NumPy's n=None, the twin's n <= 0)
        want = sampler.padded_sobol_2d(index, None, key, dim)
        got = np.array([JS.padded_sobol_2d(i, -1, k, dim) for i, k in zip(index, key)])
        np.testing.assert_array_equal(got, want)
    a, b, c, d = (rng.integers(0, 1 << 40, 50) for _ in range(4))
    np.testing.assert_array_equal([JS.hash32_4(*k) for k in zip(a, b, c, d)], sampler.hash32(a, b, c, d))
