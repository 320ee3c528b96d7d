"""Ray differentials and normal maps on the compiled path (:mod:`pyrt.integrators.compiled_diffs`,
:mod:`pyrt.textures.compiled_normal_map`): each scalar function held to its NumPy twin on random hits, grazing ones
included, to 1e-6 relative in float64."""
import numba
import numpy as np
import pytest

import pyrt
from pyrt.core import unmanaged as U
from pyrt.geometry.differentials import refract_differentials, reflect_differentials
from pyrt.geometry.surface import surface_from_hits
from pyrt.integrators import compiled
from pyrt.integrators import compiled_diffs as D
from pyrt.integrators.compiled_layout import LANES, STACK_DIFF, V_DP, V_RAY, V_SIZE
from pyrt.shaders.vec import dot, normalize, refract
from pyrt.textures import compiled_normal_map as NM
from pyrt.textures.normal_map import perturb_normal


def _scene(spp=1):
    """A smooth sphere (vertex normals: dn/dx) over a UV-mapped plane seen at grazing angles, a flat box."""
    cam = pyrt.Camera(position=(0.3, 0.25, 3.0), target=(0, 0.1, -4), fov=70, width=48, height=32, spp=spp)
    s = pyrt.Scene(cam)
    img = np.random.default_rng(2).random((32, 32, 3)).astype(np.float32)
    s.add_plane((0, 0, 0), 30.0, pyrt.Lambert(albedo=pyrt.ImageTexture(img, filter="trilinear", scale=(40, 40))))
    s.add_sphere((0.2, 0.5, 0), 0.5, pyrt.Lambert(albedo=0.5), subdivisions=2)
    s.add_box((-0.9, 0.2, -0.5), (0.4, 0.4, 0.4), pyrt.Lambert(albedo=0.5))
    return s


def _hits(seed=3, spp=1):
    """The NumPy path's surface (with differentials) at the hits of the camera's jittered rays."""
    s = _scene(spp)
    ps = pyrt.PreparedScene(s)
    cam = s.camera
    rays = cam.generate_rays(0, cam.width * cam.height, np.random.default_rng(seed), differentials=True)
    idx, hits = ps.accel.intersect_hits(rays.origins, rays.directions)
    diffs = tuple(np.ascontiguousarray(x[idx]) for x in rays.differentials)
    surf = surface_from_hits(ps.geo, hits, rays.origins[idx], rays.directions[idx], diffs)
    return ps, surf, diffs


@numba.njit(cache=False)
def _surface_diffs(geo_f, geo_i, face, p, ng, front, rays, mats, tex, mat, uv):
    G = (U.pointer(geo_f[0]), U.pointer(geo_f[1]), U.pointer(geo_f[2]), U.pointer(geo_f[3]), U.pointer(geo_f[4]),
         U.pointer(geo_f[5]), U.pointer(geo_i[0]), U.pointer(geo_i[1]), U.pointer(geo_i[2]), U.pointer(geo_i[3]),
         U.pointer(geo_f[6]), U.pointer(geo_f[7]))
    Va = np.zeros(V_SIZE * LANES)
    V = U.pointer(Va)
    mt, mp, tt, tp = U.pointer(mats[0]), U.pointer(mats[1]), U.pointer(tex[0]), U.pointer(tex[1])
    n = face.shape[0]
    fp = np.zeros((n, 4))
    dp = np.zeros((n, 12))
    tan = np.zeros((n, 6))
    albedo = np.zeros((n, 3))
    for i in range(n):
        lane = i % LANES
        for k in range(12):
            V[(V_RAY + k) * LANES + lane] = rays[i, k]
        pi, ngi = (p[i, 0], p[i, 1], p[i, 2]), (ng[i, 0], ng[i, 1], ng[i, 2])
        r = D.surface_diffs(G, V, lane, face[i], pi, ngi, front[i])
        for k in range(4):
            fp[i, k] = r[k]
        for k in range(12):
            dp[i, k] = V[(V_DP + k) * LANES + lane]
            V[(V_DP + k) * LANES + lane] = 0.0
        # the function the kernel calls: the same differentials (stored), the albedo at their footprint
        a, _, _ = D.extended_inputs(G, V, lane, True, False, False, face[i], 0.0, 0.0, pi, ngi, ngi, ngi, front[i],
                                    (uv[i, 0], uv[i, 1]), mt[mat[i]], mp, mat[i], tt, tp)
        albedo[i, 0], albedo[i, 1], albedo[i, 2] = a[0], a[1], a[2]
        for k in range(12):
            if V[(V_DP + k) * LANES + lane] != dp[i, k]:
                albedo[i, 0] = np.nan
        a, b = D.face_uv_tangents(G, face[i], (ng[i, 0], ng[i, 1], ng[i, 2]), G[2], 0)
        for k in range(3):
            tan[i, k], tan[i, 3 + k] = a[k], b[k]
    keep = Va[0]
    return fp, dp, tan, albedo, keep


def _close(got, want, rtol=1e-6):
    """``got`` equals ``want`` to ``rtol`` relative to each row's scale (a component near zero of a long vector is
    held to the vector's length)."""
    assert got.shape == want.shape
    err = np.abs(got - want) / np.maximum(np.abs(want).max(axis=1, keepdims=True), 1e-300)
    assert np.all(err <= rtol), f"{np.count_nonzero(err > rtol)} of {err.size} differ, worst {np.nanmax(err)}"


def test_surface_differentials_are_the_numpy_ones():
    """dp/dx, dp/dy, dn/dx, dn/dy and the UV footprint at every hit (smooth sphere, flat box, a plane from near to
    grazing), and the triangles' UV tangents."""
    ps, surf, diffs = _hits()
    cs = compiled.CompiledScene(ps)
    rays = np.concatenate(diffs, axis=1)
    fp, dp, tan, albedo, _ = _surface_diffs(cs.geo_f, cs.geo_i, surf.face, surf.p, surf.ng, surf.front, rays,
                                            cs.materials, cs.textures, surf.material_id, surf.uv)
    stretch = np.linalg.norm(surf.dpdy, axis=1) / np.linalg.norm(surf.dpdx, axis=1)
    assert np.any(surf.dndx != 0) and stretch.max() > 10.0          # smooth faces; grazing hits (long footprints)
    _close(fp[:, :2], surf.duvdx)
    _close(fp[:, 2:], surf.duvdy)
    for k, name in enumerate(("dpdx", "dpdy", "dndx", "dndy")):
        want = getattr(surf, name)
        rows = np.abs(want).max(axis=1) > 0
        _close(dp[rows, 3 * k:3 * k + 3], want[rows])
        assert np.all(dp[~rows, 3 * k:3 * k + 3] == 0)
    _close(tan[:, :3], surf.dpdu)
    _close(tan[:, 3:], surf.dpdv)
    plane = surf.material_id == 0
    tex = ps.scene.materials[0].albedo_value
    assert plane.sum() > 300
    _close(albedo[plane], tex.lookup(surf.uv[plane], surf.duvdx[plane], surf.duvdy[plane]))


@numba.njit(cache=False)
def _camera_diffs(cam, d, scale):
    V = np.zeros(V_SIZE * LANES)
    out = np.zeros((d.shape[0], 12))
    for i in range(d.shape[0]):
        for c in range(3):
            V[c * LANES] = d[i, c]           # V_D is field 0
        D.camera_ray_diffs(V, cam, 0, scale)
        for k in range(12):
            out[i, k] = V[(V_RAY + k) * LANES]
    return out


@pytest.mark.parametrize("spp", [1, 4, 100])
def test_camera_differentials_are_the_cameras(spp):
    """The offset rays recovered from the camera ray's direction: :meth:`Camera.generate_rays`' (the scale
    ``max(1/8, 1/sqrt(spp))``), over the whole image of a wide, non-square camera."""
    cam = pyrt.Camera(position=(1, 2, 3), target=(0, 0.5, -1), up=(0.1, 1, 0), fov=100, width=37, height=23, spp=spp)
    rays = cam.generate_rays(0, cam.width * cam.height, np.random.default_rng(1), differentials=True)
    got = _camera_diffs(compiled.camera_record(cam), rays.directions, max(0.125, 1 / np.sqrt(spp)))
    for k, want in enumerate(rays.differentials):
        _close(got[:, 3 * k:3 * k + 3], want, 1e-12)
    assert not np.allclose(rays.differentials[1], rays.directions)


@numba.njit(cache=False)
def _push(p, ns, wo, d, eta, rays, dps):
    V = np.zeros(V_SIZE * LANES)
    stack = np.zeros(22)
    out = np.zeros((p.shape[0], 12))
    for i in range(p.shape[0]):
        for k in range(12):
            V[(V_RAY + k) * LANES + 3] = rays[i, k]
            V[(V_DP + k) * LANES + 3] = dps[i, k]
        D.push_diffs(stack, 0, V, 3, (p[i, 0], p[i, 1], p[i, 2]), (ns[i, 0], ns[i, 1], ns[i, 2]),
                     (wo[i, 0], wo[i, 1], wo[i, 2]), (d[i, 0], d[i, 1], d[i, 2]), eta[i])
        for k in range(12):
            out[i, k] = stack[STACK_DIFF + k]
        D.load_ray_diffs(stack, 0, V, 5)
        for k in range(12):
            if V[(V_RAY + k) * LANES + 5] != out[i, k]:
                out[i, 0] = np.nan
    return out


def test_reflection_and_refraction_differentials_are_the_numpy_ones():
    """The spawned rays' offset rays (mirror reflection; refraction into and out of glass, ior 1.5, grazing included)
    from the hits' differentials: :func:`reflect_differentials`, :func:`refract_differentials`."""
    _ps, surf, diffs = _hits(seed=7)
    rays = np.concatenate(diffs, axis=1)
    dps = np.concatenate([surf.dpdx, surf.dpdy, surf.dndx, surf.dndy], axis=1)
    ns, wo = surf.ns, surf.wo
    wr = normalize(2.0 * dot(wo, ns)[:, None] * ns - wo)
    got = _push(surf.p, ns, wo, wr, np.zeros(len(wo)), rays, dps)
    for k, want in enumerate(reflect_differentials(surf, diffs[1], diffs[3], wr)):
        _close(got[:, 3 * k:3 * k + 3], want)
    for eta_in in (1.5, 1 / 1.5):
        eta = np.where(surf.front, eta_in, 1.0 / eta_in)
        wt, tir = refract(wo, ns, eta)
        keep = np.flatnonzero(~tir)
        sub = surf.subset(keep)
        wt = normalize(wt[keep])
        got = _push(sub.p, sub.ns, sub.wo, wt, eta[keep], rays[keep], dps[keep])
        for k, want in enumerate(refract_differentials(sub, diffs[1][keep], diffs[3][keep], wt, eta[keep])):
            _close(got[:, 3 * k:3 * k + 3], want)


@numba.njit(cache=False)
def _perturb(rgb, strength, flip, bend, ns, ng, wo, front, dpdu, dpdv):
    out = np.zeros(ns.shape)
    for i in range(ns.shape[0]):
        v = lambda a: (a[i, 0], a[i, 1], a[i, 2])       # noqa: E731
        out[i] = NM.perturb(v(rgb), strength, flip, bend, v(ns), v(ng), v(wo), front[i], v(dpdu), v(dpdv))
    return out


@pytest.mark.parametrize("strength, flip, reflection", [(1.0, False, "bend"), (3.0, True, "bend"),
                                                        (1.0, False, "drop"), (0.0, False, "bend")])
def test_normal_map_perturbation_is_perturb_normal(strength, flip, reflection, rng):
    """A random normal map (steep normals, flat texels, texels below the tangent plane) on front and back faces at
    every angle: :func:`pyrt.textures.normal_map.perturb_normal`'s normals (bent and not, flipped green, strengths)."""
    _ps, surf, _ = _hits(seed=11)
    img = rng.random((16, 16, 3)).astype(np.float32)
    img[..., 2] = 0.6 + 0.4 * img[..., 2]                # mostly z > 0: steep to mild normals
    img[::3, ::3] = (0.5, 0.5, 1.0)
    img[1::5, ::2, 2] = 0.3                          # z < 0: kept unperturbed
    nm = pyrt.NormalMap(img, strength=strength, flip_green=flip, reflection=reflection)
    n = surf.n_hits
    front = surf.front.copy()
    front[::3] = ~front[::3]                         # back faces (the mirrored perturbation)
    surf.front = front
    want = perturb_normal(surf, nm)
    rgb = nm.lookup(surf.uv, surf.duvdx, surf.duvdy)
    got = _perturb(rgb, strength, flip, reflection == "bend", surf.ns, surf.ng, surf.wo, front, surf.dpdu, surf.dpdv)
    _close(got, want)
    changed = np.abs(want - surf.ns).max(axis=1) > 1e-3
    assert changed.mean() > 0.5 if strength > 0 else not changed.any()
    assert n > 500
