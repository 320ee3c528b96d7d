"""Ray differentials and normal maps on the compiled tile kernel (:mod:`pyrt.integrators.compiled_kernel`).

A render whose textures read footprints (trilinear MIP maps, ``opts[O_DIFFS]``) carries pbrt's ray differentials as
the NumPy path does (:meth:`pyrt.core.camera.Camera.generate_rays`, :func:`pyrt.geometry.surface.surface_from_hits`,
:mod:`pyrt.geometry.differentials`, :class:`pyrt.integrators.whitted.Integrator`): the camera rays' offset rays one
scaled pixel to the right and below (:func:`camera_ray_diffs`), at each hit the offsets on the tangent plane, their
barycentric and UV derivatives and the vertex normals' derivatives (:func:`surface_diffs`), through mirror
reflections and refractions (:func:`push_diffs`: the spawned ray's offset rays in its stack row). A packet lane keeps
the differentials of the ray it is shading, and of its hit, in the scratch ``V`` (fields :data:`V_RAY`, :data:`V_DP`);
the specular tree of a lane reuses the lane's fields for each of its rays. Renders without such textures skip all of
it (one test of the option per hit).

:func:`hit_inputs` is what the kernel asks of a hit (a camera hit or one of the specular tree): the albedo
(footprint-filtered) and the shading normal, perturbed by the material's normal map when it has one
(:mod:`pyrt.textures.compiled_normal_map`, ``opts[O_NMAPS]``). The kernel's hooks (:func:`camera_diffs`,
:func:`camera_lane_diffs`, :func:`load_ray`, :func:`push_ray`, :func:`hit_inputs`) test the options inline and call
the work only when a render needs it.
Precision: float64 throughout, as the NumPy path.
"""
from __future__ import annotations

import math

import numba
import numpy as np

from pyrt.integrators import kernel_cache

kernel_cache.use_cache_dir()      # before the decorators below run

from pyrt.integrators.compiled_layout import (  # noqa: E402
    C_FWD, C_K, C_POS, C_RIGHT, C_UP, LANES, O_DIFFS, O_NMAPS, O_SPP, STACK_DIFF, V_D, V_DP, V_RAY, _njit, lane_vec,
    set_lane_vec)
from pyrt.materials import compiled as MC  # noqa: E402
from pyrt.materials import compiled_sampling as CS  # noqa: E402
from pyrt.shaders.jit import bary3, dot, row3  # noqa: E402
from pyrt.textures import compiled as TC  # noqa: E402
from pyrt.textures import compiled_normal_map as NM  # noqa: E402
from pyrt.textures.compiled import texture_rgb  # noqa: E402

#: the entries the kernel calls (:func:`camera_ray_diffs`, :func:`hit_inputs`' work, :func:`push_diffs`,
#: :func:`load_ray_diffs`) are compiled as functions of their own, not inlined into the kernel's loops: inlined into
#: ``trace_stack``, :func:`surface_diffs`' stores to the scratch were seen not to happen (Numba 0.68's IR inliner; the
#: same code inlined into a small loop stored them), and a call with pointers and numbers costs no reference counting
_own = numba.njit(nogil=True, cache=True, error_model="numpy")


@_njit
def _pinhole_dir(cam, sx, sy):
    """The unit direction ``normalize(forward + sx right + sy up)`` of the camera record ``cam``."""
    inv = 1.0 / math.sqrt(1.0 + sx * sx + sy * sy)
    return (inv * (cam[C_FWD] + sx * cam[C_RIGHT] + sy * cam[C_UP]),
            inv * (cam[C_FWD + 1] + sx * cam[C_RIGHT + 1] + sy * cam[C_UP + 1]),
            inv * (cam[C_FWD + 2] + sx * cam[C_RIGHT + 2] + sy * cam[C_UP + 2]))


@_own
def camera_ray_diffs(V, cam, lane, scale):
    """The offset rays of lane ``lane``'s camera ray (direction at :data:`V_D`) into its :data:`V_RAY` fields: from
    the camera's position through the raster point ``scale`` pixels to the right and ``scale`` pixels below
    (:meth:`pyrt.core.camera.Camera.generate_rays`, ``scale = max(1/8, 1/sqrt(spp))``). The raster offsets are
    found from the direction itself (a pinhole: ``sx = d.right / d.forward``, ``sy = d.up / d.forward``), so the
    camera-ray loops stay as they are."""
    d = lane_vec(V, V_D, lane)
    f = d[0] * cam[C_FWD] + d[1] * cam[C_FWD + 1] + d[2] * cam[C_FWD + 2]
    sx = (d[0] * cam[C_RIGHT] + d[1] * cam[C_RIGHT + 1] + d[2] * cam[C_RIGHT + 2]) / f
    sy = (d[0] * cam[C_UP] + d[1] * cam[C_UP + 1] + d[2] * cam[C_UP + 2]) / f
    step = scale * cam[C_K]
    o = (cam[C_POS], cam[C_POS + 1], cam[C_POS + 2])
    set_lane_vec(V, V_RAY, lane, o)
    set_lane_vec(V, V_RAY + 3, lane, _pinhole_dir(cam, sx + step, sy))
    set_lane_vec(V, V_RAY + 6, lane, o)
    set_lane_vec(V, V_RAY + 9, lane, _pinhole_dir(cam, sx, sy - step))


@_njit
def camera_diffs(V, cam, opts, n):
    """With ``opts[O_DIFFS]``: :func:`camera_ray_diffs` of the packet's ``n`` lanes at the fixed-spp scale
    ``max(1/8, 1/sqrt(opts[O_SPP]))`` (:meth:`pyrt.core.camera.Camera.generate_rays`)."""
    if opts[O_DIFFS] != 0:
        scale = max(0.125, 1.0 / math.sqrt(float(opts[O_SPP])))
        for lane in range(n):
            camera_ray_diffs(V, cam, lane, scale)


@_njit
def camera_lane_diffs(V, cam, opts, lane, scale):
    """With ``opts[O_DIFFS]``: :func:`camera_ray_diffs` of lane ``lane`` at ``scale`` (an adaptive pass's pixel)."""
    if opts[O_DIFFS] != 0:
        camera_ray_diffs(V, cam, lane, scale)


@_njit
def load_ray(stack, row, V, lane, diffs):
    """With ``diffs``: :func:`load_ray_diffs`."""
    if diffs:
        load_ray_diffs(stack, row, V, lane)


@_njit
def push_ray(stack, row, V, lane, diffs, p, ns, wo, d, eta):
    """With ``diffs``: :func:`push_diffs`."""
    if diffs:
        push_diffs(stack, row, V, lane, p, ns, wo, d, eta)


@_njit
def _offset_point(o, d, ng, d_plane, p):
    """``q - p`` for the point ``q = o + t d`` of the offset ray on the tangent plane ``ng.x = d_plane`` (zero where
    the ray is parallel to it)."""
    denom = dot(ng, d)
    if not abs(denom) > 1e-12:
        return 0.0, 0.0, 0.0
    t = (d_plane - dot(ng, o)) / denom
    return o[0] + t * d[0] - p[0], o[1] + t * d[1] - p[1], o[2] + t * d[2] - p[2]


@_njit
def surface_diffs(G, V, lane, face, p, ng, front):
    """The differentials at the hit on triangle ``face`` (point ``p``, viewer-side ``ng``) of lane ``lane``'s ray (its
    offset rays at :data:`V_RAY`): dp/dx, dp/dy, dn/dx, dn/dy into :data:`V_DP` and ``(du/dx, dv/dx, du/dy, dv/dy,
    db1/dx, db2/dx, db1/dy, db2/dy)`` returned, the UV footprint and the barycentric derivatives
    (:func:`pyrt.textures.compiled.footprint`'s ``d``; :func:`pyrt.geometry.surface.surface_from_hits`' differential
    group: the offset rays met on the tangent plane, their least-squares barycentric derivatives, the vertex normals'
    differences turned to the viewer's side; dn zero on flat faces)."""
    normals, faces, fsmooth = G[1], G[6], G[9]
    i0, i1, i2 = faces[3 * face], faces[3 * face + 1], faces[3 * face + 2]
    dpdx, dpdy, bx1, bx2, by1, by2, fp = _plane_diffs(G, V, lane, face, p, ng)
    set_lane_vec(V, V_DP, lane, dpdx)
    set_lane_vec(V, V_DP + 3, lane, dpdy)
    dndx = dndy = (0.0, 0.0, 0.0)
    if fsmooth[face] != 0:
        s = 1.0 if front else -1.0
        n0, n1, n2 = row3(normals, i0), row3(normals, i1), row3(normals, i2)
        dn1 = ((n1[0] - n0[0]) * s, (n1[1] - n0[1]) * s, (n1[2] - n0[2]) * s)
        dn2 = ((n2[0] - n0[0]) * s, (n2[1] - n0[1]) * s, (n2[2] - n0[2]) * s)
        dndx = (bx1 * dn1[0] + bx2 * dn2[0], bx1 * dn1[1] + bx2 * dn2[1], bx1 * dn1[2] + bx2 * dn2[2])
        dndy = (by1 * dn1[0] + by2 * dn2[0], by1 * dn1[1] + by2 * dn2[1], by1 * dn1[2] + by2 * dn2[2])
    set_lane_vec(V, V_DP + 6, lane, dndx)
    set_lane_vec(V, V_DP + 9, lane, dndy)
    return fp + (bx1, bx2, by1, by2)


@_njit
def uv_footprint(G, V, lane, face, p, ng):
    """The UV footprint and barycentric derivatives at the point ``p`` of triangle ``face`` (normal ``ng``, either
    side) of lane ``lane``'s ray, as :func:`surface_diffs` returns them, without storing the hit's differentials (an
    alpha mask's or blend surface's opacity: :mod:`pyrt.integrators.compiled_coverage`)."""
    _, _, bx1, bx2, by1, by2, fp = _plane_diffs(G, V, lane, face, p, ng)
    return fp + (bx1, bx2, by1, by2)


@_njit
def hit_footprint(G, face, bu, bv, d):
    """The footprint record (:mod:`pyrt.textures.compiled`) of the hit at barycentrics ``(bu, bv)`` (Embree's ``u``,
    ``v``) of triangle ``face`` with the differentials ``d`` (:func:`surface_diffs`; :data:`pyrt.textures.compiled.
    NO_DIFFS` without them); the barycentrics as :func:`pyrt.shaders.jit.hit_surface` forms them."""
    faces = G[6]
    b1, b2 = np.float64(bu), np.float64(bv)
    return TC.footprint(d, faces[3 * face], faces[3 * face + 1], faces[3 * face + 2], 1.0 - b1 - b2, b1, b2)


@_njit
def _plane_diffs(G, V, lane, face, p, ng):
    """``(dp/dx, dp/dy, db1/dx, db2/dx, db1/dy, db2/dy, footprint)`` at the point ``p`` of triangle ``face``: lane
    ``lane``'s offset rays met on the tangent plane, their least-squares barycentric derivatives and the UV
    footprint."""
    verts, uvs, faces = G[0], G[2], G[6]
    i0, i1, i2 = faces[3 * face], faces[3 * face + 1], faces[3 * face + 2]
    v0, v1, v2 = row3(verts, i0), row3(verts, i1), row3(verts, i2)
    e1 = (v1[0] - v0[0], v1[1] - v0[1], v1[2] - v0[2])
    e2 = (v2[0] - v0[0], v2[1] - v0[1], v2[2] - v0[2])
    d_plane = dot(ng, p)
    dpdx = _offset_point(lane_vec(V, V_RAY, lane), lane_vec(V, V_RAY + 3, lane), ng, d_plane, p)
    dpdy = _offset_point(lane_vec(V, V_RAY + 6, lane), lane_vec(V, V_RAY + 9, lane), ng, d_plane, p)
    a11, a12, a22 = dot(e1, e1), dot(e1, e2), dot(e2, e2)
    det = a11 * a22 - a12 * a12
    inv = 1.0 / det if abs(det) > 1e-300 else 0.0
    r1, r2 = dot(e1, dpdx), dot(e2, dpdx)
    bx1, bx2 = (a22 * r1 - a12 * r2) * inv, (a11 * r2 - a12 * r1) * inv
    r1, r2 = dot(e1, dpdy), dot(e2, dpdy)
    by1, by2 = (a22 * r1 - a12 * r2) * inv, (a11 * r2 - a12 * r1) * inv
    du1, dv1 = uvs[2 * i1] - uvs[2 * i0], uvs[2 * i1 + 1] - uvs[2 * i0 + 1]
    du2, dv2 = uvs[2 * i2] - uvs[2 * i0], uvs[2 * i2 + 1] - uvs[2 * i0 + 1]
    fp = (bx1 * du1 + bx2 * du2, bx1 * dv1 + bx2 * dv2, by1 * du1 + by2 * du2, by1 * dv1 + by2 * dv2)
    return dpdx, dpdy, bx1, bx2, by1, by2, fp


@_njit
def face_uv_tangents(G, face, ng, uvs, o):
    """``(dpdu, dpdv)`` of the triangle ``face`` in the UV set whose per-vertex table starts at ``uvs[o]`` (set 0:
    ``G[2]`` from 0; set ``k``: the texture table's, :mod:`pyrt.textures.compiled`)
    (:func:`pyrt.textures.compiled_normal_map.uv_tangents`)."""
    verts, faces = G[0], G[6]
    i0, i1, i2 = o + 2 * faces[3 * face], o + 2 * faces[3 * face + 1], o + 2 * faces[3 * face + 2]
    j0, j1, j2 = faces[3 * face], faces[3 * face + 1], faces[3 * face + 2]
    v0, v1, v2 = row3(verts, j0), row3(verts, j1), row3(verts, j2)
    e1 = (v1[0] - v0[0], v1[1] - v0[1], v1[2] - v0[2])
    e2 = (v2[0] - v0[0], v2[1] - v0[1], v2[2] - v0[2])
    du1 = (uvs[i1] - uvs[i0], uvs[i1 + 1] - uvs[i0 + 1])
    du2 = (uvs[i2] - uvs[i0], uvs[i2 + 1] - uvs[i0 + 1])
    return NM.uv_tangents(e1, e2, du1, du2, ng)


@_njit
def hit_inputs(G, V, lane, opts, face, bu, bv, p, ng, ns, wo, front, uv, mtag, mats_par, m, tex_tag, tex_par):
    """What the kernel reads of a hit of material ``m`` at barycentrics ``(bu, bv)`` (Embree's ``u``, ``v``) beyond
    :func:`pyrt.shaders.jit.hit_surface`: ``(albedo, ns, emission)``, the hit's inputs
    (:func:`pyrt.materials.compiled.albedo_at`) at its footprint (with ``diffs``: :func:`surface_diffs` of lane
    ``lane``'s ray, else none) and its vertex colour (:func:`vertex_color`), the shading normal, perturbed by the
    material's normal map (with ``nmaps``; :data:`pyrt.materials.compiled.NORMAL_MAP`) the NumPy path's way
    (:func:`pyrt.textures.normal_map.perturb_normal`: the mesh's vertex tangents where it has them), and the emitted
    radiance (:func:`pyrt.materials.compiled.emission_at`). Without footprints, normal maps or vertex colours,
    inline (no call)."""
    diffs, nmaps = opts[O_DIFFS] != 0, opts[O_NMAPS] != 0
    if diffs or nmaps or mats_par[m * MC.RECORD + MC.VERTEX_COLOR] != 0.0:
        albedo, n, e = extended_inputs(G, V, lane, diffs, nmaps, opts[O_NMAPS] == 2, face, bu, bv, p, ng, ns, wo,
                                       front, uv, mtag, mats_par, m, tex_tag, tex_par)
    else:
        fp = hit_footprint(G, face, bu, bv, TC.NO_DIFFS)
        albedo, n = MC.albedo_at(mtag, mats_par, m, tex_tag, tex_par, uv[0], uv[1], fp, MC.WHITE), ns
        e = MC.emission_at(mtag, mats_par, m, front, tex_tag, tex_par, uv[0], uv[1], fp)
    return albedo, n, e


@_own
def extended_inputs(G, V, lane, diffs, nmaps, vtan, face, bu, bv, p, ng, ns, wo, front, uv, mtag, mats_par, m,
                    tex_tag, tex_par):
    """:func:`hit_inputs` with footprints, normal maps (``vtan``: some mesh has vertex tangents) or vertex colours (a
    function of its own)."""
    return _inputs(G, V, lane, diffs, nmaps, vtan, face, bu, bv, p, ng, ns, wo, front, uv, mtag, mats_par, m,
                   tex_tag, tex_par)


@_njit
def _inputs(G, V, lane, diffs, nmaps, vtan, face, bu, bv, p, ng, ns, wo, front, uv, mtag, mats_par, m, tex_tag,
            tex_par):
    d = TC.NO_DIFFS
    if diffs:
        d = surface_diffs(G, V, lane, face, p, ng, front)
    fp = hit_footprint(G, face, bu, bv, d)
    vc = vertex_color(G, mats_par, m, face, bu, bv)
    albedo = MC.albedo_at(mtag, mats_par, m, tex_tag, tex_par, uv[0], uv[1], fp, vc)
    if nmaps:
        n0 = ns
        b = m * MC.RECORD + MC.NORMAL_MAP
        t = int(mats_par[b]) - 1
        if t >= 0:
            ns = _mapped(G, vtan, face, bu, bv, ng, wo, front, uv, fp, mats_par, b, t, n0, tex_tag, tex_par)
        bc = m * MC.RECORD + MC.COAT + 7
        tc = int(mats_par[bc]) - 1
        if MC.is_coated(mtag, mats_par, m) and (t >= 0 or tc >= 0):
            # the coat's normal: the normal before the base's map, perturbed by the coat's own map
            # (pyrt.Clearcoat._coat_frame), in the local frame of the shading normal
            nc = n0 if tc < 0 else _mapped(G, vtan, face, bu, bv, ng, wo, front, uv, fp, mats_par, bc, tc, n0, tex_tag,
                                           tex_par)
            fs, ft = CS.coordinate_frame(ns[0], ns[1], ns[2])
            x, y, z = CS.to_local(nc, fs, ft, ns)
            inv = 1.0 / max(math.sqrt(x * x + y * y + z * z), 1e-300)
            albedo = MC.with_coat_normal(albedo, (x * inv, y * inv, z * inv))
    if mtag == MC.UNLIT:        # its colour times the vertex colours, as its albedo
        return albedo, ns, (albedo[0], albedo[1], albedo[2])
    return albedo, ns, MC.emission_at(mtag, mats_par, m, front, tex_tag, tex_par, uv[0], uv[1], fp)


@_own
def _mapped(G, vtan, face, bu, bv, ng, wo, front, uv, fp, mats_par, b, t, ns, tex_tag, tex_par):
    """``ns`` perturbed by the normal map whose fields are at ``mats_par[b:]`` (:data:`pyrt.materials.compiled.
    NORMAL_MAP`'s layout), texture row ``t`` (:func:`pyrt.textures.compiled_normal_map.perturb`), in the frame of
    the mesh's vertex tangents where it has them, else of the triangle's tangents in the map's UV set."""
    rgb = texture_rgb(tex_tag, tex_par, t, uv[0], uv[1], fp)
    has, dpdu, dpdv = vertex_tangents(G, face, bu, bv) if vtan else (False, ns, ns)
    if not has:
        o = int(tex_par[t * TC.RECORD + TC.UV_SET])
        dpdu, dpdv = face_uv_tangents(G, face, ng, G[2] if o == 0 else tex_par, o)
    return NM.perturb(rgb, mats_par[b + 1], mats_par[b + 2] != 0.0, mats_par[b + 3] != 0.0, ns, ng, wo, front, dpdu,
                      dpdv)


@_njit
def vertex_color(G, mats_par, m, face, bu, bv):
    """The vertex colour material ``m`` reads at barycentrics ``(bu, bv)`` of triangle ``face``: the colours packed
    with the geometry (``G[10]``) interpolated as :meth:`pyrt.io.assets.VertexColorTexture.evaluate` does (``b0 c0 +
    b1 c1 + b2 c2``, ``b0 = 1 - b1 - b2`` in float64); :data:`pyrt.materials.compiled.WHITE` for a material that
    reads none (:data:`pyrt.materials.compiled.VERTEX_COLOR`)."""
    if mats_par[m * MC.RECORD + MC.VERTEX_COLOR] == 0.0:
        return MC.WHITE
    faces, vcol = G[6], G[10]
    b1, b2 = np.float64(bu), np.float64(bv)
    return bary3(1.0 - b1 - b2, b1, b2, row3(vcol, faces[3 * face]), row3(vcol, faces[3 * face + 1]),
                 row3(vcol, faces[3 * face + 2]))


@_njit
def vertex_tangents(G, face, bu, bv):
    """``(has, t, b)``: the vertex tangent frames (``G[11]``, ``[t, w (n x t)]`` per vertex) interpolated at
    barycentrics ``(bu, bv)`` of triangle ``face`` as :func:`pyrt.geometry.surface.surface_from_hits`' ``vtangent``
    (``b0 f0 + b1 f1 + b2 f2``), and whether the tangent is non-zero (the mesh has them:
    :meth:`pyrt.geometry.SurfaceBatch.shading_tangents`)."""
    faces, fr = G[6], G[11]
    i0, i1, i2 = faces[3 * face], faces[3 * face + 1], faces[3 * face + 2]
    b1, b2 = np.float64(bu), np.float64(bv)
    b0 = 1.0 - b1 - b2
    t = bary3(b0, b1, b2, row3(fr, 2 * i0), row3(fr, 2 * i1), row3(fr, 2 * i2))
    b = bary3(b0, b1, b2, row3(fr, 2 * i0 + 1), row3(fr, 2 * i1 + 1), row3(fr, 2 * i2 + 1))
    return t[0] != 0.0 or t[1] != 0.0 or t[2] != 0.0, t, b


@_own
def push_diffs(stack, row, V, lane, p, ns, wo, d, eta):
    """The offset rays of the ray spawned in direction ``d`` (unit) from the hit at ``p`` (shading normal ``ns``,
    ``wo``) of lane ``lane``'s ray into words :data:`STACK_DIFF` on of its stack row ``row``: a mirror reflection
    (``eta`` 0, :func:`pyrt.geometry.differentials.reflect_differentials`) or a refraction with ``eta = eta_t /
    eta_i`` (:func:`pyrt.geometry.differentials.refract_differentials`), from the hit's differentials at
    :data:`V_DP` and the incoming ray's at :data:`V_RAY`."""
    cos_o = dot(wo, ns)
    if eta != 0.0:
        cos_t = -dot(d, ns)
        mu = cos_o / eta - cos_t
        safe_ct = cos_t if abs(cos_t) > 1e-12 else 1e-12
        k_mu = 1.0 / eta - cos_o / (eta * eta * safe_ct)
    for axis in range(2):
        dp = lane_vec(V, V_DP + 3 * axis, lane)
        dn = lane_vec(V, V_DP + 6 + 3 * axis, lane)
        d_in = lane_vec(V, V_RAY + 3 + 6 * axis, lane)
        dwo = (-d_in[0] - wo[0], -d_in[1] - wo[1], -d_in[2] - wo[2])
        dcos = dot(dwo, ns) + dot(wo, dn)
        if eta == 0.0:
            dw = (2.0 * (ns[0] * dcos + dn[0] * cos_o) - dwo[0], 2.0 * (ns[1] * dcos + dn[1] * cos_o) - dwo[1],
                  2.0 * (ns[2] * dcos + dn[2] * cos_o) - dwo[2])
        else:
            dmu = k_mu * dcos
            dw = (-dwo[0] / eta + mu * dn[0] + dmu * ns[0], -dwo[1] / eta + mu * dn[1] + dmu * ns[1],
                  -dwo[2] / eta + mu * dn[2] + dmu * ns[2])
        k = row + STACK_DIFF + 6 * axis
        stack[k], stack[k + 1], stack[k + 2] = p[0] + dp[0], p[1] + dp[1], p[2] + dp[2]
        stack[k + 3], stack[k + 4], stack[k + 5] = d[0] + dw[0], d[1] + dw[1], d[2] + dw[2]


@_own
def load_ray_diffs(stack, row, V, lane):
    """The offset rays of the ray in stack row ``row`` into lane ``lane``'s :data:`V_RAY` fields."""
    for i in range(12):
        V[(V_RAY + i) * LANES + lane] = stack[row + STACK_DIFF + i]


kernel_cache.restore()
