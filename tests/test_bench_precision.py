"""tools/bench_precision.py times the same kernels in float64 and float32: they must compute the same thing, and the
float32 run must really be float32 (else the tool's ratios would mean nothing)."""
import os
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "tools"))
import bench_precision  # noqa: E402


def _arrays(x):
    return [np.asarray(a) for a in (x if isinstance(x, tuple) else (x,))]


def test_both_precisions_agree_and_the_float32_run_is_float32():
    for name, (f64, f32) in bench_precision.kernels(4096, seed=3).items():
        for a, b in zip(_arrays(f64()), _arrays(f32())):
            assert b.dtype == np.float32, name
            assert a.shape == b.shape and np.all(np.isfinite(a)) and np.all(np.isfinite(b)), name
            # float32 rounding of the inputs, carried through: measured up to 1.1e-4 (the BRDF near its GGX peak;
            # the bilinear lookup, whose uv in [0, 4) rounds by up to 2.4e-4 texel across texels differing by <= 1),
            # 1e-5 or less for the others (seeds 3-5)
            scale = np.maximum(np.abs(a), 1.0)
            assert np.max(np.abs(a - b) / scale) < 2e-4, (name, np.max(np.abs(a - b) / scale))


def test_the_tool_prints_a_ratio_per_kernel(capsys):
    bench_precision.main(["--lanes", "256", "--rounds", "2"])
    out = capsys.readouterr().out.splitlines()
    assert out[0].startswith("machine: ")
    assert [line.split()[0] for line in out[1:]] == list(bench_precision.kernels(8))
    assert all("ratio" in line for line in out[1:])
