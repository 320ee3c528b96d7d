"""One delta light per hit (``light_select_depth``, :mod:`pyrt.integrators.light_choice`): chosen by irradiance and
weighted 1 / p, its mean is the sum over the lights (within standard errors, per ray and channel), with one shadow
ray per hit instead of one per light."""
import numpy as np
import pytest

import pyrt
from pyrt.apps.preview import PreviewError, PreviewOptions
from pyrt.core.rays import RayBatch
from pyrt.integrators import GlossyIntegrator, Integrator, PreparedScene
from pyrt.integrators import direct

COPIES = 4000


def _scene():
    """A Lambert floor, a Lambert box, a mirror and a rough metal sphere under a point, a spot and two directional
    lights of different colours (the spot's cone and the box's shadow make some lights miss some hits)."""
    cam = pyrt.Camera(position=(0, 1.5, 4.0), target=(0, 0.4, 0), fov=45.0, width=8, height=8, spp=1)
    scene = pyrt.Scene(cam, background=(0.1, 0.1, 0.1))
    scene.add_plane((0, 0, 0), 10.0, pyrt.Lambert(albedo=(0.8, 0.6, 0.4)), name="floor")
    scene.add_box((-0.8, 0.3, 0.0), (0.3, 0.3, 0.3), pyrt.Lambert(albedo=0.5), name="box")
    scene.add_sphere((0.6, 0.5, 0.0), 0.5, pyrt.Mirror(), name="mirror")
    scene.add_sphere((0.0, 0.3, 1.0), 0.3, pyrt.CookTorrance(kd=0.2, ks=0.6, roughness=0.3, ior=1.5), name="rough")
    scene.add_light(pyrt.PointLight((1.0, 3.0, 2.0), intensity=6.0, color=(1.0, 0.9, 0.8)))
    scene.add_light(pyrt.SpotLight((-2.0, 2.5, 1.0), target=(0.0, 0.0, 0.0), intensity=10.0, inner_angle=15.0, outer_angle=25.0))
    scene.add_light(pyrt.DirectionalLight((0.3, -1.0, -0.4), irradiance=1.5, color=(0.6, 0.7, 1.0)))
    scene.add_light(pyrt.DirectionalLight((-0.6, -0.5, 0.2), irradiance=0.4))
    return scene


def _rays(scene):
    o = np.array(scene.camera.position, dtype=np.float64)
    targets = np.array([[0.0, 0.0, 0.5], [-0.8, 0.5, 0.3], [0.6, 0.5, 0.5], [0.3, 0.6, 0.1], [-1.5, 0.0, -1.0],
                        [0.0, 0.35, 1.25], [-0.4, 0.0, 0.0]])
    d = targets - o
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    return np.broadcast_to(o, d.shape).copy(), d


def _render(ps, cls, o, d, copies, **kw):
    integ = cls(ps, max_depth=3, **kw)
    L, _ = integ.render_samples(RayBatch(np.repeat(o, copies, axis=0), np.repeat(d, copies, axis=0)),
                                rng=np.random.default_rng(11))
    return L.reshape(o.shape[0], copies, 3), integ.stats


@pytest.mark.parametrize("cls", [Integrator, GlossyIntegrator])
def test_one_light_per_hit_has_the_sum_over_lights_as_its_mean(cls):
    scene = _scene()
    o, d = _rays(scene)
    ps = PreparedScene(scene)
    try:
        ref, ref_stats = _render(ps, cls, o, d, COPIES)      # the same random numbers for the glossy rays' sake
        est, stats = _render(ps, cls, o, d, COPIES, light_select_depth=0)
    finally:
        ps.close()
    m_ref, m_est = ref.mean(axis=1), est.mean(axis=1)
    # independent estimates (the glossy rays differ too): the difference's standard error
    se = np.sqrt(ref.var(axis=1, ddof=1) / COPIES + est.var(axis=1, ddof=1) / COPIES)
    assert np.all(m_ref.max(axis=1) > 0) and np.all(se.max(axis=1) > 0)
    z = np.abs(m_est - m_ref) / np.maximum(se, 1e-12)
    assert z.max() < 4.5, (z, m_est, m_ref)
    assert stats.shadow_rays < 0.5 * ref_stats.shadow_rays       # one shadow ray per hit instead of up to four


def test_selection_from_bounce_one_leaves_camera_hits_exact():
    scene = _scene()
    o, d = _rays(scene)
    ps = PreparedScene(scene)
    try:
        integ = Integrator(ps, max_depth=0, light_select_depth=1)
        b, _ = integ.render_samples(RayBatch(o, d), rng=np.random.default_rng(1))
        c, _ = Integrator(ps, max_depth=0).render_samples(RayBatch(o, d), rng=np.random.default_rng(1))
    finally:
        ps.close()
    np.testing.assert_array_equal(b, c)


def test_light_select_depth_is_checked():
    with pytest.raises(pyrt.RenderError):
        pyrt.render_full(_scene(), light_select_depth=-1)


@pytest.mark.parametrize("field, bad", [("light_select_depth", -1), ("split_depth", 1.5),
                                        ("dielectric_chunk_samples", 0)])
def test_preview_options_check_the_speed_switches(field, bad):
    PreviewOptions(**{field: None if field != "dielectric_chunk_samples" else 4096}).validate()
    with pytest.raises(PreviewError, match=field):
        PreviewOptions(**{field: bad}).validate()


def _light_by_light(lights, surf, bsdf, visible, rng):
    """direct.estimate as it was before the delta lights shared a shadow query: one query per light."""
    L = np.zeros((surf.n_hits, 3))
    for light in lights:
        if light.environment is None and light.n_samples == 1 and not light.bsdf_samples:
            direct.light_sampling_estimate(light, surf, bsdf, visible, rng, out=L)
        else:
            L += direct.estimate_light(light, surf, bsdf, visible, rng)
    return L


@pytest.mark.parametrize("transparent", [False, True])
@pytest.mark.parametrize("select", [None, 0])
def test_delta_lights_in_one_shadow_query_give_the_light_by_light_image(monkeypatch, transparent, select):
    """direct.shadow_queries: the delta lights' shadow rays traced in one query (and, with light selection, the
    per-light batches of the hits that keep every light) give bit for bit what one query per light gives, through
    glass with transparent shadows too (per-ray end points of the point and spot lights, infinite directional ones)."""
    scene = _scene()
    scene.add_sphere((-0.2, 1.2, 0.6), 0.25, pyrt.Glass(ior=1.5), name="glass")   # shadows through glass
    o, d = _rays(scene)
    ps = PreparedScene(scene)
    kw = dict(transparent_shadows=transparent, light_select_depth=select)
    try:
        fused, _ = _render(ps, GlossyIntegrator, o, d, 50, **kw)
        monkeypatch.setattr(direct, "estimate", _light_by_light)
        calls = []
        real = direct.shadow_queries

        def one_by_one(visible, surf, queries):
            calls.append(len(queries))
            return [real(visible, surf, [q])[0] for q in queries]
        monkeypatch.setattr(direct, "shadow_queries", one_by_one)
        single, _ = _render(ps, GlossyIntegrator, o, d, 50, **kw)
    finally:
        ps.close()
    assert np.array_equal(fused, single) and fused.max() > 0
    if select is not None:
        assert max(calls) > 1     # the per-light batches were really several queries
