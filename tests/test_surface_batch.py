"""SurfaceBatch life cycle: lazy fields, and no reference cycles (big arrays are freed when the batch is)."""
import gc
import weakref

import numpy as np
import pytest

import pyrt
from pyrt.geometry.surface import surface_from_hits
from pyrt.integrators import PreparedScene


def _batch():
    cam = pyrt.Camera(position=(0, 1, 3), target=(0, 0.5, 0), width=32, height=24)
    scene = pyrt.Scene(cam)
    scene.add_plane((0, 0, 0), 4.0, pyrt.Lambert(0.5))
    scene.add_sphere((0, 0.5, 0), 0.5, pyrt.BlinnPhong(), subdivisions=2)
    ps = PreparedScene(scene)
    rays = cam.generate_rays(0, 32 * 24, np.random.default_rng(0), differentials=False)
    o, d = rays.origins, rays.directions
    idx, hits = ps.accel.intersect_hits(o, d)
    return surface_from_hits(ps.geo, hits, o[idx], d[idx])


@pytest.mark.parametrize("touched", [(), ("p_lift", "uv"), ("frame_s", "frame_t", "p_lift", "uv", "tri_v",
                                                               "p_error", "tri_extent")])
def test_batches_are_freed_without_the_cycle_collector(touched):
    gc.disable()
    try:
        surf = _batch()
        sub = surf.subset(np.arange(0, surf.n_hits, 2))
        for name in touched:
            assert getattr(surf, name) is not None
            assert getattr(sub, name) is not None
        refs = [weakref.ref(surf), weakref.ref(sub)]
        del surf, sub
        assert all(r() is None for r in refs), "a SurfaceBatch is part of a reference cycle"
    finally:
        gc.enable()


def test_lazy_frame_is_orthonormal_and_follows_a_new_shading_normal():
    surf = _batch()
    s, t, n = surf.frame_s, surf.frame_t, surf.ns
    for a, b in ((s, t), (s, n), (t, n)):
        np.testing.assert_allclose(np.einsum("ij,ij->i", a, b), 0, atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(s, axis=1), 1, atol=1e-12)
    flipped = -surf.ns
    surf.set_shading_normal(flipped)
    np.testing.assert_allclose(np.einsum("ij,ij->i", surf.frame_s, flipped), 0, atol=1e-12)


class _CountingTexture(pyrt.Texture):
    """A per-hit texture (a function of the hit point) that counts its evaluations and the lanes it read."""

    channels = 3

    def __init__(self):
        self.calls = 0
        self.lanes = 0

    def evaluate(self, ctx):
        self.calls += 1
        self.lanes += ctx.n_hits
        return np.abs(np.sin(7.0 * ctx.p))


def test_a_view_gathers_texture_lookups_its_parent_made():
    """Material.param on a view cut from a batch that already read the texture gathers that lookup (the BSDF
    sample and pdf of an estimator reuse what f_cos read), and the values are those of a direct lookup."""
    surf = _batch()
    tex = _CountingTexture()
    mat = pyrt.Lambert(albedo=tex)
    group = surf.subset(np.arange(1, surf.n_hits, 2))
    full = mat.param(tex, group)
    assert tex.calls == 1
    view = group.subset(np.arange(3, group.n_hits, 5)).subset(np.array([4, 0, 2]))
    got = mat.param(tex, view)
    assert tex.calls == 1, "the view read the texture again"
    direct = np.abs(np.sin(7.0 * view.p))
    assert np.array_equal(got, direct)
    assert np.array_equal(got, full[np.arange(3, group.n_hits, 5)[[4, 0, 2]]])
    # a batch that is not an ancestor has nothing to give: evaluated (once) on its own lanes
    other = surf.subset(np.arange(0, surf.n_hits, 3))
    mat.param(tex, other)
    assert tex.calls == 2
