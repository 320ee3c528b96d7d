"""The vectorisable elementary functions of :mod:`pyrt.shaders.jit_math` against NumPy's (libm's) on random and
edge inputs, compiled (their use in the kernels) and as plain Python (the same code)."""
import math

import numba
import numpy as np

from pyrt.shaders import jit_math as M


@numba.njit(cache=False)
def _eval(y, x):
    out = np.empty((4, y.size))
    for i in range(y.size):
        out[0, i] = M.atan2(y[i], x[i])
        out[1, i] = M.acos(x[i])
        out[2, i], out[3, i] = M.sincos(y[i])
    return out


def _inputs():
    rng = np.random.default_rng(7)
    n = 200_000
    y = rng.normal(size=n) * 10.0 ** rng.uniform(-8, 8, n)
    x = rng.normal(size=n) * 10.0 ** rng.uniform(-8, 8, n)
    edge_y = [0.0, -0.0, 1.0, -1.0, 0.0, 0.0, np.inf, 1e-320, 5e-324, 1.0, -1.0, 1e300, 1.0]
    edge_x = [0.0, 0.0, 0.0, 0.0, 1.0, -1.0, 1.0, 1.0, -1.0, -1e-300, -1e-300, 1e-300, np.inf]
    return np.concatenate([y, edge_y]), np.concatenate([x, edge_x])


def test_atan2_within_two_ulp_of_numpy():
    y, x = _inputs()
    got, want = _eval(y, x)[0], np.arctan2(y, x)
    ulps = np.abs(got - want) / np.spacing(np.maximum(np.abs(want), np.finfo(float).tiny))
    assert ulps.max() <= 2.0, ulps.max()
    # the axes and signed zeros exactly as libm's
    for yy in (0.0, -0.0, 1.0, -1.0):
        for xx in (0.0, -0.0, 1.0, -1.0):
            got0, want0 = M.atan2(yy, xx), math.atan2(yy, xx)
            assert got0 == want0 and math.copysign(1.0, got0) == math.copysign(1.0, want0), (yy, xx)


def test_acos_within_4e16_of_numpy_near_the_poles_too():
    rng = np.random.default_rng(8)
    x = np.concatenate([rng.uniform(-1, 1, 200_000), 1 - 10.0 ** -rng.uniform(0, 16, 20_000),
                        -1 + 10.0 ** -rng.uniform(0, 16, 20_000), [1.0, -1.0, 0.0, -0.0, 1.5, -2.0]])
    got = _eval(np.zeros_like(x), x)[1]
    assert np.abs(got - np.arccos(np.clip(x, -1.0, 1.0))).max() <= 4.5e-16
    assert M.acos(1.0) == 0.0 and M.acos(-1.0) == math.pi


def test_sincos_within_3e16_of_numpy():
    rng = np.random.default_rng(9)
    x = np.concatenate([rng.uniform(-400, 400, 200_000), rng.uniform(-1e-3, 1e-3, 10_000),
                        np.arange(-64, 65) * (math.pi / 4), [0.0, -0.0]])
    out = _eval(x, np.ones_like(x))
    assert np.abs(out[2] - np.sin(x)).max() <= 3.4e-16 and np.abs(out[3] - np.cos(x)).max() <= 3.4e-16


def test_plain_python_is_the_same_code():
    y, x = _inputs()
    got = _eval(y[:50], x[:50])
    for i in range(50):
        assert M.atan2(y[i], x[i]) == got[0, i]
        assert M.acos(x[i]) == got[1, i]
        assert M.sincos(y[i]) == (got[2, i], got[3, i])
