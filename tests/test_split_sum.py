"""The split-sum environment preview (shaders/dfg.py, Material.preview_lobes, integrators/direct.py).

Ground truths: the DFG tables against the same quadrature with 16x the points and against closed forms (a mirror's
albedo is Schlick's F(mu); E5 by a fine 2D midpoint rule); a white furnace per material (constant environment:
the split sum must give the material's directional albedo, estimated from its own ``sample()`` with a standard
error); the renderer end to end; occlusion maps; the switch back to the sampled preview.
"""
import math

import numpy as np
import pytest

import pyrt
from pyrt.geometry.surface import SurfaceBatch
from pyrt.io.assets.materials import GltfMaterial
from pyrt.lights.environment import ConstantEnvironment, LatLongEnvironment, procedural_sky
from pyrt.lights.environment_light import EnvironmentLight, set_environment
from pyrt.materials import Clearcoat, GltfPBR, MetallicRoughness
from pyrt.shaders import dfg
from pyrt.shaders.sampling import hammersley
from pyrt.textures import ConstantTexture


def test_tables_converged():
    """256 Hammersley points per cell are within 4e-3 of 4096 (the bound the module states)."""
    for geometry in ("smith_separable", "smith_correlated"):
        A, B = dfg.specular_albedo_tables(16, 16, 256, geometry)
        A2, B2 = dfg.specular_albedo_tables(16, 16, 4096, geometry)
        assert np.abs(A - A2).max() < 4e-3 and np.abs(B - B2).max() < 4e-3


def test_tables_mirror_limit_and_energy():
    """At alpha -> 0 the lobe is a mirror: A = 1 - (1 - mu)^5, B = (1 - mu)^5 (so F0 A + B = Schlick's F(mu));
    with a Smith G the Fresnel-free albedo never exceeds 1 and falls with roughness at grazing view."""
    A, B = dfg.specular_albedo_tables(geometry="smith_correlated")
    mu, _ = dfg.grid(*A.shape)
    x5 = (1 - mu) ** 5
    np.testing.assert_allclose(A[:, 0], 1 - x5, atol=2e-3)
    np.testing.assert_allclose(B[:, 0], x5, atol=2e-3)
    assert (A + B).max() <= 1 + 1e-9


def _hemisphere_midpoints(n):
    """Directions (n^2, 3) and solid angles (n^2,) of an n x n midpoint rule in (theta, phi) over the upper hemisphere."""
    th = (np.arange(n) + 0.5) * (np.pi / 2) / n
    ph = (np.arange(n) + 0.5) * 2 * np.pi / n
    T, P = np.meshgrid(th, ph, indexing="ij")
    l = np.stack([np.sin(T) * np.cos(P), np.sin(T) * np.sin(P), np.cos(T)], -1).reshape(-1, 3)
    return l, (np.sin(T) * (np.pi / 2 / n) * (2 * np.pi / n)).ravel()


def test_tables_against_direct_quadrature():
    """Visible-normal sampling against a 1200 x 1200 midpoint rule over the hemisphere of the same lobe
    (rough cells, where the rule resolves the lobe: its error is below 1e-3 there)."""
    from pyrt.shaders import brdfs
    l, dw = _hemisphere_midpoints(1200)
    for geometry in ("smith_separable", "smith_correlated"):
        A, B = dfg.specular_albedo_tables(geometry=geometry)
        mus, rs = dfg.grid(*A.shape)
        for i, j in ((0, 31), (16, 31), (31, 31), (5, 20), (16, 16)):
            v = np.tile([math.sqrt(1 - mus[i] ** 2), 0.0, mus[i]], (l.shape[0], 1))
            spec, _ = brdfs.microfacet_spec_cos(v, l, np.full(l.shape[0], rs[j] ** 2), geometry=geometry)
            assert abs((A + B)[i, j] - np.sum(spec * dw)) < 4e-3, (geometry, i, j)


def test_e5_against_quadrature():
    """E5(mu) against a 2D midpoint rule over the hemisphere (1000 x 1000 cells: error < 1e-5)."""
    table = dfg.schlick_diffuse_loss_table(16)
    mus, _ = dfg.grid(16, 2)
    l, dw = _hemisphere_midpoints(1000)
    for i in (0, 5, 15):
        v = np.array([math.sqrt(1 - mus[i] ** 2), 0.0, mus[i]])
        h = l + v
        h /= np.linalg.norm(h, axis=1, keepdims=True)
        ref = np.sum((1 - h @ v) ** 5 * l[:, 2] / np.pi * dw)
        assert abs(table[i] - ref) < 2e-4, (mus[i], table[i], ref)


def _batch(mu, n_lanes=1):
    """One hit per view cosine: normal +z, the viewer at n.v = mu in the xz plane."""
    mu = np.repeat(np.asarray(mu, dtype=np.float64), n_lanes)
    n = mu.size
    z = np.tile([0.0, 0.0, 1.0], (n, 1))
    wo = np.stack([np.sqrt(1 - mu * mu), np.zeros(n), mu], 1)
    return SurfaceBatch(p=np.zeros((n, 3)), ng=z, ns=z, wo=wo, front=np.ones(n, bool), uv=np.full((n, 2), 0.5),
                        duvdx=np.zeros((n, 2)), duvdy=np.zeros((n, 2)))


def _albedo_by_sampling(mat, mu, n=65536):
    """Directional albedo (3,) and its standard error from the material's own importance sampling."""
    ctx = _batch([mu], n)
    wo = ctx.to_local(ctx.wo)
    u = hammersley(n)
    rng = np.random.default_rng(3)
    u = (u + rng.random(2)) % 1.0                          # a randomly shifted lattice: unbiased
    _, w, _ = mat.sample(wo, u, ctx)
    return w.mean(0), w.std(0) / math.sqrt(n)


def _split_sum_white(mat, mu):
    lobes = mat.preview_lobes(_batch([mu]))
    total = lobes.diffuse[0].copy()
    for lb in lobes.glossy:
        total += lb.weight[0]
    return total


MATERIALS = {
    "metallic_roughness_dielectric": MetallicRoughness(base_color=(0.8, 0.3, 0.1), metallic=0.0, roughness=0.5),
    "metallic_roughness_metal": MetallicRoughness(base_color=(0.95, 0.7, 0.3), metallic=1.0, roughness=0.35),
    "metallic_roughness_half": MetallicRoughness(base_color=(0.5, 0.6, 0.9), metallic=0.5, roughness=0.8,
                                                 geometry="smith_correlated"),
    "gltf_pbr_specular": GltfPBR(base_color=(0.8, 0.5, 0.3), roughness=0.4, specular=0.7,
                                 specular_color=(1.0, 0.8, 0.6), ior=1.7),
    "clearcoat": Clearcoat(MetallicRoughness(base_color=(0.7, 0.1, 0.1), roughness=0.6), clearcoat=0.8,
                           roughness=0.35),
    # smooth transmission (roughness <= SMOOTH_ROUGHNESS): the reflection half; its mirror share is a delta lobe
    "gltf_pbr_smooth_transmission": GltfPBR(base_color=(0.7, 0.8, 0.9), metallic=0.2, roughness=0.02,
                                            transmission=0.8, ior=1.5),
    "gltf_pbr_smooth_thin": GltfPBR(base_color=(0.9, 0.6, 0.6), roughness=0.0, transmission=0.6, thin=True,
                                    specular=0.8),
}


@pytest.mark.parametrize("name", sorted(MATERIALS))
@pytest.mark.parametrize("mu", [0.95, 0.6, 0.25])
def test_white_furnace_equals_directional_albedo(name, mu):
    """Under a constant environment (prefiltered = L, SH irradiance = pi L, both exact) the split sum is the
    material's directional albedo within the tables' 4e-3 plus 4 standard errors of the reference (measured <= 4e-4)."""
    mat = MATERIALS[name]
    ref, se = _albedo_by_sampling(mat, mu)
    got = _split_sum_white(mat, mu)
    np.testing.assert_allclose(got, ref, atol=4e-3 + 4 * se.max())   # measured <= 4e-4


def test_transmitting_and_half_fresnel_coat_fall_back_to_samples():
    """Materials whose reflection is not GGX-plus-Lambert in the preview's sense declare no lobes (rough
    transmission; smooth transmission declares its reflection half)."""
    ctx = _batch([0.7])
    assert GltfPBR(transmission=0.5).preview_lobes(ctx) is None          # rough (0.5) transmission: sampled
    assert GltfPBR(transmission=0.5, roughness=0.0).preview_lobes(ctx) is not None
    assert Clearcoat(MetallicRoughness(), fresnel="half").preview_lobes(ctx) is None
    assert pyrt.BlinnPhong(kd=0.5, ks=0.3, exponent=60).preview_lobes(ctx) is None


def _plane(material, size=16):
    cam = pyrt.Camera(position=(0, 3, 0), target=(0, 0, 0), up=(0, 0, -1), fov=2, width=size, height=size)
    sc = pyrt.Scene(cam)
    sc.add_plane((0, 0, 0), 4.0, material)
    return sc


def test_render_white_furnace_and_switch():
    """End to end, straight down at a plane (n.v = 1 to 2e-4): the split sum gives the directional albedo at
    normal incidence, noise-free; ``preview_method="samples"`` is the older sampled estimate."""
    mat = MetallicRoughness(base_color=(0.9, 0.6, 0.3), metallic=0.3, roughness=0.5)
    sc = _plane(mat)
    set_environment(sc, ConstantEnvironment(2.0), lighting="preview")
    img = pyrt.render(sc, spp=1).astype(np.float64).reshape(-1, 3)
    ref, se = _albedo_by_sampling(mat, 1.0 - 1e-4)
    np.testing.assert_allclose(img.mean(0), 2.0 * ref, atol=2.0 * (4e-3 + 4 * se.max()))
    assert np.ptp(img, axis=0).max() < 1e-5
    set_environment(sc, ConstantEnvironment(2.0), lighting="preview", preview_method="samples")
    assert not np.allclose(pyrt.render(sc, spp=1).reshape(-1, 3), img, atol=1e-6)


def test_split_sum_close_to_the_integral_on_a_sky():
    """On a smooth sky the split sum stays within 10 % (mean absolute difference over the mean) of the unshadowed
    integral of a rough gold plane, and no further from it than the sampled preview it replaces: measured 5.1 %
    against 5.8 %, of which ~2 % is the reference's own noise (two 64-sample MIS references differ by 2.5 %; the
    plane sees only the sky, so MIS without shadows is the integral)."""
    env = LatLongEnvironment(procedural_sky(64, 32, sun_angle=30.0, sun_radiance=(5.0, 5.0, 5.0)),
                             filter="bilinear")
    mat = MetallicRoughness(base_color=0.8, metallic=1.0, roughness=0.5)
    sc = _plane(mat, size=12)
    sc.camera.fov = 30
    set_environment(sc, env, lighting="mis", n_samples=64)
    ref = pyrt.render(sc, spp=4, seed=2).astype(np.float64)
    err = {}
    for method in ("split_sum", "samples"):
        set_environment(sc, env, lighting="preview", preview_method=method)
        got = pyrt.render(sc, spp=1).astype(np.float64)
        err[method] = np.abs(got - ref).mean() / ref.mean()
    assert err["split_sum"] < 0.10 and err["split_sum"] <= err["samples"], err


def test_occlusion_map_scales_the_environment():
    """A glTF occlusion texture (strength 1) multiplies the split-sum environment term (image-based light)."""
    occ = ConstantTexture(0.25)
    plain = GltfMaterial(base_color=(0.8, 0.8, 0.8), metallic=0.0, roughness=0.5)
    occluded = GltfMaterial(base_color=(0.8, 0.8, 0.8), metallic=0.0, roughness=0.5, occlusion=occ)
    vals = []
    for m in (plain, occluded):
        sc = _plane(m)
        set_environment(sc, ConstantEnvironment(1.0), lighting="preview")
        vals.append(pyrt.render(sc, spp=1).astype(np.float64).mean())
    assert vals[1] == pytest.approx(0.25 * vals[0], rel=1e-6)


def test_preview_method_is_checked():
    with pytest.raises(pyrt.Error, match="preview_method"):
        EnvironmentLight(ConstantEnvironment(1.0), strategy="preview", preview_method="fast")


def test_shipped_tables_equal_a_fresh_build(tmp_path, monkeypatch):
    """pyrt/materials/dfg_tables.npz (tools/make_tables.py) holds what shaders.dfg builds today, for every shipped
    Smith term and E5; without the file the tables are built (same values)."""
    from pyrt.materials import preview as PV
    shipped = PV._shipped()
    assert set(shipped) == {"E5"} | {f"{ab}_{g}" for g in PV.SHIPPED_GEOMETRIES for ab in "AB"}
    np.testing.assert_allclose(shipped["E5"], dfg.schlick_diffuse_loss_table(), rtol=0, atol=1e-12)
    for g in PV.SHIPPED_GEOMETRIES:
        A, B = dfg.specular_albedo_tables(geometry=g)
        np.testing.assert_allclose(shipped[f"A_{g}"], A, rtol=0, atol=1e-12)
        np.testing.assert_allclose(shipped[f"B_{g}"], B, rtol=0, atol=1e-12)
    monkeypatch.setattr(PV, "TABLES_FILE", tmp_path / "missing.npz")
    PV._shipped.cache_clear()
    PV._ab.cache_clear()
    try:
        assert PV._shipped() == {}
        np.testing.assert_allclose(PV._ab("smith_separable")[0], shipped["A_smith_separable"], atol=1e-12)
    finally:
        PV._shipped.cache_clear()
        PV._ab.cache_clear()
