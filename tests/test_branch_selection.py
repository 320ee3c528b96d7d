"""Stochastic branch selection at dielectric interfaces (``split_depth``, :func:`choose_one_lobe`): following one
delta lobe per hit, chosen by weight and weighted 1 / p, has the deterministic splitting tree's value as its
mean (within standard errors, per ray and channel), and a ray costs one path instead of a tree."""
import numpy as np
import pytest

import pyrt
from pyrt.core.rays import RayBatch
from pyrt.integrators import Integrator, PreparedScene
from pyrt.integrators.whitted import choose_one_lobe
from pyrt.materials import DeltaLobe

COPIES = 3000


def _scene():
    """Two glass spheres (one tinted and absorbing, so nested-media stacks are on) over a Lambert floor, a point
    light and a coloured background; deterministic under splitting (delta light, no sampled lobe)."""
    cam = pyrt.Camera(position=(0, 1.0, 4.0), target=(0, 0.6, 0), fov=40.0, width=8, height=8, spp=1)
    scene = pyrt.Scene(cam, background=(0.3, 0.5, 0.9))
    scene.add_plane((0, 0, 0), 10.0, pyrt.Lambert(albedo=(0.8, 0.6, 0.4)), name="floor")
    scene.add_sphere((-0.45, 0.6, 0), 0.5, pyrt.Glass(ior=1.5), name="clear")
    scene.add_sphere((0.5, 0.55, 0.2), 0.45, pyrt.Glass(ior=1.33, tint=(1.0, 0.9, 0.8), absorption=(0.2, 0.8, 2.0)),
                     name="tinted")
    scene.add_light(pyrt.PointLight((1.0, 3.0, 2.0), intensity=8.0))
    return scene


def _rays(scene):
    """Six camera rays through the spheres (centre, rims where Fresnel reflection is strong, the gap)."""
    o = np.array(scene.camera.position, dtype=np.float64)
    targets = np.array([[-0.45, 0.6, 0.0], [-0.9, 0.7, 0.0], [-0.45, 1.05, 0.1], [0.5, 0.55, 0.2],
                        [0.9, 0.5, 0.3], [0.05, 0.5, 0.0]])
    d = targets - o
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    return np.broadcast_to(o, d.shape).copy(), d


def _render(ps, o, d, copies, **kw):
    integ = Integrator(ps, max_depth=7, throughput_cutoff=0.0, transparent_shadows=True, **kw)
    L, _ = integ.render_samples(RayBatch(np.repeat(o, copies, axis=0), np.repeat(d, copies, axis=0)),
                                rng=np.random.default_rng(7))
    return L.reshape(o.shape[0], copies, 3), integ.stats


@pytest.mark.parametrize("split_depth", [0, 1])
def test_one_branch_per_hit_has_the_splitting_value_as_its_mean(split_depth):
    scene = _scene()
    o, d = _rays(scene)
    ps = PreparedScene(scene)
    try:
        ref, ref_stats = _render(ps, o, d, 1)
        ref = ref[:, 0]
        est, stats = _render(ps, o, d, COPIES, split_depth=split_depth)
    finally:
        ps.close()
    assert ps.media is not None                     # the nested-media stacks were carried along
    mean = est.mean(axis=1)
    se = est.std(axis=1, ddof=1) / np.sqrt(COPIES)
    assert np.all(ref > 0) and np.all(se[:5] > 0)   # the glass rays are random now; the gap ray may be too
    z = np.abs(mean - ref) / np.maximum(se, 1e-12 * ref)
    assert z.max() < 4.5, (z, mean, ref)
    # fewer rays: splitting traces a tree per camera ray, selection (from the first bounce on) about one path
    rays_per_camera_ray = stats.secondary_rays / (o.shape[0] * COPIES)
    assert rays_per_camera_ray < ref_stats.secondary_rays / o.shape[0]


def test_choose_one_lobe_keeps_one_lobe_and_the_expected_weight():
    rng = np.random.default_rng(3)
    n = 200000
    w_r = np.tile([0.1, 0.2, 0.3], (n, 1))
    w_t = np.tile([0.8, 0.5, 0.0], (n, 1))
    w_z = np.zeros((n, 3))                          # a lobe of weight 0 is never chosen
    wi = np.tile([0.0, 0.0, 1.0], (n, 1))
    out = choose_one_lobe([DeltaLobe(wi, w_r, "reflect"), DeltaLobe(wi, w_z, "reflect"),
                           DeltaLobe(-wi, w_t, "refract", np.ones(n))], rng.random(n))
    nonzero = np.stack([o.weight.max(axis=1) > 0 for o in out])
    assert np.all(nonzero.sum(axis=0) == 1) and not nonzero[1].any()
    p_r = 0.2 / (0.2 + 13.0 / 30.0)
    assert abs(nonzero[0].mean() - p_r) < 5 * np.sqrt(p_r * (1 - p_r) / n)
    for o, w in zip(out, (w_r, w_z, w_t)):
        np.testing.assert_allclose(o.weight.mean(axis=0), w[0], rtol=0.01, atol=1e-12)
    assert out[2].kind == "refract" and out[2].eta is not None
    # all lobes of weight 0: none kept
    none = choose_one_lobe([DeltaLobe(wi[:4], w_z[:4], "reflect")] * 2, rng.random(4))
    assert all(not o.weight.any() for o in none)


def test_split_depth_is_checked_and_reaches_render_full():
    scene = _scene()
    with pytest.raises(pyrt.RenderError):
        pyrt.render_full(scene, split_depth=-1)
    a = pyrt.render_full(scene, split_depth=None, seed=1)
    b = pyrt.render_full(scene, split_depth=0, seed=1)
    assert b.stats.secondary_rays < a.stats.secondary_rays
