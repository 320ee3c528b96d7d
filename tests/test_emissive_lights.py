"""Emissive scene triangles as a light (pyrt.EmissiveMeshLight, Scene.add_emissive_lights, the previewer's default).

Ground truth: Lambert's polygon formula for the irradiance of a uniformly emitting polygon,
``E = L / 2 sum_i beta_i n . (a_i x b_i) / |a_i x b_i|`` (``a_i``, ``b_i`` the unit directions to consecutive
vertices, ``beta_i`` the angle between them); Monte Carlo means within 5 standard errors of the samples (or of
independent seeds for renders); the triangle choice against its pmf by a chi-square test.
"""
import math

import numpy as np
import pytest
from scipy import stats

import pyrt
from pyrt.apps.preview import PreviewError, PreviewOptions, PreviewScene
from pyrt.apps.preview.cli import main as preview_main
from pyrt.lights import LightError
from pyrt.textures import ImageTexture

QUAD = np.array([[-0.5, 1.0, -0.5], [0.5, 1.0, -0.5], [0.5, 1.0, 0.5], [-0.5, 1.0, 0.5]])
DOWN = [[0, 1, 2], [0, 2, 3]]          # winding normal -y: the front faces the floor
UV = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])


def polygon_irradiance(verts, p, n, L):
    """Lambert's formula: irradiance at ``p`` (normal ``n``) from the polygon ``verts`` (entirely above the plane
    of ``p``) of uniform radiance ``L``."""
    a = verts - p
    a = a / np.linalg.norm(a, axis=1, keepdims=True)
    s = 0.0
    for i in range(len(a)):
        ai, bi = a[i], a[(i + 1) % len(a)]
        c = np.cross(ai, bi)
        s += math.acos(np.clip(ai @ bi, -1, 1)) * (n @ c) / np.linalg.norm(c)
    return L / 2 * abs(s)


def quad_mesh(uv=False):
    import trimesh
    m = trimesh.Trimesh(vertices=QUAD, faces=DOWN, process=False)
    if uv:
        m.visual = trimesh.visual.TextureVisuals(uv=UV)
    return m


def emitter_scene(material, uv=False, n_samples=1, selection="power"):
    sc = pyrt.Scene(pyrt.Camera(position=(0, 0.5, 3.0), target=(0, 0, 0)))
    sc.add_mesh(quad_mesh(uv), material, smooth=False, name="panel")
    light = sc.add_emissive_lights(n_samples=n_samples, selection=selection)
    return sc, light


def irradiance_estimate(light, p, n, count=200_000, seed=0):
    """Mean and standard error of ``E cos theta`` at the point ``p`` with normal ``n`` (front side only)."""
    pts = np.broadcast_to(np.asarray(p, dtype=np.float64), (count, 3))
    ls = light.sample_li(np.ascontiguousarray(pts), np.random.default_rng(seed).random((count, 2)))
    f = ls.irradiance()[:, 0] * np.maximum(ls.wi @ np.asarray(n, dtype=np.float64), 0.0)
    return f.mean(), f.std() / math.sqrt(count)


# ------------------------------------------------------------------------------------------- (a) closed form

@pytest.mark.parametrize("selection", ["power", "oriented"])
@pytest.mark.parametrize("p, n", [((0.0, 0.0, 0.0), (0.0, 1.0, 0.0)), ((0.7, 0.2, -0.3), (0.0, 1.0, 0.0)),
                                  ((0.4, -0.5, 0.9), (-0.3, 0.9, -0.3))])
def test_irradiance_from_a_uniform_quad_matches_lamberts_polygon_formula(p, n, selection):
    _, light = emitter_scene(pyrt.AreaEmitter(3.0), selection=selection)
    n = np.asarray(n) / np.linalg.norm(n)
    mean, se = irradiance_estimate(light, p, n)
    ref = polygon_irradiance(QUAD, np.asarray(p), n, 3.0)
    assert abs(mean - ref) <= 5 * se, (mean, ref, se)
    assert se < 0.01 * ref          # the test can tell a wrong density (a factor of 2 is far outside)


@pytest.mark.parametrize("selection", ["power", "oriented"])
def test_sample_pdf_equals_pdf_li_and_pdf_hit(selection):
    """The sample's own density, the brute-force pdf_li of the direction and pdf_hit of the point agree."""
    _, light = emitter_scene(pyrt.AreaEmitter(3.0), selection=selection)
    rng = np.random.default_rng(1)
    p = np.column_stack([rng.uniform(-2, 2, 500), rng.uniform(-1, 0.5, 500), rng.uniform(-2, 2, 500)])
    ls = light.sample_li(p, rng.random((500, 2)))
    np.testing.assert_allclose(light.pdf_li(p, ls.wi), ls.pdf, rtol=1e-9)
    y = p + ls.dist[:, None] * ls.wi
    tri = np.zeros(500, dtype=np.int64)                  # each point's triangle, by barycentric coordinates
    for k in range(2):
        v = QUAD[DOWN[k]]
        e1, e2, q = v[1] - v[0], v[2] - v[0], y - v[0]
        b = np.linalg.lstsq(np.column_stack([e1, e2]), q.T, rcond=None)[0].T
        inside = (b >= -1e-9).all(axis=1) & (b.sum(axis=1) <= 1 + 1e-9)
        tri[inside] = k
    np.testing.assert_allclose(light.pdf_hit(p, np.zeros(500, dtype=np.int64), tri, ls.dist, -ls.wi[:, 1]), ls.pdf,
                               rtol=1e-9)
    assert np.all(light.pdf_hit(p, np.ones(500, dtype=np.int64), tri, ls.dist, ls.wi[:, 1]) == 0)  # not its mesh


# -------------------------------------------------------------------------------- (c) textures, (d) sidedness

def test_half_black_emission_texture_gives_the_half_quads_irradiance():
    """An emission texture black for u < 0.5 (nearest filtering): the irradiance is that of the bright half."""
    img = np.array([[[0.0] * 3, [1.0] * 3], [[0.0] * 3, [1.0] * 3]])
    tex = ImageTexture(img, filter="nearest", decode="linear")
    _, light = emitter_scene(pyrt.Lambert(0.0, emission=tex), uv=True)
    half = np.array([[0.0, 1.0, -0.5], [0.5, 1.0, -0.5], [0.5, 1.0, 0.5], [0.0, 1.0, 0.5]])
    for p in ([0.0, 0.0, 0.0], [-0.6, 0.3, 0.2]):
        p = np.asarray(p)
        mean, se = irradiance_estimate(light, p, np.array([0.0, 1.0, 0.0]))
        ref = polygon_irradiance(half, p, np.array([0.0, 1.0, 0.0]), 1.0)
        full = polygon_irradiance(QUAD, p, np.array([0.0, 1.0, 0.0]), 1.0)
        assert abs(mean - ref) <= 5 * se, (mean, ref, se)
        assert abs(full - ref) > 20 * se      # the untextured answer would fail


@pytest.mark.parametrize("how", ["uv_set_1", "offset"])
def test_emission_texture_read_in_its_uv_set_and_with_its_transform(how):
    """The bright half of the quad moves where the texture says: UV set 1 (set 0 is all zeros, black: reading it
    would give no light) or a texture offset of 0.5 in u (repeat wrap: the bright half becomes u < 0.5)."""
    import trimesh
    img = np.array([[[0.0] * 3, [1.0] * 3], [[0.0] * 3, [1.0] * 3]])
    sc = pyrt.Scene()
    m = trimesh.Trimesh(vertices=QUAD, faces=DOWN, process=False)
    if how == "uv_set_1":
        m.visual = trimesh.visual.TextureVisuals(uv=np.zeros((4, 2)))
        tex = ImageTexture(img, filter="nearest", decode="linear", texcoord=1)
        sc.add_mesh(m, pyrt.Lambert(0.0, emission=tex), smooth=False, uv_sets={1: UV})
        bright = [0.0, 0.5]
    else:
        m.visual = trimesh.visual.TextureVisuals(uv=UV)
        tex = ImageTexture(img, filter="nearest", decode="linear", offset=(0.5, 0.0))
        sc.add_mesh(m, pyrt.Lambert(0.0, emission=tex), smooth=False)
        bright = [-0.5, 0.0]
    light = sc.add_emissive_lights()
    half = np.array([[bright[0], 1.0, -0.5], [bright[1], 1.0, -0.5], [bright[1], 1.0, 0.5], [bright[0], 1.0, 0.5]])
    p, n = np.array([0.3, 0.0, 0.1]), np.array([0.0, 1.0, 0.0])
    mean, se = irradiance_estimate(light, p, n)
    ref = polygon_irradiance(half, p, n, 1.0)
    other = polygon_irradiance(QUAD, p, n, 1.0) - ref
    assert abs(mean - ref) <= 5 * se and abs(other - ref) > 20 * se, (mean, ref, other, se)


def test_vertex_colour_emission_reads_the_scene_meshes_colours():
    """Emission from colours bound to scene mesh 1 (a floor is mesh 0): the sampled radiance is the barycentric
    interpolation of the vertex colours at the sampled point (the light's surface batch reports scene mesh ids)."""
    from pyrt.io.assets.materials import VertexColorTexture
    cols = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 1.0, 1.0]])
    tex = VertexColorTexture()
    sc = pyrt.Scene()
    sc.add_plane((0, 0, 0), 4.0, pyrt.Lambert(0.5))
    mid = sc.add_mesh(quad_mesh(), pyrt.Lambert(0.0, emission=tex), smooth=False)
    tex.bind(mid, sc.meshes[mid].faces, cols)
    light = sc.add_emissive_lights()
    n = 300
    p = np.zeros((n, 3)) + [0.1, 0.0, -0.2]
    ls = light.sample_li(p, np.random.default_rng(9).random((n, 2)))
    Le = ls.irradiance() * ls.pdf[:, None]
    y = p + ls.dist[:, None] * ls.wi
    expect = np.zeros((n, 3))
    for f in sc.meshes[mid].faces:
        v = QUAD[f]
        b = np.linalg.lstsq(np.column_stack([v[1] - v[0], v[2] - v[0]]), (y - v[0]).T, rcond=None)[0].T
        inside = (b >= -1e-9).all(axis=1) & (b.sum(axis=1) <= 1 + 1e-9)
        bb = np.column_stack([1 - b.sum(axis=1), b])[inside]
        expect[inside] = bb @ cols[f]
    np.testing.assert_allclose(Le, expect, atol=1e-9)
    assert np.ptp(Le[:, 0]) > 0.5         # not the unbound white


@pytest.mark.parametrize("material, behind", [
    (pyrt.AreaEmitter(2.0), 0.0),                                    # one-sided by default
    (pyrt.AreaEmitter(2.0, two_sided=True), 1.0),
    (pyrt.Lambert(0.0, emission=2.0), 1.0),                          # double_sided (default): both sides
    (pyrt.Lambert(0.0, emission=2.0).set_coverage(double_sided=False), 0.0),   # glTF doubleSided false
])
def test_emitters_light_the_sides_their_material_emits_from(material, behind):
    _, light = emitter_scene(material)
    front_p, back_p = np.array([0.1, 0.0, 0.1]), np.array([0.1, 2.0, 0.1])
    mean, se = irradiance_estimate(light, front_p, np.array([0.0, 1.0, 0.0]), count=50_000)
    ref = polygon_irradiance(QUAD, front_p, np.array([0.0, 1.0, 0.0]), 2.0)
    assert abs(mean - ref) <= 5 * se
    mean_b, se_b = irradiance_estimate(light, back_p, np.array([0.0, -1.0, 0.0]), count=50_000)
    ref_b = behind * polygon_irradiance(QUAD, back_p, np.array([0.0, -1.0, 0.0]), 2.0)
    assert abs(mean_b - ref_b) <= 5 * se_b + 1e-12
    if behind == 0:
        assert mean_b == 0


# ----------------------------------------------------------------------------------------------- (e) the pmf

def test_triangle_choice_follows_area_times_emission_chi_square():
    """Three emitters of different areas and strengths: triangles are chosen with pmf ~ area x emission."""
    sc = pyrt.Scene()
    sc.add_mesh(quad_mesh(), pyrt.AreaEmitter(1.0), smooth=False)
    sc.add_box((2.0, 1.0, 0.0), (0.5, 1.0, 2.0), pyrt.AreaEmitter(4.0))
    sc.add_plane((0, 0, 0), 3.0, pyrt.Lambert(0.5))                 # no emission: not part of the light
    sc.add_sphere((-2.0, 1.0, 0.0), 0.3, pyrt.Lambert(0.2, emission=(1.0, 2.0, 3.0)), subdivisions=1)
    light = sc.add_emissive_lights()
    assert light.mesh_ids == (0, 1, 3)
    geo = sc.geometry_table()
    area = []
    for i, L in ((0, 1.0), (1, 4.0), (3, 2.0)):
        m = sc.meshes[i]
        v = m.vertices[m.faces]
        area.append(0.5 * np.linalg.norm(np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0]), axis=1) * L)
    expected = np.concatenate(area) / np.concatenate(area).sum()
    np.testing.assert_allclose(light.pmf, expected, rtol=1e-12)
    n = 200_000
    u = np.random.default_rng(3).random((n, 2))
    # the light's choice: the float64 CDF of the pmf at the first random number (as sample_li uses it)
    tri = np.minimum(np.searchsorted(np.cumsum(light.pmf), u[:, 0], side="right"), light.pmf.size - 1)
    obs = np.bincount(tri, minlength=light.pmf.size)
    chi2 = np.sum((obs - n * expected) ** 2 / (n * expected))
    assert stats.chi2.sf(chi2, expected.size - 1) > 1e-4
    # the sampled points lie on the chosen triangles (on their planes)
    ls = light.sample_li(np.zeros((n, 3)) + [0.0, -1.0, 0.0], u)
    counts = np.cumsum([sc.meshes[i].faces.shape[0] for i in light.mesh_ids])
    mesh = np.searchsorted(counts, tri, side="right")
    prim = tri - np.concatenate([[0], counts])[mesh]
    y = ls.dist[:, None] * ls.wi + [0.0, -1.0, 0.0]
    v = np.stack([sc.meshes[light.mesh_ids[m]].vertices[sc.meshes[light.mesh_ids[m]].faces[q]]
                  for m, q in zip(mesh[:2000], prim[:2000])])
    nrm = np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0])
    assert np.allclose(np.einsum("ij,ij->i", y[:2000] - v[:, 0], nrm), 0.0, atol=1e-9)


def test_triangles_that_emit_nothing_at_their_probes_are_not_sampled():
    """A texture black on one triangle of the quad (v > u, nearest texels): that triangle has pmf 0, no sample
    lands on it and pdf_hit is 0 there (a ray that hits it counts its emission with weight 1)."""
    h = w = 64
    r, c = np.mgrid[0:h, 0:w]
    vv, uu = 1.0 - (r + 0.5) / h, (c + 0.5) / w
    img = np.repeat(np.where(vv > uu, 0.0, 1.0)[..., None], 3, axis=2)
    _, light = emitter_scene(pyrt.Lambert(0.0, emission=ImageTexture(img, filter="nearest", decode="linear")),
                             uv=True)
    assert light.sampled_triangles == 1 and sorted(light.pmf.tolist()) == [0.0, 1.0]
    dark = int(np.flatnonzero(light.pmf == 0)[0])
    n = 1000
    ls = light.sample_li(np.zeros((n, 3)), np.random.default_rng(5).random((n, 2)))
    assert np.all(ls.irradiance().max(axis=1) > 0)
    assert np.all(light.pdf_hit(np.zeros((n, 3)), np.zeros(n, dtype=np.int64), np.full(n, dark), ls.dist,
                                np.ones(n)) == 0)


# ------------------------------------------------------------------------------- (b) renders: NEE vs BSDF rays

def _receiver_scene(material, emissive_samples, selection="power"):
    cam = pyrt.Camera(position=(0, 1.0, 3.0), target=(0, 0, 0), fov=40, width=16, height=12, spp=16)
    sc = pyrt.Scene(cam)
    sc.add_plane((0, 0, 0), 4.0, material, name="floor")
    sc.add_mesh(quad_mesh(), pyrt.AreaEmitter(3.0), smooth=False, name="panel")
    sc.add_box((1.2, 0.6, -0.8), 0.3, pyrt.AreaEmitter(5.0), name="cube")       # one-sided: the oriented cut
    if emissive_samples:
        sc.add_emissive_lights(n_samples=emissive_samples, selection=selection)
    return sc


def _floor_radiance(sc, seeds, **kw):
    """Per-seed mean radiance of the floor rows (the lower half of the image) and its standard error."""
    vals = np.array([pyrt.render(sc, integrator="glossy", seed=s, **kw)[6:].astype(np.float64).mean()
                     for s in seeds])
    return vals.mean(), vals.std(ddof=1) / math.sqrt(len(vals))


@pytest.mark.parametrize("material, threshold, selection", [
    (pyrt.MetallicRoughness(base_color=0.8, metallic=1.0, roughness=0.5), 0.4, "power"),     # glossy (alpha 0.25)
    (pyrt.MetallicRoughness(base_color=0.8, metallic=1.0, roughness=0.5), 0.4, "oriented"),
    pytest.param(pyrt.MetallicRoughness(base_color=0.8, metallic=0.0, roughness=1.0), 1.0, "power",  # + diffuse
                 marks=pytest.mark.slow),
    pytest.param(pyrt.MetallicRoughness(base_color=0.8, metallic=0.0, roughness=1.0), 1.0, "oriented",
                 marks=pytest.mark.slow),
])
def test_emitter_sampling_with_mis_agrees_with_bsdf_rays_alone(material, threshold, selection):
    """Three estimators of the same image: the glossy rays alone (no emissive light, 64 per hit), the emissive
    light alone (glossy_threshold 0: no rays, light samples with weight 1) and both MIS-combined. They agree
    within 5 standard errors; counting a direction twice would double the MIS estimate."""
    seeds = range(6)
    bsdf, se_b = _floor_radiance(_receiver_scene(material, 0), seeds, spp=16, glossy_samples=64,
                                 glossy_threshold=threshold)
    nee, se_n = _floor_radiance(_receiver_scene(material, 2, selection), seeds, spp=16, glossy_threshold=0.0)
    mis, se_m = _floor_radiance(_receiver_scene(material, 2, selection), seeds, spp=16, glossy_samples=4,
                                glossy_threshold=threshold)
    assert bsdf > 0.05
    for est, se in ((nee, se_n), (mis, se_m)):
        assert abs(est - bsdf) <= 5 * math.hypot(se, se_b) + 1e-4 * bsdf, (est, bsdf, se, se_b)
    assert 5 * math.hypot(se_m, se_b) < 0.2 * bsdf       # double counting (2x) would be far outside


@pytest.mark.parametrize("selection", ["power", "oriented"])
def test_lambertian_floor_lit_by_emitter_matches_the_closed_form(selection):
    """A Lambertian floor under the emissive quad (camera straight down past its edge): each pixel's radiance is
    albedo / pi x the polygon irradiance averaged over the pixel (8 x 8 sub-pixel midpoints); without the
    emissive light the floor gets nothing (Lambertian hits trace no rays)."""
    cam = pyrt.Camera(position=(1.2, 3.0, 0.0), target=(1.2, 0.0, 0.0), up=(0, 0, -1), fov=30, width=8, height=8,
                      spp=16)
    sc = pyrt.Scene(cam)
    sc.add_plane((0, 0, 0), 20.0, pyrt.Lambert(0.5), name="floor")
    panel = QUAD + [0.0, 0.0, 0.0]
    sc.add_mesh((panel, DOWN), pyrt.AreaEmitter(3.0), smooth=False, name="panel")
    dark = pyrt.render(sc, integrator="glossy", seed=0)
    assert dark.max() == 0
    sc.add_emissive_lights(n_samples=4, selection=selection)
    imgs = np.array([pyrt.render(sc, integrator="glossy", seed=s)[..., 0] for s in range(4)], dtype=np.float64)
    k = 8
    ys, xs = np.mgrid[0:cam.height * k, 0:cam.width * k]
    d = cam.directions((xs.ravel() + 0.5) / k, (ys.ravel() + 0.5) / k)
    t = -cam.position[1] / d[:, 1]
    pts = cam.position + t[:, None] * d
    ref = np.array([0.5 / math.pi * polygon_irradiance(panel, q, np.array([0.0, 1.0, 0.0]), 3.0) for q in pts])
    ref = ref.reshape(cam.height, k, cam.width, k).mean(axis=(1, 3))
    mean = imgs.mean(axis=0)
    se = imgs.std(axis=0, ddof=1) / 2.0
    assert ref.min() > 0.01
    # the image as a whole (SE of the mean over pixels and seeds) and every pixel (its own SE over 4 seeds, loose)
    se_all = imgs.mean(axis=(1, 2)).std(ddof=1) / 2.0
    assert abs(mean.mean() - ref.mean()) <= 5 * se_all + 2e-3 * ref.mean(), (mean.mean(), ref.mean(), se_all)
    assert np.all(np.abs(mean - ref) <= 8 * se + 0.02 * ref)


def test_whitted_and_default_render_are_unchanged_without_the_light():
    """Off unless asked: a scene without add_emissive_lights renders as before (the light is the only switch)."""
    sc = _receiver_scene(pyrt.Lambert(0.5), 0)
    assert not any(lt.scene_emitter for lt in sc.lights)
    img = pyrt.render(sc, seed=0)
    assert img[6:].max() == 0          # Whitted: the floor receives nothing from a mesh that is no light
    sc.add_emissive_lights()
    assert pyrt.render(sc, seed=0)[6:].max() > 0     # with it, the Whitted integrator samples it too


# --------------------------------------------------------------------------------------- (f) switches, errors

OBJ = "v -1 0 -1\nv 1 0 -1\nv 1 0 1\nv -1 0 1\nv -1 1 -1\nv 1 1 -1\nv 1 1 1\nv -1 1 1\n" \
      "mtllib m.mtl\nusemtl floor\nf 1 3 2\nf 1 4 3\nusemtl lamp\nf 5 6 7\nf 5 7 8\n"


def _obj(tmp_path, emissive):
    (tmp_path / "m.mtl").write_text("newmtl floor\nKd 0.5 0.5 0.5\nnewmtl lamp\nKd 0 0 0\n"
                                    + ("Ke 2 2 2\n" if emissive else ""))
    (tmp_path / "m.obj").write_text(OBJ)
    return str(tmp_path / "m.obj")


@pytest.mark.parametrize("emissive", [True, False])
def test_previewer_turns_emitter_sampling_on_for_emissive_models_only(tmp_path, emissive):
    tiny = dict(width=32, height=24, spp=1)
    ps = PreviewScene(pyrt.load_asset(_obj(tmp_path, emissive)), PreviewOptions(**tiny))
    lights = [lt for lt in ps.asset_lights if lt.scene_emitter]
    assert (ps.emissive_light is not None) == emissive == (len(lights) == 1)
    if emissive:
        assert ps.emissive_light.n_samples == PreviewOptions().emissive_samples
        assert ps.render_view(ps.azimuth).image.max() > 0
    off = PreviewScene(pyrt.load_asset(_obj(tmp_path, emissive)), PreviewOptions(emissive_lights="off", **tiny))
    assert off.emissive_light is None and not any(lt.scene_emitter for lt in off.scene.lights)


def test_bad_arguments_raise_pyrt_errors_naming_the_problem(tmp_path, capsys):
    sc, light = emitter_scene(pyrt.AreaEmitter(1.0))
    with pytest.raises(pyrt.SceneError, match="already has an emissive-mesh light"):
        sc.add_emissive_lights()
    for bad in (0, -1, 1.5, True):
        with pytest.raises(LightError, match="n_samples must be a positive integer"):
            pyrt.EmissiveMeshLight(sc.meshes, sc.materials, n_samples=bad)
    with pytest.raises(LightError, match="mesh_ids must be indices"):
        pyrt.EmissiveMeshLight(sc.meshes, sc.materials, mesh_ids=[3])
    plain = pyrt.Scene()
    plain.add_plane((0, 0, 0), 1.0, pyrt.Lambert(0.5))
    assert plain.add_emissive_lights() is None and plain.lights == []
    with pytest.raises(LightError, match="no emissive mesh"):
        pyrt.EmissiveMeshLight(plain.meshes, plain.materials)
    light.n_samples = 0
    with pytest.raises(LightError, match="n_samples"):
        sc.validate()
    with pytest.raises(PreviewError, match="emissive_lights must be 'auto' or 'off'"):
        PreviewOptions(emissive_lights="on").validate()
    with pytest.raises(PreviewError, match="emissive_samples must be a positive integer"):
        PreviewOptions(emissive_samples=0).validate()
    with pytest.raises(PreviewError, match="emissive_selection must be 'power' or 'oriented'"):
        PreviewOptions(emissive_selection="bvh").validate()
    with pytest.raises(SystemExit) as exc:
        preview_main([_obj(tmp_path, True), "-o", str(tmp_path / "x.png"), "--emissive-samples", "0"])
    assert exc.value.code == 2
    assert "emissive-samples" in capsys.readouterr().err


@pytest.mark.parametrize("integrator", ["whitted", "glossy"])
def test_render_refuses_a_light_built_for_other_meshes(integrator):
    sc, light = emitter_scene(pyrt.AreaEmitter(1.0))
    other = pyrt.Scene(sc.camera)
    other.add_mesh(quad_mesh(), pyrt.AreaEmitter(1.0), smooth=False)
    other.add_light(light)
    with pytest.raises(pyrt.RenderError, match="built for other meshes"):
        pyrt.render(other, integrator=integrator, spp=1)


@pytest.mark.parametrize("selection", ["power", "oriented"])
def test_light_and_ray_weights_of_one_point_sum_to_one(selection):
    """At a glossy hit: the MIS weight of a light sample toward a point of the emissive quad (its own pdf) plus the
    weight the integrator gives a glossy ray that hits the same point (``_emission_weight`` with the hit's
    triangle and distance) is 1: each direction is counted once."""
    from pyrt.geometry.surface import surface_from_hits
    from pyrt.integrators import PreparedScene
    from pyrt.integrators.glossy import GlossyIntegrator, mis_weights
    sc = _receiver_scene(pyrt.MetallicRoughness(base_color=0.8, metallic=1.0, roughness=0.5), 3, selection)
    light = next(lt for lt in sc.lights if lt.scene_emitter)
    n = 400
    rng = np.random.default_rng(7)
    o = np.column_stack([rng.uniform(-1, 1, n), np.full(n, 1e-3), rng.uniform(-1, 1, n)])
    ls = light.sample_li(o, rng.random((n, 2)))
    p_b = rng.exponential(size=n)                         # any BSDF density of the direction
    lit = np.flatnonzero(ls.irradiance().max(axis=1) > 0)     # samples on faces that face o (their point is hit)
    assert lit.size > n // 3
    o, wi, dist, pdf, p_b = o[lit], ls.wi[lit], ls.dist[lit], ls.pdf[lit], p_b[lit]
    with PreparedScene(sc) as ps:
        integ = GlossyIntegrator(ps, glossy_samples=4)
        hits = ps.accel.intersect(o, wi)
        assert np.all(hits.hit) and np.all(np.isin(hits.mesh_id, [1, 2]))
        np.testing.assert_allclose(hits.t, dist, rtol=1e-5)
        ctx = surface_from_hits(ps.geo, hits, o, wi)
        w_l = mis_weights(light.n_samples, pdf, 4, p_b)[0]
        w_b = np.zeros(lit.size)
        for k in np.unique(ctx.material_id):
            sel = np.flatnonzero(ctx.material_id == k)
            w_b[sel] = integ._emission_weight(int(k), o[sel], wi[sel], 4 * p_b[sel], ctx.subset(sel))
            np.testing.assert_array_equal(integ._emission_weight(int(k), o[sel], wi[sel], np.zeros(sel.size),
                                                                 ctx.subset(sel)), 1.0)   # delta rays: weight 1
        np.testing.assert_allclose(w_l + w_b, 1.0, rtol=1e-4)         # hit t is float32-exact, the sample's float64
        assert 0.05 < w_b.mean() < 0.95


def test_scene_files_turn_the_emissive_meshes_into_a_light():
    spec = {"camera": {"position": [0, 0.5, 3], "target": [0, 0, 0], "width": 8, "height": 6},
            "materials": {"lamp": {"type": "area_emitter", "radiance": 2.0}, "floor": {"type": "lambert"}},
            "meshes": [{"primitive": "plane", "size": 4, "material": "floor"},
                       {"primitive": "plane", "size": 1, "normal": [0, -1, 0], "translate": [0, 1, 0], "material": "lamp"}],
            "lights": [{"type": "emissive_mesh", "n_samples": 3}]}
    sc, _ = pyrt.load_dict(spec)
    (light,) = sc.lights
    assert light.scene_emitter and light.n_samples == 3 and light.mesh_ids == (1,)
    with pytest.raises(pyrt.SceneFileError, match="allowed parameters"):
        pyrt.load_dict({**spec, "lights": [{"type": "emissive_mesh", "samples": 3}]})
    with pytest.raises(pyrt.SceneFileError, match="n_samples must be a positive integer"):
        pyrt.load_dict({**spec, "lights": [{"type": "emissive_mesh", "n_samples": 0}]})


def test_area_light_meshes_are_not_sampled_twice():
    """The visible mesh of a RectLight (AreaLight.add_to) is lit by the RectLight: add_emissive_lights leaves it out
    (None when nothing else emits; only the other emitter otherwise), so the floor's irradiance is counted once."""
    sc = pyrt.Scene()
    sc.add_plane((0, 0, 0), 4.0, pyrt.Lambert(0.5))
    rect = pyrt.RectLight((0.0, 1.0, 0.0), size=1.0, radiance=2.0, name="key")
    rect.add_to(sc)
    assert sc.meshes[-1].name == rect.emitter_mesh_name == "key_emitter"
    assert sc.add_emissive_lights() is None and sc.lights == [rect]
    mid = sc.add_mesh(quad_mesh(), pyrt.AreaEmitter(1.0), smooth=False, name="panel")
    light = sc.add_emissive_lights()
    assert light.mesh_ids == (mid,)


# ------------------------------------------------------------------------------------ selection="oriented"

def _cube_faces(center, size):
    """The six faces (4 vertices each, counter-clockwise seen from outside) and outward normals of a cube."""
    c, h = np.asarray(center, dtype=np.float64), size / 2
    faces = []
    for axis in range(3):
        for sgn in (-1.0, 1.0):
            n = np.zeros(3)
            n[axis] = sgn
            u, v = np.roll(np.eye(3), 1, axis=0)[axis], np.roll(np.eye(3), 2, axis=0)[axis]
            if sgn < 0:
                u, v = v, u
            q = c + n * h
            faces.append((np.array([q - h * u - h * v, q + h * u - h * v, q + h * u + h * v, q - h * u + h * v]), n))
    return faces


@pytest.mark.parametrize("selection", ["power", "oriented"])
def test_one_sided_cube_irradiance_matches_the_sum_over_its_faces_that_face_the_point(selection):
    """A one-sided emissive cube (AreaEmitter) beside a panel: the irradiance at points outside is the polygon
    formula summed over the faces that face the point (convex: exactly the visible ones) plus the panel's; the
    oriented choice, which never samples the faces of a cluster behind the point, gives the same."""
    sc = pyrt.Scene()
    sc.add_mesh(quad_mesh(), pyrt.AreaEmitter(3.0), smooth=False)
    sc.add_box((1.5, 1.2, 0.0), 0.6, pyrt.AreaEmitter(5.0))
    light = sc.add_emissive_lights(selection=selection)
    n = np.array([0.0, 1.0, 0.0])
    for p in ([0.0, 0.0, 0.0], [2.5, 0.2, 0.4]):
        p = np.asarray(p)
        ref = polygon_irradiance(QUAD, p, n, 3.0)
        for verts, nf in _cube_faces((1.5, 1.2, 0.0), 0.6):
            if nf @ (p - verts[0]) > 0:
                ref += polygon_irradiance(verts, p, n, 5.0)
        mean, se = irradiance_estimate(light, p, n)
        assert abs(mean - ref) <= 5 * se, (selection, p, mean, ref, se)


def test_oriented_choice_probabilities_chi_square_and_the_back_face_cut():
    """At a point, the oriented light's triangle probabilities sum to 1, faces of one-sided clusters behind the
    point get 0 (two-sided ones do not), and the chosen triangles follow the probabilities (chi-square)."""
    sc = pyrt.Scene()
    sc.add_box((1.5, 1.2, 0.0), 0.6, pyrt.AreaEmitter(5.0))                    # one-sided: 6 clusters
    sc.add_box((-1.5, 1.2, 0.0), 0.6, pyrt.Lambert(0.0, emission=5.0))         # two-sided (double_sided)
    light = sc.add_emissive_lights(selection="oriented")
    assert light._choice.clusters == 12 and light._choice.cut.sum() == 6
    p = np.array([[0.0, 0.0, 0.3]])
    tris = np.arange(light.triangles)
    prob = light._choice.triangle_probabilities(p, tris)[0]
    np.testing.assert_allclose(prob.sum(), 1.0, rtol=1e-12)
    geo_n = light._geo.face_normals
    y0 = light._geo.vertices[light._geo.faces[:, 0]]
    facing = np.einsum("ij,ij->i", geo_n, p[0] - y0) > 0
    one_sided = tris < 12
    assert np.all(prob[one_sided & ~facing] == 0) and np.all(prob[one_sided & facing] > 0)
    assert np.all(prob[~one_sided] > 0)
    n = 100_000
    tri, _, pr = light._choice.choose(np.repeat(p, n, axis=0), np.random.default_rng(11).random(n))
    np.testing.assert_allclose(pr, prob[tri], rtol=1e-12)
    obs = np.bincount(tri, minlength=tris.size)
    keep = prob > 0
    assert np.all(obs[~keep] == 0)
    chi2 = np.sum((obs[keep] - n * prob[keep]) ** 2 / (n * prob[keep]))
    assert stats.chi2.sf(chi2, keep.sum() - 1) > 1e-4


def test_bad_selection_is_a_light_error():
    sc = pyrt.Scene()
    sc.add_mesh(quad_mesh(), pyrt.AreaEmitter(3.0), smooth=False)
    with pytest.raises(LightError, match="selection must be 'power' or 'oriented'"):
        sc.add_emissive_lights(selection="bvh")


def test_previewer_samples_only_emitters_that_are_light_sources(tmp_path):
    """``emissive_lights="auto"`` keeps the light only when its power (pi sum A L) is
    at least EMISSIVE_POWER_RATIO of the key light onto the model (key x pi R^2): scaling the key up past that
    point turns it off (decorative glow), down turns it on; without the studio rig it is always on."""
    from pyrt.apps.preview.options import EMISSIVE_POWER_RATIO
    tiny = dict(width=32, height=24, spp=1)
    path = _obj(tmp_path, True)
    ps = PreviewScene(pyrt.load_asset(path), PreviewOptions(**tiny))
    try:
        lt = ps.emissive_light
        assert lt is not None
        ratio = lt.power / (PreviewOptions().key * math.pi * ps.radius ** 2)
        radius = ps.radius
    finally:
        ps.close()
    key0 = PreviewOptions().key
    for key, on in ((0.5 * key0 * ratio / EMISSIVE_POWER_RATIO, True),
                    (2.0 * key0 * ratio / EMISSIVE_POWER_RATIO, False)):
        ps = PreviewScene(pyrt.load_asset(path), PreviewOptions(key=key, **tiny))
        try:
            assert (ps.emissive_light is not None) is on, (key, ratio)
            assert any(lt.scene_emitter for lt in ps.scene.lights) is on
            assert ps.radius == radius
        finally:
            ps.close()
    ps = PreviewScene(pyrt.load_asset(path), PreviewOptions(key=1e9, lights="asset", **tiny))
    try:
        assert ps.emissive_light is not None       # no studio rig: nothing to compare with
    finally:
        ps.close()


def test_power_of_a_uniform_one_sided_emitter():
    """``EmissiveMeshLight.power`` = pi A L for a one-sided Lambertian emitter of constant radiance L."""
    import trimesh
    _, light = emitter_scene(pyrt.AreaEmitter(3.0))
    area = trimesh.Trimesh(vertices=QUAD, faces=DOWN, process=False).area
    assert light.power == pytest.approx(math.pi * area * 3.0, rel=1e-12)
    for min_power, added in ((0.99 * light.power, True), (1.01 * light.power, False)):
        sc = pyrt.Scene(pyrt.Camera(position=(0, 0.5, 3.0), target=(0, 0, 0)))
        sc.add_mesh(quad_mesh(), pyrt.AreaEmitter(3.0), smooth=False, name="panel")
        got = sc.add_emissive_lights(min_power=min_power)
        assert (got is not None) is added and (len(sc.lights) == 1) is added


def test_glTF_and_OBJ_materials_emit_only_with_an_emission():
    """SurfaceExtras (glTF, OBJ materials) declares when it emits: a constant zero emission does not, a colour or a
    texture does. (Before, every such material counted as an emitter: the previewer probed all their triangles for an
    emissive-mesh light, 12-15 s of a 5.24 M-triangle PLY, and evaluated their zero emission at every hit.)"""
    from pyrt.io.assets.materials import GltfMaterial, ObjMaterial
    from pyrt.materials import Clearcoat, Material

    kw = dict(base_color=(0.8, 0.8, 0.8), metallic=0.0, roughness=0.5)
    assert not GltfMaterial(**kw).emits and not GltfMaterial(**kw, emission=(0.0, 0.0, 0.0)).emits
    assert GltfMaterial(**kw, emission=(0.0, 0.0, 2.0)).emits
    assert GltfMaterial(**kw, emission=ImageTexture(np.zeros((2, 2, 3), np.float32))).emits   # a map may emit
    assert not ObjMaterial((0.5, 0.5, 0.5), (0.0, 0.0, 0.0), 10.0).emits
    assert ObjMaterial((0.5, 0.5, 0.5), (0.0, 0.0, 0.0), 10.0, emission=(1.0, 1.0, 1.0)).emits
    assert not Clearcoat(GltfMaterial(**kw)).emits and Clearcoat(GltfMaterial(**kw, emission=(1, 1, 1))).emits

    class Glows(Material):            # overrides emission() and says nothing: may emit
        def emission(self, ctx):
            return np.ones((ctx.n_hits, 3))

    class Quiet(GltfMaterial):        # a subclass of a class that declares it keeps the declaration
        pass
    assert Glows.emits is True and not Quiet(**kw).emits and Quiet(**kw, emission=(1, 0, 0)).emits


def test_previewer_probes_no_emitters_for_a_model_that_does_not_emit(tmp_path, monkeypatch):
    """A PLY (the clay material) and a glTF without emission: no emissive-mesh light is built at all."""
    import trimesh

    from pyrt.io.assets import load_asset
    from pyrt.lights import mesh as light_mesh

    def refuse(*args, **kwargs):
        raise AssertionError("EmissiveMeshLight built for a model that does not emit")
    monkeypatch.setattr(light_mesh.EmissiveMeshLight, "__init__", refuse)
    m = trimesh.creation.icosphere(2)
    for name in ("s.ply", "s.glb"):
        m.export(tmp_path / name)
        ps = PreviewScene(load_asset(str(tmp_path / name)), PreviewOptions(width=16, height=12))
        assert ps.emissive_light is None
