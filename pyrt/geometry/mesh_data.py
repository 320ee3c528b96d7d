"""A mesh as the scene holds it (:class:`MeshData`, world space, float64) and the checks every mesh passes on its way
in (:func:`validate_mesh`, :func:`degenerate_faces`)."""
from __future__ import annotations

from dataclasses import dataclass
import warnings

import numpy as np

from pyrt.core.errors import Error
from pyrt.shaders.vec import cross, norm, take_rows


class GeometryError(Error, ValueError):
    """A mesh cannot be rendered (non-finite vertices, bad indices, no valid triangle)."""


@dataclass
class MeshData:
    """One mesh in world space (float64), after validation."""

    vertices: np.ndarray          # (V, 3) world space
    faces: np.ndarray             # (F, 3) int64
    normals: np.ndarray | None    # (V, 3) unit world-space vertex normals or None (flat)
    uv: np.ndarray | None         # (V, 2) or None
    vertices_object: np.ndarray   # (V, 3) object space (for 3D procedural textures)
    material_id: int
    smooth: bool
    name: str
    uv_sets: dict | None = None   # {k: (V, 2)} UV sets k >= 1 a material reads (pyrt.geometry.uvsets)
    tangents: np.ndarray | None = None   # (V, 4) unit world-space vertex tangents + bitangent sign (glTF TANGENT)


def validate_mesh(vertices, faces, name):
    """Check a mesh and drop degenerate triangles.

    Non-finite vertices and out-of-range indices raise :class:`GeometryError` naming the mesh.
    Zero-area triangles (including repeated indices) are *skipped with a warning*: they cannot be
    hit and have no normal. Returns ``(vertices float64, faces int64 with degenerate rows removed)``.
    """
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces)
    if f.size == 0:     # an OBJ of points or lines only: say what is missing, not a shape
        raise GeometryError(f"mesh {name!r} has no triangles")
    if v.ndim != 2 or v.shape[1] != 3 or v.shape[0] == 0:
        raise GeometryError(f"mesh {name!r}: vertices must have shape (V, 3), got {v.shape}")
    if f.ndim != 2 or f.shape[1] != 3:
        raise GeometryError(f"mesh {name!r}: faces must have shape (F, 3), got {f.shape}")
    if not np.issubdtype(f.dtype, np.integer):
        raise GeometryError(f"mesh {name!r}: faces must be integer indices, got {f.dtype}")
    bad = ~np.all(np.isfinite(v), axis=1)
    if np.any(bad):
        raise GeometryError(f"mesh {name!r}: {int(bad.sum())} non-finite vertex coordinates (NaN or Inf): "
                            f"vertices are not finite, first at index {int(np.flatnonzero(bad)[0])}")
    f = f.astype(np.int64)
    if f.min() < 0 or f.max() >= v.shape[0]:
        raise GeometryError(f"mesh {name!r}: face indices out of range [0, {v.shape[0]})")
    degenerate = degenerate_faces(v, f)
    if np.all(degenerate):
        raise GeometryError(f"mesh {name!r}: all {f.shape[0]} triangles are degenerate (zero area)")
    if np.any(degenerate):
        warnings.warn(f"mesh {name!r}: skipping {int(degenerate.sum())} degenerate (zero-area) triangles",
                      stacklevel=3)
        f = f[~degenerate]
    return v, f


def degenerate_faces(vertices, faces):
    """(F,) bool: the triangles :func:`validate_mesh` skips, those whose doubled area ``|e1 x e2|`` is at most
    ``(eps32 max|v|)^2`` (zero once float32 rounding is near; repeated indices included)."""
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    p0 = take_rows(v, f[:, 0])
    area2 = norm(cross(take_rows(v, f[:, 1]) - p0, take_rows(v, f[:, 2]) - p0))
    scale = np.max(np.abs(v)) if v.size else 1.0
    return area2 <= (np.finfo(np.float32).eps * max(scale, 1e-30)) ** 2
