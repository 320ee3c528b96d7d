import os

import numpy as np
import pytest


def pytest_configure(config):
    """A run of the whole suite on several xdist workers compiles the render kernels once, before the workers start
    (``pyrt.render.warmup.compile_kernels``: both entries side by side), instead of every worker compiling both on a
    cold cache (that doubled the compile's share of the run). A run of chosen files, or in one process, compiles on
    first use as before."""
    if os.environ.get("PYTEST_XDIST_WORKER") or config.option.collectonly:
        return
    workers = config.getoption("numprocesses", 0) or 0
    whole = not config.args or all(os.path.abspath(a) == os.path.dirname(os.path.abspath(__file__))
                                   for a in config.args)
    if not (isinstance(workers, int) and workers >= 2 and whole):
        return
    from pyrt.integrators import kernel_cache
    from pyrt.render.warmup import compile_kernels

    if not kernel_cache.is_warm():
        seconds, _cached, where = compile_kernels()
        print(f"\ncompiled the render kernels once for the test workers in {seconds:.0f} s ({where})")


@pytest.fixture
def rng():
    return np.random.default_rng(12345)


@pytest.fixture(params=[np.float32, np.float64], ids=["f32", "f64"])
def dtype(request):
    return request.param
