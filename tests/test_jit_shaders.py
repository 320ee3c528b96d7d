"""The scalar formulas of :mod:`pyrt.shaders.jit` (what the compiled kernel computes) against their NumPy twins.

Each twin is evaluated on random inputs with grazing and degenerate cases added, in float64, and must agree to
1e-6 relative (absolute below 1e-12): the compiled path and the NumPy reference use one formula each, and this is
what keeps them one. The scalars run as plain Python here (``register_jitable`` functions are Python functions
too); tests/test_compiled_render.py checks them compiled, inside whole renders.
"""
import math

import numba
import numpy as np
import pytest

from pyrt.shaders import brdfs, fresnel, lights
from pyrt.shaders import jit as J
from pyrt.geometry import offsets

# the 64-bit hashes wrap around by design (NumPy scalars warn when run as Python)
pytestmark = pytest.mark.filterwarnings("ignore:overflow encountered:RuntimeWarning")


def _close(a, b):
    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    assert np.all(np.isfinite(a)), a
    np.testing.assert_allclose(a, b, rtol=1e-6, atol=1e-12)


def _cosines(rng, n=400):
    """Cosines in [-1, 1] with the grazing ends and exact 0, +-1 included."""
    c = rng.uniform(-1, 1, n)
    c[:12] = [0.0, 1.0, -1.0, 1e-9, -1e-9, 1e-4, 0.9999999, -0.9999999, 0.5, -0.5, 1e-300, 0.7071]
    return c


def test_fr_dielectric_matches_numpy(rng):
    cos = _cosines(rng)
    for eta in (1.5, 1 / 1.5, 1.0, 2.4, 1.000001):
        _close([J.fr_dielectric(c, eta) for c in cos], fresnel.fr_dielectric(cos, eta))


def test_fr_dielectric_is_one_under_total_internal_reflection():
    assert J.fr_dielectric(0.1, 1 / 1.5) == 1.0


def _directions(rng, n):
    """Unit vectors (n, 3), a few at the horizon (z = 0, +-1e-9) and along +-z."""
    w = rng.normal(size=(n, 3))
    w[:4, 2] = [0.0, 1e-9, -1e-9, 0.0]
    w[4] = [0, 0, 1.0]
    w[5] = [0, 0, -1.0]
    return w / np.linalg.norm(w, axis=1, keepdims=True)


def test_blinn_phong_matches_numpy(rng):
    n = 400
    wo, wi = _directions(rng, n), _directions(rng, n)
    wi[6] = wo[6]                 # the mirror-free half vector along the normal: n.h = 1
    wi[7] = -wo[7]                # wo + wi = 0: no half vector
    cos_o, cos_i, cos_io = wo[:, 2], wi[:, 2], np.sum(wo * wi, axis=1)
    kd, ks = np.array([0.2, 0.3, 0.4]), np.array([0.3, 0.2, 0.1])
    for e in (0.0, 1.0, 32.0, 120.0, 4000.0):
        want = brdfs.blinn_phong_normalized_f_cos_cosines(cos_o, cos_i, cos_io, kd, ks, e)
        got = np.array([[(kd[c] / math.pi + ks[c] * J.blinn_phong_spec(o, i, io, e)) * J.upper_cos(o, i)
                         for c in range(3)] for o, i, io in zip(cos_o, cos_i, cos_io)])
        _close(got, want)


def test_lambert_matches_numpy(rng):
    cos_o, cos_i = _cosines(rng), _cosines(rng)[::-1].copy()
    albedo = np.array([0.7, 0.2, 0.05])
    want = brdfs.lambert_f_cos_cosines(cos_o, cos_i, albedo)
    got = np.array([[albedo[c] * J.upper_cos(o, i) / math.pi for c in range(3)] for o, i in zip(cos_o, cos_i)])
    _close(got, want)


@pytest.mark.parametrize("kind", J.SPOT_KINDS)
def test_spot_falloff_matches_numpy(rng, kind):
    cos = _cosines(rng)
    for ci, co in ((0.95, 0.8), (0.9, 0.9), (1.0, -1.0), (0.5, 0.49999)):
        want = lights.SPOT_FALLOFFS[kind](cos, ci, co)
        _close([J.spot_falloff(J.SPOT_KINDS.index(kind), c, ci, co) for c in cos], want)


@pytest.mark.parametrize("kind", J.DISTANCE_KINDS)
def test_distance_falloff_matches_numpy(rng, kind):
    r = np.concatenate([[0.0, 1e-9, 2.9999, 3.0, 3.5], rng.uniform(0, 5, 200)])
    rng_ = np.inf if kind in ("inverse_square", "inverse_square_eps", "clq") else 3.0
    args = dict(eps=0.25, light_range=rng_, clq=(0.5, 0.3, 0.2))
    want = lights.distance_falloff(r, kind, **args)
    got = [J.distance_falloff(J.DISTANCE_KINDS.index(kind), x, 0.25, rng_, 0.5, 0.3, 0.2) for x in r]
    _close(got, want)


def test_distance_falloff_with_range_cuts_at_the_range():
    k = J.DISTANCE_KINDS.index("inverse_square")
    assert J.distance_falloff(k, 2.0, 0, 2.0, 0, 0, 1) == 0.0
    assert J.distance_falloff(k, 1.9, 0, 2.0, 0, 0, 1) == pytest.approx(1 / 1.9 ** 2)


@pytest.mark.parametrize("name", ["float32_step", "float32_step_vec"])
def test_float32_step_is_round_away(rng, name):
    """Both forms (branches, selects) bit-identical (up to the sign of zero) to np.nextafter after the float32 cast, powers of two (where the spacing changes), subnormals,
    the normal/subnormal boundary and the largest float32 included."""
    p2 = 2.0 ** np.arange(-130, 128)
    edge = np.array([0.0, -0.0, 1e-45, -1e-45, 2.0 ** -126, -(2.0 ** -126), 1.1754942e-38, 3.4028235e38, 1e30, 3.0])
    x = np.concatenate([rng.normal(0, 10, 3000), rng.normal(0, 1e-3, 1000) * 10.0 ** rng.integers(-40, 38, 1000),
                        p2, -p2, np.nextafter(p2.astype(np.float32), 0).astype(np.float64), edge])
    x = np.concatenate([x, x])
    d = np.concatenate([np.ones(x.size // 2), -np.ones(x.size // 2)])
    d[:5] = [1.0, -1.0, 0.0, 1.0, -1.0]
    want = offsets._round_away(x[:, None] * np.ones((1, 3)), d[:, None] * np.ones((1, 3)))[:, 0]
    with np.errstate(over="ignore"):
        got = [getattr(J, name)(a, b) for a, b in zip(x, d)]
    got = np.array(got)
    np.testing.assert_array_equal(got, want)      # (equal values: -1e-45 stepped up is +0.0 here, -0.0 there)
    assert np.array_equal(got.view(np.int64)[got != 0], want.view(np.int64)[want != 0])
    # compiled, in a loop over an array (the vectorised form where the compiler vectorises it)
    got_c = _step_loop(getattr(J, name))(x, d)
    np.testing.assert_array_equal(got_c, want)
    assert np.array_equal(got_c.view(np.int64)[got_c != 0], want.view(np.int64)[want != 0])


def _step_loop(step):
    """A compiled loop applying ``step`` elementwise (what the kernel's lane loops do)."""
    @numba.njit(error_model="numpy")
    def loop(x, d):
        out = np.empty_like(x)
        for i in range(x.size):
            out[i] = step(x[i], d[i])
        return out
    return loop


def test_float32_step_of_infinities_and_nan():
    """Its branch-free form keeps np.nextafter's answers at the ends: an infinity stays outward and becomes the largest
    float32 inward; NaN stays NaN (in Python and compiled)."""
    step = numba.njit(lambda x, d: J.float32_step(x, d))
    step_vec = numba.njit(lambda x, d: J.float32_step_vec(x, d))
    for x in (np.inf, -np.inf, np.nan):
        for d in (1.0, -1.0):
            want = np.float64(np.nextafter(np.float32(x), np.float32(d * np.inf)))
            for f in (J.float32_step, step, J.float32_step_vec, step_vec):
                got = f(x, d)
                assert (np.isnan(got) and np.isnan(want)) or got == want, (x, d, got, want)


def test_gamma_matches_offsets():
    assert J.gamma(4.0, J.EPS64) == offsets._gamma(4, offsets._EPS64)
    assert J.gamma(7.0, J.EPS32) == offsets._gamma(7)


def test_uniform_is_uniform_and_keyed():
    """Counter-based numbers: in [0, 1), distinct per key and dimension, uniform (chi-square over 64 bins)."""
    u = np.array([J.uniform(J.key64(3, p, s), d) for p in range(40) for s in range(16) for d in range(8)])
    assert u.min() >= 0.0 and u.max() < 1.0
    assert np.unique(u).size == u.size
    counts = np.bincount((u * 64).astype(int), minlength=64)
    expected = u.size / 64
    chi2 = float(np.sum((counts - expected) ** 2 / expected))
    assert chi2 < 120.0          # 63 degrees of freedom: P(chi2 > 120) ~ 1e-5
    assert J.uniform(J.key64(3, 5, 7), 2) == J.uniform(J.key64(3, 5, 7), 2)
    assert J.uniform(J.key64(4, 5, 7), 2) != J.uniform(J.key64(3, 5, 7), 2)


@pytest.mark.parametrize("n", [1, 2, 3, 7, 16, 17, 100])
def test_permute_is_a_permutation(n):
    for seed in (0, 1, 12345, 2 ** 31 - 1):
        assert sorted(J.permute(i, n, seed) for i in range(n)) == list(range(n))


class _Fixed:
    """A stand-in generator whose ``random`` returns the given array (the jitter of each sample)."""

    def __init__(self, xi):
        self.xi = xi

    def random(self, shape):
        return self.xi.reshape(shape)


@pytest.mark.parametrize("spp", [1, 2, 3, 5, 7, 16, 17, 99, 768, 1000, 4097])
def test_strata_position_is_pixel_strata(rng, spp):
    """The kernel's equal-area grid (float floors, no integer division) is pyrt.core.sampler.pixel_strata's
    (to rounding: the same cells, the same point in each), compiled and in Python; isqrt is exact."""
    from pyrt.core.sampler import pixel_strata
    s = np.arange(spp)
    xi = rng.random((spp, 2))
    xi[:2] = [[0.0, 0.0], [1.0 - 2.0 ** -53, 1.0 - 2.0 ** -53]][:min(2, spp)]
    want = pixel_strata(_Fixed(xi), spp, s)
    k = J.isqrt(spp)
    assert k * k <= spp < (k + 1) * (k + 1)
    got = np.array([J.strata_position(float(spp), float(k), float(i), a, b) for i, (a, b) in zip(s, xi)])
    np.testing.assert_allclose(got, want, rtol=1e-14, atol=1e-15)
    compiled = numba.njit(lambda n, r, i, a, b: J.strata_position(n, r, i, a, b))
    got_c = np.array([compiled(float(spp), float(k), float(i), a, b) for i, (a, b) in zip(s[:50], xi[:50])])
    np.testing.assert_allclose(got_c, want[:50], rtol=1e-14, atol=1e-15)
    assert numba.njit(lambda n: J.isqrt(n))(spp) == k


def test_wide_vectors_asks_llvm_for_512_bit_vectors():
    """pyrt.core.unmanaged.wide_vectors: the same results, and 512-bit registers in the loop on an AVX-512 CPU
    (LLVM's default tuning there stays at 256 bits)."""
    import llvmlite.binding as llvm
    from pyrt.core.unmanaged import wide_vectors

    @numba.njit(error_model="numpy")
    def wide(a, b):
        wide_vectors()
        for i in range(a.size):
            a[i] = a[i] * b[i] + 1.0

    @numba.njit(error_model="numpy")
    def plain(a, b):
        for i in range(a.size):
            a[i] = a[i] * b[i] + 1.0

    x, y = np.arange(100.0), np.linspace(0, 1, 100)
    a, b = x.copy(), x.copy()
    wide(a, y)
    plain(b, y)
    np.testing.assert_array_equal(a, b)
    if "+avx512f" in llvm.get_host_cpu_features().flatten():
        assert "zmm" in list(wide.inspect_asm().values())[0]


def test_prefetch_changes_nothing():
    """pyrt.core.unmanaged.prefetch: a prefetch instruction in the code, the same results, and no fault for addresses
    outside the array (a prefetch never faults)."""
    from pyrt.core.unmanaged import pointer, prefetch

    @numba.njit(error_model="numpy")
    def gather(a, idx, pf):
        p = pointer(a)
        s = 0.0
        for k in range(idx.size):
            if pf:
                prefetch(p, idx[min(k + 8, idx.size - 1)])
                prefetch(p, idx[k] + 1 << 40)
            s += p[idx[k]] * (k + 1)
        return s

    a = np.random.default_rng(2).random(1 << 16)
    idx = np.random.default_rng(3).integers(0, a.size, 5000)
    assert gather(a, idx, True) == gather(a, idx, False)
    assert "prefetch" in list(gather.inspect_asm().values())[0]


def test_robust_tmax_matches_offsets(rng):
    """The compiled kernel's shadow-ray length equals pyrt.geometry.offsets.robust_tmax (the robust strategy)."""
    o = rng.normal(0, 50, (200, 3))
    end = rng.normal(0, 50, 3)
    wi = end - o
    wi /= np.linalg.norm(wi, axis=1, keepdims=True)
    o[:3] = [[1e-9, 0, 0], [1e4, -1e4, 3], end + 1e-7]         # tiny, far, and a light almost at the origin
    want = offsets.robust_tmax(o, wi, end)
    got = [J.robust_tmax(a, w, end[0], end[1], end[2], True) for a, w in zip(o, wi)]
    np.testing.assert_allclose(got, want, rtol=1e-12)
    assert J.robust_tmax(o[0], wi[0], 0.0, 0.0, 0.0, False) == np.inf


def test_wrap_int_is_python_modulo():
    """J.wrap_int: Python's ``%`` on every index near and far from [0, n) (the division only off the fast range)."""
    f = numba.njit(lambda i, n: J.wrap_int(i, n))
    for n in (1, 2, 3, 7, 512):
        for i in list(range(-3 * n - 2, 3 * n + 3)) + [-10**12 - 1, 10**12 + 7]:
            assert f(i, n) == i % n
