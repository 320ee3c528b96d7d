"""``batch_rays``: a bounce shaded in slices whose spawned rays make the next bounce's batch computes what one batch
does (:meth:`pyrt.integrators.whitted.Integrator.render_samples`)."""
import numpy as np
import pytest

import pyrt
from pyrt.core.errors import RenderError
from pyrt.core.rays import RayBatch


def _scene(jitter=False, spp=1, metal=None):
    cam = pyrt.Camera(position=(0, 1.2, 3.5), target=(0, 0.4, 0), fov=45, width=24, height=18, spp=spp,
                      jitter=jitter)
    s = pyrt.Scene(cam)
    s.add_plane((0, 0, 0), 8.0, pyrt.Lambert(albedo=pyrt.CheckerTexture((0.8, 0.8, 0.8), (0.2, 0.3, 0.2), scale=8)),
                name="ground")
    s.add_sphere((-0.6, 0.5, 0), 0.5, pyrt.Glass(ior=1.5), name="glass")
    s.add_sphere((0.6, 0.5, -0.3), 0.45, metal or pyrt.Mirror(), name="mirror")
    s.add_light(pyrt.PointLight((2, 4, 2), intensity=30))
    return s


@pytest.mark.parametrize("integrator", ["whitted", "glossy"])
def test_slices_at_least_the_chunk_change_nothing(integrator):
    s = _scene(jitter=True, spp=4, metal=pyrt.CookTorrance(kd=0.1, ks=0.9, roughness=0.3))
    a = pyrt.render(s, seed=1, integrator=integrator, threads=1)
    b = pyrt.render(s, seed=1, integrator=integrator, threads=1, batch_rays=1 << 15)
    np.testing.assert_array_equal(a, b)


def test_deterministic_paths_give_the_same_image_in_slices():
    """Delta light, delta lobes, no jitter: nothing random, so slicing only reorders float64 additions."""
    s = _scene()
    a = pyrt.render_full(s, threads=1, aovs=True, split_depth=None)   # the full tree: no random branch choice
    for step in (1, 7, 100):
        b = pyrt.render_full(s, threads=1, aovs=True, batch_rays=step, split_depth=None)
        np.testing.assert_allclose(b.image, a.image, rtol=1e-6, atol=1e-7)   # float32 image
        for k in a.aovs:
            np.testing.assert_array_equal(b.aovs[k], a.aovs[k])
        assert b.stats.rays == a.stats.rays and b.stats.secondary_rays > 0


def test_sliced_glossy_render_is_the_same_estimate():
    """Glossy rays in slices draw other random numbers: the same mean within standard errors."""
    s = _scene(jitter=True, spp=8, metal=pyrt.CookTorrance(kd=0.1, ks=0.9, roughness=0.3))
    a = [pyrt.render(s, seed=k, integrator="glossy", threads=1) for k in range(3)]
    b = [pyrt.render(s, seed=k, integrator="glossy", threads=1, batch_rays=500) for k in range(3)]
    ma, mb = np.mean(a), np.mean(b)
    se = np.hypot(np.std([x.mean() for x in a]), np.std([x.mean() for x in b])) / np.sqrt(3) + 1e-4 * ma
    assert abs(ma - mb) < 5 * se, (ma, mb, se)


def test_bad_batch_rays():
    with pytest.raises(RenderError, match="batch_rays"):
        pyrt.render(_scene(), batch_rays=0)


def test_raybatch_rows_and_concatenate():
    rng = np.random.default_rng(0)
    n = 10
    b = RayBatch(rng.random((n, 3)), rng.random((n, 3)), sample=np.arange(n) * 2, throughput=rng.random((n, 3)),
                 differentials=tuple(rng.random((n, 3)) for _ in range(4)), bsdf_pdf=rng.random(n), depth=2)
    parts = [b.rows(0, 3), b.rows(3, 7), b.rows(7, 10)]
    c = RayBatch.concatenate(parts)
    for name in ("origins", "directions", "sample", "throughput", "bsdf_pdf"):
        np.testing.assert_array_equal(getattr(c, name), getattr(b, name))
    for x, y in zip(c.differentials, b.differentials):
        np.testing.assert_array_equal(x, y)
    assert c.depth == 2 and c.stack is None
    parts[1].bsdf_pdf = None                         # delta-lobe rays: pdf 0 where a part has none
    c = RayBatch.concatenate(parts)
    assert np.all(c.bsdf_pdf[3:7] == 0) and np.array_equal(c.bsdf_pdf[:3], b.bsdf_pdf[:3])
