"""Russian roulette, transparent shadows and transmission on the compiled path against the NumPy path.

The two paths draw different random numbers, so their images agree in distribution (as in
``tests/test_compiled_glossy.py``): per pixel, the difference of the means of R renders of each divided by its
standard error from the renders' spread must look like a standard normal (mean near 0, spread near 1, few beyond 5),
and the mean brightness of the two agrees to a fraction of a percent.
"""
import numpy as np
import pytest

import pyrt
from pyrt.integrators import compiled
from pyrt.integrators.compiled_hit import survive

KEY = np.uint64(0x1234ABCD)


def _renders(scene, backend, seeds, **kw):
    """Mean image and its squared standard error over renders with ``seeds``; the paths taken."""
    imgs, paths = [], set()
    for seed in seeds:
        r = pyrt.render_full(scene, seed=seed, execution=pyrt.Execution(backend=backend, progress=False), **kw)
        imgs.append(r.image.astype(np.float64))
        paths.add(r.stats.backend)
    a = np.array(imgs)
    return a.mean(axis=0), a.var(axis=0, ddof=1) / len(seeds), paths


def _z_agree(ma, va, mb, vb, rel_tol=0.005):
    """The per-pixel z-scores of two mean images look standard normal and their mean brightness agrees."""
    z = (ma - mb) / np.sqrt(va + vb + 1e-12)
    # z of R = 4 renders each is t-like (heavier tails than a normal): loose bounds; a bias shifts the mean z by far
    # more and the mean brightness by percents
    assert abs(z.mean()) < 0.1, z.mean()
    assert 0.75 < z.std() < 1.25, z.std()
    assert (np.abs(z) > 5).mean() < 0.005
    rel = abs(ma.mean() - mb.mean()) / mb.mean()
    assert rel < rel_tol, rel


def _assert_agree(scene, R=4, **kw):
    mc, vc, pc = _renders(scene, "compiled", range(100, 100 + R), **kw)
    mn, vn, pn = _renders(scene, "numpy", range(200, 200 + R), **kw)
    assert pc == {"compiled"} and pn == {"numpy"}
    _z_agree(mc, vc, mn, vn)
    return mc, vc, mn, vn


def _glass_scene(width=40, height=30, spp=16):
    """A glass sphere and slab (tinted), a mirror and a glossy sphere on a checker floor under a point light, a
    rectangle light with its visible mesh and a sky-coloured background."""
    cam = pyrt.Camera(position=(0, 1.3, 4.0), target=(0, 0.5, 0), fov=40, width=width, height=height, spp=spp,
                      jitter=True)
    s = pyrt.Scene(cam, background=(0.5, 0.6, 0.8), ambient=(0.01, 0.01, 0.01))
    s.add_plane((0, 0, 0), 6.0, pyrt.Lambert(albedo=pyrt.CheckerTexture(0.15, 0.8, scale=6, filtered=False)))
    s.add_sphere((-0.9, 0.45, -0.3), 0.45, pyrt.CookTorrance(kd=0.1, ks=0.8, roughness=0.3), subdivisions=3)
    glass = pyrt.Glass(ior=1.5, tint=(0.95, 0.9, 0.75))      # one dielectric (two are nested media: NumPy path)
    s.add_sphere((0.0, 0.5, 0.4), 0.5, glass, subdivisions=3)
    s.add_box((0.95, 0.4, -0.2), (0.1, 0.8, 0.8), glass)
    s.add_box((0.0, 0.6, -1.2), (1.4, 1.2, 0.05), pyrt.Mirror(reflectance=0.8))
    s.add_light(pyrt.PointLight((2, 3, 2), intensity=20.0))
    pyrt.RectLight(center=(0, 2.5, 0), normal=(0, -1, 0), size=(1.0, 0.6), radiance=6.0).add_to(s)
    return s


# -- Russian roulette ---------------------------------------------------------------------------------------------


def test_survive_is_the_numpy_roulette_for_one_ray():
    """compiled_hit.survive: above the cutoff unchanged (no number drawn); below it alive with probability m / cutoff
    and lifted to the cutoff (colour kept); without roulette or at m = 0 dropped. (Keys are uint64, as the
    kernel's.)"""
    assert survive((0.2, 0.1, 0.0), 0.1, True, KEY, 5) == (True, (0.2, 0.1, 0.0), 5)
    assert survive((0.05, 0.01, 0.0), 0.1, False, KEY, 5) == (False, (0.05, 0.01, 0.0), 5)
    assert survive((0.0, 0.0, 0.0), 0.1, True, KEY, 5)[0] is False
    t = (0.004, 0.002, 0.001)
    n = 20000
    alive = np.zeros(n, dtype=bool)
    for k in range(n):
        ok, tt, dim = survive(t, 0.01, True, KEY, k)
        assert dim == k + 1
        alive[k] = ok
        if ok:
            np.testing.assert_allclose(tt, (0.01, 0.005, 0.0025), rtol=1e-12)
    q = 0.4
    assert abs(alive.mean() - q) < 5 * np.sqrt(q * (1 - q) / n)


def test_roulette_takes_the_compiled_path():
    s = _glass_scene(spp=1)
    ps = pyrt.PreparedScene(s)
    try:
        assert compiled.unsupported(ps, roulette=True) == []
        assert compiled.unsupported(ps, integrator="glossy", roulette=True) == []
    finally:
        ps.close()


@pytest.mark.parametrize("integrator", [pyrt.Whitted(throughput_cutoff=0.05, roulette=True, split_depth=None),
                                        pyrt.Glossy(throughput_cutoff=0.05, roulette=True, samples=4, depth=2)])
def test_roulette_agrees_with_numpy_in_distribution(integrator):
    """A cutoff of 0.05 puts every glass reflection (R ~ 0.04) and the glossy rays' deeper bounces under roulette."""
    _assert_agree(_glass_scene(), integrator=integrator)


def test_roulette_is_unbiased_on_the_compiled_path():
    """The mean of roulette renders (cutoff 0.05) is the image without a cutoff (the full glass tree to max_depth 6)
    within the standard errors; dropping the rays instead (no roulette) is measurably darker."""
    s = _glass_scene(width=32, height=24)
    rr, vr, _ = _renders(s, "compiled", range(300, 308), integrator=pyrt.Whitted(
        max_depth=6, throughput_cutoff=0.05, roulette=True, split_depth=None))
    full, vf, _ = _renders(s, "compiled", range(400, 408), integrator=pyrt.Whitted(
        max_depth=6, throughput_cutoff=0.0, split_depth=None))
    cut, _v, _ = _renders(s, "compiled", range(400, 408), integrator=pyrt.Whitted(
        max_depth=6, throughput_cutoff=0.05, split_depth=None))
    _z_agree(rr, vr, full, vf)
    se = np.sqrt(vr.sum() + vf.sum()) / full.size
    assert full.mean() - cut.mean() > 10 * se
