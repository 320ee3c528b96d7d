"""PLY and STL -> :class:`Asset` through trimesh: one mesh, the default "clay" material; PLY normals
are used when the file has them, PLY vertex colours (8-bit sRGB) are linearised."""
from __future__ import annotations

import os
import re

import numpy as np
import trimesh

from pyrt.io.assets.common import AssetError, trimesh_load, vertex_colors
from pyrt.io.assets.asset import Asset, AssetInstance, AssetMesh


def load_ply_stl(path, fmt):
    """Load a PLY or STL file (``fmt`` "ply" or "stl") into an :class:`Asset` with one mesh.

    Parameters
    ----------
    path : str
        The model file.
    fmt : {"ply", "stl"}
        Its format (names the format in error messages; PLY normals are read when present).

    Returns
    -------
    Asset
        One mesh (``material = -1``: the default clay) with one identity instance.
    """
    asset = Asset(path=path, format=fmt)
    if fmt == "stl":
        _check_binary_stl_size(path)
    tm = trimesh_load(path, fmt.upper())
    if isinstance(tm, trimesh.Scene):
        meshes = [g for g in tm.dump() if isinstance(g, trimesh.Trimesh)] if hasattr(tm, "dump") else []
        tm = trimesh.util.concatenate(meshes) if meshes else None
    if not isinstance(tm, trimesh.Trimesh) or len(tm.faces) == 0:
        raise AssetError(f"{path}: no triangles found in the {fmt.upper()} file")
    normals = None
    if fmt == "ply" and _ply_has_normals(path):
        normals = np.asarray(tm.vertex_normals, dtype=np.float64)
    colors = vertex_colors(tm)
    uv = getattr(tm.visual, "uv", None)
    uv = np.asarray(uv, dtype=np.float64) if uv is not None and len(uv) == len(tm.vertices) else None
    v = np.asarray(tm.vertices, dtype=np.float64)
    if not np.all(np.isfinite(v)):
        raise AssetError(f"{path}: vertex positions contain NaN or Inf")
    f = np.asarray(tm.faces, dtype=np.int64)
    if f.min() < 0 or f.max() >= len(v):
        raise AssetError(f"{path}: face {int(np.flatnonzero((f < 0).any(1) | (f >= len(v)).any(1))[0])} refers to a "
                         f"vertex that does not exist (indices must be in [0, {len(v)}))")
    asset.meshes.append(AssetMesh(name=os.path.basename(path), vertices=v, faces=np.asarray(tm.faces, dtype=np.int64),
                                  normals=normals, uv=uv, colors=colors, material=-1))
    asset.instances.append(AssetInstance(mesh=0, world_from_object=np.eye(4), node=os.path.basename(path)))
    return asset


def _check_binary_stl_size(path):
    """A binary STL (not starting with ``solid``) is 84 + 50 n bytes for the n triangles its header names: a
    truncated or padded one is refused here (trimesh would try to decode it as text and fail obscurely)."""
    size = os.path.getsize(path)
    with open(path, "rb") as fh:
        head = fh.read(84)
    if head[:5].lower() == b"solid" and b"\0" not in head:   # ASCII STL (binary headers may say "solid" too)
        return
    if len(head) < 84:
        raise AssetError(f"{path}: not a readable STL file (truncated: {size} bytes, a binary STL header is 84)")
    n = int.from_bytes(head[80:84], "little")
    if size != 84 + 50 * n:
        raise AssetError(f"{path}: not a readable STL file (binary header says {n} triangles = {84 + 50 * n} "
                         f"bytes, the file has {size})")


def _ply_has_normals(path):
    with open(path, "rb") as fh:
        head = fh.read(4096)
    end = head.find(b"end_header")
    return re.search(rb"property\s+\w+\s+nx\b", head[: end if end > 0 else None]) is not None
