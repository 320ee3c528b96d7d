"""The loaded asset: object-space meshes, their instances, cameras and lights, and how an asset is
added to a :class:`pyrt.Scene` (crease-angle normals for meshes without normals, vertex colours,
lights converted from photometric units)."""
from __future__ import annotations

import copy
from dataclasses import dataclass, field
import math
import time

import numpy as np

from pyrt.core.camera import Camera
from pyrt.core.transforms import apply_matrix, rewound, transform_normals, transform_tangents
from pyrt.geometry.tangents import vertex_tangents
from pyrt.geometry.normals import crease_normals
from pyrt.lights import DirectionalLight, PointLight, SpotLight
from pyrt.io.assets.common import DEFAULT_CREASE_ANGLE, AssetError, DefaultParams, PBRParams
from pyrt.geometry.mesh_data import degenerate_faces
from pyrt.io.assets.alpha import apply_coverage, uses_alpha
from pyrt.io.assets.materials import FaceColorTexture, VertexColorTexture, to_pyrt_material
from pyrt.io.assets.merge import merge_plan


# ============================================================================ data model

@dataclass
class AssetMesh:
    """One triangle mesh in object space (a glTF primitive, an OBJ material group, a PLY/STL file).

    ``uv`` uses pyrt's convention (v up); ``colors`` are linear RGB per vertex; ``material`` indexes
    :attr:`Asset.materials` (-1: the format's default material).
    """

    name: str
    vertices: np.ndarray            # (V, 3) float64
    faces: np.ndarray               # (F, 3) int64
    normals: np.ndarray | None = None   # (V, 3) unit, from the file
    uv: np.ndarray | None = None        # (V, 2) float64
    colors: np.ndarray | None = None    # (V, 3) float64 linear
    material: int = -1
    alpha: np.ndarray | None = None     # (V,) coverage alpha (glTF COLOR_0's A), read by MASK / BLEND materials
    face_colors: np.ndarray | None = None   # (F, 3) float64 linear, one per face (PLY); used when colors is None
    uv_sets: dict | None = None         # {k: (V, 2)}: UV sets k >= 1 the material's textures read (glTF TEXCOORD_k)
    tangents: np.ndarray | None = None  # (V, 4) object-space vertex tangents + bitangent sign (glTF TANGENT)


@dataclass
class AssetInstance:
    """A mesh placed in the world: ``world_from_object`` (4, 4) float64."""

    mesh: int
    world_from_object: np.ndarray
    node: str = ""



@dataclass
class AssetCamera:
    """A perspective camera: world position, unit forward and up, vertical fov (degrees)."""

    name: str
    position: np.ndarray
    forward: np.ndarray
    up: np.ndarray
    yfov_deg: float
    aspect: float | None = None

    def to_pyrt(self, width, height, **kwargs):
        """A :class:`pyrt.Camera` with this pose and field of view."""
        return Camera(self.position, self.position + self.forward, self.up, fov=self.yfov_deg, width=width,
                      height=height, **kwargs)


@dataclass
class AssetLight:
    """A ``KHR_lights_punctual`` light in photometric units, placed in the world.

    ``intensity`` is in candela (point, spot) or lux (directional); ``direction`` is the unit
    direction the light travels (the node's -Z).
    """

    name: str
    kind: str                       # "point" | "spot" | "directional"
    color: np.ndarray
    intensity: float
    position: np.ndarray
    direction: np.ndarray
    range: float | None = None
    inner_cone: float = 0.0         # radians
    outer_cone: float = math.pi / 4

    def to_pyrt(self):
        """The pyrt light in radiometric units (conversion: see :mod:`pyrt.io.assets`, "Lights")."""
        return light_from_photometric(self)


@dataclass
class Asset:
    """A loaded asset. ``up_axis`` is "+y" when the format defines it (glTF), else None."""

    path: str
    format: str
    meshes: list[AssetMesh] = field(default_factory=list)
    instances: list[AssetInstance] = field(default_factory=list)
    materials: list = field(default_factory=list)
    cameras: list[AssetCamera] = field(default_factory=list)
    lights: list[AssetLight] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    up_axis: str | None = None
    #: the up axis a comment in the file states (a PLY header's ``comment up_axis Z``, an OBJ's ``# Z-up``: read at
    #: load time by :func:`pyrt.io.assets.common.metadata_up_axis`), or None
    stated_up_axis: str | None = None
    load_time: float = 0.0
    #: the seconds of :attr:`load_time` spent decoding texture images (glTF: :attr:`pyrt.io.assets.gltf_file.GltfFile.
    #: decode_time`; 0 for formats that do not time it)
    decode_time: float = 0.0
    #: what was replaced so that the model loads anyway (a missing or unreadable texture -> its factor alone, a
    #: missing MTL -> the default material, ...), one message each; every one is also in :attr:`warnings`
    substitutions: list[str] = field(default_factory=list)
    #: glTF materials that differ only in their base colour factor are added as one material, the factors moved
    #: into the vertex colours (:mod:`pyrt.io.assets.merge`: the same image, far fewer materials to shade)
    merge_materials: bool = True
    #: meshes whose material has a normal map (or anisotropy) and that carry no tangents get vertex tangents generated
    #: from their UVs as they are added to a scene (:mod:`pyrt.geometry.tangents`); False: each triangle's UV tangents
    generate_tangents: bool = True

    def substitute(self, message):
        """Record a substitution: ``message`` goes to :attr:`substitutions` and :attr:`warnings`."""
        self.substitutions.append(message)
        self.warnings.append(message)

    @property
    def n_triangles(self):
        """Triangles rendered (instances counted)."""
        return int(sum(self.meshes[i.mesh].faces.shape[0] for i in self.instances))

    def world_vertices(self):
        """All instances' vertices in world space, (N, 3) float64."""
        out = []
        for inst in self.instances:
            out.append(apply_matrix(self.meshes[inst.mesh].vertices, inst.world_from_object))
        return np.concatenate(out) if out else np.zeros((0, 3))

    def bounds(self):
        v = self.world_vertices()
        if v.shape[0] == 0:
            raise AssetError(f"{self.path}: the asset has no geometry")
        return v.min(axis=0), v.max(axis=0)

    def add_to_scene(self, scene, *, transform=None, crease_angle=DEFAULT_CREASE_ANGLE, lights=True,
                     name_prefix="", timings=None):
        """Add the meshes (with materials) and, if ``lights``, the lights to ``scene``.

        ``transform`` (4, 4) is applied on top of every instance's world transform (e.g. an up-axis
        change). ``timings`` (a dict, optional) gets the seconds spent added to its ``"normals"`` (welding
        and crease-angle normals of meshes without normals), ``"tangents"`` (generated tangents:
        :attr:`generate_tangents`) and ``"scene"`` (everything else: materials, :meth:`pyrt.Scene.add_mesh` checks and
        transforms). Returns the list of scene mesh indices added.
        """
        t_start = time.perf_counter()
        t_normals = 0.0
        pre = np.eye(4) if transform is None else np.asarray(transform, dtype=np.float64)
        prepared = {}
        mats = {}
        added = []
        # materials that differ only in their base colour become one (pyrt.io.assets.merge)
        used = {self.meshes[i.mesh].material for i in self.instances} - {-1}
        plan = merge_plan(self.materials, used) if self.merge_materials else {}
        t0 = time.perf_counter()       # meshes without normals: their crease normals in one call
        prepared.update(_prepare_meshes({i.mesh: self.meshes[i.mesh] for i in self.instances}, crease_angle))
        t1 = time.perf_counter()
        t_normals += t1 - t0
        if self.generate_tangents:
            prepared = {i: self._with_tangents(self.meshes[i], p) for i, p in prepared.items()}
        t_tangents = time.perf_counter() - t1
        parts = []                     # (material key, record) per instance, in instance order
        for k, inst in enumerate(self.instances):
            geometry, normals, colors, alpha, uv_sets, uv, tangents = prepared[inst.mesh]
            am = self.meshes[inst.mesh]
            params = self._params(am)
            if alpha is not None and not uses_alpha(params):
                alpha = None
            per_face = colors is not None and am.colors is None     # face colours, one row per kept face
            group = am.material
            if am.material in plan:        # the factor moves into the (vertex or face) colours
                params, gid, factor = plan[am.material]
                group = ("merged", gid)
                colors = np.tile(factor, (geometry[0].shape[0], 1)) if colors is None else colors * factor
            # meshes with colours or alpha share their material's pyrt material too: one colour texture bound to
            # each of them (a model of many coloured parts is then one material, not one per part)
            key = group if colors is None and alpha is None else ("vc", group, per_face, colors is None,
                                                                    alpha is None)
            if key not in mats:
                mats[key] = self._material(params, colors, alpha, per_face=per_face)
            m = pre @ inst.world_from_object
            if abs(np.linalg.det(m[:3, :3])) < 1e-300:
                self.warnings.append(f"instance {inst.node or k} of mesh {am.name!r} has a singular transform "
                                     "(zero scale): skipped")
                continue
            parts.append((key, _Part(geometry, normals, colors, alpha, uv_sets, uv, m, per_face,
                                     f"{name_prefix}{inst.node or am.name}#{k}", tangents)))
        for key, part in _flattened(parts) if len(parts) >= FLATTEN_MIN_INSTANCES else parts:
            material, vc_tex, va_tex = mats[key]
            mid = scene.add_mesh(part.geometry, material, transform=part.matrix, normals=part.normals,
                                 uv_sets=part.uv_sets, uv=part.uv, name=part.name, tangents=part.tangents)
            if vc_tex is not None:
                vc_tex.bind(mid, scene.meshes[mid].faces, part.colors)
            if va_tex is not None:
                va_tex.bind(mid, scene.meshes[mid].faces, part.alpha[:, None])
            added.append(mid)
        if lights:
            for L in self.lights:
                light = L.to_pyrt()
                if transform is not None:
                    light = _transform_light(light, pre)
                scene.add_light(light)
        if timings is not None:
            timings["normals"] = timings.get("normals", 0.0) + t_normals
            timings["tangents"] = timings.get("tangents", 0.0) + t_tangents
            timings["scene"] = timings.get("scene", 0.0) + (time.perf_counter() - t_start - t_normals - t_tangents)
        return added

    def _with_tangents(self, am, prepared):
        """``prepared`` (:func:`_prepare_mesh`'s tuple) with vertex tangents generated from the UV set the mesh's
        material reads its tangent frame in (:func:`pyrt.geometry.tangents.vertex_tangents`), where it needs one and
        has none."""
        (v, f), normals, colors, alpha, uv_sets, uv, tangents = prepared
        k = self._params(am).tangent_texcoord
        if tangents is not None or k is None or normals is None:
            return prepared
        uvk = uv if k == 0 else (uv_sets or {}).get(k)
        if uvk is None:
            return prepared
        return (v, f), normals, colors, alpha, uv_sets, uv, vertex_tangents(v, f, normals, uvk)

    def _params(self, am):
        """The loaded material parameters of a mesh (the format's default for ``material = -1``)."""
        return self.materials[am.material] if am.material >= 0 else (
            PBRParams(name="gltf-default") if self.format == "gltf" else DefaultParams())

    @staticmethod
    def _material(params, colors, alpha=None, *, per_face=False):
        """(pyrt material, vertex- or face-colour texture or None, vertex-alpha texture or None) for the material
        parameters ``params`` of a mesh with ``colors`` / ``alpha`` (or None); the coverage (alpha mode,
        doubleSided) is set by :func:`pyrt.io.assets.alpha.apply_coverage`."""
        vc = None if colors is None else (FaceColorTexture() if per_face else VertexColorTexture())
        va = VertexColorTexture(channels=1) if alpha is not None else None
        return apply_coverage(to_pyrt_material(params, vertex_colors=vc), params, va), vc, va


# ============================================================================ lights

def light_from_photometric(L):
    """Convert an :class:`AssetLight` (candela / lux) to a pyrt light (W/sr / W/m^2).

    Uses the lights' photometric constructors (``candela=``, ``lux=``; ``I = cd / 683``,
    ``E = lux / 683`` times ``color``, see :mod:`pyrt.lights`), glTF's spot falloff
    (``spot_falloff="gltf"``) and, when the light has a ``range``, glTF's range window
    (``falloff="gltf_range"``).
    """
    color = np.asarray(L.color, dtype=np.float64)
    if L.kind == "directional":
        return DirectionalLight(L.direction, lux=L.intensity, color=color, name=L.name)
    rng = {} if L.range is None else {"falloff": "gltf_range", "range": float(L.range)}
    if L.kind == "point":
        return PointLight(L.position, candela=L.intensity, color=color, name=L.name, **rng)
    if L.kind == "spot":
        return SpotLight(L.position, L.direction, candela=L.intensity, inner_angle=math.degrees(L.inner_cone),
                         outer_angle=math.degrees(L.outer_cone), spot_falloff="gltf", color=color, name=L.name,
                         **rng)
    raise AssetError(f"unknown light type {L.kind!r}")


def _transform_light(light, m):
    """A copy of ``light`` (a light :func:`light_from_photometric` makes) moved by the 4x4 rigid transform ``m``."""
    out = copy.copy(light)
    if isinstance(out, (PointLight, SpotLight)):
        out.position = m[:3, :3] @ light.position + m[:3, 3]
    if isinstance(out, (DirectionalLight, SpotLight)):
        d = m[:3, :3] @ light.direction
        out.direction = d / np.linalg.norm(d)
    return out


# ============================================================================ meshes for the scene

#: models of at least this many instances are flattened (:func:`_flattened`): the instances that share a material
#: become one world-space scene mesh
FLATTEN_MIN_INSTANCES = 64


@dataclass
class _Part:
    """One instance as :meth:`Asset.add_to_scene` adds it: prepared arrays, ``world_from_object`` and scene name."""

    geometry: tuple
    normals: np.ndarray
    colors: np.ndarray | None
    alpha: np.ndarray | None
    uv_sets: dict | None
    uv: np.ndarray | None
    matrix: np.ndarray
    per_face: bool
    name: str
    tangents: np.ndarray | None = None


def _flattened(parts):
    """``parts`` ((material key, :class:`_Part`) in instance order) with the instances of one material and the same
    attributes (UVs, UV sets, vertex colours, alpha; face colours are never joined) joined into one world-space part
    each, named after its first instance with ``(+N joined)``.

    A model of many parts (a CAD assembly: thousands of instances) otherwise pays :meth:`pyrt.Scene.add_mesh`'s
    checks, the precision check and an Embree geometry per part: ~0.4 ms each, 4 s for 10,000 parts. The scene
    held a world-space copy per instance already; joined, the copies are the same triangles. Each part's vertices
    and normals are transformed as :meth:`pyrt.Scene.add_mesh` would (the inverse transpose for normals), and the
    faces of a mirrored part are re-wound as it would.
    """
    groups = {}
    for key, p in parts:
        sig = (key, p.per_face, p.uv is None, None if p.uv_sets is None else tuple(sorted(p.uv_sets)),
               p.colors is None, p.alpha is None, p.tangents is None)
        groups.setdefault(sig, []).append((key, p))
    out = []
    for members in groups.values():
        if len(members) == 1 or members[0][1].per_face:
            out += members
            continue
        verts, faces, normals, tangents, n = [], [], [], [], 0
        for _key, p in members:        # each part moved to the world as Scene.add_mesh would move it
            v, f = p.geometry
            verts.append(apply_matrix(v, p.matrix))
            normals.append(transform_normals(p.normals, p.matrix))
            if p.tangents is not None:
                tangents.append(transform_tangents(p.tangents, p.matrix))
            faces.append(rewound(np.asarray(f, dtype=np.int64), p.matrix) + n)
            n += v.shape[0]

        def cat(get):
            vals = [get(p) for _k, p in members]
            return None if vals[0] is None else np.concatenate(vals)

        first = members[0][1]
        uv_sets = None if first.uv_sets is None else {k: np.concatenate([p.uv_sets[k] for _k, p in members])
                                                      for k in first.uv_sets}
        out.append((members[0][0], _Part((np.concatenate(verts), np.concatenate(faces)), np.concatenate(normals),
                                         cat(lambda p: p.colors), cat(lambda p: p.alpha), uv_sets, cat(lambda p: p.uv),
                                         np.eye(4), False, f"{first.name} (+{len(members) - 1} joined)",
                                         np.concatenate(tangents) if tangents else None)))
    return out


def _prepare_meshes(meshes, crease_angle):
    """:func:`_prepare_mesh` of every mesh of ``meshes`` ({index: AssetMesh}): ``{index: prepared}``.

    The meshes without normals get their crease normals from one :func:`crease_normals` call over all of them (each
    mesh's vertices a group of their own, so nothing welds across meshes): the same normals, vertices and faces as
    one call per mesh, whose fixed cost (~0.4 ms) made the normals of a 10,000-part model take 4 s.
    """
    bare = [i for i, am in meshes.items() if am.normals is None]
    out = {i: _prepare_mesh(am, crease_angle) for i, am in meshes.items() if am.normals is not None}
    if len(bare) < 2:
        out.update({i: _prepare_mesh(meshes[i], crease_angle) for i in bare})
        return out
    nv = np.array([meshes[i].vertices.shape[0] for i in bare])
    nf = np.array([meshes[i].faces.shape[0] for i in bare])
    vo = np.concatenate([[0], np.cumsum(nv)])
    fo = np.concatenate([[0], np.cumsum(nf)])
    v = np.concatenate([np.asarray(meshes[i].vertices, dtype=np.float64) for i in bare])
    f = np.concatenate([np.asarray(meshes[i].faces, dtype=np.int64) + vo[g] for g, i in enumerate(bare)])
    src, faces, normals = crease_normals(v, f, crease_angle, groups=np.repeat(np.arange(len(bare)), nv))
    # output vertices follow their source vertices: each mesh's are one run, starting where its sources start
    ro = np.searchsorted(src, vo)
    for g, i in enumerate(bare):
        lo, hi = ro[g], ro[g + 1]
        out[i] = _prepare_mesh(meshes[i], crease_angle, creased=(src[lo:hi] - vo[g], faces[fo[g]:fo[g + 1]] - lo,
                                                                  normals[lo:hi]))
    return out


def _prepare_mesh(am, crease_angle, creased=None):
    """((vertices, faces) in object space, object-space normals, linear colours or None, vertex alpha or None, further
    UV sets or None, UVs or None, vertex tangents or None) for add_mesh (no trimesh: a glTF preview never imports
    it; tangents only with the file's normals: crease normals re-index the vertices).

    The colours are per vertex, or, for a mesh with face colours only, per face of the faces
    :meth:`pyrt.Scene.add_mesh` keeps (its degenerate triangles, which it skips, are left out here too).
    ``creased``: the mesh's ``crease_normals`` result when the caller computed it (:func:`_prepare_meshes`).
    """
    v, f, uv, col, nrm, alpha, uv_sets = am.vertices, am.faces, am.uv, am.colors, am.normals, am.alpha, am.uv_sets
    tangents = am.tangents if nrm is not None else None
    if nrm is None:
        src, f, nrm = crease_normals(v, f, crease_angle) if creased is None else creased
        # np.take: the rows of fancy indexing at ~0.1x its time (2.6 M vertices: 0.02 s against 0.18 s of CPU)
        v, uv, col, alpha = (None if a is None else np.take(a, src, axis=0) for a in (v, uv, col, alpha))
        uv_sets = None if uv_sets is None else {k: np.take(a, src, axis=0) for k, a in uv_sets.items()}
    if col is None and am.face_colors is not None:     # faces keep their order; add_mesh's test on the same arrays
        col = am.face_colors[~degenerate_faces(v, f)]
    return (v, f), nrm, col, alpha, uv_sets, uv, tangents
