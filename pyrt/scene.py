"""The scene: meshes with materials and transforms, lights, camera, background.

A :class:`Scene` only holds validated parameters; rendering lives in :mod:`pyrt.integrators`.
"""
from __future__ import annotations

import numbers
import sys

import numpy as np

from pyrt.core import checks
from pyrt.core.camera import Camera
from pyrt.geometry.normals import crease_normals
from pyrt.geometry.mesh_data import GeometryError, MeshData, validate_mesh
from pyrt.geometry.surface import GeometryTable
from pyrt.lights.base import Light
from pyrt.lights.mesh import EmissiveMeshLight
from pyrt.materials import Material
from pyrt.core.transforms import (SceneError, align_vectors, apply_matrix,  # noqa: F401 (public here too)
                                  rewound, transform_matrix, transform_normals, transform_tangents)


def _rgb(owner, name, v):
    return checks.rgb(owner, name, v, SceneError)


#: the finest :meth:`Scene.add_sphere` tessellation (9 levels: 5.2 million triangles)
MAX_SUBDIVISIONS = 9


def plane_quad(sx, sz):
    """The square of :meth:`Scene.add_plane` and the scene files' ``plane`` primitive before it is turned to its
    normal: ``(vertices (4, 3), faces (2, 3), uv (4, 2))``, side ``sx`` along x and ``sz`` along z, centred at the
    origin in the plane y = 0, facing +y, uv (0, 0) at (-x, +z)."""
    v = np.array([[-sx / 2, 0, sz / 2], [sx / 2, 0, sz / 2], [sx / 2, 0, -sz / 2], [-sx / 2, 0, -sz / 2]])
    return v, np.array([[0, 1, 2], [0, 2, 3]]), np.array([[0, 0], [1, 0], [1, 1], [0, 1.0]])


def _who(kind, name):
    """A primitive as messages name it: ``sphere 'ball'`` (or just ``sphere``)."""
    return f"{kind} {name!r}" if name else kind


def _positive_sizes(who, name, value, n):
    """``value`` (a number or ``n`` numbers) as float64 (n,), each finite and > 0; else a :class:`SceneError`."""
    try:
        a = np.broadcast_to(np.asarray(value, dtype=np.float64), (n,)).copy()
    except (TypeError, ValueError):
        a = None
    if a is None or isinstance(value, bool) or not np.all(np.isfinite(a)) or not np.all(a > 0):
        raise SceneError(f"{who}: {name} must be {'a finite number' if n == 1 else f'{n} finite numbers'} > 0, "
                         f"got {value!r}")
    return a


def _checked_tangents(tangents, n_vertices, name):
    """``tangents`` of :meth:`Scene.add_mesh` as (V, 4) float64 with ``w`` = +-1 (None when None); rows whose
    ``xyz`` is zero are kept (zero: no tangent there); a :class:`GeometryError` naming the mesh for a bad shape or a
    non-finite value."""
    if tangents is None:
        return None
    t = np.asarray(tangents, dtype=np.float64)
    if t.shape != (n_vertices, 4) or not np.all(np.isfinite(t)):
        raise GeometryError(f"mesh {name!r}: tangents must be finite with shape ({n_vertices}, 4), got {t.shape}")
    t = t.copy()
    t[:, 3] = np.where(t[:, 3] < 0, -1.0, 1.0)
    return t


def _checked_uv_sets(uv_sets, n_vertices, name):
    """``uv_sets`` of :meth:`Scene.add_mesh` as ``{int k >= 1: (V, 2) float64}`` (None when empty); a
    :class:`GeometryError` naming the mesh for a bad key, shape or non-finite value."""
    out = {}
    for k, a in (uv_sets or {}).items():
        a = np.asarray(a, dtype=np.float64)
        if isinstance(k, bool) or not isinstance(k, numbers.Integral) or k < 1:
            raise GeometryError(f"mesh {name!r}: uv_sets keys must be integers >= 1 (set 0 is the mesh's UVs), got {k!r}")
        if a.shape != (n_vertices, 2) or not np.all(np.isfinite(a)):
            raise GeometryError(f"mesh {name!r}: UV set {k} must be finite with shape ({n_vertices}, 2), got {a.shape}")
        out[int(k)] = a
    return out or None


class Scene:
    """Container of meshes, materials, lights and a camera.

    Parameters
    ----------
    camera : Camera, optional
    background : RGB radiance seen where rays miss (default black)
    ambient : RGB constant ambient radiance L_a; a hit adds ``albedo * L_a`` (the classic k_a L_a term,
        with k_a the material's albedo). Default 0 (physically based).
    shading_normal_fallback : bool
        Where a smooth face's interpolated vertex normal faces away from the viewer, shade with the
        geometric normal instead (default True, pyrt's better picture). False keeps the back-facing
        normal, so such hits shade black as in pbrt and Mitsuba (a reference switch, README conventions).
    """

    def __init__(self, camera=None, *, background=(0.0, 0.0, 0.0), ambient=(0.0, 0.0, 0.0),
                 shading_normal_fallback=True):
        self.camera = camera if camera is not None else Camera()
        #: Replace a back-facing interpolated normal by the geometric one (see the class docstring).
        if not isinstance(shading_normal_fallback, (bool, np.bool_)):
            raise SceneError(f"Scene: shading_normal_fallback must be True or False, got {shading_normal_fallback!r}")
        self.shading_normal_fallback = bool(shading_normal_fallback)
        self.background = _rgb("Scene", "background", background)
        self.ambient = _rgb("Scene", "ambient", ambient)
        self.environment = None
        self.materials: list[Material] = []
        self.lights: list[Light] = []
        self.meshes: list[MeshData] = []
        #: indices of meshes shaded per vertex (``add_mesh(..., shading="gouraud")``, see pyrt.integrators.gouraud)
        self.gouraud_meshes: set[int] = set()

    # -- building -----------------------------------------------------------------------------
    def add_material(self, material):
        """Add ``material`` (once) and return its index in :attr:`materials`."""
        if not isinstance(material, Material):
            raise SceneError(f"expected a pyrt Material, got {type(material).__name__}")
        for i, m in enumerate(self.materials):
            if m is material:
                return i
        self.materials.append(material)
        return len(self.materials) - 1

    def add_light(self, light):
        """Add a :class:`pyrt.Light`; returns it."""
        if not isinstance(light, Light):
            raise SceneError(f"expected a pyrt Light, got {type(light).__name__}")
        self.lights.append(light)
        return light

    def add_mesh(self, mesh, material, *, transform=None, smooth="auto", crease_angle=30.0, name=None, normals=None,
                 shading=None, uv_sets=None, uv=None, tangents=None):
        """Add a trimesh mesh (or a ``(vertices, faces)`` pair) with a material.

        Parameters
        ----------
        mesh : trimesh.Trimesh or (vertices, faces)
            A pair of arrays needs no trimesh (pyrt imports it only where it needs it: OBJ / PLY / STL files,
            spheres, boxes).
        material : Material
        transform : (4, 4) array, optional
            ``world_from_object``; normals use its inverse transpose. A mirroring transform (negative
            determinant) reverses the faces' winding, so that the winding normal still points to the side the
            object's normals face (glTF's rule; front/back faces: culling, entering/leaving dielectrics).
        smooth : {"auto", True, False}
            Shading normals. True: trimesh's area-weighted vertex normals; "auto": split vertices at
            edges sharper than ``crease_angle`` degrees (a box stays flat, a sphere is smooth);
            False: flat shading (shading normal = geometric normal).
        normals : (V, 3) array, optional
            Object-space vertex normals to use as given (smooth shading; overrides ``smooth``).
        shading : {None, "flat", "phong", "gouraud"}
            The course's shading models. "flat": one normal per triangle (same as ``smooth=False``);
            "phong": normals interpolated, lighting at every hit (the default with ``smooth``);
            "gouraud": lighting evaluated at the three vertices (vertex normals per ``smooth``) and
            the resulting radiance interpolated across the triangle (:mod:`pyrt.integrators.gouraud`).
        uv_sets : dict, optional
            ``{k: (V, 2)}``: UV sets k >= 1 beside the mesh's own UVs (set 0), read by textures with
            ``texcoord=k`` (glTF ``TEXCOORD_k``; :mod:`pyrt.geometry.uvsets`).
        uv : (V, 2) array, optional
            The texture coordinates (UV set 0) of a ``(vertices, faces)`` pair (a Trimesh's own are
            ``mesh.visual.uv``, used when this is None).
        tangents : (V, 4) array, optional
            Object-space vertex tangents ``(x, y, z, w)`` as glTF's ``TANGENT``: a unit tangent and the bitangent's
            sign, bitangent = ``w (normal x tangent)``. Normal maps and anisotropic lobes then use them,
            interpolated across each triangle, instead of the tangents of the UV parameterisation
            (:meth:`pyrt.geometry.SurfaceBatch.shading_tangents`). Used only with vertex normals (``normals``
            given, or smooth shading that keeps the vertices as they are); dropped where ``smooth="auto"``
            re-indexes the vertices; a vertex whose tangent is zero has none (the UV tangents are used there).
        """
        if name is not None and not isinstance(name, str):
            raise SceneError(f"mesh {name!r}: name must be a string, got {type(name).__name__}")
        name = name or f"mesh{len(self.meshes)}"
        if isinstance(crease_angle, bool) or not isinstance(crease_angle, (int, float)) \
                or not 0 <= crease_angle <= 180:
            raise SceneError(f"mesh {name!r}: crease_angle must be a number of degrees in [0, 180], got {crease_angle!r}")
        if shading not in (None, "flat", "phong", "gouraud"):
            raise SceneError(f"mesh {name!r}: shading must be None, 'flat', 'phong' or 'gouraud', got {shading!r}")
        if shading == "flat":
            smooth = False
        if isinstance(mesh, (tuple, list)):
            if len(mesh) != 2:
                raise SceneError(f"mesh {name!r}: expected a trimesh.Trimesh or a (vertices, faces) pair, got a "
                                 f"{type(mesh).__name__} of {len(mesh)} items (vertices alone? pass "
                                 "(vertices, [[0, 1, 2], ...]))")
            v_in, f_in = mesh
            try:
                v_in, f_in, vis_uv = np.asarray(v_in, dtype=np.float64), np.asarray(f_in), uv
            except (TypeError, ValueError) as exc:
                raise SceneError(f"mesh {name!r}: vertices and faces must be arrays of numbers ({exc})") from None
            if f_in.dtype.kind == "f" and np.all(f_in == np.round(f_in)):   # 0.0, 1.0, 2.0: indices (as trimesh took)
                f_in = f_in.astype(np.int64)
        else:
            tm = sys.modules.get("trimesh")     # a Trimesh was made by a program that imported trimesh
            if tm is None or not isinstance(mesh, tm.Trimesh):
                raise SceneError(f"mesh {name!r}: expected trimesh.Trimesh, got {type(mesh).__name__}")
            v_in, f_in = mesh.vertices, mesh.faces
            vis_uv = getattr(mesh.visual, "uv", None) if uv is None else uv
        if smooth not in ("auto", True, False):
            raise SceneError(f"mesh {name!r}: smooth must be 'auto', True or False, got {smooth!r}")
        v_obj, faces = validate_mesh(v_in, f_in, name)
        uv = None
        if vis_uv is not None and len(vis_uv) == len(v_in):
            uv = np.asarray(vis_uv, dtype=np.float64)
            if not np.all(np.isfinite(uv)):
                raise GeometryError(f"mesh {name!r}: texture coordinates are not finite")
        uv_sets = _checked_uv_sets(uv_sets, len(v_in), name)
        given = normals
        normals = None
        if given is not None:
            normals = np.asarray(given, dtype=np.float64)
            if normals.shape != v_obj.shape or not np.all(np.isfinite(normals)):
                raise GeometryError(f"mesh {name!r}: normals must be finite with shape {v_obj.shape}, "
                                    f"got {normals.shape}")
        # vertex tangents stay with vertex normals on the vertices as given (crease normals re-index them)
        tangents = _checked_tangents(tangents, len(v_obj), name) if given is not None or smooth is True else None
        if given is None and smooth == "auto":
            src, faces, normals = crease_normals(v_obj, faces, crease_angle, weld="edges")
            v_obj, uv = np.take(v_obj, src, axis=0), (None if uv is None else np.take(uv, src, axis=0))
            uv_sets = uv_sets and {k: np.take(a, src, axis=0) for k, a in uv_sets.items()}
        elif given is None and smooth:
            import trimesh      # its area-weighted vertex normals
            src = trimesh.Trimesh(vertices=v_obj, faces=faces, process=False)
            normals = np.asarray(src.vertex_normals, dtype=np.float64)
        m = np.eye(4) if transform is None else transform_matrix(matrix=transform)
        v_world = apply_matrix(v_obj, m)
        if not np.all(np.isfinite(v_world)):
            raise GeometryError(f"mesh {name!r}: transformed vertices are not finite")
        # Embree sees float32 vertices: keep exactly those (as float64) so that rebuilt hit points lie on
        # the triangles Embree intersects.
        if not np.all(np.abs(v_world) <= np.finfo(np.float32).max):
            raise GeometryError(f"mesh {name!r}: transformed vertices lie beyond the float32 range (|x| < 3.4e38) "
                                "Embree traces in")
        v_world = v_world.astype(np.float32).astype(np.float64)
        if normals is not None:
            normals = transform_normals(normals, m)
        if tangents is not None:
            tangents = transform_tangents(tangents, m)
        faces = rewound(faces, m)          # a mirror turns counter-clockwise into clockwise: keep the front side
        mat_id = self.add_material(material)
        self.meshes.append(MeshData(vertices=v_world, faces=faces, normals=normals, uv=uv, vertices_object=v_obj,
                                    material_id=mat_id, smooth=normals is not None, name=name, uv_sets=uv_sets or None,
                                    tangents=tangents))
        if shading == "gouraud":
            self.gouraud_meshes.add(len(self.meshes) - 1)
        return len(self.meshes) - 1

    def add_emissive_lights(self, *, n_samples=1, selection="power", min_power=0.0, name="emitters"):
        """Make the emissive meshes (materials that declare ``emits``) a light source: add one
        :class:`pyrt.EmissiveMeshLight` over them, so that every hit that receives direct light samples them with
        ``n_samples`` shadow rays (the glossy integrator MIS-combines those with its BSDF rays); ``selection``
        chooses the triangles by power (``"power"``, default) or per shading point (``"oriented"``,
        :mod:`pyrt.lights.mesh_clusters`). Call it once the
        meshes are added (later meshes are not part of it). The visible meshes of area lights added by
        :meth:`pyrt.AreaLight.add_to` are left out (their light samples them already). Returns the light, or None
        when no other mesh emits (no material declares ``emits``, or their emission is 0 at every probe point;
        nothing is added; also when its estimated power, :attr:`pyrt.EmissiveMeshLight.power` in W, is below
        ``min_power``). Off unless called: without it, emitters light other surfaces only through the glossy
        integrator's BSDF rays.
        """
        if any(lt.scene_emitter for lt in self.lights):
            raise SceneError("add_emissive_lights: the scene already has an emissive-mesh light")
        # the visible meshes of area lights (AreaLight.add_to) are sampled by their own light: not twice
        own = {lt.emitter_mesh_name for lt in self.lights if lt.has_mesh}
        ids = [i for i, m in enumerate(self.meshes) if self.materials[m.material_id].emits and m.name not in own]
        if not ids:
            return None
        light = EmissiveMeshLight(self.meshes, self.materials, mesh_ids=ids, n_samples=n_samples, selection=selection,
                                  name=name)
        return self.add_light(light) if light.sampled_triangles and light.power >= min_power else None

    # -- convenience primitives ----------------------------------------------------------------
    def add_sphere(self, center, radius, material, *, subdivisions=4, smooth=True, name=None):
        """Icosphere of ``radius`` (finite, > 0) at ``center`` (``subdivisions`` levels, an integer in
        0..:data:`MAX_SUBDIVISIONS`; 4 -> 5120 triangles, each level four times more)."""
        who = _who("sphere", name)
        (radius,) = _positive_sizes(who, "radius", radius, 1)
        if (not isinstance(subdivisions, numbers.Integral) or isinstance(subdivisions, bool)
                or not 0 <= subdivisions <= MAX_SUBDIVISIONS):
            raise SceneError(f"{who}: subdivisions must be an integer in 0..{MAX_SUBDIVISIONS}, got {subdivisions!r}")
        import trimesh
        # a unit icosphere scaled by the transform: trimesh's own radius= renormalises per level and a tiny radius
        # (1e-30) came out as NaN vertices (with a RuntimeWarning from trimesh)
        m = trimesh.creation.icosphere(subdivisions=int(subdivisions), radius=1.0)
        return self.add_mesh(m, material, transform=transform_matrix(translate=center, scale=radius), smooth=smooth,
                             name=name)

    def add_box(self, center, extents, material, *, name=None):
        """An axis-aligned box of ``extents`` (3 finite numbers > 0, or one for a cube) centred at ``center``
        (flat shaded); returns the mesh index."""
        extents = _positive_sizes(_who("box", name), "extents", extents, 3)
        import trimesh
        m = trimesh.creation.box(extents=extents)
        return self.add_mesh(m, material, transform=transform_matrix(translate=center), smooth=False, name=name)

    def add_plane(self, center, size, material, *, normal=(0, 1, 0), name=None):
        """Square of side ``size`` (or (sx, sz); finite, > 0) centred at ``center`` facing ``normal``
        (default +y), with UVs."""
        sx, sz = _positive_sizes(_who("plane", name), "size", size, 2)
        v, f, uv = plane_quad(sx, sz)
        nrm = checks.numbers_array(_who("plane", name), "normal", normal, SceneError)
        if nrm.shape != (3,) or not np.all(np.isfinite(nrm)) or np.linalg.norm(nrm) == 0:
            raise SceneError(f"{_who('plane', name)}: normal must be a finite non-zero 3-vector, got {normal!r}")
        rot = align_vectors([0, 1, 0], nrm / np.linalg.norm(nrm))
        m = transform_matrix(translate=center) @ rot
        return self.add_mesh((v, f), material, transform=m, smooth=False, name=name, uv=uv)

    # -- checks ----------------------------------------------------------------------------------
    def validate(self):
        """Check every parameter again as it is now; raise the family's :class:`pyrt.Error` naming the object.

        :class:`pyrt.PreparedScene` calls it before every render, so an attribute assigned after
        construction (``light.intensity = float("nan")``, ``mat.albedo_value = 2.0``, ``camera.fov = 0``)
        is an error rather than a silently wrong image: the camera, ``background`` and ``ambient``, every
        material, every light and every environment (the scene's and those of its lights) are checked by
        their own ``validate()``.
        """
        self.camera.validate()
        _rgb("Scene", "background", self.background)
        _rgb("Scene", "ambient", self.ambient)
        for m in self.materials:
            m.validate()
        envs = [self.environment] if self.environment is not None else []
        for lt in self.lights:
            lt.validate()
            if lt.environment is not None and all(lt.environment is not e for e in envs):
                envs.append(lt.environment)
        for env in envs:
            env.validate()

    # -- queries ---------------------------------------------------------------------------------
    def geometry_table(self):
        """The flat float64 :class:`pyrt.geometry.GeometryTable` of every mesh (what the accelerator is built from)."""
        if not self.meshes:
            raise SceneError("the scene has no meshes")
        return GeometryTable(self.meshes, shading_normal_fallback=self.shading_normal_fallback)

    def bounds(self):
        """World bounding box ``(lo (3,), hi (3,))`` of all meshes."""
        v = np.concatenate([m.vertices for m in self.meshes])
        return v.min(axis=0), v.max(axis=0)
