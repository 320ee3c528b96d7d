"""pyrt.geometry.accel against trimesh's own ray test and the binding's sharp edges."""
import numpy as np
import pytest
import trimesh

from pyrt.geometry.accel import Accel


@pytest.fixture
def two_meshes():
    a = Accel()
    s = trimesh.creation.icosphere(subdivisions=3, radius=1.0)
    b = trimesh.creation.box(extents=(1, 1, 1))
    b.apply_translation((3, 0, 0))
    a.add_mesh(s.vertices, s.faces)
    a.add_mesh(b.vertices, b.faces)
    return a, s, b


def test_closest_hit_agrees_with_trimesh(two_meshes, rng):
    a, s, b = two_meshes
    n = 2000
    o = rng.uniform(-4, 6, size=(n, 3))
    o[:, 2] = 6.0
    d = np.column_stack([rng.normal(0, 0.1, n), rng.normal(0, 0.1, n), -np.ones(n)])
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    h = a.intersect(o, d)
    both = trimesh.util.concatenate([s, b])
    # brute-force reference: trimesh's triangle-ray test (no embree) on the combined mesh
    ref = trimesh.ray.ray_triangle.RayMeshIntersector(both)
    loc, ray_idx, tri_idx = ref.intersects_location(o, d, multiple_hits=True)
    t_ref = np.full(n, np.inf)
    np.minimum.at(t_ref, ray_idx, np.einsum("ij,ij->i", loc - o[ray_idx], d[ray_idx]))
    assert np.array_equal(np.isfinite(t_ref), h.hit)
    np.testing.assert_allclose(h.t[h.hit], t_ref[h.hit], rtol=0, atol=1e-4)
    # mesh id and triangle: rebuild the point from barycentrics and compare with o + t d
    assert set(np.unique(h.mesh_id[h.hit])) <= {0, 1}
    for mid, m in ((0, s), (1, b)):
        sel = h.mesh_id == mid
        tri = m.vertices[m.faces[h.prim_id[sel]]]
        p = (1 - h.u[sel] - h.v[sel])[:, None] * tri[:, 0] + h.u[sel, None] * tri[:, 1] + h.v[sel, None] * tri[:, 2]
        np.testing.assert_allclose(p, o[sel] + h.t[sel, None] * d[sel], atol=1e-4)
        # geometric normal has the orientation of trimesh's face normals and |Ng| = 2 area
        fn = m.face_normals[h.prim_id[sel]]
        ng = h.ng[sel] / np.linalg.norm(h.ng[sel], axis=1, keepdims=True)
        np.testing.assert_allclose(ng, fn, atol=1e-5)


def test_misses_are_masked(two_meshes):
    a, _, _ = two_meshes
    o = np.array([[0, 10, 0], [0, 0, 5]], dtype=np.float64)
    d = np.array([[0, 1, 0], [0, 0, -1]], dtype=np.float64)
    h = a.intersect(o, d)
    assert h.hit.tolist() == [False, True]
    assert np.isinf(h.t[0]) and h.mesh_id[0] == -1 and h.prim_id[0] == -1
    assert np.all(np.isfinite(o + np.where(h.hit, h.t, 0)[:, None] * d))
    np.testing.assert_allclose(h.t[1], 4.0, atol=1e-5)


def test_occlusion_respects_tmax(two_meshes):
    a, _, _ = two_meshes
    o = np.tile([0.0, 0.0, 5.0], (3, 1))
    d = np.tile([0.0, 0.0, -1.0], (3, 1))
    occ = a.occluded(o, d, np.array([3.9, 4.1, np.inf]))
    assert occ.tolist() == [False, True, True]


def test_caller_arrays_untouched(two_meshes):
    a, _, _ = two_meshes
    o = np.tile(np.array([0.0, 0.0, 5.0], dtype=np.float32), (4, 1))
    d = np.tile(np.array([0.0, 0.0, -1.0], dtype=np.float32), (4, 1))
    tmax = np.full(4, 100.0, dtype=np.float32)
    o0, d0, t0 = o.copy(), d.copy(), tmax.copy()
    a.intersect(o, d, tmax)
    a.occluded(o, d, tmax)
    assert np.array_equal(o, o0) and np.array_equal(d, d0) and np.array_equal(tmax, t0)


def test_shape_checks(two_meshes):
    a, _, _ = two_meshes
    with pytest.raises(ValueError, match="same shape"):
        a.intersect(np.zeros((4, 3)), np.ones((3, 3)))
    with pytest.raises(ValueError, match="tmax"):
        a.occluded(np.zeros((4, 3)), np.ones((4, 3)), np.ones(3))
    with pytest.raises(ValueError, match=r"\(N, 3\)"):
        a.intersect(np.zeros((4, 2)), np.ones((4, 2)))
    with pytest.raises(ValueError, match="finite"):
        a.intersect(np.full((1, 3), np.nan), np.ones((1, 3)))


def test_no_geometry_after_commit(two_meshes):
    a, s, _ = two_meshes
    a.intersect(np.zeros((1, 3)), np.ones((1, 3)))
    with pytest.raises(RuntimeError, match="committed"):
        a.add_mesh(s.vertices, s.faces)


def test_threaded_batches_identical_to_single_thread(rng):
    s = trimesh.creation.icosphere(subdivisions=4)
    a1, a2 = Accel(threads=1), Accel(threads=2)
    for a in (a1, a2):
        a.add_mesh(s.vertices, s.faces)
    n = 200_000  # > chunk size: exercised on the pool
    o = np.tile([0.0, 0.0, 4.0], (n, 1))
    d = rng.normal(size=(n, 3)) * 0.2 + [0, 0, -1]
    h1, h2 = a1.intersect(o, d), a2.intersect(o, d)
    assert np.array_equal(h1.t, h2.t) and np.array_equal(h1.prim_id, h2.prim_id)
    assert np.array_equal(a1.occluded(o, d, np.full(n, 3.5)), a2.occluded(o, d, np.full(n, 3.5)))


@pytest.mark.parametrize("threads", [1, 2])
@pytest.mark.parametrize("n", [0, 1000, 150_000])   # 150k: split over the pool, hits from several chunks
def test_intersect_hits_is_intersect_restricted_to_the_hits(threads, n, rng):
    s = trimesh.creation.icosphere(subdivisions=3)
    b = trimesh.creation.box(extents=(1, 1, 1))
    b.apply_translation((1.6, 0, 0))
    a = Accel(threads=threads)
    a.add_mesh(s.vertices, s.faces)
    a.add_mesh(b.vertices, b.faces)
    o = np.tile([0.0, 0.0, 4.0], (n, 1))
    d = rng.normal(size=(n, 3)) * 0.4 + [0, 0, -1]            # a part of the rays miss
    full = a.intersect(o, d)
    idx, h = a.intersect_hits(o, d)
    np.testing.assert_array_equal(idx, np.flatnonzero(full.hit))
    if n:
        assert 0.1 * n < idx.size < 0.9 * n and np.any(h.mesh_id == 1)
    for f in ("t", "mesh_id", "prim_id", "u", "v", "ng"):
        got, want = getattr(h, f), getattr(full, f)[idx]
        assert got.dtype == want.dtype
        np.testing.assert_array_equal(got, want)
    assert h.hit.all() and h.hit.shape == idx.shape


def test_finite_check_exact_even_where_a_sum_overflows(two_meshes):
    a = two_meshes[0]
    big = np.full((4, 3), 3e38, dtype=np.float32)          # finite, but their float32 sum overflows
    d = np.tile(np.float32([0, 0, -1]), (4, 1))
    assert a.occluded(big, d).shape == (4,)                 # accepted: every value is finite
    for bad in (np.nan, np.inf, -np.inf):
        o = big.copy()
        o[2, 1] = bad
        with pytest.raises(ValueError, match="finite"):
            a.occluded(o, d)
        d_bad = d.copy()
        d_bad[1, 0] = bad
        with pytest.raises(ValueError, match="finite"):
            a.intersect(np.zeros((4, 3)), d_bad)


def test_to_float32_matches_astype():
    from pyrt.shaders.vec import to_float32
    x = np.random.default_rng(0).normal(size=(1000, 3)) * 1e3
    np.testing.assert_array_equal(to_float32(x), x.astype(np.float32))
    y = x.astype(np.float32)
    assert to_float32(y) is y
    z = to_float32(x[:, ::2])                                # non-contiguous input
    assert z.flags.c_contiguous and z.dtype == np.float32


def _hits_of(accel, o, d, tmax=None):
    h = accel.intersect(o, d, tmax)
    return h, accel.occluded(o, d, 0.5 if tmax is None else tmax)


@pytest.mark.parametrize("quality", ["medium", "low", "high"])
def test_shared_buffers_give_the_binding_copys_hits(rng, quality):
    """Embree reading pyrt's arrays (no copy) holds the same geometry as the binding's element-by-element copy:
    bitwise the same closest hits and occlusion, over two meshes (mesh ids kept), at every build quality."""
    s = trimesh.creation.icosphere(subdivisions=4, radius=1.0)
    b = trimesh.creation.box(extents=(1, 2, 1))
    b.apply_translation((2.5, 0.3, 0))
    accels = {}
    for mode, q in (("copy", "medium"), ("shared", quality)):
        a = Accel(buffers=mode, build_quality=q)
        assert a.add_mesh(s.vertices, s.faces) == 0
        assert a.add_mesh(b.vertices, b.faces) == 1
        accels[mode] = a
    assert accels["copy"].buffers == "copy"
    assert accels["shared"].buffers == "shared" and accels["shared"].build_quality == quality
    n = 20000
    o = rng.uniform(-4, 4, size=(n, 3))
    d = rng.uniform((-1.2, -1.2, -1.2), (3.2, 1.2, 1.2), size=(n, 3)) - o      # toward the meshes' box
    (h0, occ0), (h1, occ1) = (_hits_of(accels[m], o, d) for m in ("copy", "shared"))
    assert 0.2 * n < h0.hit.sum() < 0.9 * n and 0 < occ0.sum() < n
    assert set(np.unique(h0.mesh_id[h0.hit])) == {0, 1}
    for field in ("hit", "t", "mesh_id", "prim_id", "u", "v", "ng"):
        assert np.array_equal(getattr(h0, field), getattr(h1, field)), field
    assert np.array_equal(occ0, occ1)


def test_shared_buffers_do_not_alias_the_callers_arrays():
    """The arrays Embree reads are the Accel's own: changing the caller's vertices afterwards changes nothing."""
    s = trimesh.creation.icosphere(subdivisions=2, radius=1.0)
    v = np.array(s.vertices, dtype=np.float32)
    a = Accel()
    a.add_mesh(v, s.faces)
    v *= 10.0
    h = a.intersect(np.array([[0.0, 0.0, 5.0]]), np.array([[0.0, 0.0, -1.0]]))
    assert h.hit[0] and 3.9 < h.t[0] <= 4.0


def test_accel_options_are_checked():
    from pyrt.core.errors import RenderError
    with pytest.raises(RenderError, match="buffers"):
        Accel(buffers="mmap")
    with pytest.raises(RenderError, match="build_quality"):
        Accel(build_quality="fast")
