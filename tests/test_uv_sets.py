"""Several UV sets (glTF TEXCOORD_0, TEXCOORD_1, ...): each texture slot reads its own set (``texcoord``), with the
footprints and tangents of that set.

Ground truth: on a mesh whose set 1 is an affine map ``uv1 = A uv0 + b`` of set 0, set 1's UVs, footprints and
tangents follow from set 0's by that map exactly (``duv1 = A duv0``, ``[dpdu1 dpdv1] = [dpdu0 dpdv0] A^-1``);
end to end, a glTF whose slot reads TEXCOORD_1 renders bit-identically to the same file with that set moved to
TEXCOORD_0 (the one-set path), and differently from the file read with the wrong set (so the check can fail).
"""
import gc
import json
import weakref

import numpy as np
import pytest
import trimesh

import pyrt
from pyrt.geometry.mesh_data import GeometryError
from pyrt.geometry.surface import surface_from_hits
from pyrt.integrators import PreparedScene
from pyrt.io.assets import load_asset
from pyrt.io.assets.gltf_write import embedded_gltf

A_MAP = np.array([[0.0, 3.0], [-2.0, 0.5]])      # set 1 = A_MAP @ set 0 + B_MAP: rotated, sheared, tiled
B_MAP = np.array([0.25, 0.5])


def _grid_mesh(n=6):
    """A (2n^2 triangles) square in z = 0, [-1, 1]^2, UV set 0 = ((x + 1) / 2, (y + 1) / 2)."""
    x, y = np.meshgrid(np.linspace(-1, 1, n + 1), np.linspace(-1, 1, n + 1))
    v = np.column_stack([x.ravel(), y.ravel(), np.zeros(x.size)])
    i = np.arange(n * (n + 1)).reshape(n, n + 1)[:, :n].ravel()
    f = np.concatenate([np.column_stack([i, i + 1, i + n + 2]), np.column_stack([i, i + n + 2, i + n + 1])])
    uv0 = (v[:, :2] + 1.0) / 2.0
    return v, f, uv0


def _surface(*, differentials=True, second_mesh=False, copy_of_set0=False):
    cam = pyrt.Camera(position=(0.2, -0.3, 3), target=(0, 0, 0), fov=40, width=24, height=20)
    scene = pyrt.Scene(cam)
    v, f, uv0 = _grid_mesh()
    tm = trimesh.Trimesh(v, f, process=False)
    tm.visual = trimesh.visual.TextureVisuals(uv=uv0)
    scene.add_mesh(tm, pyrt.Lambert(0.5), smooth=False, uv_sets={1: uv0.copy() if copy_of_set0 else uv0 @ A_MAP.T + B_MAP})
    if second_mesh:    # a mesh without set 1, in front of the first one's left half
        tm2 = trimesh.Trimesh(v * [0.3, 0.3, 1] + [-0.6, 0, 0.5], f, process=False)
        tm2.visual = trimesh.visual.TextureVisuals(uv=uv0)
        scene.add_mesh(tm2, pyrt.Lambert(0.5), smooth=False)
    ps = PreparedScene(scene)
    rays = cam.generate_rays(0, cam.width * cam.height, np.random.default_rng(0), differentials=differentials)
    o, d = rays.origins, rays.directions
    idx, hits = ps.accel.intersect_hits(o, d)
    diffs = None
    if differentials:
        diffs = tuple(a[idx] for a in rays.differentials)
    return surface_from_hits(ps.geo, hits, o[idx], d[idx], diffs)


def test_second_set_is_the_affine_map_of_the_first_with_its_footprints_and_tangents():
    surf = _surface()
    assert surf.n_hits > 100
    uv1, dx1, dy1 = surf.uv_set(1)
    np.testing.assert_allclose(uv1, surf.uv @ A_MAP.T + B_MAP, atol=1e-12)
    assert np.abs(surf.duvdx).max() > 1e-3                       # the rays carry differentials
    np.testing.assert_allclose(dx1, surf.duvdx @ A_MAP.T, atol=1e-12)
    np.testing.assert_allclose(dy1, surf.duvdy @ A_MAP.T, atol=1e-12)
    dpdu1, dpdv1 = surf.uv_tangents(1)
    inv = np.linalg.inv(A_MAP)            # p(uv1) = p(uv0(uv1)): d p / d uv1 = (d p / d uv0) A^-1
    np.testing.assert_allclose(dpdu1, surf.dpdu * inv[0, 0] + surf.dpdv * inv[1, 0], atol=1e-12)
    np.testing.assert_allclose(dpdv1, surf.dpdu * inv[0, 1] + surf.dpdv * inv[1, 1], atol=1e-12)
    assert surf.uv_set(0) == (surf.uv, surf.duvdx, surf.duvdy) and surf.uv_tangents(0) == (surf.dpdu, surf.dpdv)
    assert surf.uv_set(1)[0] is uv1                                  # reconstructed once per batch


def test_a_second_set_equal_to_the_first_gives_the_same_bits():
    surf = _surface(copy_of_set0=True)
    for a, b in zip(surf.uv_set(1) + surf.uv_tangents(1), surf.uv_set(0) + surf.uv_tangents(0)):
        np.testing.assert_array_equal(a, b)


def test_views_gather_the_set_and_meshes_without_it_read_zeros():
    surf = _surface(second_mesh=True)
    rows = np.arange(1, surf.n_hits, 3)
    sub = surf.subset(rows).subset(np.arange(0, rows.size, 2))
    for a, b in zip(sub.uv_set(1) + sub.uv_tangents(1), surf.uv_set(1) + surf.uv_tangents(1)):
        np.testing.assert_array_equal(a, b[rows[::2]])
    other = surf.mesh_id == 1
    assert 10 < other.sum() < surf.n_hits - 10
    assert np.all(surf.uv_set(1)[0][other] == 0) and np.all(surf.uv_set(1)[0][~other] != 0)
    assert np.all(surf.uv_set(1)[1][other] == 0)


def test_no_differentials_gives_zero_footprints_in_every_set():
    surf = _surface(differentials=False)
    _, dx1, dy1 = surf.uv_set(1)
    assert np.all(dx1 == 0) and np.all(dy1 == 0)


def test_a_batch_reading_a_second_set_is_freed_without_the_cycle_collector():
    gc.disable()
    try:
        surf = _surface()
        sub = surf.subset(np.arange(0, surf.n_hits, 2))
        assert sub.uv_set(1)[0] is not None and surf.uv_tangents(1)[0] is not None
        refs = [weakref.ref(surf), weakref.ref(sub)]
        del surf, sub
        assert all(r() is None for r in refs), "a SurfaceBatch reading UV set 1 is part of a reference cycle"
    finally:
        gc.enable()


def test_a_batch_built_from_fields_has_only_set_zero():
    uv = np.array([[0.1, 0.2], [0.3, 0.4]])
    surf = pyrt.geometry.SurfaceBatch(uv=uv, duvdx=np.zeros((2, 2)), duvdy=np.zeros((2, 2)))
    assert surf.uv_set(2)[0] is uv


@pytest.mark.parametrize("sets, match", [({0: np.zeros((4, 2))}, "keys must be integers >= 1"),
                                         ({1: np.zeros((3, 2))}, r"UV set 1 must be finite with shape \(4, 2\)"),
                                         ({1: np.full((4, 2), np.nan)}, "UV set 1 must be finite")])
def test_add_mesh_refuses_bad_uv_sets(sets, match):
    v = [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]]
    with pytest.raises(GeometryError, match=match):
        pyrt.Scene().add_mesh((v, [[0, 1, 2], [0, 2, 3]]), pyrt.Lambert(0.5), name="quad", uv_sets=sets)


def test_image_texture_refuses_a_bad_texcoord():
    with pytest.raises(pyrt.Error, match="texcoord must be an integer >= 0"):
        pyrt.ImageTexture(np.zeros((2, 2, 3)), texcoord=-1)


# ------------------------------------------------------------------------------------------- glTF end to end

def _write(path, uv_sets, material, images):
    """A .gltf of the grid square with the given TEXCOORD_k arrays (glTF top-left UVs), one material, the images
    as textures (no sampler: trilinear, repeat)."""
    v, f, _ = _grid_mesh()
    attrs = {"POSITION": v.astype(np.float32), "NORMAL": np.tile(np.float32([0, 0, 1]), (len(v), 1))}
    attrs.update({f"TEXCOORD_{k}": np.asarray(uv, np.float32) for k, uv in uv_sets.items()})
    path.write_text(json.dumps(embedded_gltf(attrs, f, material, images)))
    return str(path)


def _gltf_sets():
    _, _, uv0 = _grid_mesh()
    g0 = np.column_stack([uv0[:, 0], 1.0 - uv0[:, 1]])            # upright in glTF's top-left UVs
    g1 = uv0 @ (4.0 * A_MAP).T + B_MAP                            # another set, tiled (minified: other MIP levels)
    return g0, g1


def _render(path, *, light=False, **kw):
    """Render the file on the NumPy path: a slot on TEXCOORD_1 is not compiled, so the one-set references must take
    the same path (the same random numbers) to compare pixel by pixel."""
    cam = pyrt.Camera(position=(0.2, -0.3, 3), target=(0, 0, 0), fov=40, width=40, height=32, spp=4)
    scene = pyrt.Scene(cam, background=(0, 0, 0))
    asset = load_asset(path)
    asset.add_to_scene(scene, lights=False)
    if light:
        scene.add_light(pyrt.DirectionalLight((0.6, -0.3, -1.0), irradiance=3.0))
    res = pyrt.render_full(scene, seed=3, aovs=True, backend="numpy", **kw)
    return asset, res.image, res.aovs["albedo"]


def test_each_gltf_slot_reads_its_own_uv_set(tmp_path):
    """baseColorTexture on TEXCOORD_0, emissiveTexture on TEXCOORD_1: the albedo AOV equals the base colour read
    through a one-set file with TEXCOORD_0, the emission (black base, no light) the emissive texture read through a
    one-set file whose TEXCOORD_0 is the second set; reading the wrong set gives another image."""
    rng = np.random.default_rng(5)
    base, emit = (rng.integers(0, 256, (16, 16, 3), dtype=np.uint8) for _ in range(2))
    g0, g1 = _gltf_sets()
    both = {"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}, "metallicFactor": 0.0},
            "emissiveFactor": [1, 1, 1], "emissiveTexture": {"index": 1, "texCoord": 1}}
    asset, img, alb = _render(_write(tmp_path / "two.gltf", {0: g0, 1: g1}, both, [base, emit]))
    assert asset.warnings == []
    assert sorted(asset.meshes[0].uv_sets) == [1]
    emission_only = {"pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1], "metallicFactor": 0.0},
                     "emissiveFactor": [1, 1, 1], "emissiveTexture": {"index": 0}}
    base_only = {"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}, "metallicFactor": 0.0}}
    _, img_ref, _ = _render(_write(tmp_path / "e1.gltf", {0: g1}, emission_only, [emit]))
    _, _, alb_ref = _render(_write(tmp_path / "b0.gltf", {0: g0}, base_only, [base]))
    _, img_wrong, _ = _render(_write(tmp_path / "e0.gltf", {0: g0}, emission_only, [emit]))
    # the two-set file's radiance is emission + base colour x ambient 0 (no light, black background)
    np.testing.assert_array_equal(img, img_ref)
    np.testing.assert_array_equal(alb, alb_ref)
    assert np.abs(img - img_wrong).mean() > 0.05


def test_texture_transform_texcoord_and_a_normal_map_on_the_second_set(tmp_path):
    """``KHR_texture_transform.texCoord = 1`` (over textureInfo texCoord 0) on the base colour and a normal map on
    TEXCOORD_1 (its tangents from that set): lit by a light, the render equals the one-set file with the second set
    as TEXCOORD_0."""
    rng = np.random.default_rng(7)
    base = rng.integers(0, 256, (16, 16, 3), dtype=np.uint8)
    nrm = np.clip(rng.normal([128, 128, 230], [40, 40, 10], (16, 16, 3)), 0, 255).astype(np.uint8)
    g0, g1 = _gltf_sets()
    tt = {"KHR_texture_transform": {"texCoord": 1}}
    two = {"pbrMetallicRoughness": {"baseColorTexture": {"index": 0, "texCoord": 0, "extensions": tt},
                                    "metallicFactor": 0.0, "roughnessFactor": 0.5},
           "normalTexture": {"index": 1, "texCoord": 1}}
    one = {"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}, "metallicFactor": 0.0, "roughnessFactor": 0.5},
           "normalTexture": {"index": 1}}
    asset, img, _ = _render(_write(tmp_path / "two.gltf", {0: g0, 1: g1}, two, [base, nrm]), light=True)
    assert asset.materials[0].texcoords == (1,)
    _, img_ref, _ = _render(_write(tmp_path / "one.gltf", {0: g1}, one, [base, nrm]), light=True)
    np.testing.assert_array_equal(img, img_ref)
    flat = {**one, "normalTexture": {"index": 1, "scale": 0.0}}
    _, img_flat, _ = _render(_write(tmp_path / "flat.gltf", {0: g1}, flat, [base, nrm]), light=True)
    assert np.abs(img - img_flat).mean() > 1e-3          # the normal map matters: the check can fail


def test_a_set_no_material_reads_is_not_kept(tmp_path):
    g0, g1 = _gltf_sets()
    mat = {"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}
    asset = load_asset(_write(tmp_path / "m.gltf", {0: g0, 1: g1}, mat, [np.zeros((2, 2, 3), np.uint8)]))
    assert asset.meshes[0].uv_sets is None and asset.meshes[0].uv is not None


def test_a_missing_set_is_a_warning_naming_it(tmp_path):
    g0, _ = _gltf_sets()
    mat = {"emissiveFactor": [1, 1, 1], "emissiveTexture": {"index": 0, "texCoord": 2}}
    asset = load_asset(_write(tmp_path / "m.gltf", {0: g0}, mat, [np.zeros((2, 2, 3), np.uint8)]))
    assert any("TEXCOORD_2 but the primitive has none" in w for w in asset.warnings)
    asset.add_to_scene(pyrt.Scene())
