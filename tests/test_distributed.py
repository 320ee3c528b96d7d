"""Renders on Dask (pyrt.render.distributed): the merged image equals the local render with the same seed,
bit for bit, for fixed-spp renders (whole-pixel chunks and pixels split into pieces) and adaptive ones."""
import numpy as np
import pytest

import pyrt

distributed = pytest.importorskip("distributed")

from test_adaptive import _scene  # noqa: E402


@pytest.fixture(scope="module")
def client():
    cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None)
    c = distributed.Client(cluster)
    yield c
    c.close()
    cluster.close()


def test_fixed_spp_equals_local(client):
    scene = _scene(20, 12)
    # AOVs on Dask workers render on the NumPy path (a fallback reason): the local render on it too
    a = pyrt.render_full(scene, spp=8, seed=4, aovs=True, backend="numpy")
    b = pyrt.render_full(scene, spp=8, seed=4, aovs=True, dask=client, chunk_samples=1 << 15)
    assert b.stats.backend == "numpy" and any("AOVs on Dask" in x for x in b.stats.fallback_reasons)
    assert b.complete and np.array_equal(a.film.sum, b.film.sum) and np.array_equal(a.image, b.image)
    assert all(np.array_equal(a.aovs[k], b.aovs[k]) for k in a.aovs)
    assert a.stats.rays == b.stats.rays


def test_fixed_spp_pieces_equal_local(client):
    scene = _scene(3, 2)
    a = pyrt.render_full(scene, spp=300, seed=5, chunk_samples=128)
    b = pyrt.render_full(scene, spp=300, seed=5, chunk_samples=128, dask=client)
    assert np.array_equal(a.film.sum, b.film.sum) and np.array_equal(a.film.weight, b.film.weight)


def test_adaptive_equals_local(client):
    scene = _scene(20, 12)
    # adaptive passes on Dask workers run the NumPy path (said in fallback_reasons): the local render on it too
    a = pyrt.render_full(scene, target_error=3e-4, seed=6, backend="numpy")
    b = pyrt.render_full(scene, target_error=3e-4, seed=6, dask=client)
    assert b.stats.backend == "numpy" and any("Dask" in x for x in b.stats.fallback_reasons)
    assert a.passes == b.passes and a.passes > 1
    assert np.array_equal(a.film.weight, b.film.weight) and np.array_equal(a.image, b.image)
    assert b.estimated_error == a.estimated_error


def test_bad_dask_argument():
    with pytest.raises(pyrt.RenderError, match="dask must be"):
        pyrt.render(_scene(4, 4), spp=1, dask=3.5)


def test_compiled_render_on_dask_equals_local(client):
    """A scene the compiled kernel covers renders as groups of tiles on the workers: the same film, bit for bit."""
    from test_compiled_render import _scene as compiled_scene
    scene = compiled_scene(width=40, height=30, spp=4, jitter=True)
    a = pyrt.render_full(scene, seed=3, progress=False)
    b = pyrt.render_full(scene, seed=3, progress=False, dask=client)
    assert a.stats.backend == b.stats.backend == "compiled"
    assert b.complete and np.array_equal(a.film.sum, b.film.sum) and np.array_equal(a.film.weight, b.film.weight)
    assert a.stats.rays == b.stats.rays
