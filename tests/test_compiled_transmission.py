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
from pyrt.textures import ChannelTexture

from test_compiled_glossy import _add_sky, _renders, _z_agree  # noqa: E402

KEY = np.uint64(0x1234ABCD)


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


# -- transparent shadows ------------------------------------------------------------------------------------------


def _slab_scene(tint=(0.9, 0.8, 0.6), spp=1, jitter=False, material=None):
    """A glass slab (ior 1.5; or of ``material``) 1 above a Lambert floor under a directional light straight down; the
    camera looks at the floor from below the slab's height, so it sees the slab's shadow and not the slab."""
    cam = pyrt.Camera(position=(0, 0.9, 2.0), target=(0, 0, 0), fov=40, width=48, height=36, spp=spp, jitter=jitter)
    s = pyrt.Scene(cam, background=(0.0, 0.0, 0.0))
    s.add_plane((0, 0, 0), 8.0, pyrt.Lambert(albedo=0.5))
    s.add_box((0.0, 1.0, 0.0), (1.2, 0.05, 1.2), material or pyrt.Glass(ior=1.5, tint=tint))
    s.add_light(pyrt.DirectionalLight(direction=(0, -1, 0), irradiance=3.0))
    return s


def test_transparent_shadows_take_the_compiled_path():
    s = _glass_scene(spp=1)
    ps = pyrt.PreparedScene(s)
    try:
        assert compiled.unsupported(ps, transparent_shadows=True) == []
        assert compiled.unsupported(ps, integrator="glossy", transparent_shadows=True, roulette=True) == []
    finally:
        ps.close()


def test_a_glass_slab_transmits_tint_squared_times_fresnel_squared():
    """At normal incidence each of the slab's two faces passes ``tint (1 - R)``, ``R = ((1.5 - 1) / 2.5)^2 = 0.04``:
    the floor in the slab's shadow is ``tint^2 0.96^2`` of the lit floor beside it (pixel centres: exact to float32
    rounding), and the compiled image is the NumPy path's."""
    tint = np.array([0.9, 0.8, 0.6])
    s = _slab_scene(tuple(tint))
    kw = dict(integrator=pyrt.Whitted(transparent_shadows=True))
    rc = pyrt.render_full(s, execution=pyrt.Execution(backend="compiled", progress=False), **kw)
    rn = pyrt.render_full(s, execution=pyrt.Execution(backend="numpy", progress=False), **kw)
    assert rc.stats.backend == "compiled"
    np.testing.assert_allclose(rc.image, rn.image, rtol=1e-5, atol=1e-6)
    opaque = pyrt.render_full(s, execution=pyrt.Execution(backend="compiled", progress=False)).image
    img = rc.image.astype(np.float64)
    shadow = (opaque[..., 0] == 0) & (img[..., 0] > 0)   # the floor in the slab's shadow (black when it is opaque)
    assert shadow.sum() > 200, shadow.sum()
    lit = opaque.reshape(-1, 3).max(axis=0)               # the floor in the open: the same everywhere
    np.testing.assert_allclose(img[shadow] / lit, np.broadcast_to(tint ** 2 * 0.96 ** 2, (shadow.sum(), 3)), rtol=1e-5)


@pytest.mark.parametrize("integrator", [pyrt.Whitted(transparent_shadows=True),
                                        pyrt.Glossy(transparent_shadows=True, samples=4, depth=2)])
def test_transparent_shadows_agree_with_numpy_in_distribution(integrator):
    """Point, rectangle (light and BSDF samples) lights' shadow rays through the glass sphere and the tinted slab,
    from camera hits (the packet stages) and the specular tree's and glossy rays' hits (single rays)."""
    _assert_agree(_glass_scene(), integrator=integrator)


def test_transparent_shadows_under_a_sampled_environment_agree_with_numpy():
    """The environment light's shadow rays (``strategy="mis"``: the packet rounds at camera hits, single rays at the
    specular tree's hits and, with glossy rays, the map's samples at glossy hits) through glass."""
    s = _add_sky(_glass_scene())
    _assert_agree(s, integrator=pyrt.Glossy(transparent_shadows=True, samples=4, depth=2))


def test_transparent_shadows_through_glass_and_a_blend_surface_match_the_numpy_path():
    """A blend veil (coverage 0.55) between the light and the slab: the floor in the shadow of both gets
    ``(1 - 0.55) tint^2 0.96^2`` of the light, pixel by pixel the NumPy path's image (pixel centres)."""
    s = _slab_scene()
    s.add_plane((0.0, 1.5, 0.0), 1.0, pyrt.Lambert(albedo=0.3).set_coverage(opacity=0.55, alpha_mode="blend"))
    _shadow_is_numpys(s, 0.45 * np.array([0.9, 0.8, 0.6]) ** 2 * 0.96 ** 2, 50)


def _shadow_is_numpys(s, want, n_pixels):
    """Whitted with transparent shadows on both paths: the same image at pixel centres, and more than ``n_pixels``
    pixels at ``want`` times the lit floor (the brightest pixels)."""
    kw = dict(integrator=pyrt.Whitted(transparent_shadows=True))
    rc = pyrt.render_full(s, execution=pyrt.Execution(backend="compiled", progress=False), **kw)
    rn = pyrt.render_full(s, execution=pyrt.Execution(backend="numpy", progress=False), **kw)
    assert rc.stats.backend == "compiled"
    np.testing.assert_allclose(rc.image, rn.image, rtol=1e-5, atol=1e-6)
    rgb = rc.image.reshape(-1, 3).astype(np.float64)
    rel = rgb / rgb.max(axis=0)
    assert np.count_nonzero(np.all(np.abs(rel - want) < 1e-5 * want + 1e-7, axis=1)) > n_pixels
# -- smooth glTF transmission -------------------------------------------------------------------------------------


def _gltf_glass(thin, **kw):
    """A smooth transmitting GltfPBR: tinted, partly metallic, partly transmitting, with the specular extension."""
    return pyrt.GltfPBR(base_color=(0.9, 0.75, 0.5), metallic=0.2, roughness=0.0, transmission=0.85, specular=0.8,
                        specular_color=(1.0, 0.9, 0.8), ior=1.4, thin=thin, name="thin" if thin else "volume", **kw)


def _gltf_glass_scene(thin, spp=1, jitter=False, env=False):
    """A smooth glTF-transmitting sphere and slab (one material: thin walls or one volume) before a checker floor and
    a glossy sphere under a point light and a spot light (``env``: the studio-like preview of a lat-long sky too)."""
    cam = pyrt.Camera(position=(0, 1.3, 4.0), target=(0, 0.5, 0), fov=40, width=40, height=30, spp=spp, jitter=jitter)
    s = pyrt.Scene(cam, background=(0.5, 0.6, 0.8), ambient=(0.01, 0.01, 0.01))
    s.add_plane((0, 0, 0), 6.0, pyrt.Lambert(albedo=pyrt.CheckerTexture(0.15, 0.8, scale=6, filtered=False)))
    s.add_sphere((-0.9, 0.45, -0.3), 0.45, pyrt.CookTorrance(kd=0.1, ks=0.8, roughness=0.3), subdivisions=3)
    glass = _gltf_glass(thin)
    s.add_sphere((0.0, 0.5, 0.4), 0.5, glass, subdivisions=3)
    s.add_box((0.95, 0.4, -0.2), (0.1, 0.8, 0.8), glass)
    s.add_light(pyrt.PointLight((2, 3, 2), intensity=20.0))
    s.add_light(pyrt.SpotLight((-2, 3, 1), target=(0, 0, 0), intensity=30.0, inner_angle=15, outer_angle=25))
    if env:
        img = np.full((16, 32, 3), 0.2)
        img[3:6, 20:24] = (8.0, 7.0, 5.0)
        img[8:] = 0.05
        s.environment = pyrt.LatLongEnvironment(img)
        s.add_light(pyrt.EnvironmentLight(s.environment, strategy="preview"))
    return s


@pytest.mark.parametrize("thin", [True, False])
def test_smooth_gltf_transmission_takes_the_compiled_path(thin):
    ps = pyrt.PreparedScene(_gltf_glass_scene(thin, env=True))
    try:
        assert compiled.unsupported(ps, transparent_shadows=True) == []
        assert compiled.unsupported(ps, integrator="glossy", transparent_shadows=True, roulette=True) == []
    finally:
        ps.close()


@pytest.mark.parametrize("env", [False, True])
@pytest.mark.parametrize("thin", [True, False])
def test_smooth_gltf_transmission_matches_numpy_at_pixel_centres(thin, env):
    """Pixel centres, delta lights (and the environment's noise-free preview: its split sum at the transmitting
    hits), the full tree of delta lobes (``w R`` untinted, ``base w (1 - R) / eta^2`` or a thin wall's ``w F`` and
    ``base w (1 - max F)``), the reflection's share ``1 - transmission`` and transparent shadows: the compiled image
    is the NumPy path's pixel by pixel (a few pixels may differ where a ray meets an edge exactly)."""
    s = _gltf_glass_scene(thin, env=env)
    kw = dict(integrator=pyrt.Whitted(transparent_shadows=True, split_depth=None, max_depth=6))
    rc = pyrt.render_full(s, execution=pyrt.Execution(backend="compiled", progress=False), **kw)
    rn = pyrt.render_full(s, execution=pyrt.Execution(backend="numpy", progress=False), **kw)
    assert rc.stats.backend == "compiled" and rn.stats.backend == "numpy"
    close = np.isclose(rc.image, rn.image, rtol=1e-5, atol=1e-6).all(axis=2)
    assert (~close).mean() < 0.002, np.argwhere(~close)
    assert rc.image.mean() > 0.05


@pytest.mark.parametrize("thin", [True, False])
def test_smooth_gltf_transmission_agrees_with_numpy_in_distribution(thin):
    """Jittered samples, glossy rays, the split depth's one lobe per hit, Russian roulette, a rectangle light's
    light and BSDF samples and a sampled sky's (``strategy="mis"``) through the smooth glTF glass."""
    s = _add_sky(_gltf_glass_scene(thin, spp=16, jitter=True))
    pyrt.RectLight(center=(0, 2.5, 0), normal=(0, -1, 0), size=(1.0, 0.6), radiance=6.0).add_to(s)
    _assert_agree(s, integrator=pyrt.Glossy(transparent_shadows=True, samples=4, depth=2, throughput_cutoff=0.05,
                                            roulette=True))


@pytest.mark.parametrize("thin", [True, False])
def test_the_shadow_of_a_smooth_gltf_slab_is_the_numpy_paths(thin):
    """A smooth glTF slab (metallic 0.25, transmission 0.8) instead of the glass: each face passes ``tint (1 - R)``,
    ``tint = base (1 - metallic) transmission``, ``R = 0.04`` at normal incidence (ior 1.5, thin or not), pixel by
    pixel the NumPy path's image."""
    base = np.array([0.9, 0.8, 0.6])
    s = _slab_scene(material=pyrt.GltfPBR(base_color=tuple(base), metallic=0.25, roughness=0.0, transmission=0.8,
                                          ior=1.5, thin=thin))
    _shadow_is_numpys(s, (base * 0.75 * 0.8) ** 2 * 0.96 ** 2, 200)


# -- transmission: what keeps it on the NumPy path ----------------------------------------------------------------


def test_rough_and_textured_gltf_transmission_are_named_in_the_reasons():
    """Rough glTF transmission (a BTDF lobe) and smooth transmission with a textured transmission weight keep the
    NumPy path; the reasons name each material and say why. A textured base colour (the tint) and absorbing or nested
    volumes do not (tests/test_compiled_media.py)."""
    s = _glass_scene(spp=1)
    s.add_sphere((0.6, 0.3, 0.9), 0.3, pyrt.GltfPBR(base_color=(0.9, 0.5, 0.2), roughness=0.3, transmission=1.0,
                                                   name="rough"))
    s.add_sphere((-0.6, 0.3, 0.9), 0.3, pyrt.GltfPBR(roughness=0.0, transmission=1.0, thin=False,
                                                    absorption=(0.5, 0.1, 0.1), name="vol"))
    tex = pyrt.ImageTexture(np.full((4, 4, 3), 0.5))
    s.add_sphere((0.0, 0.3, 1.2), 0.2, pyrt.GltfPBR(base_color=tex, roughness=0.0, transmission=1.0, name="tint"))
    s.add_sphere((0.0, 0.3, 1.6), 0.2, pyrt.GltfPBR(roughness=0.0, transmission=ChannelTexture(tex, 0), name="tex"))
    ps = pyrt.PreparedScene(s)
    try:
        r = compiled.unsupported(ps, integrator="glossy", transparent_shadows=True, roulette=True)
    finally:
        ps.close()
    lobes = "(a dielectric with a BSDF lobe, e.g. glTF KHR_materials_transmission or rough glass"
    assert [x for x in r if x.startswith("material")] == [
        f"material GltfPBR(rough) {lobes}: the kernel's dielectrics are Glass and smooth glTF transmission)",
        "material GltfPBR(tex) (smooth glTF transmission: the kernel reads it with constant metallic, transmission, "
        "specular and specular colour, isotropic)"]
    assert "the glossy integrator with rough transmission (GltfPBR(rough))" in r
    assert not any(x.startswith("nested") for x in r)
