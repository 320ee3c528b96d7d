"""The emissive-mesh light (pyrt.EmissiveMeshLight) on the compiled path (:mod:`pyrt.lights.compiled_mesh`,
:mod:`pyrt.integrators.compiled_mesh_stage`).

The scalar twins are held to the light's NumPy ``sample_li`` and ``pdf_hit`` (random points and numbers, both
triangle choices). Renders: with pixel-centre camera samples, one light sample or a square number of them per hit
(the padded numbers both paths share) and no specular tree, the two paths' images are equal pixel by pixel; with
Latin-hypercube strata, mirrors (hashed numbers per hit) and the glossy integrator (MIS of the light samples against
glossy rays that reach the emitters) they agree in distribution (per-pixel z-scores of a few renders, the helpers of
tests/test_compiled_glossy.py and tests/test_compiled_area_lights.py). Ground truth: Lambert's polygon formula for the
irradiance of a uniformly emitting quad (tests/test_emissive_lights.py), the render's error within bounds from its
own per-pixel noise.
"""
import numba
import numpy as np
import pytest

import pyrt
from pyrt.integrators import compiled
from pyrt.io.assets.materials import GltfMaterial
from pyrt.lights import compiled_mesh as CM
from pyrt.textures import ImageTexture
from test_compiled_area_lights import assert_agree_in_distribution
from test_compiled_coverage import _both, _close
from test_compiled_glossy import _assert_agree
from test_emissive_lights import QUAD, polygon_irradiance, quad_mesh


def _emitters(width=48, height=36, spp=1, jitter=False, n_samples=1, selection="power", mirror=False, glossy=False,
              points=False):
    """A checker floor, a Blinn-Phong sphere (``glossy``: a rough Cook-Torrance one too), ``mirror``: a mirror
    sphere; emitters of every kind the light packs: a two-sided Lambert box, a one-sided AreaEmitter box, a glTF
    panel that culls its back faces (one-sided, as glTF's default) and a double-sided glTF panel; ``points``: two
    point lights (the light choice's candidates). The emitters are the scene's emissive-mesh light."""
    cam = pyrt.Camera(position=(0, 1.3, 4.0), target=(0, 0.5, 0), fov=45, width=width, height=height, spp=spp,
                      jitter=jitter)
    s = pyrt.Scene(cam, background=(0.02, 0.02, 0.03))
    s.add_plane((0, 0, 0), 6.0, pyrt.Lambert(albedo=pyrt.CheckerTexture(0.2, 0.7, scale=6, filtered=False)))
    s.add_sphere((0.7, 0.4, 0.0), 0.4, pyrt.BlinnPhong(kd=(0.5, 0.2, 0.1), ks=0.3, exponent=40), subdivisions=2)
    if mirror:
        s.add_sphere((-0.7, 0.45, -0.3), 0.45, pyrt.Mirror(0.9), subdivisions=2)
    if glossy:
        s.add_sphere((-0.2, 0.35, 0.6), 0.35, pyrt.CookTorrance(kd=0.1, ks=0.8, roughness=0.25), subdivisions=2)
    s.add_box((0.2, 1.2, -0.6), (0.4, 0.2, 0.3), pyrt.Lambert(albedo=0.1, emission=(4.0, 2.0, 1.0)))
    s.add_box((-0.9, 1.0, 0.6), (0.2, 0.3, 0.2), pyrt.AreaEmitter((1.0, 3.0, 2.0)))
    kw = dict(base_color=(0.0, 0.0, 0.0), metallic=0.0, roughness=0.8)
    one_sided = GltfMaterial(**kw, emission=(0.4, 2.0, 3.6)).set_coverage(double_sided=False)
    s.add_plane((-1.6, 0.8, -0.8), 0.6, one_sided, normal=(0.6, -0.2, 0.75), name="one_sided")
    s.add_plane((1.6, 0.9, -0.6), 0.5, GltfMaterial(**kw, emission=(3.0, 1.0, 0.5)), normal=(-0.7, -0.3, 0.6),
                name="two_sided")
    if points:
        s.add_light(pyrt.PointLight((2, 3, 2), intensity=6.0))
        s.add_light(pyrt.PointLight((-2, 2.5, 1), intensity=4.0))
    s.add_emissive_lights(n_samples=n_samples, selection=selection)
    return s


@numba.njit(cache=False)
def _sample_all(pars, P, U):
    out = np.zeros((P.shape[0], 8))
    for i in range(P.shape[0]):
        r = CM.sample(pars, 0, P[i, 0], P[i, 1], P[i, 2], U[i, 0], U[i, 1])
        for k in range(8):
            out[i, k] = r[k]
    return out


@numba.njit(cache=False)
def _pdf_hit_all(pars, P, geom, prim, dist, cos_l):
    out = np.zeros(P.shape[0])
    for i in range(P.shape[0]):
        out[i] = CM.pdf_hit(pars, 0, P[i, 0], P[i, 1], P[i, 2], geom[i], prim[i], dist[i], cos_l[i])
    return out


def _packed(light):
    tags, table = CM.pack_table([light.compiled_record()])
    assert tags[0] == pyrt.lights.compiled.MESH
    return table.ravel()


@pytest.mark.parametrize("selection", ["power", "oriented"])
def test_mesh_sample_and_pdf_hit_are_the_lights(selection, rng):
    """For the same numbers the compiled sampler gives the NumPy light's direction, distance, density and irradiance
    (``L / pdf``), at points all around the emitters (behind one-sided ones too, ``u`` at the square's edges); its
    density at hit points is ``pdf_hit``'s on every scene mesh (0 on those the light does not sample)."""
    scene = _emitters(width=8, height=6, selection=selection)
    light = scene.lights[0]
    pars = _packed(light)
    P = rng.normal(size=(3000, 3)) * 1.5 + (0.0, 0.8, 0.0)
    U = rng.random((3000, 2))
    U[:6] = [[0, 0], [0, 1 - 1e-16], [1 - 1e-16, 0], [0.5, 0.5], [1e-300, 0.5], [0.5, 1e-300]]
    got = _sample_all(pars, P, U)
    ls = light.sample_li(P, U)
    # (the oriented choice's sum over the clusters runs left to right, NumPy's pairs terms: rounding apart)
    np.testing.assert_allclose(got[:, :3], ls.wi, rtol=0, atol=1e-9)
    np.testing.assert_allclose(got[:, 3], ls.dist, rtol=1e-9)
    np.testing.assert_allclose(got[:, 4], ls.pdf, rtol=1e-6, atol=0)
    live = got[:, 4] > 0
    E = np.where(live[:, None], got[:, 5:8] / np.where(live, got[:, 4], 1.0)[:, None], 0.0)
    np.testing.assert_allclose(E, ls.irradiance(), rtol=1e-6, atol=1e-300)
    dark = (E.max(axis=1) == 0).mean()    # a one-sided emitter's back: power chooses it, oriented does not
    assert live.mean() > 0.9 and (dark > 0.05 if selection == "power" else dark < 0.05), dark
    geom = rng.integers(0, len(scene.meshes), 3000)
    prim = np.array([rng.integers(0, len(scene.meshes[g].faces)) for g in geom])
    dist, cos_l = rng.random(3000) * 3 + 0.1, rng.random(3000) * 2 - 1
    want = light.pdf_hit(P, geom, prim, dist, cos_l)
    np.testing.assert_allclose(_pdf_hit_all(pars, P, geom, prim, dist, cos_l), want, rtol=1e-6, atol=0)
    assert 0.3 < (want > 0).mean() < 0.95


@pytest.mark.parametrize("selection", ["power", "oriented"])
@pytest.mark.parametrize("n_samples", [1, 4])
def test_emitters_match_the_numpy_path_pixel_by_pixel(selection, n_samples):
    """Pixel centres, one or a 2 x 2 grid of light samples per hit (the padded numbers both paths draw): the same
    image and shadow rays; the glTF panel lights only what faces its front, the two-sided emitters both sides."""
    c, n = _both(_emitters(n_samples=n_samples, selection=selection), seed=0)
    _close(c.image, n.image)
    assert c.stats.shadow_rays == n.stats.shadow_rays
    assert c.image.mean() > 0.01


def test_latin_hypercube_samples_and_mirrors_agree_with_the_numpy_path_in_distribution():
    """Three samples per hit (Latin-hypercube strata: a permutation per hit on each path) and a mirror (the specular
    tree's hits key their numbers per hit): in distribution."""
    assert_agree_in_distribution(_emitters(width=40, height=30, spp=16, jitter=True, n_samples=3, mirror=True), K=5)


@pytest.mark.parametrize("selection,select", [("oriented", 1), ("power", None)])
def test_glossy_integrator_with_emitters_agrees_with_numpy_in_distribution(selection, select):
    """Glossy rays from the rough Cook-Torrance and Blinn-Phong hits reach the emitters (their emission weighed by
    the power heuristic against the light's density at the hit point) while the light samples at those hits are
    weighed against them; with the previewer's ``light_select_depth=1`` beside two point lights."""
    scene = _emitters(width=40, height=30, spp=16, jitter=True, selection=selection, glossy=True, mirror=True,
                      points=True)
    _assert_agree(scene, integrator=pyrt.Glossy(samples=4, depth=2, light_select_depth=select))


@pytest.mark.parametrize("selection", ["power", "oriented"])
def test_quad_emitter_over_a_lambert_floor_matches_lamberts_polygon_formula(selection):
    """A one-sided quad of radiance 3 facing a Lambert floor (albedo 0.6): at each pixel centre's floor point (within
    3 of the quad's axis) ``L_o = rho / pi E``, ``E`` by Lambert's polygon formula. Per pixel the mean of K = 6
    renders against it, z from the renders' spread (t-distributed, 5 degrees of freedom): the pooled mean of z within
    4 of its standard errors, no pixel beyond 10; the floor's total within 4 standard errors of the renders' totals."""
    cam = pyrt.Camera(position=(0, 0.5, 3.0), target=(0, 0, 0), fov=40, width=24, height=18, jitter=False, spp=4)
    s = pyrt.Scene(cam)
    s.add_plane((0, 0, 0), 20.0, pyrt.Lambert(albedo=0.6))
    s.add_mesh(quad_mesh(), pyrt.AreaEmitter(3.0), smooth=False, name="panel")
    s.add_emissive_lights(n_samples=4, selection=selection)
    run = pyrt.Execution(backend="compiled", progress=False)
    K = 6
    renders = [pyrt.render_full(s, execution=run, seed=k) for k in range(K)]
    assert all(r.stats.backend == "compiled" for r in renders)
    ys, xs = np.mgrid[0:18, 0:24]
    d = cam.directions((xs + 0.5).ravel(), (ys + 0.5).ravel())
    down = d[:, 1] < -1e-3                     # rays from below the panel's plane toward the floor
    p = cam.position + (-cam.position[1] / np.where(down, d[:, 1], -1.0))[:, None] * d
    near = down & (np.abs(p[:, 0]) < 3.0) & (np.abs(p[:, 2]) < 3.0)
    assert near.sum() > 100
    want = np.array([0.6 / np.pi * polygon_irradiance(QUAD, q, np.array([0.0, 1.0, 0.0]), 3.0) for q in p[near]])
    img = np.array([r.image[..., 0].ravel()[near] for r in renders], dtype=np.float64)
    z = (img.mean(axis=0) - want) / np.sqrt(img.var(axis=0, ddof=1) / K)
    assert abs(z.mean()) < 4.0 * z.std() / np.sqrt(z.size), (z.mean(), z.std())
    assert np.abs(z).max() < 10.0, np.abs(z).max()
    tot = img.sum(axis=1) / want.sum()
    assert abs(tot.mean() - 1.0) < 4.0 * tot.std(ddof=1) / np.sqrt(K), tot


def test_emission_the_kernel_cannot_read_falls_back_and_says_why():
    """A textured glTF emission or a blended emitter: the light's record is None, the render takes the NumPy path and
    the reason names the light; a constant one takes the compiled path."""
    kw = dict(base_color=(0.0, 0.0, 0.0), metallic=0.0, roughness=0.8)
    tex = ImageTexture(np.full((2, 2, 3), 0.5, np.float32), filter="bilinear")
    for mat, ok in ((GltfMaterial(**kw, emission=(1.0, 2.0, 3.0)), True),
                    (GltfMaterial(**kw, emission=tex), False),
                    (pyrt.Lambert(albedo=0.2, emission=2.0).set_coverage(opacity=0.5, alpha_mode="blend"), False)):
        s = pyrt.Scene(pyrt.Camera(position=(0, 0.5, 3.0), target=(0, 0, 0), width=8, height=6))
        s.add_plane((0, 0, 0), 4.0, pyrt.Lambert(albedo=0.5))
        s.add_mesh(quad_mesh(uv=True), mat, smooth=False, name="panel")
        light = s.add_emissive_lights()
        assert (light.compiled_record() is not None) is ok
        reasons = compiled.unsupported(pyrt.PreparedScene(s))
        assert any(r.startswith(f"light {light.label} (an emitter whose emission") for r in reasons) is not ok, reasons


def test_the_previewer_renders_an_emissive_model_on_the_compiled_path(tmp_path):
    """An OBJ whose lamp emits (MTL ``Ke``): the previewer's oriented emissive-mesh light, its glossy integrator, light
    choice and sampler, and the compiled path renders it."""
    from pyrt.apps.preview import PreviewOptions, PreviewScene
    from test_emissive_lights import _obj
    o = PreviewOptions(width=32, height=24, spp=1).validate()
    ps = PreviewScene(pyrt.load_asset(_obj(tmp_path, True)), o)
    try:
        assert ps.emissive_light is not None and ps.emissive_light.selection == "oriented"
        assert compiled.unsupported(ps.prepared, integrator="glossy", transparent_shadows=True,
                                    light_select_depth=o.light_select_depth, sampler=o.sampler) == []
        r = ps.render_view(ps.azimuth)
        assert r.stats.backend == "compiled" and r.image.max() > 0
    finally:
        ps.close()


def test_transparent_shadows_toward_emitters_match_the_numpy_path():
    """The light's shadow rays through a tinted glass slab (the camera sees the slab's shadow on the floor, not the
    slab; a one-sided quad emitter above it): pixel by pixel at pixel centres (the packet stage's shadow rays
    walked); with the glass sphere, mirror and glossy rays of tests/test_compiled_transmission.py's scene (single
    shadow rays from the specular tree's and glossy rays' hits) in distribution."""
    from test_compiled_transmission import _glass_scene, _slab_scene
    s = _slab_scene()
    s.add_mesh(quad_mesh(), pyrt.AreaEmitter(4.0), smooth=False, transform=np.diag([2.0, 2.0, 2.0, 1.0]),
               name="panel")
    s.add_emissive_lights(n_samples=4, selection="oriented")
    kw = dict(integrator=pyrt.Whitted(transparent_shadows=True))
    c = pyrt.render_full(s, execution=pyrt.Execution(backend="compiled", progress=False), **kw)
    n = pyrt.render_full(s, execution=pyrt.Execution(backend="numpy", progress=False), **kw)
    assert c.stats.backend == "compiled"
    _close(c.image, n.image)
    g = _glass_scene()
    g.add_box((-0.2, 1.3, -0.6), (0.4, 0.1, 0.3), pyrt.Lambert(albedo=0.1, emission=(5.0, 3.0, 1.0)))
    g.add_emissive_lights(selection="oriented")
    _assert_agree(g, integrator=pyrt.Glossy(transparent_shadows=True, samples=4, depth=2, light_select_depth=1))
