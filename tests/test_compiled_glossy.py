"""The glossy integrator and light selection on the compiled path (:mod:`pyrt.integrators.compiled_hit`).

The two paths draw different random numbers, so their images agree in distribution: per pixel, the difference of
the means of R renders of each is divided by its standard error (from the renders' spread), and those z-scores
must look like standard normal ones (mean near 0, spread near 1, few beyond 4) while the mean brightness of the
two agrees to a fraction of a percent (a bias of the compiled estimator, e.g. a missing MIS weight, moves it by
several percent).
"""
import math

import numpy as np
import pytest

import pyrt
from pyrt.integrators import compiled
from pyrt.materials import compiled as MC


def _scene(width=40, height=30, spp=16, area=True):
    """Glossy Cook-Torrance and Blinn-Phong spheres, glass, a checker floor, an emissive box; point and spot lights
    and (``area``) a rectangle light with its visible mesh, which glossy rays reach."""
    cam = pyrt.Camera(position=(0, 1.3, 4.0), target=(0, 0.5, 0), fov=40, width=width, height=height, spp=spp,
                      jitter=True)
    s = pyrt.Scene(cam, background=(0.3, 0.35, 0.4), ambient=(0.01, 0.01, 0.01))
    s.add_plane((0, 0, 0), 6.0, pyrt.Lambert(albedo=pyrt.CheckerTexture(0.15, 0.8, scale=6, filtered=False)))
    s.add_sphere((-0.9, 0.45, -0.3), 0.45, pyrt.CookTorrance(kd=0.1, ks=0.8, roughness=0.3), subdivisions=3)
    s.add_sphere((0.0, 0.5, 0.4), 0.5, pyrt.Glass(ior=1.5), subdivisions=3)
    s.add_sphere((0.95, 0.4, -0.2), 0.4, pyrt.BlinnPhong(kd=(0.5, 0.2, 0.1), ks=0.3, exponent=60), subdivisions=2)
    s.add_box((0.2, 0.15, -1.0), (0.6, 0.3, 0.4), pyrt.Lambert(albedo=(0.2, 0.5, 0.3), emission=0.05))
    s.add_light(pyrt.PointLight((2, 3, 2), intensity=20.0))
    s.add_light(pyrt.SpotLight((-2, 3, 1), target=(0, 0, 0), intensity=30.0, inner_angle=15, outer_angle=25))
    if area:
        pyrt.RectLight(center=(0, 2.5, 0), normal=(0, -1, 0), size=(1.0, 0.6), radiance=6.0).add_to(s)
    return s


def _renders(scene, backend, seeds, **kw):
    """Mean image and its squared standard error over renders with ``seeds``; the path taken."""
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
    # z of R = 4 renders each is t-like (heavier tails than a normal): loose bounds, but a biased estimator (a
    # missing or doubled MIS weight) shifts the mean z by far more and the mean brightness by percents
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
    return mc, mn


def test_glossy_integrator_agrees_with_numpy_in_distribution():
    """Glossy rays from glossy hits, MIS of the rectangle light's samples against the rays that reach its mesh."""
    _assert_agree(_scene(), integrator=pyrt.Glossy(samples=4, depth=2))


@pytest.mark.parametrize("select", [0, 1])
def test_light_selection_agrees_with_numpy_in_distribution(select):
    """One delta light chosen by irradiance at camera hits (0) or at the glossy rays' hits (1)."""
    _assert_agree(_scene(), integrator=pyrt.Glossy(samples=4, depth=2, light_select_depth=select))


def test_whitted_light_selection_agrees_with_numpy_in_distribution():
    _assert_agree(_scene(area=False), integrator=pyrt.Whitted(light_select_depth=0))


def test_glossy_clamp_agrees_with_numpy_and_darkens():
    """The clamp of the direct light at the glossy rays' hits: the same (biased) estimate on both paths."""
    mc, _mn = _assert_agree(_scene(), integrator=pyrt.Glossy(samples=4, depth=2, clamp=0.02))
    free, _v, _p = _renders(_scene(), "compiled", range(100, 104), integrator=pyrt.Glossy(samples=4, depth=2))
    assert mc.mean() < free.mean() - 0.001


def test_glossy_depth_zero_renders_the_whitted_image():
    """No glossy rays: the glossy integrator's kernel options change nothing else (same seed, same image)."""
    s = _scene(spp=4)
    ex = pyrt.Execution(backend="compiled", progress=False)
    a = pyrt.render_full(s, seed=3, execution=ex, integrator=pyrt.Glossy(depth=0)).image
    b = pyrt.render_full(s, seed=3, execution=ex, integrator=pyrt.Whitted()).image
    np.testing.assert_array_equal(a, b)


def test_glossy_adaptive_passes_take_the_compiled_path():
    s = _scene(spp=4)
    r = pyrt.render_full(s, seed=1, execution=pyrt.Execution(backend="compiled", progress=False),
                         integrator=pyrt.Glossy(samples=2, depth=2, light_select_depth=1),
                         sampling=pyrt.Sampling(target_error=0.05, max_spp=16))
    assert r.stats.backend == "compiled" and np.isfinite(r.image).all() and r.image.mean() > 0


def test_glossy_fields_of_the_material_records():
    """The records' glossy alpha: the material's constant, inf for a diffuse lobe, -1 (per hit) for GLTF."""
    s = _scene(spp=1)
    ps = pyrt.PreparedScene(s)
    try:
        cs = compiled.CompiledScene(ps, None)
        recs = cs.materials[1]
        for k, m in enumerate(s.materials):
            a = m.glossy_alpha(MC.ONE_HIT) if m.has_diffuse else None
            want = math.inf if a is None else float(np.asarray(a).reshape(-1)[0])
            assert recs[k, MC.GLOSSY] == want, m
        emitter = next(k for k, m in enumerate(s.materials) if type(m).__name__ == "AreaEmitter")
        assert recs[emitter, MC.TRACED] == 1 + next(j for j, lt in enumerate(s.lights) if lt.has_mesh)
    finally:
        ps.close()
    g = pyrt.GltfPBR(base_color=(0.8, 0.6, 0.2), metallic=1.0, roughness=0.4)
    tag, _rec = g.compiled_record(lambda t: 0)
    assert tag == MC.GLTF and compiled.glossy_field(g, tag) == -1.0


def test_light_choice_needs_two_delta_lights():
    s = _scene()
    integ = dict(integrator="glossy", glossy_samples=4, glossy_depth=2, glossy_threshold=0.4, glossy_clamp=None,
                 light_select_depth=1)
    assert compiled.kernel_integrator(s, integ) == ((4, 2, 1, 0), (0.4, math.inf))
    s.lights[:] = [lt for lt in s.lights if not isinstance(lt, pyrt.SpotLight)]
    assert compiled.kernel_integrator(s, integ)[0] == (4, 2, -1, 0)
    assert compiled.kernel_integrator(s, None) == ((0, 0, -1, 0), (0.0, math.inf))


def _env_scene(spp=16):
    """The scene under a lat-long sky (a bright patch: the map's samples and the glossy rays both find it) lighting
    by ``strategy="mis"``."""
    return _add_sky(_scene(spp=spp, area=False))


def _add_sky(s):
    """``s`` with a 32 x 16 lat-long sky (a bright patch, a dark lower half) as its environment and its
    ``strategy="mis"`` light (2 samples per hit)."""
    h, w = 16, 32
    img = np.full((h, w, 3), 0.2)
    img[3:6, 20:24] = (8.0, 7.0, 5.0)
    img[h // 2:] = 0.05
    env = pyrt.LatLongEnvironment(img)
    s.environment = env
    s.add_light(pyrt.EnvironmentLight(env, strategy="mis", n_samples=2))
    return s


def test_glossy_integrator_under_a_sampled_environment_agrees_with_numpy():
    """At glossy hits the map's samples against the glossy rays, the escaped rays weighted likewise."""
    s = _env_scene()
    integ = dict(integrator="glossy", glossy_samples=4, glossy_depth=2, glossy_threshold=0.4, glossy_clamp=None,
                 light_select_depth=None)
    assert compiled.kernel_integrator(s, integ)[0] == (4, 2, -1, 2)
    _assert_agree(s, integrator=pyrt.Glossy(samples=4, depth=2))


def test_glossy_reasons():
    s = _scene(spp=1)
    assert compiled.glossy_reasons(s) == []
    lt = pyrt.RectLight(center=(0, 2.5, 0), normal=(0, -1, 0), size=(1.0, 0.6), radiance=6.0, name="panel")
    lt.add_to(s)
    twin = pyrt.RectLight(center=(0, 2.5, 0), normal=(0, -1, 0), size=(1.0, 0.6), radiance=6.0, name="panel")
    s.add_light(twin)               # the same emitter mesh name: one mesh for two lights
    assert compiled.glossy_reasons(s) == [
        "the glossy integrator with a visible emitter mesh shared by several area lights"]
    r = pyrt.render_full(s, seed=0, execution=pyrt.Execution(progress=False), integrator=pyrt.Glossy())
    assert r.stats.backend == "numpy"


def test_glossy_integrator_under_the_preview_environment_agrees_with_numpy():
    """The previewer's set-up: the studio environment lighting by ``strategy="preview"`` (glossy hits take nothing
    from it, escaped glossy rays carry it with weight 1), glossy rays, one of the delta lights chosen per glossy-ray
    hit."""
    from pyrt.apps.preview.studio import StudioEnvironment
    s = _scene(area=False)
    env = StudioEnvironment(intensity=0.5)
    s.environment = env
    pyrt.lights.set_environment(s, env, lighting="preview")
    assert compiled.glossy_reasons(s) == []
    _assert_agree(s, integrator=pyrt.Glossy(samples=4, depth=2, light_select_depth=1))


def test_glossy_image_does_not_depend_on_the_thread_count():
    """Every glossy ray's numbers are keyed on its sample and hit: one thread and two give the same image."""
    s = _scene(spp=4)
    integ = pyrt.Glossy(samples=4, depth=2, light_select_depth=1)
    a = pyrt.render_full(s, seed=5, execution=pyrt.Execution(backend="compiled", progress=False, threads=1),
                         integrator=integ).image
    b = pyrt.render_full(s, seed=5, execution=pyrt.Execution(backend="compiled", progress=False, threads=2),
                         integrator=integ).image
    np.testing.assert_array_equal(a, b)


def test_compiled_clamp_is_the_numpy_clamp():
    """compiled_hit.clamp_sampled against pyrt.integrators.whitted.clamp_sampled row by row (rows over the limit and
    under it, float64)."""
    from pyrt.integrators.compiled_hit import clamp_sampled as clamp_one
    from pyrt.integrators.whitted import clamp_sampled
    rng = np.random.default_rng(7)
    Ld = rng.uniform(0.0, 10.0, (300, 3))
    thr = rng.uniform(0.0, 1.0, (300, 3))
    want = clamp_sampled(Ld, thr, np.ones(300, dtype=bool), 2.0)
    got = np.array([clamp_one(*Ld[i], tuple(thr[i]), 2.0) for i in range(300)])
    assert (np.max(thr * Ld, axis=1) > 2.0).any() and (np.max(thr * Ld, axis=1) <= 2.0).any()
    np.testing.assert_allclose(got, want, rtol=1e-15, atol=0.0)
