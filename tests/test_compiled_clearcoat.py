"""The clear coat (:class:`pyrt.Clearcoat`, glTF ``KHR_materials_clearcoat``) on the compiled path.

A coat over an opaque base that packs as a GLTF record is that record with the coat's fields
(:data:`pyrt.materials.compiled.COAT`; :func:`pyrt.materials.gltf_record.clearcoat_record`):

- the scalar twins (:func:`pyrt.materials.compiled_sampling.f_cos_local`, ``pdf_wi``, ``sample_f``, compiled in
  ``numba.njit`` loops) equal the NumPy coat's ``f_cos``, ``pdf`` and ``sample`` to 1e-6 relative for coat normals
  tilted away from the shading normal (a base's or the coat's own normal map), with and without the coat's own map,
  random and grazing directions; the sampler follows its pdf (chi-square, and the same checks with an untilted coat:
  tests/test_compiled_sampling.py; the material contracts on the kernel's evaluation: tests/test_compiled_contracts.py);
- renders at pixel centres (delta lights, the environment's noise-free split-sum preview) give the NumPy path's
  image pixel by pixel: constant and textured clear coat and coat roughness, a textured base, the base's normal map,
  the coat's own map and one map shared by both (ClearCoatTest's cases);
- jittered renders with the glossy integrator (glossy rays off the coat, a rectangle light's light and BSDF samples,
  a sampled sky; the light choice under the previewer's studio-like preview) agree in distribution;
- what the kernel does not read keeps the NumPy path with the coat named in the reasons.
"""
import numba
import numpy as np
import pytest

import pyrt
from material_helpers import LocalCtx
from pyrt.integrators import compiled
from pyrt.io.assets import load_asset
from pyrt.materials import compiled as MC
from pyrt.materials import compiled_sampling as CS
from pyrt.shaders.vec import coordinate_frame
from pyrt.textures import ChannelTexture
from pyrt.textures import compiled as TC

from test_compiled_footprints import _normal_map
from test_compiled_glossy import _add_sky, _assert_agree
from test_gltf_materials import _quad, write_gltf

pytestmark = pytest.mark.filterwarnings("ignore:invalid value encountered:RuntimeWarning",
                                        "ignore:divide by zero encountered:RuntimeWarning",
                                        "ignore:render. material .* is a mirror-like microfacet lobe")


# ----------------------------------------------------------------------------------------- the scalar twins

class _TiltedCoat(pyrt.Clearcoat):
    """A coat whose normal is given per hit (``nc`` (N, 3), local): the frame a normal map would make."""

    nc = None

    def _coat_frame(self, ctx):
        return (*coordinate_frame(self.nc), self.nc)


@numba.njit
def _twins(tag, rec, inputs, nc, wo, wi, u, f, pdf, smp):
    tex_tag = np.zeros(1, dtype=np.int64)
    tex_par = np.zeros(8)
    a0 = MC.albedo_at(tag, rec, 0, tex_tag, tex_par, 0.0, 0.0, TC.NO_FOOTPRINT, MC.WHITE)
    for k in range(wo.shape[0]):
        a = (a0[0], a0[1], a0[2], a0[3], a0[4], a0[5], a0[6], a0[7], a0[8], a0[9], a0[10], a0[11], a0[12],
             inputs[k, 0], inputs[k, 1], a0[15], a0[16], a0[17])
        a = MC.with_coat_normal(a, (nc[k, 0], nc[k, 1], nc[k, 2]))
        f[k, 0], f[k, 1], f[k, 2] = CS.f_cos_local(tag, rec, 0, a, wo[k, 0], wo[k, 1], wo[k, 2], wi[k, 0], wi[k, 1],
                                                   wi[k, 2])
        pdf[k] = CS.pdf_wi(tag, rec, 0, a, wo[k, 0], wo[k, 1], wo[k, 2], wi[k, 0], wi[k, 1], wi[k, 2])
        r = CS.sample_f(tag, rec, 0, a, wo[k, 0], wo[k, 1], wo[k, 2], u[k, 0], u[k, 1])
        for j in range(7):
            smp[k, j] = r[j]
        d = CS.sample_wi(tag, rec, 0, a, wo[k, 0], wo[k, 1], wo[k, 2], u[k, 0], u[k, 1])
        if d[0] != r[0] or d[1] != r[1] or d[2] != r[2] or d[3] != r[6]:
            smp[k, 6] = np.nan                 # sample_wi and sample_f disagree


def _unit(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _inputs(rng, n):
    """Random and grazing ``wo``, ``wi`` (N, 3), ``u`` (N, 2), coat normals tilted up to ~40 degrees, per-hit clear
    coat and coat alpha (textures' values)."""
    wo, wi = _unit(rng.normal(size=(n, 3))), _unit(rng.normal(size=(n, 3)))
    wo[:, 2] = np.abs(wo[:, 2])
    g = n // 8
    for c, rows in ((1e-3, slice(0, g)), (1e-6, slice(g, 2 * g)), (0.0, slice(2 * g, 3 * g))):
        wo[rows, 2] = c
        wo[rows, :2] *= np.sqrt(1.0 - c * c) / np.linalg.norm(wo[rows, :2], axis=1, keepdims=True)
    nc = _unit(rng.normal(size=(n, 3)) * 0.35 + [0.0, 0.0, 1.0])
    nc[-g:] = (0.0, 0.0, 1.0)
    u = rng.random((n, 2))
    u[:g // 2, 0] = np.nextafter(1.0, 0.0)
    u[g // 2:g, 0] = 0.0
    cc = np.column_stack([rng.uniform(0.0, 1.0, n), rng.uniform(0.0, 1.0, n) ** 2])
    cc[:g, 1] = 9e-4                                  # ClearCoatTest's coat roughness 0.03
    return wo, wi, u, nc, cc


@pytest.mark.parametrize("coat_map", [False, True])
def test_coat_twins_equal_the_numpy_coat_for_tilted_coat_normals(coat_map, rng):
    """f_cos, pdf and the sample (direction, weight, pdf) of a coat over a metallic-roughness base, the coat's normal
    tilted from the shading normal (without its own map: the base's map tilted the shading normal; with it: the
    coat's lobe is also cut below the shading horizon), per-hit clear coat and roughness: 1e-6 relative."""
    n = 4000
    wo, wi, u, nc, cc = _inputs(rng, n)
    nm = pyrt.NormalMap(np.full((2, 2, 3), 0.5, dtype=np.float32)) if coat_map else None
    base = pyrt.MetallicRoughness(base_color=(0.5, 0.3, 0.1), metallic=0.2, roughness=0.45)
    f_np, p_np, s_np = np.zeros((n, 3)), np.zeros(n), np.zeros((n, 7))
    for k0 in range(0, n, 500):            # the NumPy coat's clear coat and roughness are per material: per block
        rows = slice(k0, k0 + 500)
        mat = _TiltedCoat(base, clearcoat=float(cc[k0, 0]), roughness=float(np.sqrt(cc[k0, 1])), normal_map=nm)
        cc[rows] = (mat.clearcoat, mat.roughness ** 2)
        mat.nc = nc[rows]
        ctx = LocalCtx(500)
        f_np[rows] = mat.f_cos(wo[rows], wi[rows], ctx)
        p_np[rows] = mat.pdf(wo[rows], wi[rows], ctx)
        w, weight, pdf = mat.sample(wo[rows], u[rows], ctx)
        s_np[rows] = np.column_stack([w, weight, pdf])
    tag, rec = mat.compiled_record(lambda t: 0)
    assert tag == MC.GLTF and rec[MC.COAT] == 1.0 and (rec[MC.COAT + 7] != 0.0) == coat_map
    f, pdf, smp = np.zeros((n, 3)), np.zeros(n), np.zeros((n, 7))
    _twins(tag, np.ascontiguousarray(rec), cc, nc, wo, wi, u, f, pdf, smp)
    assert not np.any(np.isnan(smp[:, 6])), "sample_wi and sample_f disagree"
    np.testing.assert_allclose(f, f_np, rtol=1e-6, atol=1e-12)
    np.testing.assert_allclose(pdf, p_np, rtol=1e-6, atol=1e-12)
    ok = s_np[:, 6] > 0
    assert ok.mean() > 0.5
    np.testing.assert_allclose(smp[ok, :3], s_np[ok, :3], rtol=1e-6, atol=1e-9)
    np.testing.assert_allclose(smp[:, 3:], s_np[:, 3:], rtol=1e-6, atol=1e-12)
    assert np.all(np.isfinite(f)) and np.all(f >= 0) and np.all(smp[:, 3:6] >= 0)


def test_the_glossy_alpha_is_the_coats_where_it_coats():
    """:func:`pyrt.materials.compiled.glossy_alpha` of a coated GLTF record: the smaller of the base's and the coat's
    alpha where ``c > 0`` (:meth:`pyrt.Clearcoat.glossy_alpha`), the base's where ``c = 0``."""
    tag, rec = pyrt.Clearcoat(pyrt.MetallicRoughness(roughness=0.5), roughness=0.1).compiled_record(lambda t: 0)
    rec[MC.GLOSSY] = -1.0
    base = (0.0,) * 7 + (0.5, 1.0, 1.0, 0.04, 0.04, 0.04)
    assert MC.glossy_alpha(rec, 0, base + (1.0, 0.01, 0.0, 0.0, 1.0)) == 0.01
    assert MC.glossy_alpha(rec, 0, base + (0.0, 0.01, 0.0, 0.0, 1.0)) == 0.25


# ----------------------------------------------------------------------------------------- what packs

def _coat_texture(rng, n=16):
    """An RGB image whose R is a clear-coat mask (ClearCoatTest's partial coating) and G a roughness ramp (its stripes)."""
    img = np.zeros((n, n, 3), dtype=np.float32)
    img[..., 0] = (rng.random((n, n)) > 0.4)
    img[..., 1] = np.linspace(0.0, 1.0, n)[None, :]
    img[..., 2] = 0.5
    return pyrt.ImageTexture(img, srgb=False, filter="bilinear")


def _coats(rng):
    """ClearCoatTest's cases: a plain coat, a partial coat (clear-coat texture x factor) with textured roughness over
    a textured base, a base normal map under a coat, a coat normal map over a plain base, one map shared by both."""
    tex = _coat_texture(rng)
    red = dict(base_color=(0.5, 0.02, 0.01), roughness=0.44)
    plain = pyrt.Clearcoat(pyrt.MetallicRoughness(**red), clearcoat=1.0, roughness=0.03, name="simple")
    textured_base = pyrt.MetallicRoughness(base_color=pyrt.ImageTexture(rng.random((8, 8, 3)).astype(np.float32)),
                                           roughness=0.6)
    partial = pyrt.Clearcoat(textured_base, clearcoat=ChannelTexture(tex, 0), name="partial",
                             roughness=ChannelTexture(tex, 1))
    mapped = pyrt.MetallicRoughness(**red)
    mapped.normal_map = pyrt.NormalMap(_normal_map(rng), strength=0.8)
    base_norm = pyrt.Clearcoat(mapped, clearcoat=1.0, roughness=0.03, name="base_norm")
    coat_norm = pyrt.Clearcoat(pyrt.MetallicRoughness(**red), clearcoat=0.9, roughness=0.03, name="coat_norm",
                               normal_map=pyrt.NormalMap(_normal_map(rng), strength=0.6))
    shared_map = pyrt.NormalMap(_normal_map(rng))
    shared = pyrt.MetallicRoughness(base_color=(0.02, 0.03, 0.2), roughness=0.3)
    shared.normal_map = shared_map
    shared_norm = pyrt.Clearcoat(shared, clearcoat=1.0, roughness=0.2, name="shared_norm", normal_map=shared_map)
    return plain, partial, base_norm, coat_norm, shared_norm


def _coat_scene(width=48, height=32, spp=1, jitter=False, env=None, seed=0):
    """The five coats of :func:`_coats` as spheres and a box on a checker floor under a point and a directional light
    (``env``: a lat-long sky with its ``"preview"`` light, or ``"mis"``: sampled)."""
    rng = np.random.default_rng(seed)
    cam = pyrt.Camera(position=(0, 1.4, 4.2), target=(0, 0.4, 0), fov=42, width=width, height=height, spp=spp,
                      jitter=jitter)
    s = pyrt.Scene(cam, background=(0.3, 0.35, 0.45), ambient=(0.02, 0.02, 0.02))
    s.add_plane((0, 0, 0), 8.0, pyrt.Lambert(albedo=pyrt.CheckerTexture(0.15, 0.7, scale=6, filtered=False)))
    plain, partial, base_norm, coat_norm, shared_norm = _coats(rng)
    s.add_sphere((-1.4, 0.4, 0.0), 0.4, plain, subdivisions=3)
    s.add_sphere((-0.45, 0.4, 0.3), 0.4, partial, subdivisions=3)
    s.add_sphere((0.5, 0.4, 0.0), 0.4, base_norm, subdivisions=3)
    s.add_sphere((1.45, 0.4, 0.3), 0.4, coat_norm, subdivisions=3)
    s.add_box((0.0, 0.35, -1.1), (1.6, 0.7, 0.3), shared_norm)
    s.add_light(pyrt.PointLight((2, 3, 2.5), intensity=25.0))
    s.add_light(pyrt.DirectionalLight((-0.4, -1, -0.5), irradiance=0.8))
    if env == "mis":
        _add_sky(s)
    elif env is not None:
        img = np.full((16, 32, 3), 0.25)
        img[3:6, 20:24] = (8.0, 7.0, 5.0)
        img[8:] = 0.05
        s.environment = pyrt.LatLongEnvironment(img)
        s.add_light(pyrt.EnvironmentLight(s.environment, strategy="preview", preview_method=env))
    return s


@pytest.mark.parametrize("env", [None, "split_sum", "samples", "mis"])
def test_coated_scenes_take_the_compiled_path(env):
    ps = pyrt.PreparedScene(_coat_scene(env=env))
    try:
        assert compiled.unsupported(ps) == []
        assert compiled.unsupported(ps, integrator="glossy", transparent_shadows=True, light_select_depth=1) == []
    finally:
        ps.close()


def test_a_coats_own_normal_map_turns_the_kernels_normal_maps_on():
    s = pyrt.Scene(pyrt.Camera(width=8, height=8))
    s.add_sphere((0, 0, -3), 1.0, _coats(np.random.default_rng(1))[3], subdivisions=1)
    ps = pyrt.PreparedScene(s)
    try:
        assert compiled.CompiledScene(ps).normal_maps == 1
    finally:
        ps.close()


def _same_pixels(s, **kw):
    """Both paths' renders of ``s`` at pixel centres: the same image (fewer than 0.2 % of pixels may differ where a
    ray meets an edge exactly); the compiled image."""
    c = pyrt.render_full(s, backend="compiled", progress=False, seed=0, **kw)
    n = pyrt.render_full(s, backend="numpy", progress=False, seed=0, **kw)
    assert c.stats.backend == "compiled" and c.stats.fallback_reasons == [] and n.stats.backend == "numpy"
    diff = np.abs(c.image.astype(np.float64) - n.image)
    bad = (diff > 1e-5 * (1.0 + np.abs(n.image))).any(axis=2)
    assert bad.mean() < 0.002, f"{bad.sum()} pixels differ, max {diff.max()}"
    return c.image.astype(np.float64)


@pytest.mark.parametrize("env", [None, "split_sum", "samples"])
def test_coats_match_the_numpy_path_at_pixel_centres(env):
    """Delta lights (and the noise-free preview of a sky: the coat's split-sum lobe about its own normal, or the
    preview's BSDF samples), the full Whitted tree: the compiled image is the NumPy path's; and the coats are seen
    (the image of the bases alone differs)."""
    s = _coat_scene(env=env)
    img = _same_pixels(s, integrator=pyrt.Whitted(split_depth=None))
    for m in s.materials:
        if isinstance(m, pyrt.Clearcoat):
            m.clearcoat = 0.0
    bare = pyrt.render_full(s, backend="compiled", progress=False, seed=0,
                            integrator=pyrt.Whitted(split_depth=None)).image
    assert (np.abs(bare - img) > 1e-3).any(axis=2).mean() > 0.02


@pytest.mark.parametrize("env", ["mis", "split_sum"])
def test_coats_agree_with_numpy_in_distribution(env):
    """Jittered samples, the glossy integrator: a rectangle light's light and BSDF samples and a sampled sky (MIS
    with the coat's pdf), or the previewer's set-up (the split-sum preview, one chosen light per hit)."""
    s = _coat_scene(width=32, height=24, spp=8, jitter=True, env=env)
    if env == "mis":
        pyrt.RectLight(center=(0, 2.5, 0.5), normal=(0, -1, 0), size=(1.0, 0.6), radiance=6.0).add_to(s)
        integ = pyrt.Glossy(samples=2, depth=2)
    else:
        integ = pyrt.Glossy(samples=2, depth=2, light_select_depth=0)
    _assert_agree(s, R=8, integrator=integ)


# ----------------------------------------------------------------------------------------- what falls back

def test_coats_the_kernel_cannot_read_are_named_in_the_reasons():
    """``fresnel="half"``, a transmitting base, a base without a GLTF record (a sheen) and a bicubic coat texture
    keep the NumPy path, each coat named (and the texture with it)."""
    rng = np.random.default_rng(2)
    base = dict(base_color=(0.5, 0.2, 0.1), roughness=0.5)
    bicubic = pyrt.ImageTexture(_coat_texture(rng).image, srgb=False, filter="bicubic", name="cubic")
    coats = [pyrt.Clearcoat(pyrt.MetallicRoughness(**base), fresnel="half", name="half"),
             pyrt.Clearcoat(pyrt.GltfPBR(**base, transmission=0.5), name="glass"),
             pyrt.Clearcoat(pyrt.Sheen(pyrt.MetallicRoughness(**base)), name="sheen"),
             pyrt.Clearcoat(pyrt.MetallicRoughness(**base), clearcoat=ChannelTexture(bicubic, 0), name="cubic")]
    for coat in coats:
        s = pyrt.Scene(pyrt.Camera(width=8, height=8))
        s.add_sphere((0, 0, -3), 1.0, coat, subdivisions=1)
        s.add_light(pyrt.PointLight((2, 3, 2), intensity=20.0))
        ps = pyrt.PreparedScene(s)
        try:
            assert any(r.startswith(f"material {coat.label}") for r in compiled.unsupported(ps)), coat.label
            if coat.name == "cubic":
                assert f"material {coat.label} (texture ImageTexture 'cubic': filter 'bicubic')" in \
                    compiled.unsupported(ps)
        finally:
            ps.close()


# ----------------------------------------------------------------------------------------- unlit

def _unlit_scene(tmp_path):
    """Unlit surfaces (``KHR_materials_unlit``): a constant sphere, a textured box, and a glTF quad whose colour is
    factor x texture x vertex colours, on a Lambert floor under a point light (they ignore it), seen directly and in
    a mirror."""
    rng = np.random.default_rng(3)
    cam = pyrt.Camera(position=(0, 1.2, 4.0), target=(0, 0.4, 0), fov=45, width=40, height=30, jitter=False)
    s = pyrt.Scene(cam, background=(0.1, 0.1, 0.15), ambient=(0.05, 0.05, 0.05))
    s.add_plane((0, 0, 0), 8.0, pyrt.Lambert(albedo=0.5))
    s.add_sphere((-1.0, 0.4, 0.0), 0.4, pyrt.Unlit((0.2, 0.4, 0.6)), subdivisions=3)
    tex = pyrt.ImageTexture(rng.random((8, 8, 3)).astype(np.float32), filter="bilinear")
    s.add_box((0.2, 0.3, 0.2), (0.5, 0.6, 0.5), pyrt.Unlit(tex))
    s.add_box((0.0, 0.6, -1.3), (2.0, 1.2, 0.05), pyrt.Mirror(0.8))
    q = _quad(size=0.8)
    q["color"] = [[0.5, 1.0, 0.25], [1.0, 0.5, 0.5], [0.2, 0.9, 0.6], [0.7, 0.7, 1.0]]
    mats = [{"pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.6, 1.0, 1.0], "baseColorTexture": {"index": 0}},
             "extensions": {"KHR_materials_unlit": {}}}]
    path = write_gltf(tmp_path / "v.gltf", [q], mats, images=[np.full((2, 2, 3), (200, 100, 50), np.uint8)],
                      extensions_used=["KHR_materials_unlit"])
    asset = load_asset(path)
    asset.add_to_scene(s, transform=np.array([[1, 0, 0, 1.1], [0, 1, 0, 0.5], [0, 0, 1, 0.3], [0, 0, 0, 1.0]]))
    s.add_light(pyrt.PointLight((2, 3, 2), intensity=20.0))
    return s


def test_unlit_surfaces_match_the_numpy_path_at_pixel_centres(tmp_path):
    """Constant, textured and factor x texture x vertex-colour unlit surfaces take the compiled path and give the
    NumPy path's image and albedo AOV pixel by pixel (seen directly and in a mirror; the light changes none of
    them)."""
    s = _unlit_scene(tmp_path)
    assert sum(isinstance(m, pyrt.Unlit) for m in s.materials) == 3
    c = pyrt.render_full(s, backend="compiled", progress=False, seed=0, split_depth=None, aovs=True)
    n = pyrt.render_full(s, backend="numpy", progress=False, seed=0, split_depth=None, aovs=True)
    assert c.stats.backend == "compiled" and c.stats.fallback_reasons == []
    bad = (np.abs(c.image.astype(np.float64) - n.image) > 1e-5 * (1.0 + np.abs(n.image))).any(axis=2)
    assert bad.mean() < 0.002
    np.testing.assert_allclose(c.aovs["albedo"], n.aovs["albedo"], rtol=1e-5, atol=1e-6)
