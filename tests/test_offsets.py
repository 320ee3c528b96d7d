"""Ray-origin offsets (pyrt.geometry.offsets): each strategy's formula, side, float32 behaviour, self-intersection.

The scene-level behaviour (acne, leaks, terminator, lights on surfaces) is tested by tests/test_acne.py.
"""
import math

import numpy as np
import pytest
import trimesh

import pyrt
from pyrt.geometry import offsets
from pyrt.geometry.accel import Accel
from pyrt.geometry.mesh_data import MeshData
from pyrt.geometry.surface import GeometryTable, SurfaceBatch, surface_from_hits

EPS32 = 2.0 ** -24


# ------------------------------------------------------------------------------------------------ helpers
def _table(vertices, faces, normals=None):
    v = np.asarray(vertices, dtype=np.float32).astype(np.float64)   # what Embree sees
    m = MeshData(vertices=v, faces=np.asarray(faces, dtype=np.int64), normals=normals, uv=None, vertices_object=v,
                 material_id=0, smooth=normals is not None, name="m")
    return GeometryTable([m])


def _hits_on(geo, rng, n, camera, spread):
    """Surface batch of ``n`` rays from ``camera`` toward random points of the mesh (all hitting)."""
    acc = Accel(threads=1)
    for m in geo.meshes:
        acc.add_mesh(m.vertices, m.faces)
    acc.commit()
    tri = geo.faces[rng.integers(0, geo.faces.shape[0], n)]
    b = rng.dirichlet([1.0, 1.0, 1.0], n)
    target = np.einsum("ij,ijk->ik", b, geo.vertices[tri])
    o = np.broadcast_to(camera, (n, 3)).astype(np.float32).astype(np.float64)
    d = target - o
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    h = acc.intersect(o, d)
    keep = np.flatnonzero(h.hit)
    from pyrt.integrators.whitted import _subset_hits
    surf = surface_from_hits(geo, _subset_hits(h, keep), o[keep], d[keep])
    return acc, surf


def _leaving_dirs(surf, rng, grazing):
    """Random unit directions on the ng side; a share of them within ``grazing`` rad of the plane."""
    n = surf.n_hits
    t, s = surf.frame_s, surf.frame_t
    phi = rng.uniform(0, 2 * np.pi, n)
    elev = np.where(rng.random(n) < 0.5, rng.uniform(1e-6, grazing, n), rng.uniform(grazing, np.pi / 2, n))
    # build from the geometric normal (not the shading frame)
    a = np.where(np.abs(surf.ng[:, :1]) > 0.9, [[0.0, 1.0, 0.0]], [[1.0, 0.0, 0.0]])
    e1 = np.cross(surf.ng, a)
    e1 /= np.linalg.norm(e1, axis=1, keepdims=True)
    e2 = np.cross(surf.ng, e1)
    del t, s
    w = (np.cos(elev)[:, None] * (np.cos(phi)[:, None] * e1 + np.sin(phi)[:, None] * e2)
         + np.sin(elev)[:, None] * surf.ng)
    return w / np.linalg.norm(w, axis=1, keepdims=True)


def _self_hits(acc, surf, strategy, w):
    o = offsets.get_strategy(strategy)(surf, w)
    h = acc.intersect(o, w)
    return np.mean(h.hit & (h.prim_id == surf.prim_id))


def _plane(scale, shift):
    v = np.array([[-1, 0, 1], [1, 0, 1], [1, 0, -1], [-1, 0, -1.0]]) * 2 * scale + shift
    return _table(v, [[0, 1, 2], [0, 2, 3]])


def _tilted_sphere(scale, shift, subdiv=3):
    m = trimesh.creation.icosphere(subdivisions=subdiv, radius=scale)
    return _table(m.vertices + shift, m.faces, normals=np.asarray(m.vertex_normals))


# ------------------------------------------------------------------------------------------------ formulas
def test_default_is_robust_and_names_resolve():
    assert offsets.DEFAULT == "robust"
    st = offsets.get_strategy(None)
    assert st is offsets.STRATEGIES["robust"]
    assert st.terminator and st.tmax == "robust" and st.origin is offsets.local_bound
    for name, s in offsets.STRATEGIES.items():
        assert offsets.get_strategy(name) is s and s.name == name


def test_unknown_strategy_error_names_the_value_and_choices():
    with pytest.raises(ValueError, match=r"unknown offset strategy 'nope'.*robust"):
        offsets.get_strategy("nope")
    with pytest.raises(ValueError, match="tmax must be one of"):
        offsets.Strategy("x", offsets.none, tmax="far")
    with pytest.raises(ValueError, match="origin must be callable"):
        offsets.Strategy("x", 3)


def test_plain_callable_is_wrapped_with_relative_tmax():
    def mine(surf, w):
        return surf.p + 1e-3 * surf.ng
    st = offsets.get_strategy(mine)
    assert isinstance(st, offsets.Strategy) and st.name == "mine" and st.tmax == "relative" and not st.terminator
    surf = _flat_surf(np.array([[0.0, 0.0, 0.0]]))
    o, tmax = st.shadow(surf, np.array([[0.0, 1.0, 0.0]]), np.array([2.0]))
    np.testing.assert_allclose(o, [[0, 1e-3, 0]])
    np.testing.assert_allclose(tmax, (2.0 - 1e-3) * offsets.SHADOW_TMAX_SCALE)


def _flat_surf(p, ng=(0.0, 1.0, 0.0), scale=1.0):
    n = p.shape[0]
    ng = np.broadcast_to(np.asarray(ng, float), (n, 3)).copy()
    tv = p[:, None, :] + scale * np.array([[-1.0, 0, -1], [1, 0, -1], [0, 0, 1]])[None]
    bary = np.full((n, 3), 1.0 / 3)
    return SurfaceBatch(p=p, ng=ng, ns=ng, front=np.ones(n, bool), wo=ng, bary=bary,
                        p_error=np.einsum("ij,ijk->ik", bary, np.abs(tv)), tri_v=tv, tri_n=np.zeros_like(tv),
                        mesh_id=np.zeros(n, int), prim_id=np.zeros(n, int), face=np.zeros(n, int),
                        material_id=np.zeros(n, int), t=np.ones(n))


def test_fixed_epsilons_follow_their_formulas():
    p = np.array([[1.0, 2.0, 3.0], [0.0, 0.0, 0.0]])
    surf = _flat_surf(p)
    up = np.array([[0.0, 1.0, 0.0], [0.6, 0.8, 0.0]])
    down = -up
    np.testing.assert_allclose(offsets.ray_epsilon(surf, up), p + 1e-4 * up)
    np.testing.assert_allclose(offsets.normal_epsilon(surf, up), p + [0, 1e-4, 0])
    np.testing.assert_allclose(offsets.normal_epsilon(surf, down), p - [0, 1e-4, 0])
    eps = (1 + np.array([3.0, 0.0])) * 1500 * EPS32
    np.testing.assert_allclose(offsets.scaled_epsilon(surf, up), p + eps[:, None] * [0, 1, 0])
    np.testing.assert_array_equal(offsets.none(surf, up), p)


def test_wachter_binder_matches_the_published_bit_arithmetic():
    # RTG ch. 6: of_i = int(256 n); p_i = int_as_float(float_as_int(p) +- of_i); |p| < 1/32 -> p + n / 65536
    p = np.array([[1.0, 0.01, -2.0]])
    n = np.array([[0.5, 0.0, -0.75]])
    got = offsets._wachter_binder(p, n, offsets.WB_ORIGIN, offsets.WB_FLOAT_SCALE)
    bits = np.float32([1.0, 0.01, -2.0]).view(np.int32)
    x = np.int32(bits[0] + 128).view(np.float32)            # 256 * 0.5 = 128 ulps up
    # p < 0 subtracts of_i (= int(256 * -0.75) = -192): 192 more ulps of magnitude, i.e. along n_z < 0
    z = np.int32(bits[2] - (-192)).view(np.float32)
    assert got[0, 0] == np.float64(x)
    assert got[0, 1] == np.float64(np.float32(0.01) + np.float32(0.0))      # n_y = 0: floor branch adds 0
    assert got[0, 2] == np.float64(z) and got[0, 2] < -2.0


def test_wachter_binder_scale_aware_floor():
    # triangle magnitude 1: identical to the published constants; at 1e-4 the floor shrinks with the scene
    p = np.array([[0.001, 0.0, 0.002]])
    s1 = _flat_surf(p, scale=1.0)
    s1.tri_v = np.array([[[-1.0, 0, -1], [1, 0, -1], [0, 0, 1]]])
    up = np.array([[0.0, 1.0, 0.0]])
    np.testing.assert_array_equal(offsets.wachter_binder(s1, up), offsets.wachter_binder_rtg(s1, up))
    assert offsets.wachter_binder_rtg(s1, up)[0, 1] == pytest.approx(1 / 65536, rel=1e-6)
    tiny = _flat_surf(p * 1e-4, scale=1e-4)
    y_rtg = offsets.wachter_binder_rtg(tiny, up)[0, 1]
    y_new = offsets.wachter_binder(tiny, up)[0, 1]
    assert y_rtg == pytest.approx(1.5259e-5, rel=1e-3)      # bigger than a 1e-4 scene's features
    assert 0 < y_new < 1e-8


def test_error_bound_and_local_bound_formulas():
    p = np.array([[1000.0, 0.0, -1000.0]])
    surf = _flat_surf(p, scale=1.0)
    up = np.array([[0.0, 1.0, 0.0]])
    eb = offsets.error_bound(surf, up)
    d_eb = offsets._gamma(7) * surf.p_error[0, 1] + 16 * EPS32 * surf.p_error.max()
    assert eb[0, 1] >= d_eb and eb[0, 1] <= d_eb * (1 + 1e-6) + np.spacing(np.float32(d_eb))
    lb = offsets.local_bound(surf, up)
    d_lb = 16 * EPS32 * 1.0                                       # L = max |v_i - p| = 1 (scale 1 triangle)
    assert d_lb <= lb[0, 1] < 2 * d_lb
    # the local bound does not grow with the distance from the origin, pbrt's does
    assert eb[0, 1] > 500 * lb[0, 1]


def test_round_away_never_moves_toward_the_surface():
    rng = np.random.default_rng(1)
    p = rng.normal(size=(2000, 3)) * 10.0 ** rng.uniform(-4, 6, (2000, 1))
    n = rng.normal(size=(2000, 3))
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    o = offsets._round_away(p, n)
    assert np.all(o == o.astype(np.float32))
    assert np.all(np.einsum("ij,ij->i", o - p, n) >= 0)


@pytest.mark.parametrize("name", ["none", "ray_epsilon", "normal_epsilon", "scaled_epsilon", "wachter_binder_rtg",
                                  "wachter_binder", "error_bound", "local_bound", "robust"])
def test_strategies_return_float64_and_do_not_mutate(name):
    p = np.array([[1.0, 2.0, 3.0], [0.5, 0.0, -1.0]])
    surf = _flat_surf(p)
    before = surf.p.copy()
    st = offsets.get_strategy(name)
    w = np.array([[0.0, 1.0, 0.0], [0.0, -1.0, 0.0]])
    o = st(surf, w)
    assert o.dtype == np.float64 and o.shape == (2, 3)
    o2, tmax = st.shadow(surf, w, np.array([1.0, np.inf]))
    # shadow origins may be handed over as the exact float32 rays Embree traces
    assert o2.dtype in (np.float64, np.float32) and tmax.dtype == np.float64
    assert tmax[1] == np.inf and 0 < tmax[0] <= 1.0 + 1e-12
    np.testing.assert_array_equal(surf.p, before)
    # a punctual light's position given as the common end point gives the same tmax as p + w dist
    end = p[0] + w[0] * 2.5
    s1 = _flat_surf(p[:1])
    _, t_pt = st.shadow(s1, w[:1], np.array([2.5]))
    _, t_end = st.shadow(_flat_surf(p[:1]), w[:1], np.array([2.5]), end)
    np.testing.assert_allclose(t_end, t_pt, rtol=1e-12)


# ------------------------------------------------------------------------------------------------ Embree
@pytest.mark.parametrize("scale,shift", [(1e-4, 0.0), (1.0, 0.0), (1e4, 0.0), (1.0, 1e4), (1e2, 1e6), (1e-4, 1.0)])
@pytest.mark.parametrize("mesh", ["plane", "sphere"])
def test_spawned_rays_never_rehit_their_triangle(scale, shift, mesh, rng):
    """local_bound (the default's origins) and error_bound: 0 self-hits, grazing to normal directions;
    'none' self-hits often (the test can see self-intersection)."""
    sh = np.array([shift, shift, shift])
    geo = _plane(scale, sh) if mesh == "plane" else _tilted_sphere(scale, sh)
    acc, surf = _hits_on(geo, rng, 4000, sh + scale * np.array([0.3, 3.0, 2.0]), scale)
    try:
        w = _leaving_dirs(surf, rng, grazing=1e-3)
        assert _self_hits(acc, surf, "local_bound", w) == 0
        assert _self_hits(acc, surf, "error_bound", w) == 0
        # through the surface (refraction): the origin goes to the other side, and must not hit either
        assert _self_hits(acc, surf, "local_bound", -w) == 0
        assert _self_hits(acc, surf, "none", w) > 0.05
    finally:
        acc.close()


def test_fixed_epsilon_self_hits_far_from_the_origin(rng):
    # 1e-4 is below the float32 spacing at 1e4 (~0.001): the classic epsilon cannot work there
    sh = np.full(3, 1e4)
    geo = _plane(1.0, sh)
    acc, surf = _hits_on(geo, rng, 2000, sh + np.array([0.3, 3.0, 2.0]), 1.0)
    try:
        w = _leaving_dirs(surf, rng, grazing=1e-3)
        assert _self_hits(acc, surf, "normal_epsilon", w) > 0.2
        assert _self_hits(acc, surf, "ray_epsilon", w) > 0.2
    finally:
        acc.close()


# ------------------------------------------------------------------------------------------------ terminator
def _sphere_surf(subdiv=1, flat=False):
    m = trimesh.creation.icosphere(subdivisions=subdiv, radius=1.0)
    tri = m.faces
    tv = m.vertices[tri]
    tn = np.zeros_like(tv) if flat else np.asarray(m.vertex_normals)[tri]
    rng = np.random.default_rng(3)
    b = rng.dirichlet([1.0, 1.0, 1.0], tri.shape[0])
    p = np.einsum("ij,ijk->ik", b, tv)
    ng = m.face_normals
    return SurfaceBatch(p=p, ng=ng, ns=ng, front=np.ones(len(p), bool), wo=ng, bary=b, tri_v=tv, tri_n=tn,
                        p_error=np.einsum("ij,ijk->ik", b, np.abs(tv)), mesh_id=np.zeros(len(p), int),
                        prim_id=np.arange(len(p)), face=np.arange(len(p)), material_id=np.zeros(len(p), int),
                        t=np.ones(len(p)))


def test_terminator_lift_lies_between_facet_and_sphere():
    surf = _sphere_surf()
    q = offsets.terminator_point(surf)
    r_p = np.linalg.norm(surf.p, axis=1)
    r_q = np.linalg.norm(q, axis=1)
    assert np.all(r_q >= r_p - 1e-12)                 # lifted outward (convex)
    # The implied surface blends the vertices' tangent planes, which lie outside the sphere: the lift can
    # overshoot the sphere, but by less than the facet lies below it (a known property of the method,
    # documented in pyrt.geometry.offsets.terminator_point).
    sag = 1.0 - r_p.min()
    assert np.all(r_q <= 1.0 + sag)
    assert np.mean(r_q - r_p) > 0.3 * np.mean(1.0 - r_p)   # and a real part of the way
    # Hanika's formula = barycentric blend of the projections onto the vertices' tangent planes (all convex here)
    proj = surf.p[:, None, :] - np.einsum("ijk,ijk->ij", surf.p[:, None, :] - surf.tri_v, surf.tri_n)[..., None] \
        * surf.tri_n
    np.testing.assert_allclose(q, np.einsum("ij,ijk->ik", surf.bary, proj), atol=1e-12)


def test_terminator_lift_is_zero_on_flat_faces_at_vertices_and_in_concave_regions():
    flat = _sphere_surf(flat=True)
    np.testing.assert_array_equal(offsets.terminator_point(flat), flat.p)
    s = _sphere_surf()
    s.bary = np.tile([1.0, 0.0, 0.0], (s.n_hits, 1))
    s.p = s.tri_v[:, 0].copy()
    np.testing.assert_allclose(offsets.terminator_point(s), s.p, atol=1e-15)
    concave = _sphere_surf()
    concave.tri_n = -concave.tri_n                    # normals of the inside of the sphere: concave
    np.testing.assert_array_equal(offsets.terminator_point(concave), concave.p)


def test_light_side_lets_the_terminator_zone_through_only_on_smooth_faces():
    rep = np.repeat(np.arange(80), 100)                # 100 random light directions per facet
    smooth = _sphere_surf().subset(rep)
    flat = _sphere_surf(flat=True).subset(rep)
    rng = np.random.default_rng(5)
    wi = rng.normal(size=(smooth.n_hits, 3))
    wi /= np.linalg.norm(wi, axis=1, keepdims=True)
    cos_g = np.einsum("ij,ij->i", wi, smooth.ng)
    n_i = np.einsum("ij,ijk->ik", smooth.bary, smooth.tri_n)
    zone = (cos_g <= 0) & (np.einsum("ij,ij->i", wi, n_i) > 0)
    assert zone.sum() > 50
    np.testing.assert_array_equal(flat.light_side(wi), cos_g > 0)
    np.testing.assert_array_equal(smooth.light_side(wi), (cos_g > 0) | zone)


def test_terminator_zone_shadow_ray_escapes_a_lowpoly_sphere():
    """A smooth-shaded 80-triangle sphere lit where facets face away but the vertex normals face the light:
    without the lift the shadow ray hits the sphere (the staircase terminator), with it most escape."""
    m = trimesh.creation.icosphere(subdivisions=1, radius=1.0)
    geo = _table(m.vertices, m.faces, normals=np.asarray(m.vertex_normals))
    rng = np.random.default_rng(7)
    acc, surf = _hits_on(geo, rng, 4000, np.array([0.0, 0.0, 5.0]), 1.0)
    try:
        light = np.array([1.0, 0.3, 0.2]) / math.sqrt(1.13)   # not along a symmetry plane of the icosphere
        wi = np.broadcast_to(light, (surf.n_hits, 3)).copy()
        radial = surf.p / np.linalg.norm(surf.p, axis=1, keepdims=True)
        zone = (np.einsum("ij,ij->i", wi, surf.ng) < 0) & (radial @ light > 0.05)
        assert zone.sum() > 30
        sub = surf.subset(np.flatnonzero(zone))
        dist = np.full(sub.n_hits, np.inf)
        w = wi[zone]
        o_plain, t_plain = offsets.STRATEGIES["local_bound"].shadow(sub, w, dist)
        o_fix, t_fix = offsets.STRATEGIES["robust"].shadow(sub, w, dist)
        blocked_plain = acc.occluded(o_plain, w, t_plain).mean()
        blocked_fix = acc.occluded(o_fix, w, t_fix).mean()
        assert blocked_plain == 1.0
        assert blocked_fix == 0.0                     # measured: every one escapes
    finally:
        acc.close()


# ------------------------------------------------------------------------------------------------ shadow tmax
def test_robust_tmax_margin():
    o = np.array([[0.0, 0.0, 0.0], [1e6, 1e6, 1e6], [0.0, 0.0, 0.0]])
    end = o + np.array([[10.0, 0, 0], [0, 0, 1.0], [1e-30, 0, 0]])
    wi = np.array([[1.0, 0, 0], [0, 0, 1.0], [1.0, 0, 0]])
    t = offsets.robust_tmax(o, wi, end)
    assert t[0] == pytest.approx(10.0 * (1 - 1e-4))                         # relative margin near the origin
    assert t[1] == pytest.approx(0.5)                                       # 16 * 2^-24 * 1e6 ~ 0.95: capped
    assert 0 < t[2] <= 1e-30
    assert np.all(t < np.einsum("ij,ij->i", end - o, wi))


@pytest.mark.parametrize("shift", [0.0, 1e2, 1e4, 3.3e5])
def test_light_mounted_on_a_surface_is_not_hidden_by_it(shift, rng):
    """A point light exactly on a quad (in float64); the quad's float32 vertices put it up to half an ulp
    in front of the light. Robust tmax: no shadow ray hits the quad; exact tmax: many do."""
    z = shift + 0.1   # not representable in float32: the quad moves up to half an ulp
    v = np.array([[-1, -1, z], [1, -1, z], [1, 1, z], [-1, 1, z]]) + [shift, shift, 0]
    acc = Accel(threads=1)
    acc.add_mesh(v, [[0, 1, 2], [0, 2, 3]])
    acc.commit()
    try:
        light = np.array([shift, shift, z])
        p = light + np.column_stack([rng.uniform(-3, 3, 3000), rng.uniform(-3, 3, 3000), rng.uniform(0.5, 3, 3000)])
        d = light - p
        dist = np.linalg.norm(d, axis=1)
        wi = d / dist[:, None]
        surf = _flat_surf(p, ng=(0.0, 0.0, -1.0))
        o, tmax = offsets.STRATEGIES["robust"].shadow(surf, wi, dist)
        assert not np.any(acc.occluded(o, wi, tmax))
        o, tmax = offsets.STRATEGIES["none"].shadow(surf, wi, dist)
        if np.float32(z) != z and np.float32(z) > z:      # the float32 quad is in front of the light
            assert acc.occluded(o, wi, tmax).mean() > 0.5
    finally:
        acc.close()


# ------------------------------------------------------------------------------------------------ render API
def test_render_offset_api_accepts_names_callables_and_strategies():
    cam = pyrt.Camera(position=(0, 2, 2), target=(0, 0, 0), width=16, height=12, jitter=False)
    scene = pyrt.Scene(cam)
    scene.add_plane((0, 0, 0), 40.0, pyrt.Lambert(albedo=0.5))
    scene.add_light(pyrt.DirectionalLight((0.3, -1, 0.2), irradiance=1.0))
    calls = []

    def mine(surf, w):
        calls.append(surf.n_hits)
        return offsets.local_bound(surf, w)

    ref = pyrt.render(scene)
    assert np.all(ref > 0)
    np.testing.assert_array_equal(pyrt.render(scene, offset=mine), ref)
    assert sum(calls) == 16 * 12
    np.testing.assert_array_equal(pyrt.render(scene, offset=offsets.STRATEGIES["error_bound"]), ref)
    acne = pyrt.render(scene, offset="none")
    assert np.mean(acne[..., 0] == 0) > 0.2          # self-shadowing: black pixels on a lit plane
    with pytest.raises(ValueError, match="unknown offset strategy"):
        pyrt.render(scene, offset="epsilon")

