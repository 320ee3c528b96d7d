"""pyrt.geometry.memo.row_memo: every view of a batch gets exactly what the kernel gives on it, each hit computed
at most once per batch (counted), for slices, index views, views of views and repeated rows."""
import numpy as np
import pytest

from pyrt.geometry import SurfaceBatch
from pyrt.geometry.memo import row_memo
from pyrt.materials import Lambert
from pyrt.textures import ImageTexture


@pytest.fixture
def batch():
    rng = np.random.default_rng(7)
    n = 50
    return SurfaceBatch(p=rng.random((n, 3)), uv=rng.random((n, 2)), ns=np.tile([0.0, 0.0, 1.0], (n, 1)))


def counting_kernel(log):
    def kernel(ctx):
        log.append(ctx.n_hits)
        return np.column_stack([ctx.uv[:, 0] * 2.0 + ctx.p[:, 1], ctx.uv[:, 1]])
    return kernel


def direct(ctx):
    return np.column_stack([ctx.uv[:, 0] * 2.0 + ctx.p[:, 1], ctx.uv[:, 1]])


def test_views_get_the_kernel_values_and_each_hit_is_computed_once(batch):
    log = []
    k = counting_kernel(log)
    views = [batch.subset(np.arange(10, 30)),                      # distinct rows
             batch.subset(slice(5, 15)),                           # a slice, overlapping
             batch.subset(np.repeat(np.arange(0, 40, 3), 4)),      # repeated rows (several samples per hit)
             batch.subset(np.arange(20, 50)).subset(np.arange(0, 30, 2)),   # a view of a view
             batch]                                                # the whole batch
    for v in views:
        got = row_memo(v, "k", k)
        np.testing.assert_array_equal(got, direct(v))
    assert sum(log) == batch.n_hits          # every hit once, none twice
    n_before = len(log)
    for v in views:                          # all computed now: only gathers
        np.testing.assert_array_equal(row_memo(v, "k", k), direct(v))
    assert len(log) == n_before


def test_repeated_rows_are_computed_once_each(batch):
    log = []
    v = batch.subset(np.repeat(np.arange(7), 5))
    np.testing.assert_array_equal(row_memo(v, "k", counting_kernel(log)), direct(v))
    assert log == [7]


def test_results_are_new_arrays_and_keys_are_separate(batch):
    v = batch.subset(slice(0, 10))
    a = row_memo(v, "k", direct)
    a[:] = -1.0
    np.testing.assert_array_equal(row_memo(v, "k", direct), direct(v))
    log = []
    row_memo(v, "other", counting_kernel(log))
    assert log == [10]


def test_objects_that_are_not_batches_are_computed_directly():
    class Ctx:
        n_hits = 3
        uv = np.ones((3, 2))
        p = np.zeros((3, 3))
    np.testing.assert_array_equal(row_memo(Ctx(), "k", direct), direct(Ctx()))


def test_a_texture_parameter_is_looked_up_once_per_hit_across_views(batch, monkeypatch):
    rng = np.random.default_rng(3)
    tex = ImageTexture(rng.random((8, 8, 3)), filter="bilinear")
    mat = Lambert(tex)
    rows = []
    real = ImageTexture._evaluate
    monkeypatch.setattr(ImageTexture, "_evaluate", lambda self, ctx: rows.append(ctx.n_hits) or real(self, ctx))
    a = batch.subset(np.arange(0, 30))
    b = batch.subset(np.repeat(np.arange(20, 50), 3))
    want_a, want_b = tex.lookup(a.uv), tex.lookup(b.uv)
    rows.clear()
    np.testing.assert_array_equal(mat.param(tex, a), want_a)
    np.testing.assert_array_equal(mat.param(tex, b), want_b)
    assert sum(rows) == batch.n_hits
