"""pyrt.geometry.embree_jit: Embree's queries from Numba kernels give bitwise the answers of the binding's run.

The same Embree scene (an Accel's) is traced three ways: ``Accel.intersect`` / ``Accel.occluded`` (embreex's
``run``: ``rtcIntersect1`` / ``rtcOccluded1`` one ray at a time), a kernel calling ``intersect1`` /
``occluded1``, and kernels tracing 4-, 8- and 16-wide packets with the coherent and the incoherent flag and a
partly inactive ``valid`` mask. Rays: random ones, camera-like ones, and rays aimed exactly at vertices and edge
midpoints (where two or more triangles tie). Every id, distance, barycentric and normal is compared with ``==``,
but for coherent packets at exact ties (:func:`_assert_same` says what is checked there, and why).

``python tests/test_embree_jit.py`` prints a single-thread benchmark (camera rays: embreex, single rays,
packets).
"""
import ctypes
import os
import subprocess
import sys
import textwrap

import numba
import numpy as np
import pytest
import trimesh

from pyrt.geometry import embree_jit as ej
from pyrt.geometry.accel import Accel

T_FAR = np.float32(1e37)   # what Accel passes as an unbounded tfar
N_RANDOM = 10000           # the random rays come first in the ray set


# -- kernels (cached: the second run of the suite compiles nothing) -----------------------------------------------
@numba.njit(nogil=True, cache=True, forceinline=True)
def _store(out, k, r):
    hit, t, prim, geom, u, v, ngx, ngy, ngz = r
    out[0][k] = hit
    out[1][k] = t
    out[2][k] = prim
    out[3][k] = geom
    out[4][k, 0] = u
    out[4][k, 1] = v
    out[5][k, 0] = ngx
    out[5][k, 1] = ngy
    out[5][k, 2] = ngz


@numba.njit(nogil=True, cache=True)
def _outputs(n):
    return (np.zeros(n, np.bool_), np.zeros(n, np.float32), np.zeros(n, np.int32), np.zeros(n, np.int32),
            np.zeros((n, 2), np.float32), np.zeros((n, 3), np.float32))


@numba.njit(nogil=True, cache=True)
def trace1(scene, o, d, tnear, tfar):
    out = _outputs(o.shape[0])
    buf = ej.ray_alloc()
    for k in range(o.shape[0]):
        _store(out, k, ej.intersect1(scene, o[k, 0], o[k, 1], o[k, 2], d[k, 0], d[k, 1], d[k, 2], tnear[k], tfar[k],
                                     buf))
    return out


@numba.njit(nogil=True, cache=True)
def _fill(p, valid, o, d, tnear, tfar, inactive, base, m):
    """Rays base..base+m-1 into the packet's lanes; the ``inactive`` ones set, then masked off."""
    ej.packet_clear(p)
    for lane in range(m):
        k = base + lane
        ej.packet_set_ray(p, lane, o[k, 0], o[k, 1], o[k, 2], d[k, 0], d[k, 1], d[k, 2], tnear[k], tfar[k])
        if inactive[k]:
            valid[lane] = 0


@numba.njit(nogil=True, cache=True)
def trace_packets(scene, o, d, tnear, tfar, width, coherent, inactive):
    """Rays k..k+width-1 in one packet; rays with ``inactive[k]`` are set in their lane, then masked off."""
    n = o.shape[0]
    out = _outputs(n)
    p = ej.packet_alloc(width)
    valid = ej.packet_valid(p)
    for base in range(0, n, width):
        m = min(width, n - base)
        _fill(p, valid, o, d, tnear, tfar, inactive, base, m)
        ej.intersect_packet(scene, p, coherent)
        for lane in range(m):
            _store(out, base + lane, ej.packet_hit(p, lane))
    return out


@numba.njit(nogil=True, cache=True)
def occluded_rays(scene, o, d, tnear, tfar, width, coherent, inactive):
    """Occlusion of every ray: single rays when ``width == 1``, else packets as :func:`trace_packets`."""
    n = o.shape[0]
    out = np.zeros(n, np.bool_)
    if width == 1:
        buf = ej.ray_alloc()
        for k in range(n):
            out[k] = ej.occluded1(scene, o[k, 0], o[k, 1], o[k, 2], d[k, 0], d[k, 1], d[k, 2], tnear[k], tfar[k], buf)
        return out
    p = ej.packet_alloc(width)
    valid = ej.packet_valid(p)
    for base in range(0, n, width):
        m = min(width, n - base)
        _fill(p, valid, o, d, tnear, tfar, inactive, base, m)
        ej.occluded_packet(scene, p, coherent)
        for lane in range(m):
            out[base + lane] = ej.packet_blocked(p, lane)
    return out


# -- the scene and the rays ---------------------------------------------------------------------------------------
def _meshes():
    sphere = trimesh.creation.icosphere(subdivisions=3, radius=1.0)
    plane_v = np.array([[-6, -6, -1.5], [6, -6, -1.5], [6, 6, -1.5], [-6, 6, -1.5]], dtype=np.float64)
    plane_f = np.array([[0, 1, 2], [0, 2, 3]])
    box = trimesh.creation.box(extents=(1.0, 0.8, 1.2))
    box.apply_translation((2.2, 0.3, -0.4))
    return [(sphere.vertices, sphere.faces), (plane_v, plane_f), (box.vertices, box.faces)]


@pytest.fixture(scope="module")
def scene():
    acc = Accel(threads=1)
    meshes = _meshes()
    for v, f in meshes:
        acc.add_mesh(v, f)
    if acc.buffers != "shared":
        pytest.skip("this embreex exposes no scene handle (Accel.buffers == 'copy')")
    yield acc, ej.scene_handle(acc), meshes
    acc.close()


@pytest.fixture(scope="module")
def rays(scene):
    return _rays(scene[2])


def _rays(meshes):
    """float32 (o, d): random rays, a pinhole camera's rays in row order, rays aimed at vertices and edges."""
    rng = np.random.default_rng(7)
    n = N_RANDOM
    o_r = rng.uniform(-4, 4, (n, 3))
    d_r = rng.normal(size=(n, 3))
    ys, xs = np.mgrid[0:48, 0:64]
    d_c = np.column_stack([(xs.ravel() - 31.5) / 40, (23.5 - ys.ravel()) / 40, -np.ones(xs.size)])
    o_c = np.tile([0.3, 0.2, 5.0], (xs.size, 1))
    targets = []
    for v, f in meshes:
        edges = np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1)
        edges = np.unique(edges, axis=0)
        targets += [v, 0.5 * (v[edges[:, 0]] + v[edges[:, 1]])]
    t = np.concatenate(targets).astype(np.float32)
    o_t = (rng.normal(size=t.shape) * 4).astype(np.float32)
    o = np.concatenate([o_r, o_c, o_t]).astype(np.float32)
    d = np.concatenate([d_r, d_c, t - o_t]).astype(np.float32)     # aimed exactly at the float32 targets
    return o, d


def _as_outputs(h):
    """An Accel ``Hits`` as a kernel's outputs (its float64 fields are float32 values: the casts are exact)."""
    f = np.float32
    return (h.hit, h.t.astype(f), h.prim_id.astype(np.int32), h.mesh_id.astype(np.int32),
            np.column_stack([h.u, h.v]).astype(f), h.ng.astype(f))


def _assert_same(ref, got, sel=None, ties=False):
    """Kernel outputs ``got`` equal ``ref`` bit for bit on the rays ``sel`` (default: all).

    ``ties``: allow another triangle at an exact tie. A ray aimed exactly at a vertex or an edge hits every
    triangle there at (nearly) the same t; which of them a traversal reports depends on the order it visits
    them and on how an edge test evaluates exactly 0, so coherent packets may report another one (measured:
    56 to 62 of the 5,669 aimed or camera rays with native 4/8/16-wide packets on AVX-512, 90 with SSE2's
    4-wide ones; never a random ray; never with incoherent packets, nor with a width that Embree runs ray by
    ray). Then the ray must be one of those (not a random one), both answers must lie on an edge of their
    triangle (measured: within 8e-6 in barycentrics), on the same mesh, at the same distance but for float32
    rounding (measured: |dt| <= 3.6e-7 t, 1.6e-6 t with SSE2). Every ray whose triangle is the same is still
    compared bit for bit. (This holds for robust scenes, ``RTC_SCENE_FLAG_ROBUST``, which embreex makes: without
    it rays aimed at a vertex were seen to pass between the triangles there, differently for single rays and
    coherent packets.)
    """
    n = ref[0].shape[0]
    sel = np.ones(n, np.bool_) if sel is None else sel
    other = sel & (got[2] != ref[2])
    if ties:
        assert not other[:N_RANDOM].any(), "a random ray found another triangle"
        assert other.sum() < 0.02 * n
        for r in (ref, got):
            uv = r[4][other]
            assert (np.minimum(uv.min(axis=1), 1 - uv.sum(axis=1)) < 1e-4).all(), "a differing hit off an edge"
        assert np.array_equal(ref[3][other], got[3][other])
        assert np.allclose(ref[1][other], got[1][other], rtol=4e-6, atol=0)
    else:
        assert not other.any(), f"{other.sum()} rays found another triangle"
    same = sel & ~other
    for a, b in zip(ref, got):
        assert np.array_equal(a[same], b[same])


# -- tests --------------------------------------------------------------------------------------------------------
def test_layout_constants():
    fields = (ej.TFAR, ej.MASK, ej.FLAGS, ej.NG_X, ej.U, ej.PRIM_ID, ej.GEOM_ID, ej.INST_ID)
    assert fields == (8, 9, 11, 12, 15, 17, 18, 19)
    assert 4 * ej.RAY_WORDS == 96 and ej.LANE_WORDS == 21
    for w in (4, 8, 16):
        p = ej.packet_alloc(w)
        assert p.ctypes.data % 64 == 0 and ej.packet_width(p) == w
        assert ej.packet_valid(p).ctypes.data % (4 * w) == 0 and not ej.packet_valid(p).any()
    assert ej.aligned_f32(5).ctypes.data % 64 == 0 and ej.ray_alloc().ctypes.data % 64 == 0
    with pytest.raises(ValueError):
        ej.packet_alloc(12)


def test_native_packet_width():
    assert ej.native_packet_width() in (4, 8, 16)


def _own_scene(config, meshes):
    """An Embree device made with ``config`` and a committed robust scene of ``meshes`` on it, through the C API:
    ``(device, scene, arrays to keep alive)``."""
    vp, u, i, sz = ctypes.c_void_p, ctypes.c_uint, ctypes.c_int, ctypes.c_size_t
    c = ej._c
    dev = c("rtcNewDevice", vp, [ctypes.c_char_p])(config)
    scene = c("rtcNewScene", vp, [vp])(dev)
    c("rtcSetSceneFlags", None, [vp, i])(scene, 4)         # RTC_SCENE_FLAG_ROBUST, as embreex's scenes have
    keep = []
    for v, f in meshes:
        v4 = np.zeros((len(v), 4), np.float32)
        v4[:, :3] = v
        f3 = np.zeros((len(f) + 1, 3), np.uint32)     # one row of padding, as Accel does
        f3[:-1] = f
        keep.append((v4, f3))
        geom = c("rtcNewGeometry", vp, [vp, i])(dev, 0)                                 # TRIANGLE
        setbuf = c("rtcSetSharedGeometryBuffer", None, [vp, i, u, i, vp, sz, sz, sz])
        setbuf(geom, 1, 0, 0x9003, v4.ctypes.data, 0, 16, len(v4))                         # VERTEX, FLOAT3
        setbuf(geom, 0, 0, 0x5003, f3.ctypes.data, 0, 12, len(f))                          # INDEX, UINT3
        c("rtcCommitGeometry", None, [vp])(geom)
        c("rtcAttachGeometry", u, [vp, vp])(scene, geom)
        c("rtcReleaseGeometry", None, [vp])(geom)
    c("rtcCommitScene", None, [vp])(scene)
    assert c("rtcGetDeviceError", i, [vp])(dev) == 0
    return dev, scene, keep


@pytest.mark.parametrize("config, native", [(b"isa=sse2", 4), (b"isa=avx2", 8)])
def test_packets_wider_than_native_work(rays, config, native):
    """On a device limited to a smaller ISA, every packet width still gives the single rays' answers."""
    if native > ej.native_packet_width():
        pytest.skip(f"this CPU has no {config.decode()}")
    dev, scene, keep = _own_scene(config, _meshes())
    try:
        assert ej.device_packet_width(dev) == native
        o, d = rays
        n = o.shape[0]
        z, tf = np.zeros(n, np.float32), np.full(n, T_FAR)
        one = trace1(scene, o, d, z, tf)
        assert 0.3 < one[0].mean()
        for width in (4, 8, 16):
            for coherent in (False, True):
                _assert_same(one, trace_packets(scene, o, d, z, tf, width, coherent, np.zeros(n, np.bool_)),
                             ties=coherent)
    finally:
        ej._c("rtcReleaseScene", None, [ctypes.c_void_p])(scene)
        ej._c("rtcReleaseDevice", None, [ctypes.c_void_p])(dev)


def test_scene_handle_needs_the_shared_mode():
    acc = Accel(buffers="copy")
    acc.add_mesh(np.eye(3), [[0, 1, 2]])
    with pytest.raises(RuntimeError, match="no Embree scene handle"):
        ej.scene_handle(acc)


#: a hit distance's tolerance: 2 float32 ulps (Embree's AVX2 and AVX-512 paths round differently: 4.0 against
#: 3.9999998 for the same ray)
_ULPS = 2.0 ** -22


def test_what_a_query_writes(scene):
    """The wheel's Embree has ``RTC_GEOMETRY_INSTANCE_ARRAY``: a hit writes instID[0] and instPrimID[0] (words
    19 and 20 of a lane), nothing further: RTCRayHit is 96 B, RTCRayHit16 1344 B (the sizes allocated). A miss
    writes nothing: tfar, Ng, u, v, primID keep what they held."""
    _, h, _ = scene
    marker = 0x5A5A5A5A
    buf = ej.ray_alloc()
    ints = buf.view(np.int32)
    ints[ej.NG_X:] = marker
    assert not ej.intersect1(h, 0.0, 0.0, 5.0, 0.0, 0.0, 1.0, 0.0, 7.0, buf)[0]
    assert buf[ej.TFAR] == 7.0 and ints[ej.GEOM_ID] == -1 and ints[ej.INST_ID] == -1
    assert (np.delete(ints[ej.NG_X:], [ej.GEOM_ID - ej.NG_X, ej.INST_ID - ej.NG_X]) == marker).all()
    ints[ej.INST_ID:] = marker
    hit, t, _, geom = ej.intersect1(h, 0.0, 0.0, 5.0, 0.0, 0.0, -1.0, 0.0, np.inf, buf)[:4]
    assert hit and geom == 0 and t == pytest.approx(4.0, rel=_ULPS)
    assert ints[ej.INST_ID:].tolist() == [-1, -1, marker, marker, marker]
    p = ej.packet_alloc(16)
    ints = p.view(np.int32)
    ints[16 * ej.INST_ID:16 * ej.LANE_WORDS] = marker
    ej.packet_set_ray(p, 3, 0.0, 0.0, 5.0, 0.0, 0.0, -1.0, 0.0, np.inf)
    ej.intersect_packet(h, p, False)
    hit, t, _, geom = ej.packet_hit(p, 3)[:4]
    assert hit and geom == 0 and t == pytest.approx(4.0, rel=_ULPS)
    lanes = ints[16 * ej.INST_ID:16 * ej.LANE_WORDS].reshape(2, 16)
    assert (lanes[:, 3] == -1).all() and (np.delete(lanes, 3, axis=1) == marker).all()


def test_single_rays_equal_the_binding(scene, rays):
    acc, h, _ = scene
    o, d = rays
    n = o.shape[0]
    ref = acc.intersect(o, d)
    assert 0.3 < ref.hit.mean() < 0.95 and set(np.unique(ref.mesh_id)) == {-1, 0, 1, 2}
    _assert_same(_as_outputs(ref), trace1(h, o, d, np.zeros(n, np.float32), np.full(n, T_FAR)))
    # an unbounded tfar (inf) finds the same hits
    _assert_same(_as_outputs(ref), trace1(h, o, d, np.zeros(n, np.float32), np.full(n, np.inf, np.float32)))


@pytest.mark.parametrize("width", [4, 8, 16])
@pytest.mark.parametrize("coherent", [False, True], ids=["incoherent", "coherent"])
def test_packets_equal_the_binding(scene, rays, width, coherent):
    """Incoherent packets: every ray bit for bit, ties included. Coherent ones: bit for bit but at exact ties
    (see :func:`_assert_same`)."""
    acc, h, _ = scene
    o, d = rays
    n = o.shape[0]
    ref = _as_outputs(acc.intersect(o, d))
    inactive = (np.arange(n) * 7919) % 11 == 3      # about 1 lane in 11, in varying lanes
    got = trace_packets(h, o, d, np.zeros(n, np.float32), np.full(n, T_FAR), width, coherent, inactive)
    _assert_same(ref, got, ~inactive, ties=coherent)
    # masked-off lanes (many of which would hit) are left alone: they read as misses
    assert ref[0][inactive].sum() > 100
    assert not got[0][inactive].any() and (got[3][inactive] == -1).all()


@pytest.mark.parametrize("coherent", [False, True], ids=["incoherent", "coherent"])
def test_packets_honour_tnear(scene, rays, coherent):
    """A ray segment [tnear, tfar] is handled alike by single rays and packets (the binding has tnear = 0)."""
    _, h, _ = scene
    o, d = rays
    n = o.shape[0]
    rng = np.random.default_rng(3)
    tnear = rng.uniform(0, 0.6, n).astype(np.float32)
    tfar = rng.uniform(0.5, 3.0, n).astype(np.float32)
    one = trace1(h, o, d, tnear, tfar)
    hit, t = one[0], one[1]
    assert 0.1 < hit.mean() and (t[hit] >= tnear[hit]).all() and (t[hit] <= tfar[hit]).all()
    _assert_same(one, trace_packets(h, o, d, tnear, tfar, 16, coherent, np.zeros(n, np.bool_)), ties=coherent)


@pytest.mark.parametrize("width", [1, 4, 8, 16])
@pytest.mark.parametrize("coherent", [False, True], ids=["incoherent", "coherent"])
def test_occlusion_equals_the_binding(scene, rays, width, coherent):
    """Bit for bit in every mode (ties do not matter to an any-hit query), tfar exactly at the hit included."""
    acc, h, _ = scene
    o, d = rays
    n = o.shape[0]
    first = acc.intersect(o, d)
    rng = np.random.default_rng(11)
    # tfar on both sides of the first hit, and on it exactly for one ray in ten
    tmax = np.where(first.hit, first.t * rng.uniform(0.5, 1.5, n), rng.uniform(0.1, 10, n)).astype(np.float32)
    at = first.hit & (rng.random(n) < 0.1)
    tmax[at] = first.t[at]
    ref = acc.occluded(o, d, tmax)
    assert 0.2 < ref.mean() < 0.8
    inactive = (np.arange(n) * 7919) % 13 == 5 if width > 1 else np.zeros(n, np.bool_)
    got = occluded_rays(h, o, d, np.zeros(n, np.float32), tmax, width, coherent, inactive)
    assert np.array_equal(got[~inactive], ref[~inactive])
    assert ref[inactive].any() == (width > 1) and not got[inactive].any()


def test_kernels_load_from_the_cache_in_a_new_process(scene, tmp_path):
    """A cached kernel calls Embree by symbol name: a second process (another load address of libembree4)
    loads it from the cache and gets the same answers."""
    (tmp_path / "cached_kernel.py").write_text(textwrap.dedent("""
        import numba, numpy as np
        from pyrt.geometry import embree_jit as ej
        from pyrt.geometry.accel import Accel

        @numba.njit(nogil=True, cache=True)
        def first_hits(scene, n):
            buf = ej.ray_alloc()
            p = ej.packet_alloc(16)
            out = np.zeros((n, 2), np.int64)
            for k in range(n):
                x = -0.9 + 1.8 * (k + 0.37) / n     # inside the base, never on the edge at x = 0
                out[k, 0] = ej.intersect1(scene, x, 0.1, 5.0, 0.0, 0.0, -1.0, 0.0, np.inf, buf)[2]
                ej.packet_set_ray(p, 0, x, 0.1, 5.0, 0.0, 0.0, -1.0, 0.0, np.inf)
                ej.intersect_packet(scene, p, True)
                out[k, 1] = ej.packet_hit(p, 0)[2]
            return out

        acc = Accel()
        acc.add_mesh(np.array([[-2, -2, 0], [2, -2, 0], [0, 2, 0], [0, 0, 1]], float),
                     [[0, 1, 2], [0, 1, 3], [1, 2, 3], [2, 0, 3]])
        r = first_hits(ej.scene_handle(acc), 50)
        print(sum(first_hits.stats.cache_hits.values()), sum(first_hits.stats.cache_misses.values()),
              int(r.sum()), bool((r[:, 0] == r[:, 1]).all()), bool((r[:, 0] >= 0).all()))
    """))
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(tmp_path), *sys.path]))
    runs = [subprocess.run([sys.executable, "-c", "import cached_kernel"], env=env, cwd=tmp_path, text=True,
                           capture_output=True, timeout=120) for _ in range(2)]
    for r in runs:
        assert r.returncode == 0, r.stderr
    first, second = (r.stdout.split() for r in runs)
    assert first[:2] == ["0", "1"] and second[:2] == ["1", "0"]
    assert first[2:] == second[2:] and first[3:] == ["True", "True"]


# -- a benchmark (not a test): python tests/test_embree_jit.py ----------------------------------------------------
def _camera_rays(width=320, height=240, spp=16, order="pixel", seed=0):
    """float32 rays of a pinhole camera, ``spp`` jittered samples a pixel. ``order``: "pixel" puts a pixel's
    samples together (a 16-wide packet = one pixel), "tile" puts 4x4 pixel tiles of one sample index together."""
    rng = np.random.default_rng(seed)
    ty, tx, s, yy, xx = np.meshgrid(np.arange(height // 4), np.arange(width // 4), np.arange(spp), np.arange(4),
                                    np.arange(4), indexing="ij")
    if order == "pixel":
        ty, tx, yy, xx, s = (a.transpose(0, 1, 3, 4, 2) for a in (ty, tx, yy, xx, s))
    px = (4 * tx + xx).ravel() + rng.random(s.size)
    py = (4 * ty + yy).ravel() + rng.random(s.size)
    eye, look, up = np.array([0.0, -4.0, 1.0]), np.zeros(3), np.array([0.0, 0.0, 1.0])
    w = (look - eye) / np.linalg.norm(look - eye)
    u = np.cross(w, up)
    u /= np.linalg.norm(u)
    v = np.cross(u, w)
    half = np.tan(np.radians(25))
    d = (w[None] + ((2 * px / width - 1) * half * width / height)[:, None] * u[None]
         + ((1 - 2 * py / height) * half)[:, None] * v[None])
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    return np.tile(eye, (d.shape[0], 1)).astype(np.float32), d.astype(np.float32)


def _bench():
    import time
    sphere = trimesh.creation.icosphere(subdivisions=5, radius=1.0)
    acc = Accel(threads=1)
    acc.add_mesh(sphere.vertices, sphere.faces)
    acc.add_mesh([[-50, -50, -1], [50, -50, -1], [50, 50, -1], [-50, 50, -1]], [[0, 1, 2], [0, 2, 3]])
    h = ej.scene_handle(acc)
    print(f"{sphere.faces.shape[0] + 2} triangles, native packet width {ej.native_packet_width()}, one thread")

    def rate(fn, n, reps=3):
        fn()                                           # compile / warm up
        best = min(_timed(fn) for _ in range(reps))
        return n / best / 1e6

    def _timed(fn):
        t0 = time.perf_counter()
        fn()
        return time.perf_counter() - t0

    for order in ("pixel", "tile"):
        o, d = _camera_rays(order=order)
        n = o.shape[0]
        z, tf = np.zeros(n, np.float32), np.full(n, T_FAR)
        ref = acc.intersect(o, d)
        print(f"{n} rays ({order} order), {ref.hit.mean():.0%} hit")
        print(f"  embreex run (rtcIntersect1)      {rate(lambda: acc.replay('intersect', o, d, tf), n):6.2f} Mrays/s")
        print(f"  intersect1 loop                  {rate(lambda: trace1(h, o, d, z, tf), n):6.2f} Mrays/s")
        for width in (4, 8, 16):
            for coherent in (True, False):
                r = rate(lambda: trace_packets(h, o, d, z, tf, width, coherent, np.zeros(n, np.bool_)), n)
                print(f"  intersect_packet {width:2d} {'coherent  ' if coherent else 'incoherent'}    {r:6.2f} Mrays/s")


if __name__ == "__main__":
    _bench()
