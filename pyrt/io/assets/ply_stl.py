"""PLY and STL -> :class:`Asset` through trimesh: one mesh, the default "clay" material; PLY normals
are used when the file has them, PLY vertex colours and face colours (8-bit sRGB) are linearised (face colours
shade each triangle with its own colour, :class:`~pyrt.io.assets.materials.FaceColorTexture`).

PLY triangle strips: a ``tristrips`` element (a list property of vertex indices per strip, ``-1`` restarting the
strip, as the Stanford scanning repository writes them), which trimesh does not read, is read here
(:func:`read_ply_tristrips`) into triangles when the file has no ``face`` element: triangle ``k`` of a run is
``(s_k, s_k+1, s_k+2)`` for even ``k`` and ``(s_k+1, s_k, s_k+2)`` for odd ``k`` (the winding kept, as in OpenGL and
glTF strips); triangles with a repeated index (strip stitching) are dropped.

PLY textures: a ``comment TextureFile NAME`` header line (what MeshLab and photogrammetry tools write beside
per-vertex ``s t`` / ``texture_u texture_v`` or per-face ``texcoord`` coordinates, which trimesh reads) names the
colour image. The mesh then gets the material an OBJ scan gets from ``Kd 1 1 1`` and ``map_Kd NAME``: the image
as its diffuse colour (sRGB), found and reduced as MTL maps are (:func:`pyrt.io.assets.obj.colour_map`). A missing
image is a substitution (the clay material); a TextureFile without texture coordinates is a warning."""
from __future__ import annotations

import os
import re

import numpy as np

from pyrt.io.assets.common import AssetError, MTLParams, face_colors, trimesh_load, vertex_colors
from pyrt.io.assets.asset import Asset, AssetInstance, AssetMesh
from pyrt.io.assets.obj import colour_map


def load_ply_stl(path, fmt, max_texture=None):
    """Load a PLY or STL file (``fmt`` "ply" or "stl") into an :class:`Asset` with one mesh.

    Parameters
    ----------
    path : str
        The model file.
    fmt : {"ply", "stl"}
        Its format (names the format in error messages; PLY normals are read when present).
    max_texture : int, optional
        A PLY's texture image longer than this is reduced as it is decoded (:func:`pyrt.io.assets.load_asset`).

    Returns
    -------
    Asset
        One mesh (``material = -1``: the default clay) with one identity instance.
    """
    import trimesh  # deferred (pyrt.core.transforms)
    asset = Asset(path=path, format=fmt)
    if fmt == "stl":
        _check_binary_stl_size(path)
    strips = read_ply_tristrips(path) if fmt == "ply" else None
    if strips is not None:
        tm = _strip_mesh(path, *strips)
        asset.warnings.append(f"{path}: triangle strips read ({len(strips[1])} strip(s), {len(tm.faces)} triangles)")
    else:
        # skip_materials: trimesh would decode a PLY's TextureFile image itself (a second decode of what is read
        # here, and a logged traceback when the file is not where the header names it); the UVs are still read
        tm = trimesh_load(path, fmt.upper(), skip_materials=True)
    if isinstance(tm, trimesh.Scene):
        meshes = [g for g in tm.dump() if isinstance(g, trimesh.Trimesh)] if hasattr(tm, "dump") else []
        tm = trimesh.util.concatenate(meshes) if meshes else None
    if not isinstance(tm, trimesh.Trimesh) or len(tm.faces) == 0:
        raise AssetError(f"{path}: no triangles found in the {fmt.upper()} file")
    normals = None
    if fmt == "ply" and _ply_has_normals(path):
        normals = np.asarray(tm.vertex_normals, dtype=np.float64)
    colors = vertex_colors(tm)
    fcolors = face_colors(tm) if colors is None else None
    uv = getattr(tm.visual, "uv", None)
    uv = np.asarray(uv, dtype=np.float64) if uv is not None and len(uv) == len(tm.vertices) else None
    v = np.asarray(tm.vertices, dtype=np.float64)
    if not np.all(np.isfinite(v)):
        raise AssetError(f"{path}: vertex positions contain NaN or Inf")
    f = np.asarray(tm.faces, dtype=np.int64)
    if f.min() < 0 or f.max() >= len(v):
        raise AssetError(f"{path}: face {int(np.flatnonzero((f < 0).any(1) | (f >= len(v)).any(1))[0])} refers to a "
                         f"vertex that does not exist (indices must be in [0, {len(v)}))")
    material = -1
    texture_name = ply_texture_file(path) if fmt == "ply" else None
    if texture_name is not None and uv is None:
        asset.warnings.append(f"{path}: comment TextureFile {texture_name!r} but no texture coordinates: the "
                              "texture is not used")
    elif texture_name is not None:
        subst = []
        tex = colour_map(texture_name, os.path.dirname(os.path.abspath(path)), f"{path}: comment TextureFile",
                         warnings=asset.warnings, substitutions=subst, max_texture=max_texture)
        for msg in subst:
            asset.substitute(msg.replace("rendered with the factor alone", "rendered with the clay material")
                             if tex is None else msg)
        if tex is not None:
            asset.materials = [MTLParams(name=os.path.basename(texture_name), Kd=np.ones(3), map_Kd=tex)]
            material = 0
    asset.meshes.append(AssetMesh(name=os.path.basename(path), vertices=v, faces=np.asarray(tm.faces, dtype=np.int64),
                                  normals=normals, uv=uv, colors=colors, face_colors=fcolors, material=material))
    asset.instances.append(AssetInstance(mesh=0, world_from_object=np.eye(4), node=os.path.basename(path)))
    return asset


def ply_texture_file(path):
    """The image a PLY header names in its first ``comment TextureFile NAME`` line, or None (no such line, or not a
    PLY header)."""
    with open(path, "rb") as fh:
        head = fh.read(1 << 16)
    end = head.find(b"end_header")
    if not head.startswith(b"ply") or end < 0:
        return None
    for line in head[:end].decode("latin-1").splitlines():
        parts = line.strip().split(None, 2)
        if len(parts) == 3 and parts[0] == "comment" and parts[1].lower() == "texturefile":
            return parts[2].strip()
    return None


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


# ============================================================================ PLY triangle strips

_PLY_TYPES = {"char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1", "short": "i2", "int16": "i2",
              "ushort": "u2", "uint16": "u2", "int": "i4", "int32": "i4", "uint": "u4", "uint32": "u4",
              "float": "f4", "float32": "f4", "double": "f8", "float64": "f8"}


def read_ply_tristrips(path):
    """A PLY file with a ``tristrips`` element and no ``face`` element: ``(vertex, strips)`` with ``vertex`` a dict
    of the vertex element's scalar properties (name -> (V,) array: ``x y z``, and ``nx ny nz``, ``red green blue``
    when present) and ``strips`` a list of int64 index arrays (one per strip, ``-1`` = restart); None for any other
    PLY file (trimesh reads those). trimesh reads neither such binary files ("unexpected length") nor the strips.

    ASCII: one line per element row; binary (either byte order): fixed-size rows by their size, rows with lists one
    by one; each strip is the first list property of its row.

    Raises
    ------
    AssetError
        A malformed header, an unknown property type, a vertex element with a list, or data that ends before the
        strips do (naming the file).
    """
    with open(path, "rb") as fh:
        data = fh.read()
    end = data.find(b"end_header")
    if not data.startswith(b"ply") or end < 0:
        return None
    body = data.index(b"\n", end) + 1 if b"\n" in data[end:] else len(data)
    fmt, elements = None, []
    for line in data[:end].decode("ascii", errors="replace").splitlines():
        tok = line.split()
        if not tok:
            continue
        if tok[0] == "format" and len(tok) > 1:
            fmt = tok[1]
        elif tok[0] == "element" and len(tok) > 2:
            elements.append((tok[1], int(tok[2]), []))
        elif tok[0] == "property" and elements:
            elements[-1][2].append(tok[1:])
    names = [e[0] for e in elements]
    if "tristrips" not in names or "face" in names or "vertex" not in names:
        return None
    for name, _, props in elements:
        for p in props:
            for t in (p[1:3] if p[0] == "list" else p[:1]):
                if t not in _PLY_TYPES:
                    raise AssetError(f"{path}: PLY property type {t!r} is not supported")
            if name == "vertex" and p[0] == "list":
                raise AssetError(f"{path}: a PLY vertex element with a list property is not supported")
    vertex, strips = None, None
    if fmt == "ascii":
        lines = data[body:].decode("ascii", errors="replace").splitlines()
        row = 0
        for name, count, props in elements:
            rows = lines[row: row + count]
            if len(rows) < count:
                raise AssetError(f"{path}: the file ends before its {count} {name} rows (truncated)")
            if name == "vertex":
                try:
                    vals = np.asarray(" ".join(rows).split(), dtype=np.float64).reshape(count, len(props))
                except ValueError as exc:
                    raise AssetError(f"{path}: malformed vertex rows: {exc}") from None
                vertex = {p[1]: vals[:, i] for i, p in enumerate(props)}
            elif name == "tristrips":
                strips = [_ascii_strip(path, r, props) for r in rows]
            row += count
        return vertex, strips
    order = {"binary_little_endian": "<", "binary_big_endian": ">"}.get(fmt)
    if order is None:
        raise AssetError(f"{path}: unknown PLY format {fmt!r}")
    off = body
    for name, count, props in elements:
        if name == "vertex":
            dt = np.dtype([(p[1], order + _PLY_TYPES[p[0]]) for p in props])
            rec, off = _read(path, data, off, dt, count, name)
            vertex = {p[1]: rec[p[1]] for p in props}
        elif name == "tristrips":
            strips = []
            for _ in range(count):
                strip = None
                for p in props:
                    if p[0] == "list":
                        n, off = _read(path, data, off, np.dtype(order + _PLY_TYPES[p[1]]), 1, name)
                        vals, off = _read(path, data, off, np.dtype(order + _PLY_TYPES[p[2]]), int(n[0]), name)
                        strip = vals.astype(np.int64) if strip is None else strip
                    else:
                        off = _read(path, data, off, np.dtype(order + _PLY_TYPES[p[0]]), 1, name)[1]
                strips.append(strip if strip is not None else np.zeros(0, dtype=np.int64))
        else:
            off = _skip_rows(path, data, off, count, props, order)
    return vertex, strips


def _read(path, data, off, dt, n, element="tristrips"):
    """``n`` values of ``dt`` at byte ``off`` and the offset after them (AssetError past the end)."""
    if off + n * dt.itemsize > len(data):
        raise AssetError(f"{path}: the PLY data ends at byte {len(data)} inside the {element} (truncated)")
    return np.frombuffer(data, dtype=dt, count=n, offset=off), off + n * dt.itemsize


def _skip_rows(path, data, off, count, props, order):
    """Byte offset after ``count`` binary rows of ``props`` starting at ``off``."""
    if all(p[0] != "list" for p in props):
        return off + count * sum(np.dtype(_PLY_TYPES[p[0]]).itemsize for p in props)
    for _ in range(count):
        for p in props:
            if p[0] == "list":
                cdt = np.dtype(order + _PLY_TYPES[p[1]])
                n, off = _read(path, data, off, cdt, 1, "element before the tristrips")
                off += int(n[0]) * np.dtype(_PLY_TYPES[p[2]]).itemsize
            else:
                off += np.dtype(_PLY_TYPES[p[0]]).itemsize
    return off


def _ascii_strip(path, row, props):
    tok = row.split()
    try:
        i = 0
        strip = None
        for p in props:
            if p[0] == "list":
                n = int(tok[i])
                vals = np.asarray([int(float(t)) for t in tok[i + 1: i + 1 + n]], dtype=np.int64)
                if vals.size != n:
                    raise ValueError(f"{n} indices announced, {vals.size} found")
                strip = vals if strip is None else strip
                i += 1 + n
            else:
                i += 1
        return strip if strip is not None else np.zeros(0, dtype=np.int64)
    except (ValueError, IndexError) as exc:
        raise AssetError(f"{path}: malformed tristrips row {row[:60]!r}: {exc}") from None


def tristrip_faces(strips):
    """Triangles (F, 3) int64 of triangle strips (each an index array; ``-1`` restarts a strip; see the module
    docstring for the winding); triangles with a repeated index are dropped."""
    parts = [np.asarray(s, dtype=np.int64) for s in strips]
    seq = np.concatenate([np.r_[p, -1] for p in parts]) if parts else np.zeros(0, dtype=np.int64)
    if seq.size < 3:
        return np.zeros((0, 3), dtype=np.int64)
    k = np.arange(seq.size - 2)
    a, b, c = seq[k], seq[k + 1], seq[k + 2]
    marks = np.where(seq < 0, np.arange(seq.size), -1)
    start = np.maximum.accumulate(marks) + 1               # first index of the run each position belongs to
    odd = (k - start[k]) % 2 == 1
    a, b = np.where(odd, b, a), np.where(odd, a, b)
    keep = (a >= 0) & (b >= 0) & (c >= 0) & (a != b) & (b != c) & (a != c)
    return np.stack([a[keep], b[keep], c[keep]], axis=1)


def _strip_mesh(path, vertex, strips):
    """A trimesh of :func:`read_ply_tristrips`'s output (x y z, the normals and 8-bit colours when present)."""
    import trimesh  # deferred (pyrt.core.transforms)
    if not all(k in vertex for k in "xyz"):
        raise AssetError(f"{path}: the PLY vertex element has no x, y, z properties")
    v = np.stack([np.asarray(vertex[k], dtype=np.float64) for k in "xyz"], axis=1)
    faces = tristrip_faces(strips)
    if faces.size and (faces.max() >= len(v) or faces.min() < 0):
        raise AssetError(f"{path}: tristrips refer to vertex {int(faces.max())} but the file has {len(v)} vertices")
    colors = None
    if all(k in vertex for k in ("red", "green", "blue")):
        colors = np.stack([vertex[k] for k in ("red", "green", "blue")], axis=1)
        colors = np.clip(colors, 0, 255).astype(np.uint8) if colors.dtype != np.uint8 else colors
    nrm = np.stack([vertex[k] for k in ("nx", "ny", "nz")], axis=1) if all(
        k in vertex for k in ("nx", "ny", "nz")) else None
    return trimesh.Trimesh(vertices=v, faces=faces, vertex_normals=nrm, vertex_colors=colors, process=False)
