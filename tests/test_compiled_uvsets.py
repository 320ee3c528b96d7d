"""UV sets k >= 1 (glTF ``TEXCOORD_1``, ...) on the compiled path: every texture slot reads its own set.

The set a texture reads is a field of its record, the sets' per-vertex tables are packed with the texture table, and
a hit's footprint record carries its vertex indices, barycentrics and their derivatives
(:mod:`pyrt.textures.compiled`):

- the set's uv and footprint at a hit (:func:`pyrt.textures.compiled.set_uv`) and the triangle's tangents in that
  set (:func:`pyrt.integrators.compiled_diffs.face_uv_tangents`) are the NumPy path's
  (:meth:`pyrt.geometry.SurfaceBatch.uv_set`, :meth:`~pyrt.geometry.SurfaceBatch.uv_tangents`) bit for bit, and a
  trilinear, transformed texture of set 1 looks up what :meth:`pyrt.ImageTexture.evaluate` does;
- renders whose base colour, metallic-roughness, occlusion, emission, normal map, clear coat, coat roughness, coat
  normal map, unlit colour, Lambert albedo and alpha mask read set 1 (nearest, bilinear and trilinear, with a UV
  transform, a mesh without the set) give the NumPy path's image pixel by pixel at pixel centres, and differ from
  the image of the same textures read in set 0 (so the check can fail);
- the shared Khronos models MultiUVTest and TextureTransformMultiTest take the compiled path and give the NumPy
  path's image (skipped when ../shared/khronos-gltf is absent);
- a texture the kernel still cannot read is named in the fallback reason.
"""
import os

import numba
import numpy as np
import pytest
import trimesh

import pyrt
from pyrt.geometry.surface import surface_from_hits
from pyrt.integrators import PreparedScene
from pyrt.integrators import compiled
from pyrt.integrators import compiled_diffs as D
from pyrt.io.assets import load_asset
from pyrt.io.assets.materials import GltfMaterial, ScaledTexture
from pyrt.textures import ChannelTexture
from pyrt.textures import compiled as TC

from test_compiled_footprints import _normal_map
from test_compiled_glossy import _assert_agree
from test_uv_sets import A_MAP, B_MAP, _grid_mesh

KHRONOS = "/work/shared/khronos-gltf"
MODELS = ("MultiUVTest/MultiUVTest.glb", "TextureTransformMultiTest/TextureTransformMultiTest.glb")

pytestmark = pytest.mark.filterwarnings("ignore:invalid value encountered:RuntimeWarning",
                                        "ignore:divide by zero encountered:RuntimeWarning")


# ----------------------------------------------------------------------------------------- the per-hit twins

def _grid_hits():
    """A prepared grid whose set 1 is set 0 warped (rotated, sheared, tiled, bent: its tangents vary per triangle)
    and the NumPy surface at its camera rays' hits, with differentials."""
    cam = pyrt.Camera(position=(0.2, -0.3, 3), target=(0, 0, 0), fov=40, width=24, height=20)
    scene = pyrt.Scene(cam)
    v, f, uv0 = _grid_mesh()
    uv1 = uv0 @ A_MAP.T + B_MAP + 0.2 * np.sin(3.0 * uv0[:, ::-1])
    scene.add_mesh((v, f), pyrt.Lambert(0.5), smooth=False, uv=uv0, uv_sets={1: uv1})
    ps = PreparedScene(scene)
    rays = cam.generate_rays(0, cam.width * cam.height, np.random.default_rng(0), differentials=True)
    o, d = rays.origins, rays.directions
    idx, hits = ps.accel.intersect_hits(o, d)
    surf = surface_from_hits(ps.geo, hits, o[idx], d[idx], tuple(a[idx] for a in rays.differentials))
    return ps, surf


@numba.njit(cache=False)
def _set_values(data, o, tri, bary, dbary, fp0, tags, t, verts_faces, ng, out):
    """Per hit: set ``o``'s uv and footprint (6), texture row ``t`` at the hit (3), the set's tangents (6)."""
    G = verts_faces
    for i in range(tri.shape[0]):
        fp = TC.footprint((fp0[i, 0], fp0[i, 1], fp0[i, 2], fp0[i, 3], dbary[i, 0], dbary[i, 1], dbary[i, 2],
                           dbary[i, 3]), tri[i, 0], tri[i, 1], tri[i, 2], bary[i, 0], bary[i, 1], bary[i, 2])
        u, v, f = TC.set_uv(data, o, fp)
        out[i, 0], out[i, 1], out[i, 2], out[i, 3], out[i, 4], out[i, 5] = u, v, f[0], f[1], f[2], f[3]
        out[i, 6], out[i, 7], out[i, 8] = TC.texture_rgb(tags, data, t, 0.0, 0.0, fp)
        dpdu, dpdv = D.face_uv_tangents(G, i, (ng[i, 0], ng[i, 1], ng[i, 2]), data, o)
        out[i, 9], out[i, 10], out[i, 11] = dpdu
        out[i, 12], out[i, 13], out[i, 14] = dpdv


def test_set_uv_footprints_tangents_and_lookups_are_the_numpy_paths():
    """Bit for bit: set 1's uv, footprint and tangents at every hit; a trilinear texture of set 1 with a UV transform
    (footprints by its linear part) as :meth:`pyrt.ImageTexture.evaluate` reads it (1e-12)."""
    ps, surf = _grid_hits()
    try:
        tex = pyrt.ImageTexture(np.random.default_rng(1).random((16, 32, 3)).astype(np.float32), filter="trilinear",
                                texcoord=1, scale=(2.0, 0.5), rotation_deg=25.0, offset=(0.1, -0.3))
        packer = compiled._TexturePacker()
        t = packer.add(tex)
        tags, data = TC.pack_table(packer.tags, packer.records, packer.texels, packer.uv_sets(ps.geo))
        flat = data.ravel()
        o = int(flat[t * TC.RECORD + TC.UV_SET])
        assert o > 0
        n = surf.n_hits
        tri = ps.geo.faces[surf.face]
        fp0 = np.concatenate([surf.duvdx, surf.duvdy], axis=1)
        # the geometry pointers' slots the tangents read: vertices (0) and faces (6, here one per hit)
        G = (ps.geo.vertices.ravel().copy(),) + (np.zeros(1),) * 5 + (tri.astype(np.int64).ravel(),)
        out = np.zeros((n, 15))
        _set_values(flat, o, tri.astype(np.int64), surf.bary, surf.dbary, fp0, tags, t, G, surf.ng, out)
        uv1, dx1, dy1 = surf.uv_set(1)
        assert np.abs(dx1).max() > 1e-3
        np.testing.assert_array_equal(out[:, 0:2], uv1)
        np.testing.assert_array_equal(out[:, 2:6], np.concatenate([dx1, dy1], axis=1))
        dpdu, dpdv = surf.uv_tangents(1)
        np.testing.assert_array_equal(out[:, 9:12], dpdu)
        np.testing.assert_array_equal(out[:, 12:15], dpdv)
        np.testing.assert_allclose(out[:, 6:9], tex.evaluate(surf), rtol=1e-12, atol=1e-12)
        assert not np.allclose(out[:, 0:2], surf.uv)
    finally:
        ps.close()


def test_sets_without_a_mesh_table_read_zeros_and_every_set_gets_its_own_table():
    """A set no mesh has is packed as zeros (the NumPy path reads zeros); sets 1 and 2 get tables of their own."""
    v, f, uv0 = _grid_mesh(2)
    s = pyrt.Scene(pyrt.Camera(width=4, height=4))
    s.add_mesh((v, f), pyrt.Lambert(0.5), smooth=False, uv=uv0, uv_sets={1: uv0 + 1.0, 2: uv0 * 3.0})
    ps = PreparedScene(s)
    try:
        img = np.ones((2, 2, 3), dtype=np.float32)
        packer = compiled._TexturePacker()
        rows = [packer.add(pyrt.ImageTexture(img, filter="nearest", texcoord=k)) for k in (0, 1, 2, 3)]
        sets = packer.uv_sets(ps.geo)
        assert sorted(sets) == [1, 2, 3] and not sets[3].any()
        tags, data = TC.pack_table(packer.tags, packer.records, packer.texels, sets)
        flat = data.ravel()
        offs = [int(flat[r * TC.RECORD + TC.UV_SET]) for r in rows]
        assert offs[0] == 0 and len(set(offs)) == 4
        nv = v.shape[0]
        np.testing.assert_array_equal(flat[offs[1]:offs[1] + 2 * nv], (uv0 + 1.0).ravel())
        np.testing.assert_array_equal(flat[offs[2]:offs[2] + 2 * nv], (uv0 * 3.0).ravel())
        np.testing.assert_array_equal(flat[offs[3]:offs[3] + 2 * nv], 0.0)
    finally:
        ps.close()


# ----------------------------------------------------------------------------------------- renders

def _sphere_mesh(subdivisions=3):
    """An icosphere's vertices, faces, spherical UV set 0 and a warped set 1 (rotated, tiled, bent)."""
    m = trimesh.creation.icosphere(subdivisions=subdivisions, radius=1.0)
    v = np.asarray(m.vertices, dtype=np.float64)
    uv0 = np.column_stack([0.5 + np.arctan2(v[:, 1], v[:, 0]) / (2 * np.pi), 0.5 + np.arcsin(v[:, 2]) / np.pi])
    uv1 = uv0 @ np.array([[1.5, 0.7], [-0.6, 2.0]]).T + 0.15 * np.sin(4.0 * uv0[:, ::-1]) + 0.3
    return v, np.asarray(m.faces), uv0, uv1


def _img(rng, h, w):
    return rng.random((h, w, 3)).astype(np.float32)


def _set1_materials(rng, k):
    """Materials whose every texture reads UV set ``k``: a glTF material (base colour trilinear with a transform,
    metallic and roughness of a packed map, occlusion, emission, a normal map), a clear coat (its factor, roughness
    and normal map), an unlit colour (nearest), a Lambert albedo and an alpha mask (bilinear)."""
    base = pyrt.ImageTexture(_img(rng, 32, 16), filter="trilinear", texcoord=k, scale=(2.0, 1.5), rotation_deg=30.0,
                             offset=(0.2, 0.1))
    orm = pyrt.ImageTexture(_img(rng, 8, 8), srgb=False, filter="bilinear", texcoord=k)
    emit = pyrt.ImageTexture(_img(rng, 8, 8), filter="bilinear", texcoord=k, scale=(3.0, 3.0))
    nmap = pyrt.NormalMap(_normal_map(rng, 16), strength=0.8, texcoord=k)
    gltf = GltfMaterial(base_color=ScaledTexture(base, (0.9, 0.8, 0.7)),
                        metallic=ScaledTexture(ChannelTexture(orm, 2), 0.6),
                        roughness=ScaledTexture(ChannelTexture(orm, 1), 0.9),
                        emission=ScaledTexture(emit, (0.3, 0.2, 0.1)), occlusion=ChannelTexture(orm, 0),
                        occlusion_strength=0.8, normal_map=nmap)
    coat_tex = pyrt.ImageTexture(_img(rng, 8, 8), srgb=False, filter="trilinear", texcoord=k, rotation_deg=-40.0)
    coat = pyrt.Clearcoat(pyrt.MetallicRoughness(base_color=(0.5, 0.05, 0.02), roughness=0.5),
                          clearcoat=ChannelTexture(coat_tex, 0), roughness=ChannelTexture(coat_tex, 1), name="coat",
                          normal_map=pyrt.NormalMap(_normal_map(rng, 16), strength=0.6, texcoord=k,
                                                    filter="trilinear"))
    unlit = pyrt.Unlit(pyrt.ImageTexture(_img(rng, 8, 8), filter="nearest", texcoord=k))
    lambert = pyrt.Lambert(albedo=pyrt.ImageTexture(_img(rng, 8, 8), filter="bilinear", texcoord=k))
    holes = pyrt.ImageTexture(_img(rng, 4, 4), srgb=False, filter="bilinear", texcoord=k)
    masked = pyrt.Lambert(albedo=(0.3, 0.6, 0.3)).set_coverage(opacity=ChannelTexture(holes, 0), alpha_mode="mask",
                                                               alpha_cutoff=0.5)
    return gltf, coat, unlit, lambert, masked


def _uv_scene(k=1, width=48, height=32, tangents=False, spp=1):
    """The materials of :func:`_set1_materials` on spheres whose set 1 differs from set 0 (one sphere without set 1:
    it reads zeros; with ``tangents``, the others with vertex tangents), on a Lambert floor, a mirror behind them; a
    point and a directional light, ambient light; pixel centres at 1 spp, jittered samples at more."""
    rng = np.random.default_rng(7)
    cam = pyrt.Camera(position=(0, 1.3, 4.2), target=(0, 0.4, 0), fov=45, width=width, height=height, spp=spp,
                      jitter=spp > 1)
    s = pyrt.Scene(cam, background=(0.05, 0.06, 0.1), ambient=(0.05, 0.04, 0.03))
    s.add_plane((0, 0, 0), 8.0, pyrt.Lambert(albedo=0.5))
    v, f, uv0, uv1 = _sphere_mesh()
    t = np.cross(v, [0.0, 0.0, 1.0]) + [1e-3, 2e-3, 0.0]          # around the poles' axis (v: the unit normals)
    t = np.column_stack([t / np.linalg.norm(t, axis=1, keepdims=True), np.ones(len(t))])
    spots = [(-1.5, 0.45, 0.0), (-0.5, 0.45, 0.3), (0.5, 0.45, 0.0), (1.5, 0.45, 0.3), (0.0, 0.45, 1.2)]
    for i, (m, c) in enumerate(zip(_set1_materials(rng, k), spots)):
        sets = None if i == 3 else {1: uv1}
        s.add_mesh((v * 0.42 + c, f), m, smooth=True, uv=uv0, uv_sets=sets,
                   tangents=t if tangents and sets else None)
    s.add_box((0.0, 0.6, -1.4), (3.0, 1.2, 0.05), pyrt.Mirror(0.8))
    s.add_light(pyrt.PointLight((2, 3, 2.5), intensity=25.0))
    s.add_light(pyrt.DirectionalLight((-0.4, -1, -0.5), irradiance=0.8))
    return s


def _same_pixels(s, **kw):
    """Both paths' renders of ``s`` at pixel centres: the same image (fewer than 0.2 % of pixels may differ where a
    ray meets an edge exactly) and the same albedo AOV; the compiled image."""
    c = pyrt.render_full(s, backend="compiled", progress=False, seed=0, aovs=True, **kw)
    n = pyrt.render_full(s, backend="numpy", progress=False, seed=0, aovs=True, **kw)
    assert c.stats.backend == "compiled" and c.stats.fallback_reasons == [] and n.stats.backend == "numpy"
    diff = np.abs(c.image.astype(np.float64) - n.image)
    bad = (diff > 1e-5 * (1.0 + np.abs(n.image))).any(axis=2)
    assert bad.mean() < 0.002, f"{bad.sum()} pixels differ, max {diff.max()}"
    np.testing.assert_allclose(c.aovs["albedo"], n.aovs["albedo"], rtol=1e-5, atol=1e-6)
    return c.image.astype(np.float64)


def test_every_slot_of_uv_set_1_matches_the_numpy_path_at_pixel_centres():
    """Base colour, metallic, roughness, occlusion, emission, normal map, clear coat, coat roughness and coat normal
    map, unlit colour, Lambert albedo and alpha mask in set 1 (seen directly and in a mirror, the full Whitted
    tree): the NumPy path's image; and not the image of the same textures in set 0."""
    s = _uv_scene(1)
    assert compiled.unsupported(None, scene=s) == []
    img = _same_pixels(s, integrator=pyrt.Whitted(split_depth=None))
    set0 = pyrt.render_full(_uv_scene(0), backend="compiled", progress=False, seed=0,
                            integrator=pyrt.Whitted(split_depth=None)).image
    assert (np.abs(set0 - img) > 1e-3).any(axis=2).mean() > 0.05


def test_uv_set_1_on_meshes_with_vertex_tangents_matches_the_numpy_path_at_pixel_centres():
    """Meshes with vertex tangents: normal maps of set 1 in their frame, as the NumPy path."""
    s = _uv_scene(1, width=32, height=24, tangents=True)
    ps = PreparedScene(s)
    try:
        assert compiled.CompiledScene(ps).normal_maps == 2
    finally:
        ps.close()
    _same_pixels(s, integrator=pyrt.Whitted(split_depth=None))


def test_uv_set_1_with_the_glossy_integrator_agrees_with_numpy_in_distribution():
    """Jittered samples, the glossy integrator (the glossy rays' hits read set 1 too): the two paths' mean images
    agree within their standard errors (the glossy path is compared in distribution: tests/test_compiled_glossy.py)."""
    _assert_agree(_uv_scene(1, width=32, height=24, spp=4), integrator=pyrt.Glossy(samples=1, depth=2))


# ----------------------------------------------------------------------------------------- models and reasons

@pytest.mark.parametrize("model", MODELS)
def test_the_multi_uv_khronos_models_take_the_compiled_path_and_match_numpy(model):
    """MultiUVTest (emission in TEXCOORD_1) and TextureTransformMultiTest (KHR_texture_transform on every slot, some
    in TEXCOORD_1; unlit, clear coat): no fallback reason, and the NumPy path's image at pixel centres."""
    path = os.path.join(KHRONOS, model)
    if not os.path.exists(path):
        pytest.skip(f"{path} not present")
    s = pyrt.Scene(pyrt.Camera(width=8, height=8), background=(0.1, 0.1, 0.1), ambient=(0.1, 0.1, 0.1))
    load_asset(path).add_to_scene(s, lights=False)
    lo = np.min([m.vertices.min(axis=0) for m in s.meshes], axis=0)
    hi = np.max([m.vertices.max(axis=0) for m in s.meshes], axis=0)
    centre, radius = 0.5 * (lo + hi), 0.5 * float(np.linalg.norm(hi - lo))
    s.camera = pyrt.Camera(position=centre + radius * np.array([0.0, 0.0, 2.4]), target=centre, fov=40, width=40,
                           height=30, spp=1, jitter=False)
    s.add_light(pyrt.PointLight(centre + radius * np.array([1.0, 1.5, 2.5]), intensity=20.0 * radius ** 2))
    assert any(t.texcoord == 1 for m in s.materials for t in _textures(m))
    assert compiled.unsupported(None, scene=s) == []
    _same_pixels(s)


def _textures(obj, seen=None):
    """The textures reachable from ``obj``'s attributes (a material, a texture)."""
    seen = set() if seen is None else seen
    out = []
    for v in vars(obj).values():
        if isinstance(v, pyrt.Texture) and id(v) not in seen:
            seen.add(id(v))
            out += [v] + _textures(v, seen)
        elif isinstance(v, pyrt.Material) and id(v) not in seen:
            seen.add(id(v))
            out += _textures(v, seen)
    return out


def test_textures_the_kernel_cannot_read_are_named_in_the_reasons():
    """A bicubic base colour and a grey normal map: the material's reason names the texture and why."""
    img = np.ones((4, 4, 3), dtype=np.float32)
    s = pyrt.Scene(pyrt.Camera(width=8, height=8))
    s.add_sphere((0, 0, -3), 1.0, pyrt.MetallicRoughness(
        base_color=pyrt.ImageTexture(img, filter="bicubic", name="cubic", texcoord=2)), subdivisions=1)
    grey = pyrt.Lambert(0.5)
    grey.normal_map = pyrt.ImageTexture(img[..., :1], filter="bilinear", name="flat")
    s.add_sphere((2, 0, -3), 1.0, grey, subdivisions=1)
    reasons = compiled.unsupported(None, scene=s)
    assert any("(texture ImageTexture 'cubic': filter 'bicubic')" in r for r in reasons), reasons
    assert any(r.startswith("normal map of material") and "'flat': has 1 channel(s)" in r for r in reasons), reasons
