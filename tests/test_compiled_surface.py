"""pyrt.integrators.compiled_surface: the vectorised pass over a packet's lanes on one triangle gives bit for bit the
scalar :func:`pyrt.shaders.jit.hit_surface` (the kernel's other packets and the specular tree's single rays) on real
Embree hits: smooth and flat triangles, front and back faces, with and without the shading-normal fallback and the
terminator lift; :func:`packet_faces` counts a packet's triangles and misses. (Packets of several triangles, through
the kernel: tests/test_compiled_render.py.)"""
import numba
import numpy as np
import pytest

import pyrt
from pyrt.core import unmanaged as U
from pyrt.geometry import embree_jit as E
from pyrt.integrators.compiled import CompiledScene
from pyrt.integrators.compiled_layout import (
    LANES, V_D, V_P, V_NG, V_NS, V_NV, V_LIFT, V_MAG, V_MAG_LIFT, V_FRONT, V_MAT, V_A, V_L, V_COSO, V_T, V_SIZE,
    T_INF, geometry_pointers)
from pyrt.integrators.compiled_surface import MAX_FACES, packet_faces, uniform_surface
from pyrt.integrators import kernel_cache
from pyrt.shaders import jit as J

# this module's kernels are cached with the render kernels, keyed on their sources' hash: Numba's own cache key is
# this file alone and would keep the kernel code it compiled in after an edit of the kernel's modules
kernel_cache.use_cache_dir()

#: the scratch fields the stage writes, in the order :func:`_packets` compares them
FIELDS = (V_P, V_P + 1, V_P + 2, V_NG, V_NG + 1, V_NG + 2, V_NS, V_NS + 1, V_NS + 2, V_NV, V_NV + 1, V_NV + 2,
          V_LIFT, V_LIFT + 1, V_LIFT + 2, V_MAG, V_MAG_LIFT, V_FRONT, V_COSO, V_T, V_MAT, V_A, V_A + 1, V_A + 2,
          V_L, V_L + 1, V_L + 2)
ALBEDO, LE_FRONT, LE_BACK, MAT = (0.25, 0.5, 0.75), (1.0, 2.0, 3.0), (4.0, 5.0, 6.0), 7


@numba.njit(cache=True)
def _packets(scene, geo_f, geo_i, o, d, fallback, terminator, masked):
    """Packets of 16 rays from ``o`` along ``d`` (rows): per ray the stage's fields and hit_surface's (nan where the
    packet was not on one face), and each packet's uniform_face."""
    n_rays = d.shape[0]
    got = np.full((n_rays, len(FIELDS)), np.nan)
    want = np.full((n_rays, len(FIELDS)), np.nan)
    faces = np.full(n_rays // LANES, -1)
    owner = E.packet_alloc(LANES)
    pk = U.pointer(owner)
    V = np.zeros(V_SIZE * LANES)
    Vp = U.pointer(V)
    G = geometry_pointers(geo_f, geo_i)
    E.packet_prepare(pk, LANES, o[0], o[1], o[2])
    for b in range(0, n_rays, LANES):
        for lane in range(LANES):
            E.packet_set_dir(pk, LANES, lane, d[b + lane, 0], d[b + lane, 1], d[b + lane, 2], T_INF)
            V[V_D * LANES + lane], V[(V_D + 1) * LANES + lane], V[(V_D + 2) * LANES + lane] = d[b + lane]
        E.packet_activate(pk, LANES, LANES)
        E.packet_query(scene, pk, LANES, True, False)
        k, geoms, prims, misses = packet_faces(pk, LANES, LANES)
        if k != 1 or misses > 0:
            continue
        face = geo_i[1][geoms[0], 0] + prims[0]
        faces[b // LANES] = face
        # masked (as for a packet of several faces: every lane is on it, so every lane is written) or not (the
        # stage's loop of plain stores)
        uniform_surface(G, face, geoms[0], prims[0], masked, pk, LANES, Vp, LANES, fallback, terminator, MAT, ALBEDO,
                        LE_FRONT, LE_BACK)
        for lane in range(LANES):
            for k in range(len(FIELDS)):
                got[b + lane, k] = V[FIELDS[k] * LANES + lane]
            geom, prim = E.packet_geom_prim(pk, LANES, lane)
            u, v = E.packet_uv(pk, LANES, lane)
            wo = (-d[b + lane, 0], -d[b + lane, 1], -d[b + lane, 2])
            p, ng, ns, nv, lift, mag, mag_lift, front, f, uv = J.hit_surface(G, fallback, terminator, geom, prim, u,
                                                                            v, wo)
            le = LE_FRONT if front else LE_BACK
            want[b + lane] = np.array((p[0], p[1], p[2], ng[0], ng[1], ng[2], ns[0], ns[1], ns[2], nv[0], nv[1],
                                       nv[2], lift[0] if terminator else p[0], lift[1] if terminator else p[1],
                                       lift[2] if terminator else p[2], mag, mag_lift, 1.0 if front else 0.0,
                                       J.dot(wo, ns), np.float64(E.packet_tfar(pk, LANES, lane)), MAT, ALBEDO[0],
                                       ALBEDO[1], ALBEDO[2], le[0], le[1], le[2]))
            if f != face:                       # not the face uniform_face named: the comparison fails
                want[b + lane, 0] = np.inf
    U.keep_alive(owner)
    return got, want, faces


def _scene(fallback):
    cam = pyrt.Camera(position=(0, 1.0, 3.0), target=(0, 0.4, 0), fov=50, width=8, height=8)
    s = pyrt.Scene(cam, shading_normal_fallback=fallback)
    s.add_plane((0, 0, 0), 4.0, pyrt.Lambert(albedo=0.5))
    s.add_sphere((-0.5, 0.5, 0.0), 0.5, pyrt.Lambert(albedo=0.7), subdivisions=2)          # coarse: a strong lift
    s.add_sphere((0.6, 0.4, 0.2), 0.4, pyrt.Mirror(0.9), subdivisions=2, smooth=False)
    return s


def _rays_at_faces(ps, o, rng, n_packets):
    """Per packet, 16 directions from ``o`` to random points inside one random triangle (some seen from behind:
    the sphere's far side is hidden, so such a packet hits another face and is not uniform)."""
    geo = ps.geo
    faces = rng.integers(0, geo.faces.shape[0], n_packets)
    b = rng.dirichlet((1.0, 1.0, 1.0), size=(n_packets, LANES)) * 0.98 + 0.02 / 3.0
    tri = geo.vertices[geo.faces[faces]]                       # (packets, 3 corners, 3)
    pts = np.einsum("pkc,pcx->pkx", b, tri).reshape(-1, 3)
    d = pts - o
    return d / np.linalg.norm(d, axis=1, keepdims=True)


@pytest.mark.parametrize("masked", [True, False])
@pytest.mark.parametrize("fallback", [True, False])
@pytest.mark.parametrize("terminator", [True, False])
def test_uniform_surface_is_hit_surface_bit_for_bit(fallback, terminator, masked):
    ps = pyrt.PreparedScene(_scene(fallback))
    cs = CompiledScene(ps)
    rng = np.random.default_rng(5)
    o = np.array([0.3, 1.1, 2.5])
    d = _rays_at_faces(ps, o, rng, 400)
    got, want, faces = _packets(cs.scene, cs.geo_f, cs.geo_i, o, d, fallback, terminator, masked)
    uniform = faces >= 0
    assert 0.2 < uniform.mean() < 0.95                  # packets on one face, and packets that are not
    rows = np.repeat(uniform, LANES)
    assert np.array_equal(got[rows].view(np.int64), want[rows].view(np.int64))


@numba.njit(cache=True)
def _faces_of(scene, o, d):
    """packet_faces of one packet of 16 rays (rows of ``d``) from ``o``."""
    owner = E.packet_alloc(LANES)
    pk = U.pointer(owner)
    E.packet_prepare(pk, LANES, o[0], o[1], o[2])
    for lane in range(LANES):
        E.packet_set_dir(pk, LANES, lane, d[lane, 0], d[lane, 1], d[lane, 2], T_INF)
    E.packet_activate(pk, LANES, LANES)
    E.packet_query(scene, pk, LANES, True, False)
    r = packet_faces(pk, LANES, LANES)
    U.keep_alive(owner)
    return r


def test_packet_faces_counts_triangles_and_misses():
    ps = pyrt.PreparedScene(_scene(True))
    cs = CompiledScene(ps)
    o = np.array([0.0, 1.0, 3.0])
    up = np.tile([0.0, 1.0, 0.0], (LANES, 1))                 # all miss
    assert packet_faces_of(cs, o, up)[::3] == (0, LANES)
    one = np.tile([0.0, -0.3, -1.0], (LANES, 1))
    one /= np.linalg.norm(one, axis=1, keepdims=True)
    one[-1] = (0.0, 1.0, 0.0)                                 # one lane misses
    k, geoms, prims, misses = packet_faces_of(cs, o, one)
    assert (k, misses) == (1, 1) and geoms[1:] == (-1, -1)
    pts = np.column_stack([np.linspace(-0.9, -0.1, LANES), np.full(LANES, 0.5), np.full(LANES, 0.3)])
    fan = pts - o                                           # across the coarse sphere: more triangles than MAX_FACES
    fan /= np.linalg.norm(fan, axis=1, keepdims=True)
    assert packet_faces_of(cs, o, fan)[0] == MAX_FACES + 1


kernel_cache.restore()


def packet_faces_of(cs, o, d):
    k, geoms, prims, misses = _faces_of(cs.scene, o, d)
    return int(k), tuple(int(g) for g in geoms), tuple(int(p) for p in prims), int(misses)
