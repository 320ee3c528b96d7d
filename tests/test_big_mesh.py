"""Preparation of big meshes (pyrt.geometry.normals): the two-pass crease normals give bitwise the normals,
vertices and faces of the all-pairs method they replaced, and stay within a memory bound (tracemalloc)."""
import math
import os
import sys
import tracemalloc

import numpy as np
import pytest
import trimesh

from pyrt.geometry.normals import crease_normals

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "tools"))
import big_mesh  # noqa: E402  (the generator of tools/big_mesh.py)



def all_pairs_crease_normals(vertices, faces, crease_angle):
    """The position-welded crease normals as pyrt computed them before the two-pass method (commit 2015525):
    every pair of corners sharing a position formed explicitly (O(corners x valence) memory)."""
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    nf = f.shape[0]
    p = v[f]
    fn = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    ln = np.linalg.norm(fn, axis=1, keepdims=True)
    fn = np.divide(fn, ln, out=np.zeros_like(fn), where=ln > 0)
    ang = np.zeros((nf, 3))
    for k in range(3):
        a = p[:, (k + 1) % 3] - p[:, k]
        b = p[:, (k + 2) % 3] - p[:, k]
        na = np.linalg.norm(a, axis=1)
        nb = np.linalg.norm(b, axis=1)
        c = np.divide(np.einsum("ij,ij->i", a, b), na * nb, out=np.zeros(nf), where=(na * nb) > 0)
        ang[:, k] = np.arccos(np.clip(c, -1.0, 1.0))
    corner_vertex = f.ravel()
    corner_face = np.repeat(np.arange(nf), 3)
    _, pos_id = np.unique(v, axis=0, return_inverse=True)
    pos_id = pos_id.ravel()[corner_vertex]
    order = np.argsort(pos_id, kind="stable")
    sorted_pos = pos_id[order]
    starts = np.flatnonzero(np.r_[True, sorted_pos[1:] != sorted_pos[:-1]])
    counts = np.diff(np.r_[starts, sorted_pos.size])
    group_of_sorted = np.repeat(np.arange(starts.size), counts)
    cnt_i = counts[group_of_sorted]
    total = int(np.sum(cnt_i))
    rep_i = np.repeat(np.arange(sorted_pos.size), cnt_i)
    first = np.repeat(np.cumsum(cnt_i) - cnt_i, cnt_i)
    j_sorted = starts[group_of_sorted][rep_i] + (np.arange(total) - first)
    ci = order[rep_i]
    cj = order[j_sorted]
    fi, fj = corner_face[ci], corner_face[cj]
    cos_lim = math.cos(math.radians(crease_angle))
    ok = np.einsum("ij,ij->i", fn[fi], fn[fj]) >= cos_lim - 1e-12
    ok |= fi == fj
    w = ang.ravel()[cj] * ok
    acc = np.zeros((3 * nf, 3))
    for c in range(3):
        acc[:, c] = np.bincount(ci, weights=w * fn[fj, c], minlength=3 * nf)
    la = np.linalg.norm(acc, axis=1, keepdims=True)
    acc = np.divide(acc, la, out=np.zeros_like(acc), where=la > 0)
    key = np.concatenate([corner_vertex[:, None].astype(np.float64).view(np.int64), acc.view(np.int64)], axis=1)
    _, first_idx, inv = np.unique(key, axis=0, return_index=True, return_inverse=True)
    src = corner_vertex[first_idx]
    return src.astype(np.int64), inv.reshape(nf, 3).astype(np.int64), acc[first_idx]


def _cases(rng):
    out = {"box": trimesh.creation.box(), "icosphere": trimesh.creation.icosphere(3),
           "cylinder": trimesh.creation.cylinder(1, 2, sections=24)}
    b = trimesh.creation.box()
    out["soup"] = trimesh.Trimesh(b.vertices[b.faces].reshape(-1, 3), np.arange(36).reshape(-1, 3), process=False)
    v, f = big_mesh.make_mesh(3)
    out["noisy"] = trimesh.Trimesh(v + rng.normal(0.0, 0.03, v.shape), f, process=False)     # creases everywhere
    v, f = big_mesh.make_mesh(2)
    out["degenerate"] = trimesh.Trimesh(v, np.vstack([f, [[0, 0, 1], [3, 3, 3]]]), process=False)
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [-0.0, 0, 0], [0, 0, 1.0]])
    out["minus_zero"] = trimesh.Trimesh(v, np.array([[0, 1, 2], [3, 4, 1]]), process=False)
    v, f = big_mesh.make_mesh(2)                    # a UV seam: 5 vertices duplicated, 20 faces use the copies
    v2 = np.vstack([v, v[:5]])
    f2 = f.copy()
    f2[:20] = np.where(f2[:20] < 5, f2[:20] + len(v), f2[:20])
    out["seam"] = trimesh.Trimesh(v2, f2, process=False)
    v, f = big_mesh.make_mesh(3)                    # coordinates as read from a float32 file (29 zero low bits)
    out["float32_file"] = trimesh.Trimesh(v.astype(np.float32).astype(np.float64), f, process=False)
    out["float32_soup"] = trimesh.Trimesh(out["float32_file"].vertices[f].reshape(-1, 3),
                                          np.arange(3 * len(f)).reshape(-1, 3), process=False)
    return out


@pytest.mark.parametrize("crease", [0.0, 10.0, 30.0, 89.0, 90.0, 179.0, 180.0])
def test_two_pass_crease_normals_bitwise_equal_all_pairs(crease, rng):
    for name, m in _cases(rng).items():
        ref = all_pairs_crease_normals(m.vertices, m.faces, crease)
        got = crease_normals(m.vertices, m.faces, crease)
        for what, a, b in zip(("src", "faces", "normals"), ref, got):
            assert a.dtype == b.dtype and a.shape == b.shape, (name, what)
            assert np.array_equal(a.view(np.uint8), b.view(np.uint8)), (name, crease, what)


def test_crease_normals_memory_bound():
    """328k triangles (164k vertices): the all-pairs method peaked at ~18 corner pairs x 3 x 8 bytes per triangle
    (~700 MB here); the two-pass method allocates a few (F, 3) arrays: bound 250 bytes per triangle (82 MB)."""
    v, f = big_mesh.make_mesh(7)
    tracemalloc.start()
    try:
        tracemalloc.reset_peak()
        crease_normals(v, f, 30.0)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 250 * f.shape[0], peak / f.shape[0]


def test_mesh_preparation_memory_bound(tmp_path):
    """Loading-to-BVH preparation of an 82k-triangle PLY without normals (add_to_scene: welding, crease normals,
    add_mesh; PreparedScene: geometry table, float32 range check, copies into Embree): tracemalloc peak (NumPy and
    Python allocations; Embree's own BVH memory is not traced) below 600 bytes per triangle. Measured: 414 here,
    2380 with the all-pairs normals and (F, 3, 3) copies of before."""
    import pyrt
    from pyrt.io.assets import load_asset

    v, f = big_mesh.make_mesh(6)
    big_mesh.write_ply(tmp_path / "m.ply", v, f)
    asset = load_asset(str(tmp_path / "m.ply"))
    scene = pyrt.Scene(pyrt.Camera())
    tracemalloc.start()
    try:
        tracemalloc.reset_peak()
        asset.add_to_scene(scene)
        with pyrt.PreparedScene(scene) as prepared:
            peak = tracemalloc.get_traced_memory()[1]
            assert set(prepared.timings) == {"geometry", "bvh"}
    finally:
        tracemalloc.stop()
    assert peak < 600 * f.shape[0], peak / f.shape[0]


def test_position_hash_has_no_collisions_on_float32_coordinates():
    """The welding hash mixes every bit (pyrt.geometry.normals._mix64): on the 655k float32-exact vertices of a
    level-8 bumpy sphere it has no two equal values (the multiply-add hash used before had 2 there, and its
    collisions sent the 5.24 M-triangle mesh down the three-key sort: 1.6 s instead of 0.2 s of CPU), and
    ``_position_ids`` then labels every vertex as its own position without sorting the rows."""
    from pyrt.geometry.normals import _mix64, _position_ids

    v, _ = big_mesh.make_mesh(8)
    v = v.astype(np.float32).astype(np.float64)
    ub = (v + 0.0).view(np.uint64)
    h = _mix64(ub[:, 0])
    for k in (1, 2):
        h = _mix64(h ^ ub[:, k])
    hs = np.sort(h)
    assert not np.any(hs[1:] == hs[:-1])
    gid, n = _position_ids(v)
    assert n == v.shape[0] and np.array_equal(gid, np.arange(n))
    w = np.vstack([v[:1000], v[:10], [[0.0, 0.0, 0.0]], [[-0.0, 0.0, -0.0]]])   # duplicates weld, -0.0 with 0.0
    gid, n = _position_ids(w)
    assert n == 1001 and np.array_equal(gid[1000:1010], gid[:10]) and gid[-1] == gid[-2]


def test_apply_matrix_is_bitwise_the_matmul():
    """pyrt.core.transforms.apply_matrix: signed permutations (the up-axis turns) moved as columns, others through
    ``@``; bitwise ``v @ m[:3, :3].T + m[:3, 3]`` either way, -0.0 coordinates and translations included."""
    import itertools

    from pyrt.core.transforms import apply_matrix

    rng = np.random.default_rng(3)
    v = rng.normal(size=(3000, 3))
    v[:100] = 0.0
    v[:50] *= -1.0
    v[100:200, 1] = -0.0
    for perm in itertools.permutations(range(3)):
        for signs in itertools.product((1.0, -1.0), repeat=3):
            for t in ((0.0, 0.0, 0.0), (1.5, -2.0, 0.25), (0.0, -0.0, 3.0)):
                m = np.zeros((4, 4))
                m[[0, 1, 2], perm] = signs
                m[:3, 3] = t
                m[3, 3] = 1.0
                ref = v @ m[:3, :3].T + m[:3, 3]
                assert np.array_equal(apply_matrix(v, m).view(np.int64), ref.view(np.int64)), (perm, signs, t)
                assert np.array_equal(apply_matrix(v, m[:3, :3]).view(np.int64),
                                      (v @ m[:3, :3].T + 0.0).view(np.int64))
    g = rng.normal(size=(4, 4))
    assert np.array_equal(apply_matrix(v, g), v @ g[:3, :3].T + g[:3, 3])


def test_vec_cross_is_bitwise_np_cross():
    from pyrt.shaders.vec import cross

    rng = np.random.default_rng(4)
    for sa, sb in (((500, 3), (500, 3)), ((3,), (500, 3)), ((500, 3), (3,)), ((3,), (3,)), ((4, 5, 3), (5, 3))):
        a, b = rng.normal(size=sa), rng.normal(size=sb)
        assert np.array_equal(cross(a, b), np.cross(a, b))
    a = rng.normal(size=(100, 3)).astype(np.float32)
    assert cross(a, a[::-1]).dtype == np.float32 and np.array_equal(cross(a, a[::-1]), np.cross(a, a[::-1]))


def test_vec_divide_rows_is_bitwise_the_broadcast_divide():
    from pyrt.shaders.vec import divide_rows, norm

    rng = np.random.default_rng(5)
    a = rng.normal(size=(2000, 3))
    a[:50] = 0.0
    s = np.linalg.norm(a, axis=1, keepdims=True)
    ref = np.divide(a, s, out=np.zeros_like(a), where=s > 0)
    assert np.array_equal(divide_rows(a, norm(a)).view(np.int64), ref.view(np.int64))
    assert np.array_equal(norm(a), s[:, 0])


def test_crease_normals_of_many_meshes_in_one_call_equal_one_call_each():
    """Asset.add_to_scene computes the crease normals of every mesh without normals in one call (groups): the
    same vertices, faces and normals, bit for bit, as a call per mesh, and nothing welds across meshes even
    where two meshes share positions (two boxes touching along a face, a sphere)."""
    import trimesh
    from pyrt.io.assets.asset import AssetMesh, _prepare_mesh, _prepare_meshes
    a = trimesh.creation.box(extents=(1, 1, 1))
    b = trimesh.creation.box(extents=(1, 1, 1))
    b.apply_translation((1, 0, 0))                   # shares the face x = 0.5 with a
    c = trimesh.creation.icosphere(subdivisions=2)
    meshes = {k: AssetMesh(name=str(k), vertices=np.asarray(m.vertices, float), faces=np.asarray(m.faces, np.int64),
                           uv=np.asarray(m.vertices[:, :2], float))
              for k, m in enumerate((a, b, c))}
    meshes[3] = AssetMesh(name="has normals", vertices=meshes[0].vertices, faces=meshes[0].faces,
                          normals=np.asarray(a.vertex_normals, float))
    # two single-triangle meshes sharing an edge at 10 degrees: welded they would be smoothed, alone each is flat
    t = np.radians(10.0)
    meshes[4] = AssetMesh(name="flat", vertices=np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]]), faces=np.array([[0, 1, 2]]))
    meshes[5] = AssetMesh(name="tilted", vertices=np.array([[1.0, 0, 0], [0, 1, 0], [1, 1, np.sin(t)]]),
                          faces=np.array([[0, 2, 1]]))
    batched = _prepare_meshes(meshes, 30.0)
    for k, am in meshes.items():
        one = _prepare_mesh(am, 30.0)
        (v1, f1), n1, *_r1, uv1 = one
        (v2, f2), n2, *_r2, uv2 = batched[k]
        np.testing.assert_array_equal(v1, v2)
        np.testing.assert_array_equal(f1, f2)
        np.testing.assert_array_equal(n1, n2)
        np.testing.assert_array_equal(uv1, uv2)
    # a box's corners keep three normals each (flat faces at 90 degrees), the shared face's corners too
    assert batched[1][1].shape == (24, 3)
    np.testing.assert_allclose(batched[4][1], np.tile([0, 0, 1], (3, 1)), atol=1e-12)   # not bent toward mesh 5


def test_geometry_table_holds_one_copy_of_the_geometry():
    """A scene's joined geometry table is the only copy of its meshes' arrays: one mesh's arrays are the table's,
    several meshes' arrays become views of their rows (the first mesh's faces too), with the values they had; a
    second table from the same meshes equals the first."""
    import pyrt

    s = pyrt.Scene(pyrt.Camera())
    s.add_sphere((0, 1, 0), 1.0, pyrt.Lambert(0.5), subdivisions=3)
    one = s.geometry_table()
    m = s.meshes[0]
    for name in ("vertices", "vertices_object", "faces", "normals"):
        assert np.shares_memory(getattr(one, name), getattr(m, name)), name
    s.add_plane((0, 0, 0), 4.0, pyrt.Lambert(0.7))
    before = [{k: np.array(getattr(mm, k)) for k in ("vertices", "vertices_object", "faces", "normals")}
              for mm in s.meshes]
    geo = s.geometry_table()
    for k, (mm, was) in enumerate(zip(s.meshes, before)):
        for name in ("vertices", "vertices_object", "normals"):
            if was[name].ndim:
                assert np.shares_memory(getattr(mm, name), getattr(geo, name)), (k, name)
                assert np.array_equal(getattr(mm, name), was[name]), (k, name)
        assert np.array_equal(mm.faces, was["faces"])
    assert np.shares_memory(s.meshes[0].faces, geo.faces)
    again = s.geometry_table()
    for name in ("vertices", "vertices_object", "faces", "normals", "uv", "face_normals", "face_absmax"):
        assert np.array_equal(getattr(again, name), getattr(geo, name)), name


def test_preview_forgets_the_loaders_meshes_and_keeps_what_it_reports(tmp_path):
    """render_preview drops the asset's meshes once the scene holds the model (PreviewScene.forget_model_arrays):
    the triangle count, warnings and the image stay; an Asset the caller passed keeps its meshes."""
    import pyrt
    from pyrt.apps.preview import PreviewOptions, render_preview
    from pyrt.apps.preview.render import PreviewScene

    v, f = big_mesh.make_mesh(2)
    big_mesh.write_ply(tmp_path / "m.ply", v, f)
    o = PreviewOptions(width=32, height=24, spp=1)
    ps = PreviewScene(pyrt.load_asset(str(tmp_path / "m.ply")), o)
    n = ps.n_triangles
    ps.forget_model_arrays()
    assert ps.asset.meshes == [] and ps.n_triangles == n == f.shape[0]
    asset = pyrt.load_asset(str(tmp_path / "m.ply"))
    res = render_preview(asset, o)
    assert res.triangles == f.shape[0] and len(asset.meshes) == 1
    by_path = render_preview(str(tmp_path / "m.ply"), o)
    assert by_path.triangles == f.shape[0]
    assert np.array_equal(np.asarray(by_path.images[0]), np.asarray(res.images[0]))
