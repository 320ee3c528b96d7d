"""Emissive scene triangles as a light source: :class:`EmissiveMeshLight` (next-event estimation on emitters).

A mesh whose material emits (glTF ``emissiveFactor`` x ``KHR_materials_emissive_strength`` x
``emissiveTexture``, OBJ ``Ke``, :class:`pyrt.Lambert` ``emission``, an :class:`AreaEmitter` mesh) is seen by
camera rays and reached by BSDF-sampled rays whatever the lights are. This light also lets every hit that
receives direct light (Lambertian ones too) *sample* those triangles with shadow rays, as pbrt-v4's
``DiffuseAreaLight`` / ``TriangleLight`` with a power light sampler does (one light per triangle there; one
vectorised light over all of them here).

Sampling
--------
- A triangle ``j`` is chosen from a discrete CDF (float64) with ``pmf_j`` proportional to ``area_j x b_j``, the
  emission bound ``b_j``: the mean over the RGB channels of the material's own :meth:`Material.emission`
  evaluated at four fixed points of the triangle (its centroid and ``(2/3, 1/6, 1/6)`` with its permutations),
  seen from the front. It is exact for a constant emission (factor x strength) and an estimate of the
  texture's mean over the triangle for a textured one. Triangles whose four values are all 0 are not part of
  the light (``pdf = 0`` there: what they emit is left to BSDF rays with weight 1, as without this light).
  That is ``selection="power"`` (the default); ``selection="oriented"`` first chooses a cluster of triangles per
  shading point (power over squared distance, none behind a one-sided planar cluster) and then a triangle
  inside it by the same power (:mod:`pyrt.lights.mesh_clusters`).
- A point ``y`` uniform on the triangle (``b0 = 1 - sqrt(u0)``, ``b1 = u1 sqrt(u0)``, ``u0`` the first random
  number re-used after the discrete choice), its density in solid angle from a shading point ``p``:
  ``pdf = pmf_j / area_j * r^2 / |cos theta_l|``, ``r = |y - p|``, ``cos theta_l = n_j . wi``.
- The radiance ``L_e(y, -wi)`` is evaluated **exactly** at ``y``: a :class:`pyrt.geometry.SurfaceBatch` is built
  for (triangle, barycentrics) by :func:`pyrt.geometry.surface.surface_from_hits` (the scene's own surface
  reconstruction: UVs and every UV set, texture transforms, vertex colours) with ``wo`` toward ``p``, and the
  material's :meth:`emission` is called on it. Sidedness is the material's: :class:`AreaEmitter` emits from its
  front only unless ``two_sided``; a material whose back faces are culled (glTF ``doubleSided`` false,
  :attr:`Material.culls_back_faces`) emits only from its front, as camera rays see it; alpha ``mask`` and
  ``blend`` scale it by the coverage at full texture resolution (a ray sees it filtered at its footprint).
- ``E = L_e |cos theta_l| area_j / (pmf_j r^2)`` (W/m^2), the sample's ``pdf`` carried on the
  :class:`LightSample` for MIS.

A BSDF-sampled ray that hits one of these triangles needs the same density: the integrator asks
:meth:`EmissiveMeshLight.pdf_hit` with the hit's mesh, triangle, distance and cosine (no extra ray);
:meth:`pdf_li` (a direction only) finds every emitter triangle the ray crosses with Embree (closest-hit queries of
a scene of the light's own triangles, re-traced past each hit), for the
contract tests and small emitters. Build it with :meth:`pyrt.Scene.add_emissive_lights` once the meshes are in
the scene (meshes added later are not part of it).
"""
from __future__ import annotations

from collections.abc import Iterable
import math
import numbers

import numpy as np

from pyrt.core.checks import Fixed
from pyrt.geometry.accel import Accel, Hits
from pyrt.geometry.mesh_data import MeshData
from pyrt.geometry.surface import GeometryTable, surface_from_hits
from pyrt.shaders.vec import cross, dot, take_rows

from pyrt.lights import compiled as LC
from pyrt.lights import compiled_mesh as CM
from pyrt.lights.base import LIGHTS, Light, LightError, LightSample
from pyrt.lights.area import AreaEmitter
from pyrt.materials import Material
from pyrt.materials import compiled as MC
from pyrt.lights.mesh_clusters import ClusterChoice

#: barycentric (b1, b2) of the four points per triangle at which the emission bound is evaluated
_PROBES = np.array([[1 / 3, 1 / 3], [1 / 6, 1 / 6], [2 / 3, 1 / 6], [1 / 6, 2 / 3]])
#: triangles per block when the bound is evaluated (bounded memory on big emitters)
_BLOCK = 1 << 15
#: where a glTF record (:mod:`pyrt.materials.gltf_record`) keeps its emission slot (a texture row, -1: a constant)
_GLTF_EMISSION = 10


def constant_emission(material):
    """True when the compiled kernel reads ``material``'s emission as one constant over its surfaces: an opaque
    material whose compiled record (:meth:`Material.compiled_record`) is Lambert's, Blinn-Phong's, an
    :class:`AreaEmitter`'s or a glTF record with an untextured emission slot (what :meth:`EmissiveMeshLight.
    compiled_record` can pack: a radiance per triangle and side)."""
    if material.alpha_mode != "opaque":
        return False
    packed = material.compiled_record(lambda texture: 0)
    if packed is None:
        return False
    tag, rec = packed[0], packed[1]
    return tag in (MC.LAMBERT, MC.BLINN_PHONG, MC.EMITTER) or (tag == MC.GLTF and rec[_GLTF_EMISSION] < 0)


def _emission(materials, ctx):
    """Emitted radiance (N, 3) toward ``ctx.wo`` at the hits of ``ctx``, per material, with its sidedness and
    coverage (module docstring)."""
    L = np.zeros((ctx.n_hits, 3))
    mids = ctx.material_id
    for k in np.unique(mids):
        sel = np.flatnonzero(mids == k)
        sub = ctx.subset(sel)
        mat = materials[int(k)]
        Le = np.array(mat.emission(sub), dtype=np.float64).reshape(sel.size, 3)
        if mat.culls_back_faces:
            Le *= sub.front[:, None]
        if mat.alpha_mode != "opaque":
            Le *= mat.seen_fraction(sub)[:, None]
        L[sel] = Le
    return L


@LIGHTS.register("emissive_mesh")
class EmissiveMeshLight(Light):
    """The emissive triangles of a scene's meshes as one light (module docstring).

    Parameters
    ----------
    meshes : list of pyrt.geometry.MeshData
        The scene's meshes (``scene.meshes``); the light keeps references to them.
    materials : list of Material
        The scene's materials (``scene.materials``), indexed by ``MeshData.material_id``.
    mesh_ids : sequence of int, optional
        The meshes that emit light (default: every mesh whose material declares ``emits``).
    n_samples : int
        Shadow rays per hit (stratified), each toward one sampled triangle point.
    selection : {"power", "oriented"}
        How a triangle is chosen: by power wherever the shading point is (default), or first a cluster of
        triangles by its power, distance and side at the shading point (:mod:`pyrt.lights.mesh_clusters`).
    name : str, optional
    """

    delta = False
    scene_emitter = True
    selection = Fixed("the triangle choice (the clusters of 'oriented') was built for it")
    pmf = Fixed("it derives from the meshes' emission at construction")
    area_pdf = Fixed("it derives from pmf")
    power = Fixed("it derives from the meshes' emission at construction")

    @classmethod
    def example(cls):
        """A 1 x 0.5 quad at height 2 facing down, uniform radiance 5 (an :class:`AreaEmitter`)."""
        v = np.array([[-0.5, 2.0, -0.25], [0.5, 2.0, -0.25], [0.5, 2.0, 0.25], [-0.5, 2.0, 0.25]])
        f = np.array([[0, 1, 2], [0, 2, 3]])        # winding normal -y
        mesh = MeshData(vertices=v, faces=f, normals=None, uv=None, vertices_object=v, material_id=0,
                        smooth=False, name="quad")
        return cls([mesh], [AreaEmitter(5.0)])

    def __init__(self, meshes, materials, *, mesh_ids=None, n_samples=1, selection="power", name=None):
        self.name = name
        owner = f"EmissiveMeshLight({name or ''})"
        if selection not in ("power", "oriented"):
            raise LightError(f"{owner}: selection must be 'power' or 'oriented', got {selection!r}")
        #: how a triangle is chosen ("power" or "oriented", see the class docstring)
        self.selection = selection
        if not isinstance(n_samples, numbers.Integral) or isinstance(n_samples, bool) or n_samples < 1:
            raise LightError(f"{owner}: n_samples must be a positive integer, got {n_samples!r}")
        self.n_samples = int(n_samples)
        meshes, materials = _scene_lists(owner, meshes, materials)
        if mesh_ids is None:
            mesh_ids = [i for i, m in enumerate(meshes) if materials[m.material_id].emits]
        elif isinstance(mesh_ids, (str, bytes)) or not isinstance(mesh_ids, Iterable):
            raise LightError(f"{owner}: mesh_ids must be a sequence of mesh indices, got {mesh_ids!r}")
        ids = []
        for i in mesh_ids:
            if not isinstance(i, numbers.Integral) or isinstance(i, bool) or not 0 <= i < len(meshes):
                raise LightError(f"{owner}: mesh_ids must be indices of the scene's {len(meshes)} meshes, got {i!r}")
            ids.append(int(i))
        if not ids:
            raise LightError(f"{owner}: the scene has no emissive mesh (no material declares emits)")
        for i in ids:          # the emission is read below: a bad value is named by its material, not as the power
            materials[meshes[i].material_id].validate()
        self._materials = materials
        self._geo = GeometryTable([meshes[i] for i in ids])
        #: the scene meshes (indices into ``scene.meshes``) whose triangles the light samples
        self.mesh_ids = tuple(ids)
        self._meshes = tuple(meshes[i] for i in ids)
        self._scene_mesh = np.array(ids, dtype=np.int64)
        self._local = np.full(len(meshes), -1, dtype=np.int64)      # scene mesh id -> index in the light's table
        self._local[self._scene_mesh] = np.arange(len(ids))
        geo = self._geo
        v = geo.vertices
        p0, p1, p2 = (take_rows(v, geo.faces[:, k]) for k in range(3))
        self._area = 0.5 * np.linalg.norm(cross(p1 - p0, p2 - p0), axis=1)
        bound = self._emission_bound(back=False)
        weight = self._area * bound
        total = float(weight.sum())
        #: estimated emitted power (W): ``pi sum_i A_i Lbar_i`` of a one-sided Lambertian emitter, ``Lbar_i`` the
        #: triangle's mean RGB radiance at its probe points (front side; exact for constant emission)
        self.power = math.pi * total
        #: (F,) float64 probability of choosing each triangle of the light's table (0: not part of the light; all 0
        #: when nothing emits at the probe points: the light then contributes nothing)
        self.pmf = weight / total if total > 0 else np.zeros_like(weight)
        self._cdf = np.cumsum(self.pmf)
        if total > 0:
            self._cdf[-1] = 1.0
        self._cdf_lo = self._cdf - self.pmf
        #: (F,) float64 area density ``pmf / area`` (1/m^2) of the sampled points on each triangle
        self.area_pdf = np.divide(self.pmf, self._area, out=np.zeros_like(self.pmf), where=self._area > 0)
        #: RGB radiance when the emission is the same at every probe point of every triangle, else None
        self.L = self._uniform
        self._choice = None
        self._pdf_accel = None                     # Embree scene of the light's triangles (pdf_li, built on first use)
        if selection == "oriented" and total > 0:
            one_sided = self._emission_bound(back=True) == 0
            self._choice = ClusterChoice(geo.vertices, geo.faces, geo.face_normals, geo.face_mesh, weight, one_sided)
        self.validate()

    @property
    def material_ids(self):
        """The scene material ids (a frozenset) of the meshes the light samples."""
        return frozenset(int(m.material_id) for m in self._meshes)

    @property
    def triangles(self):
        """Number of triangles in the light's table (those with ``pmf = 0`` included)."""
        return int(self._area.size)

    @property
    def sampled_triangles(self):
        """Number of triangles the light samples (``pmf > 0``)."""
        return int(np.count_nonzero(self.pmf))

    def built_for(self, meshes):
        """True when ``meshes`` (a scene's list) holds, at :attr:`mesh_ids`, the very meshes the light samples."""
        return all(i < len(meshes) and meshes[i] is m for i, m in zip(self.mesh_ids, self._meshes))

    def validate(self):
        """The base checks; ``mesh_ids`` must still name meshes whose material emits."""
        super().validate()
        for m in self._meshes:
            if not self._materials[m.material_id].emits:
                raise LightError(f"{self.label}: mesh {m.name!r} no longer has an emitting material")

    def _surface(self, tri, b1, b2, origins, dirs, dist):
        """The surface batch at the points (light triangle ``tri``, barycentrics ``b1``, ``b2``) seen along the unit
        ``dirs`` from ``origins`` at distance ``dist``; its ``mesh_id`` are the scene's mesh ids."""
        geo = self._geo
        mesh = geo.face_mesh[tri]
        hits = Hits(hit=np.ones(tri.size, dtype=bool), t=dist, mesh_id=mesh, prim_id=tri - geo.face_offset[mesh],
                    u=b1, v=b2, ng=take_rows(geo.face_normals, tri))
        return surface_from_hits(geo, hits, origins, dirs, mesh_ids=np.take(self._scene_mesh, mesh))

    def _points(self, tri, b0, b1, b2):
        """The points (N, 3) ``b0 v0 + b1 v1 + b2 v2`` of light triangles ``tri`` (N,) at barycentrics (N,) each."""
        f = take_rows(self._geo.faces, tri)
        v = self._geo.vertices
        return (b0[:, None] * take_rows(v, f[:, 0]) + b1[:, None] * take_rows(v, f[:, 1])
                + b2[:, None] * take_rows(v, f[:, 2]))

    def _emission_bound(self, back):
        """(F,) mean emission (RGB mean) of each triangle's four probe points seen from its front (or ``back``);
        the front pass also records :attr:`L` (the radiance when it is the same at every probe)."""
        geo = self._geo
        n_f = self._area.size
        out = np.zeros(n_f)
        rgb = np.zeros((n_f, 3))
        same = True
        first = None
        for lo in range(0, n_f, _BLOCK):
            tri = np.arange(lo, min(n_f, lo + _BLOCK))
            acc = np.zeros((tri.size, 3))
            for b1, b2 in _PROBES:
                bb1, bb2 = np.full(tri.size, b1), np.full(tri.size, b2)
                y = self._points(tri, 1.0 - bb1 - bb2, bb1, bb2)
                n = take_rows(geo.face_normals, tri)
                if back:
                    n = -n
                Le = _emission(self._materials, self._surface(tri, bb1, bb2, y + n, -n, np.ones(tri.size)))
                acc += Le
                if first is None:
                    first = Le[0].copy()
                same = same and bool(np.all(Le == first))
            rgb[tri] = acc / len(_PROBES)
            out[tri] = rgb[tri].mean(axis=1)
        if not back:
            self._uniform = first if same else None
        return np.maximum(out, 0.0)

    def compiled_record(self):
        """``(MESH, record, data)``: the light as a row of the compiled kernel's light table and the tables it reads
        (:mod:`pyrt.lights.compiled_mesh`: its triangles with their radiance from either side, the power CDF, the
        scene meshes' first light triangles and, with ``selection="oriented"``, the clusters); None when an emitting
        material's emission is not a constant the kernel reads (:func:`constant_emission`: a textured emission,
        vertex colours, alpha masks and blending, a material the kernel cannot shade)."""
        if not all(constant_emission(self._materials[m.material_id]) for m in self._meshes):
            return None
        geo = self._geo
        n_f = self._area.size
        tri = np.zeros((n_f, CM.TRI_W))
        for k in range(3):
            tri[:, 3 * k:3 * k + 3] = take_rows(geo.vertices, geo.faces[:, k])
        tri[:, CM.T_N:CM.T_N + 3] = geo.face_normals
        tri[:, CM.T_AREA] = self._area
        tri[:, CM.T_PMF] = self.pmf
        tri[:, CM.T_CLUSTER] = -1.0
        tri[:, CM.T_FRONT:CM.T_FRONT + 3] = self._centroid_radiance(back=False)
        tri[:, CM.T_BACK:CM.T_BACK + 3] = self._centroid_radiance(back=True)
        first = np.where(self._local >= 0, np.take(geo.face_offset, np.maximum(self._local, 0)), -1)
        parts = [tri.ravel(), self._cdf, first.astype(np.float64)]
        n_k = n_l = 0
        ch = self._choice
        if ch is not None:
            n_k, n_l = ch.clusters, ch.order.size
            tri[:, CM.T_PMF_IN] = ch.pmf_in
            tri[:, CM.T_CLUSTER] = ch.tri_cluster
            cl = np.zeros((n_k, CM.CL_W))
            cl[:, 0:3] = -2.0 * ch.center
            cl[:, CM.C_CC] = dot(ch.center, ch.center)
            cl[:, CM.C_R2] = ch.radius2
            cl[:, CM.C_POWER] = ch.power
            cl[:, CM.C_NORMAL:CM.C_NORMAL + 3] = np.where(ch.cut[:, None], ch.normal, 0.0)
            cl[:, CM.C_OFFSET] = np.where(ch.cut, ch.offset, -np.inf)
            cl[:, CM.C_START] = ch.start
            cl[:, CM.C_END] = ch.end
            parts += [cl.ravel(), ch.seg, ch.order.astype(np.float64)]
        rec = np.zeros(LC.RECORD)
        rec[CM.R_TRIS], rec[CM.R_CLUSTERS], rec[CM.R_MESHES], rec[CM.R_LIVE] = n_f, n_k, self._local.size, n_l
        rec[LC.AREA_SAMPLES] = self.n_samples
        return LC.MESH, rec, np.concatenate(parts)

    def _centroid_radiance(self, back):
        """(F, 3) the radiance each triangle emits at its centroid from its front (or ``back``), with the material's
        sidedness (:func:`_emission`): every point's, for the constant emission :meth:`compiled_record` packs."""
        geo = self._geo
        n_f = self._area.size
        out = np.zeros((n_f, 3))
        for lo in range(0, n_f, _BLOCK):
            tri = np.arange(lo, min(n_f, lo + _BLOCK))
            b = np.full(tri.size, 1.0 / 3.0)
            y = self._points(tri, 1.0 - b - b, b, b)
            n = take_rows(geo.face_normals, tri)
            if back:
                n = -n
            out[tri] = _emission(self._materials, self._surface(tri, b, b, y + n, -n, np.ones(tri.size)))
        return out

    def sample_li(self, p, u):
        """A :class:`LightSample` (``E`` and the sample's solid-angle ``pdf``) at the points ``p`` (N, 3)."""
        n = p.shape[0]
        u0 = u[:, 0]
        if self._choice is not None:
            tri, r, pm = self._choice.choose(p, u0)
        else:
            tri = np.minimum(np.searchsorted(self._cdf, u0, side="right"), self._cdf.size - 1)
            pm = np.take(self.pmf, tri)
            r = np.clip(np.divide(u0 - np.take(self._cdf_lo, tri), pm, out=np.zeros(n), where=pm > 0), 0.0, 1.0)
        su = np.sqrt(r)
        b0 = 1.0 - su
        b1 = u[:, 1] * su
        b2 = np.maximum(1.0 - b0 - b1, 0.0)
        y = self._points(tri, b0, b1, b2)
        d = y - p
        dist = np.sqrt(dot(d, d))
        ok = dist > 0
        inv = np.divide(1.0, dist, out=np.zeros(n), where=ok)
        wi = d * inv[:, None]
        wi[~ok] = (0.0, 0.0, 1.0)
        cos_l = np.abs(dot(take_rows(self._geo.face_normals, tri), wi))
        pdf = (np.divide(pm, np.take(self._area, tri)) * np.divide(dist * dist, cos_l, out=np.zeros(n),
                                                                  where=cos_l > 0))
        live = ok & (cos_l > 0) & (pm > 0)
        E = np.zeros((n, 3))
        idx = np.flatnonzero(live)
        if idx.size:
            ctx = self._surface(tri[idx], b1[idx], b2[idx], take_rows(p, idx), take_rows(wi, idx), dist[idx])
            E[idx] = _emission(self._materials, ctx) / pdf[idx, None]
        pdf = np.where(live, pdf, 0.0)
        return LightSample(wi, np.where(ok, dist, 1.0), E, pdf=pdf)

    def pdf_point(self, p, tri, dist, cos_l):
        """Solid-angle density (N,) of sampling, from the points ``p`` (N, 3), the point at distance ``dist`` on light
        triangle ``tri`` whose normal makes the cosine ``cos_l`` with the direction:
        ``P(tri | p) / area * dist^2 / |cos_l|`` (``P(tri | p) = pmf`` with ``selection="power"``)."""
        c = np.abs(cos_l)
        prob = np.take(self.pmf, tri) if self._choice is None else self._choice.triangle_probability(p, tri)
        return (np.divide(prob, np.take(self._area, tri))
                * np.divide(dist * dist, c, out=np.zeros(c.shape), where=c > 0))

    def triangle_index(self, mesh_id, prim_id):
        """(N,) the light's triangle for scene mesh ``mesh_id`` and its triangle ``prim_id``, -1 where the mesh is
        not the light's."""
        mesh_id = np.asarray(mesh_id, dtype=np.int64)
        inside = (mesh_id >= 0) & (mesh_id < self._local.size)
        local = np.where(inside, np.take(self._local, np.where(inside, mesh_id, 0)), -1)
        return np.where(local >= 0, np.take(self._geo.face_offset, np.maximum(local, 0)) + prim_id, -1)

    def pdf_hit(self, p, mesh_id, prim_id, dist, cos_l):
        """Solid-angle density (N,) of the light's sampling from the points ``p`` (N, 3) at the points rays from them
        hit: scene mesh ``mesh_id``, its triangle ``prim_id`` at distance ``dist`` with cosine ``cos_l``; 0 on
        triangles the light does not sample."""
        tri = self.triangle_index(mesh_id, prim_id)
        mine = tri >= 0
        return np.where(mine, self.pdf_point(p, np.maximum(tri, 0), dist, cos_l), 0.0)

    def pdf_li(self, p, wi):
        """Solid-angle density (N,) of :meth:`sample_li` toward ``wi`` from ``p``: the sum of :meth:`pdf_point` over
        every light triangle the ray ``p + t wi`` (t > 0) crosses, front or back. Embree finds them (a scene of the
        light's triangles, built on first use; closest hits re-traced just past each one, as many rounds as there
        are layers); ``t`` and the cosine are recomputed in float64 from the hit triangle's plane (Embree's are
        float32). The integrators never call it for this light: they know the hit (:meth:`pdf_hit`)."""
        p = np.asarray(p, dtype=np.float64)
        wi = np.asarray(wi, dtype=np.float64)
        n = wi.shape[0]
        out = np.zeros(n)
        if self._pdf_accel is None:
            self._pdf_accel = Accel(threads=1)
            self._pdf_accel.add_mesh(self._geo.vertices, self._geo.faces)   # prim_id = the light's triangle index
        geo = self._geo
        # the retrace starts past the last triangle by more than Embree's float32 rounding (1e-5 of the scene's size)
        eps = 1e-5 * float(np.abs(geo.vertices).max() + np.abs(p).max(initial=0.0))
        rows = np.arange(n)
        t_done = np.zeros(n)                       # distance from p of the last triangle counted
        last = np.full(n, -1)                      # that triangle
        for _ in range(self.triangles + 1):        # each round moves every ray past one more triangle
            if rows.size == 0:
                break
            w = take_rows(wi, rows)
            start = take_rows(p, rows) + np.where(last[rows] >= 0, t_done[rows] + eps, 0.0)[:, None] * w
            h = self._pdf_accel.intersect(start, w)
            hit = np.flatnonzero(h.hit)
            rows, tri = rows[hit], h.prim_id[hit]
            w, q = take_rows(wi, rows), take_rows(p, rows)
            nrm = take_rows(geo.face_normals, tri)
            cos_l = dot(w, nrm)
            v0 = take_rows(geo.vertices, take_rows(geo.faces, tri)[:, 0])
            t = np.divide(dot(v0 - q, nrm), cos_l, out=np.zeros(rows.size), where=cos_l != 0)
            new = tri != last[rows]
            out[rows[new]] += self.pdf_point(take_rows(q, np.flatnonzero(new)), tri[new], t[new], cos_l[new])
            t_done[rows] = np.maximum(t, t_done[rows])
            last[rows] = tri
        return out


def _scene_lists(owner, meshes, materials):
    """``(meshes, materials)`` as lists, checked: meshes are :class:`MeshData` whose ``material_id`` indexes
    ``materials``, which are :class:`pyrt.materials.Material`; else a :class:`LightError` naming ``owner``."""
    for name, seq in (("meshes", meshes), ("materials", materials)):
        if isinstance(seq, (str, bytes)) or not isinstance(seq, Iterable):
            raise LightError(f"{owner}: {name} must be the scene's list of {name}, got {seq!r}"[:300])
    meshes, materials = list(meshes), list(materials)
    for k, m in enumerate(materials):
        if not isinstance(m, Material):
            raise LightError(f"{owner}: materials[{k}] must be a pyrt Material, got {type(m).__name__}")
    for k, m in enumerate(meshes):
        if not isinstance(m, MeshData):
            raise LightError(f"{owner}: meshes[{k}] must be a mesh of the scene (MeshData), got {type(m).__name__}")
        mid = m.material_id
        if not (isinstance(mid, numbers.Integral) and 0 <= mid < len(materials)):
            raise LightError(f"{owner}: mesh {m.name!r} has material_id {mid!r}, not an index of the "
                             f"{len(materials)} materials given")
    return meshes, materials
