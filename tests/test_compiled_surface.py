"""pyrt.integrators.compiled_surface: the vectorised surface stage gives bit for bit the scalar
:func:`pyrt.shaders.jit.hit_surface` (the specular tree's form, which the pixel-by-pixel render tests hold to the NumPy
path) on packets of real Embree hits: smooth and flat meshes, misses, back faces, with and without the shading-normal
fallback and the terminator lift."""
import numba
import numpy as np
import pytest

import pyrt
from pyrt.core import unmanaged as U
from pyrt.geometry import embree_jit as E
from pyrt.integrators import compiled_kernel as K
from pyrt.integrators.compiled import CompiledScene
from pyrt.integrators.compiled_layout import (
    LANES, V_D, V_P, V_NG, V_NS, V_NV, V_LIFT, V_MAG, V_MAG_LIFT, V_FRONT, V_COSO, V_T, V_FACE, V_UV, V_SIZE, T_INF)
from pyrt.integrators.compiled_surface import surface_stage
from pyrt.shaders import jit as J

#: the scratch fields the stage writes, in the order :func:`_scalar` returns them
FIELDS = (V_P, V_P + 1, V_P + 2, V_NG, V_NG + 1, V_NG + 2, V_NS, V_NS + 1, V_NS + 2, V_NV, V_NV + 1, V_NV + 2,
          V_LIFT, V_LIFT + 1, V_LIFT + 2, V_MAG, V_MAG_LIFT, V_FRONT, V_COSO, V_T, V_FACE, V_UV, V_UV + 1)


@numba.njit(cache=True)
def _stage_and_scalar(scene, geo_f, geo_i, o, d, fallback, terminator):
    """Per packet of 16 rays from ``o`` along ``d`` (rows): the stage's scratch fields and hit_surface's, and the hit
    flags."""
    n_rays = d.shape[0]
    got = np.zeros((n_rays, len(FIELDS)))
    want = np.zeros((n_rays, len(FIELDS)))
    hits = np.zeros(n_rays, np.bool_)
    owner = E.packet_alloc(LANES)
    pk = U.pointer(owner)
    V = np.zeros(V_SIZE * LANES)
    Vp = U.pointer(V)
    G = K.geometry_pointers(geo_f, geo_i)
    E.packet_prepare(pk, LANES, o[0], o[1], o[2])
    for b in range(0, n_rays, LANES):
        n = min(LANES, n_rays - b)
        for lane in range(n):
            E.packet_set_dir(pk, LANES, lane, d[b + lane, 0], d[b + lane, 1], d[b + lane, 2], T_INF)
            V[V_D * LANES + lane], V[(V_D + 1) * LANES + lane], V[(V_D + 2) * LANES + lane] = d[b + lane]
        E.packet_activate(pk, LANES, n)
        E.packet_query(scene, pk, LANES, True, False)
        surface_stage(G, pk, LANES, Vp, n, fallback, terminator)
        for lane in range(n):
            for k in range(len(FIELDS)):
                got[b + lane, k] = V[FIELDS[k] * LANES + lane]
            geom, prim = E.packet_geom_prim(pk, LANES, lane)
            hit = geom != -1
            hits[b + lane] = hit
            u, v = E.packet_uv(pk, LANES, lane)
            wo = (-d[b + lane, 0], -d[b + lane, 1], -d[b + lane, 2])
            p, ng, ns, nv, lift, mag, mag_lift, front, face, uv = J.hit_surface(
                G, fallback, terminator, geom if hit else 0, prim if hit else 0, u, v, wo)
            vals = np.array((p[0], p[1], p[2], ng[0], ng[1], ng[2], ns[0], ns[1], ns[2], nv[0], nv[1], nv[2],
                    lift[0], lift[1], lift[2], mag, mag_lift, 1.0 if front else 0.0, J.dot(wo, ns),
                    np.float64(E.packet_tfar(pk, LANES, lane)) if hit else np.inf, np.float64(face), uv[0], uv[1]))
            for k in range(len(FIELDS)):
                want[b + lane, k] = vals[k]
    U.keep_alive(owner)
    return got, want, hits


def _scene(fallback):
    cam = pyrt.Camera(position=(0, 1.0, 3.0), target=(0, 0.4, 0), fov=50, width=8, height=8)
    s = pyrt.Scene(cam, shading_normal_fallback=fallback)
    s.add_plane((0, 0, 0), 4.0, pyrt.Lambert(albedo=0.5))
    s.add_sphere((-0.5, 0.5, 0.0), 0.5, pyrt.Lambert(albedo=0.7), subdivisions=2)          # coarse: a strong lift
    s.add_sphere((0.6, 0.4, 0.2), 0.4, pyrt.Mirror(0.9), subdivisions=3, smooth=False)
    s.add_light(pyrt.PointLight((1, 3, 2), intensity=10.0))
    return s


@pytest.mark.parametrize("fallback", [True, False])
@pytest.mark.parametrize("terminator", [True, False])
def test_surface_stage_is_hit_surface_bit_for_bit(fallback, terminator):
    ps = pyrt.PreparedScene(_scene(fallback))
    cs = CompiledScene(ps)
    rng = np.random.default_rng(3)
    o = np.array([0.0, 1.0, 3.0])
    d = rng.normal(size=(4000, 3)) * (0.5, 0.4, 0.5) + (0.0, -0.3, -1.0)
    d[:200] = rng.normal(size=(200, 3))                 # any direction: back faces, grazing hits, misses
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    got, want, hits = _stage_and_scalar(cs.scene, cs.geo_f, cs.geo_i, o, d, fallback, terminator)
    assert 0.3 < hits.mean() < 0.98                     # hits and misses both
    assert np.array_equal(got[hits].view(np.int64), want[hits].view(np.int64))
    # a miss: the hit distance says so; the rest is face 0's and unused
    assert np.all(np.isinf(got[~hits, FIELDS.index(V_T)]))
