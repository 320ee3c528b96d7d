"""Vertex colours (glTF ``COLOR_0``) and normal maps on meshes with vertex tangents (glTF ``TANGENT``) on the compiled
path, against the NumPy path.

The scalar twins (:func:`pyrt.integrators.compiled_diffs.vertex_color`, :func:`~pyrt.integrators.compiled_diffs.
vertex_tangents`) are held to :meth:`pyrt.io.assets.VertexColorTexture.evaluate` and the surface batch's
``vtangent`` on random hits; renders at pixel centres with the full glass tree give the NumPy path's image pixel by
pixel (small synthetic meshes, and the shared Khronos models when present).
"""
import os
import types

import numba
import numpy as np
import pytest

import pyrt
from pyrt.geometry.accel import Hits
from pyrt.geometry.surface import surface_from_hits
from pyrt.integrators import compiled
from pyrt.integrators import compiled_diffs as D
from pyrt.integrators import compiled_layout as KL
from pyrt.integrators.compiled_layout import geometry_pointers
from pyrt.io.assets.materials import (FaceColorTexture, GltfMaterial, ProductTexture, ScaledTexture,
                                      VertexColorTexture)
from pyrt.materials import compiled as MC
from pyrt.textures import ChannelTexture
from pyrt.textures import compiled as TC

from test_compiled_footprints import _assert_changes_the_image, _normal_map, _same_image_and_aov

KHRONOS = "/work/shared/khronos-gltf"


def _grid(n, x0, z0, size, rng, bump=0.08):
    """An ``n`` x ``n`` wavy height field at ``(x0, z0)``: vertices, faces, smooth normals, UVs in [0, 1]."""
    s = np.linspace(0.0, 1.0, n)
    u, v = np.meshgrid(s, s, indexing="xy")
    h = bump * np.sin(6.0 * u + 1.0) * np.cos(5.0 * v) + 0.02 * rng.random(u.shape)
    verts = np.stack([x0 + size * u, h, z0 - size * v], axis=-1).reshape(-1, 3)
    i = np.arange(n * n).reshape(n, n)
    a, b, c, d = i[:-1, :-1].ravel(), i[:-1, 1:].ravel(), i[1:, :-1].ravel(), i[1:, 1:].ravel()
    faces = np.concatenate([np.stack([a, b, d], 1), np.stack([a, d, c], 1)])
    fn = np.cross(verts[faces[:, 1]] - verts[faces[:, 0]], verts[faces[:, 2]] - verts[faces[:, 0]])
    nrm = np.zeros_like(verts)
    for k in range(3):
        np.add.at(nrm, faces[:, k], fn)
    nrm /= np.linalg.norm(nrm, axis=1, keepdims=True)
    return verts, faces, nrm, np.stack([u.ravel(), v.ravel()], axis=1)


def _image(rng, n=16):
    return (0.3 + 0.7 * rng.random((n, n, 3))).astype(np.float32)


def _vertex_colour_scene(width=48, height=36, rng=None):
    """Six vertex-coloured patches (Lambert times a constant and times an image, Blinn-Phong, MetallicRoughness,
    the glTF loader's GltfMaterial with a scaled texture and occlusion, GltfPBR), one patch whose material reads
    vertex colours bound to no mesh (white), a mirror that shows them; a point and a directional light, ambient
    light (the albedo with vertex colours)."""
    rng = np.random.default_rng(7) if rng is None else rng
    cam = pyrt.Camera(position=(0.0, 2.6, 1.8), target=(0.0, 0.0, -0.6), fov=55, width=width, height=height,
                      jitter=False)
    s = pyrt.Scene(cam, background=(0.05, 0.06, 0.1), ambient=(0.04, 0.05, 0.03))
    img = pyrt.ImageTexture(_image(rng), filter="bilinear", srgb=False)
    occ = ChannelTexture(pyrt.ImageTexture(_image(rng), filter="nearest", srgb=False), 0)
    bases = [
        lambda vc: pyrt.Lambert(albedo=ProductTexture(vc, (0.9, 0.8, 0.7))),
        lambda vc: pyrt.Lambert(albedo=ProductTexture(vc, img)),
        lambda vc: pyrt.BlinnPhong(kd=ProductTexture(vc, 0.8), ks=0.2, exponent=30.0),
        lambda vc: pyrt.MetallicRoughness(base_color=ProductTexture(vc, (0.9, 0.9, 0.8)), metallic=0.3,
                                          roughness=0.5),
        lambda vc: GltfMaterial(base_color=ProductTexture(vc, ScaledTexture(img, (1.0, 0.9, 0.8))), metallic=0.1,
                                roughness=0.6, occlusion=occ, occlusion_strength=0.7),
        lambda vc: pyrt.GltfPBR(base_color=ProductTexture(vc, (0.8, 0.8, 0.8)), roughness=0.4, specular=0.8),
    ]
    for k, make in enumerate(bases):
        v, f, n, uv = _grid(7, -1.65 + 1.1 * (k % 3), -0.2 - 1.1 * (k // 3), 1.0, rng)
        vc = VertexColorTexture()
        mid = s.add_mesh((v, f), make(vc), normals=n, uv=uv)
        vc.bind(mid, s.meshes[mid].faces, rng.random((v.shape[0], 3)))
    v, f, n, uv = _grid(5, -0.5, 1.0, 1.0, rng)
    s.add_mesh((v, f), pyrt.Lambert(albedo=ProductTexture(VertexColorTexture(), 0.6)), normals=n, uv=uv)
    s.add_box((0.0, 0.5, -2.6), (3.0, 1.0, 0.05), pyrt.Mirror(0.8))
    s.add_light(pyrt.PointLight((1.5, 3.0, 1.5), intensity=15.0))
    s.add_light(pyrt.DirectionalLight((0.3, -1.0, -0.4), irradiance=0.6))
    return s


def _tangent_scene(width=48, height=36):
    """Normal-mapped patches with explicit vertex tangents: one with w = +1, one with mirrored UVs and w = -1, one
    with tangents turned 30 degrees about the normal (a GltfPBR), and one without tangents (the UV tangents) in the
    same scene; a mirror; a point light."""
    rng = np.random.default_rng(11)
    cam = pyrt.Camera(position=(0.0, 2.4, 1.6), target=(0.0, 0.0, -0.5), fov=55, width=width, height=height,
                      jitter=False)
    s = pyrt.Scene(cam, background=(0.05, 0.06, 0.1), ambient=(0.03, 0.03, 0.03))
    nmap = _normal_map(rng)
    for k in range(4):
        v, f, n, uv = _grid(7, -1.65 + 1.1 * (k % 3), -0.1 - 1.1 * (k // 3), 1.0, rng)
        t = np.cross(n, [0.0, 0.0, 1.0])                      # along +x, perpendicular to the normal
        t /= np.linalg.norm(t, axis=1, keepdims=True)
        w = np.ones(v.shape[0])
        if k == 1:                                           # mirrored UVs: u runs along -x, the bitangent flips
            uv = np.stack([1.0 - uv[:, 0], uv[:, 1]], axis=1)
            t, w = -t, -w
        if k == 2:
            b = np.cross(n, t)
            t = np.cos(0.5) * t + np.sin(0.5) * b
        mat = pyrt.GltfPBR(base_color=(0.7, 0.6, 0.5), roughness=0.35) if k == 2 else pyrt.Lambert(albedo=0.7)
        mat.normal_map = pyrt.NormalMap(nmap, strength=0.9, flip_green=(k == 1))
        s.add_mesh((v, f), mat, normals=n, uv=uv, tangents=None if k == 3 else np.column_stack([t, w]))
    s.add_box((0.0, 0.5, -2.5), (3.0, 1.0, 0.05), pyrt.Mirror(0.8))
    s.add_light(pyrt.PointLight((1.2, 2.5, 1.0), intensity=12.0))
    return s


# ----------------------------------------------------------------------------------------- scalar twins

@numba.njit
def _vertex_attrs(geo_f, geo_i, mats_par, mat, face, bu, bv, col, tan, has):
    G = geometry_pointers(geo_f, geo_i)
    for k in range(face.shape[0]):
        col[k, 0], col[k, 1], col[k, 2] = D.vertex_color(G, mats_par, mat[k], face[k], bu[k], bv[k])
        h, t, b = D.vertex_tangents(G, face[k], bu[k], bv[k])
        has[k] = h
        tan[k, 0], tan[k, 1], tan[k, 2] = t
        tan[k, 3], tan[k, 4], tan[k, 5] = b


def _random_hits(ps, rng, n=4000):
    """Random (mesh, triangle, barycentrics) over every mesh, edges and corners included."""
    geo = ps.geo
    nf = np.array([m.faces.shape[0] for m in geo.meshes])
    mesh = rng.integers(0, len(nf), n)
    prim = (rng.random(n) * nf[mesh]).astype(np.int64)
    bu, bv = rng.random(n), rng.random(n)
    out = bu + bv > 1.0
    bu[out], bv[out] = 1.0 - bu[out], 1.0 - bv[out]
    bu[:50], bv[:50] = 0.0, 0.0
    bu[50:100], bv[50:100] = 1.0, 0.0
    return mesh, prim, geo.face_offset[mesh] + prim, bu, bv


#: the attributes that hold a material's colour slot 0 (Lambert, Blinn-Phong, the glTF family)
_SLOTS = ("albedo_value", "kd", "base_color")


def _product(material):
    """The material's colour-slot product with vertex colours, or None."""
    for name in _SLOTS:
        if isinstance(getattr(material, name, None), ProductTexture):
            return getattr(material, name)
    return None


def _twins(scene, rng):
    ps = pyrt.PreparedScene(scene)
    cs = compiled.CompiledScene(ps)
    mesh, prim, face, bu, bv = _random_hits(ps, rng)
    mat = ps.geo.face_material[face]
    col, tan, has = np.zeros((face.size, 3)), np.zeros((face.size, 6)), np.zeros(face.size, dtype=np.bool_)
    _vertex_attrs(cs.geo_f, cs.geo_i, np.ascontiguousarray(cs.materials[1].ravel()), mat, face, bu, bv, col, tan,
                  has)
    return ps, mesh, prim, face, bu, bv, mat, col, tan, has


def test_vertex_colours_equal_the_vertex_colour_texture_on_random_hits():
    rng = np.random.default_rng(3)
    scene = _vertex_colour_scene()
    ps, mesh, prim, face, bu, bv, mat, col, _, _ = _twins(scene, rng)
    bary = np.stack([1.0 - bu - bv, bu, bv], axis=1)
    checked = 0
    for k, m in enumerate(scene.materials):
        sel = mat == k
        tex = _product(m)
        if tex is None or not sel.any():
            np.testing.assert_array_equal(col[sel], 1.0)            # reads none: white
            continue
        ctx = types.SimpleNamespace(n_hits=int(sel.sum()), mesh_id=mesh[sel], prim_id=prim[sel], bary=bary[sel])
        np.testing.assert_allclose(col[sel], tex.a.evaluate(ctx), rtol=1e-6, atol=0.0)
        checked += 1
    assert checked == 7


@numba.njit
def _albedos(geo_f, geo_i, mats_tag, mats_par, tex_tag, tex_par, mat, face, bu, bv, uv, out):
    G = geometry_pointers(geo_f, geo_i)
    for k in range(face.shape[0]):
        m = mat[k]
        vc = D.vertex_color(G, mats_par, m, face[k], bu[k], bv[k])
        a = MC.albedo_at(mats_tag[m], mats_par, m, tex_tag, tex_par, uv[k, 0], uv[k, 1], TC.NO_FOOTPRINT, vc)
        for j in range(9):
            out[k, j] = a[j]


def test_albedo_with_vertex_colours_equals_the_materials_albedo_on_random_hits():
    """The hit's inputs with its vertex colour (:func:`pyrt.materials.compiled.albedo_at`): the diffuse colour is
    the material's ``albedo()`` (occlusion included), GLTF's base colour its ``base_color`` evaluated."""
    rng = np.random.default_rng(9)
    scene = _vertex_colour_scene()
    ps = pyrt.PreparedScene(scene)
    cs = compiled.CompiledScene(ps)
    mesh, prim, face, bu, bv = _random_hits(ps, rng)
    mat = ps.geo.face_material[face]
    tri = ps.geo.faces[face]
    bary = np.stack([1.0 - bu - bv, bu, bv], axis=1)
    uv = np.einsum("ij,ijk->ik", bary, ps.geo.uv[tri])
    out = np.zeros((face.size, 9))
    _albedos(cs.geo_f, cs.geo_i, cs.materials[0], np.ascontiguousarray(cs.materials[1].ravel()), cs.textures[0],
             np.ascontiguousarray(cs.textures[1].ravel()), mat, face, bu, bv, uv, out)
    checked = 0
    for k, m in enumerate(scene.materials):
        sel = mat == k
        if _product(m) is None or not sel.any():
            continue
        ctx = types.SimpleNamespace(n_hits=int(sel.sum()), mesh_id=mesh[sel], prim_id=prim[sel], bary=bary[sel],
                                    uv=uv[sel], face=face[sel], duvdx=None, duvdy=None)
        np.testing.assert_allclose(out[sel, 0:3], np.asarray(m.albedo(ctx)).reshape(-1, 3), rtol=1e-6, atol=1e-12)
        if cs.materials[0][k] == MC.GLTF:
            np.testing.assert_allclose(out[sel, 3:6], m.base_color.evaluate(ctx), rtol=1e-6, atol=1e-12)
        checked += 1
    assert checked == 7


def test_vertex_tangents_equal_the_surface_batch_on_random_hits():
    rng = np.random.default_rng(5)
    ps, mesh, prim, face, bu, bv, _, _, tan, has = _twins(_tangent_scene(), rng)
    n = face.size
    hits = Hits(hit=np.ones(n, dtype=bool), t=np.ones(n), mesh_id=mesh, prim_id=prim, u=bu, v=bv,
                ng=np.tile([0.0, 1.0, 0.0], (n, 1)))
    surf = surface_from_hits(ps.geo, hits, np.zeros((n, 3)), np.tile([0.0, -1.0, 0.0], (n, 1)))
    want = surf.vtangent
    np.testing.assert_allclose(tan, want, rtol=1e-6, atol=1e-12)
    np.testing.assert_array_equal(has, np.any(want[:, :3] != 0.0, axis=1))
    assert has.any() and not has.all()                           # the mesh without tangents: zeros


# ----------------------------------------------------------------------------------------- renders

def test_vertex_colours_match_the_numpy_path_pixel_by_pixel():
    """Every material that multiplies its colour by vertex colours, seen directly and in a mirror: the NumPy path's
    image and albedo AOV; and not the image without the vertex colours."""
    s = _vertex_colour_scene()
    ps = pyrt.PreparedScene(s)
    assert compiled.unsupported(ps) == []
    cs = compiled.CompiledScene(ps)
    assert cs.geo_f[6].shape == (ps.geo.vertices.shape[0], 3)
    assert sum(rec[MC.VERTEX_COLOR] > 0 for rec in cs.materials[1]) == 7
    c = _same_image_and_aov(s, "albedo", 1e-5)
    for m in s.materials:
        for name in _SLOTS:
            if isinstance(getattr(m, name, None), ProductTexture):
                setattr(m, name, getattr(m, name).b)
    _assert_changes_the_image(s, c, 0.05)


def test_vertex_colours_in_adaptive_passes_match_the_numpy_path():
    """The same passes (the NumPy path's camera samples), the same samples per pixel, the same image."""
    s = _vertex_colour_scene(width=24, height=18)
    kw = dict(progress=False, seed=1, split_depth=None, target_error=5e-3, max_spp=16)
    c = pyrt.render_full(s, backend="compiled", **kw)
    n = pyrt.render_full(s, backend="numpy", **kw)
    assert c.stats.backend == "compiled" and n.stats.backend == "numpy"
    assert c.passes == n.passes > 1
    np.testing.assert_array_equal(c.film.weight, n.film.weight)
    np.testing.assert_allclose(c.image, n.image, rtol=1e-5, atol=1e-7)


def test_normal_maps_with_vertex_tangents_match_the_numpy_path_pixel_by_pixel():
    """Vertex tangents with either handedness (mirrored UVs), turned against the UV tangents, and a mesh without
    them in the same scene: the NumPy path's image and normals; and not the image with the UV tangents."""
    s = _tangent_scene()
    ps = pyrt.PreparedScene(s)
    assert compiled.unsupported(ps) == []
    cs = compiled.CompiledScene(ps)
    opts, _ = compiled.kernel_options(cs, 1, 0, 8, 1e-4, None, True)
    assert opts[KL.O_NMAPS] == 2
    c = _same_image_and_aov(s, "normal", 1e-6)
    for m in s.meshes:
        m.tangents = None
    _assert_changes_the_image(s, c, 0.01)


def test_vertex_colours_the_kernel_cannot_read_fall_back_and_say_why():
    """Per-face colours (PLY), and colours bound with faces other than the mesh's."""
    s = _vertex_colour_scene(width=8, height=6)
    fc = FaceColorTexture()
    v, f, n, uv = _grid(3, 2.0, 0.0, 0.5, np.random.default_rng(0))
    mid = s.add_mesh((v, f), pyrt.Lambert(albedo=ProductTexture(fc, 0.5)), normals=n, uv=uv)
    fc.bind(mid, s.meshes[mid].faces, np.ones((f.shape[0], 3)))
    r = pyrt.render_full(s, progress=False)
    assert r.stats.backend == "numpy" and any("Lambert" in x for x in r.stats.fallback_reasons)
    s = _vertex_colour_scene(width=8, height=6)
    vc = s.materials[0].albedo_value.a
    vc.bind(0, s.meshes[0].faces[::-1], vc.bound(0)[1])
    reasons = compiled.unsupported(pyrt.PreparedScene(s))
    assert reasons == ["vertex colours of mesh 0 not one per vertex of its faces"]


@pytest.mark.parametrize("model", ["BoxVertexColors/BoxVertexColors.glb", "VertexColorTest/VertexColorTest.glb",
                                   "CesiumMilkTruck/CesiumMilkTruck.glb", "OrientationTest/OrientationTest.glb",
                                   "NegativeScaleTest/NegativeScaleTest.glb", "Avocado/glTF/Avocado.gltf",
                                   "NormalTangentMirrorTest/NormalTangentMirrorTest.glb",
                                   "NormalTangentTest/NormalTangentTest.glb"])
def test_khronos_vertex_attribute_models_match_the_numpy_path(model):
    """Shared Khronos models with vertex colours or vertex tangents (skipped when absent): the compiled path, the
    NumPy path's image at pixel centres."""
    path = os.path.join(KHRONOS, model)
    if not os.path.exists(path):
        pytest.skip(f"{path} not present")
    from pyrt.io.assets import load_asset
    asset = load_asset(path)
    cam = pyrt.Camera(position=(0, 0, 1), target=(0, 0, 0), fov=40, width=40, height=30, jitter=False)
    s = pyrt.Scene(cam, background=(0.1, 0.1, 0.1), ambient=(0.02, 0.02, 0.02))
    asset.add_to_scene(s, lights=False)
    lo = np.min([m.vertices.min(axis=0) for m in s.meshes], axis=0)
    hi = np.max([m.vertices.max(axis=0) for m in s.meshes], axis=0)
    centre, radius = 0.5 * (lo + hi), 0.5 * float(np.linalg.norm(hi - lo))
    s.camera = pyrt.Camera(position=centre + radius * np.array([0.3, 0.4, 2.2]), target=centre, fov=40, width=40,
                           height=30, jitter=False)
    s.add_light(pyrt.PointLight(centre + radius * np.array([1.0, 2.0, 3.0]), intensity=20.0 * radius ** 2))
    assert compiled.unsupported(pyrt.PreparedScene(s)) == []
    kw = dict(progress=False, seed=0, split_depth=None)
    c = pyrt.render_full(s, backend="auto", **kw)
    n = pyrt.render_full(s, backend="numpy", **kw)
    assert c.stats.backend == "compiled", c.stats.fallback_reasons
    diff = np.abs(c.image.astype(np.float64) - n.image)
    bad = diff > 1e-5 * (1.0 + np.abs(n.image))
    assert bad.any(axis=2).mean() < 0.005 and n.image.max() > 0
