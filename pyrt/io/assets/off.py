"""OFF (Geomview's Object File Format; the Princeton Shape Benchmark's and ModelNet's meshes) -> :class:`Asset`.

The ASCII format, read here without trimesh (which drops OFF colours)::

    [ST][C][N]OFF            header keyword (ModelNet glues the counts to it: "OFF490 518 0")
    NV NF NE                 vertex, face and edge counts (edges are ignored)
    x y z [nx ny nz] [r g b [a]] [s t]          NV vertex lines (N: normals, used; C: colour; ST: texture
                                                 coordinates, ignored)
    n i_1 ... i_n [r g b [a] | colormap index]  NF polygons, indices from 0, an optional colour

``#`` starts a comment; blank lines are skipped. Polygons are split into fans ``(i_1, i_k, i_k+1)``. Colours are
sRGB, integers 0..255 or, written with a decimal point, floats 0..1 (Geomview's rule), and are linearised like PLY's;
a face colour applies to all triangles of its polygon. A colormap index (one number) cannot be resolved without
Geomview's colour map: it is ignored with a warning. Binary OFF, 4D (``4OFF``) and n-dimensional (``nOFF``) files and
any inconsistency (a count that does not match, an index out of range, a non-number) are errors naming the file and
the line. Polygons with fewer than 3 vertices are skipped with a warning. No up axis is stored: the previewer guesses.
"""
from __future__ import annotations

import os
import re

import numpy as np

from pyrt.shaders import color as _color
from pyrt.shaders.vec import dot, normalize
from pyrt.io.assets.asset import Asset, AssetInstance, AssetMesh
from pyrt.io.assets.common import AssetError

_HEADER = re.compile(r"^(ST)?(C)?(N)?(4)?(n)?OFF(.*)$")


def _lines(path):
    """The file's non-empty lines without comments, as ``(line number, text)`` pairs."""
    with open(path, "rb") as fh:
        raw = fh.read()
    if b"\0" in raw[:4096]:
        raise AssetError(f"{path}: binary OFF files are not read (only the ASCII format)")
    text = raw.decode("latin-1")
    if "#" in text:
        text = re.sub(r"#[^\r\n]*", "", text)      # comments removed, the line structure kept
    return [(k, line) for k, line in enumerate(map(str.strip, text.splitlines()), start=1) if line]


def _numbers(path, rows, what):
    """The numbers on ``rows`` (``(line number, text)``) as one float array, or an error naming the first bad line."""
    try:
        return np.array(" ".join(t for _, t in rows).split(), dtype=np.float64)
    except ValueError:
        for k, t in rows:
            try:
                [float(x) for x in t.split()]
            except ValueError:
                raise AssetError(f"{path}: line {k}: {what} {t[:60]!r} is not a list of numbers") from None
        raise


def _colour(path, tokens, values, where):
    """Linear RGB from colour columns ``values`` (M, 3 or 4): 0..1 floats if any token has a decimal point or an
    exponent, else 0..255 integers."""
    floats = any(("." in t or "e" in t.lower()) for t in tokens)
    rgb = values[:, :3] if floats else values[:, :3] / 255.0
    if not np.all(np.isfinite(rgb)):
        raise AssetError(f"{path}: {where} colours contain NaN or Inf")
    return _color.srgb_decode(np.clip(rgb, 0.0, 1.0))


def load_off(path):
    """Load an ASCII OFF file (module docstring) into an :class:`Asset`: one mesh (the default clay material,
    vertex or face colours when the file has them) with one identity instance.

    Raises
    ------
    AssetError
        Naming the file and, where there is one, the line: not an OFF header, binary / 4D / nD OFF, wrong counts,
        a vertex that is not finite, an index out of range, no polygon with 3 or more vertices. When data lines
        follow the announced vertices and faces, the error says the header's counts are too small (the blocks
        were cut in the wrong place), whatever else went wrong.
    """
    found = {}
    try:
        asset = _load_off(path, found)
    except AssetError as exc:
        if found.get("left", 0) > 0:
            raise AssetError(f"{exc} -- the header (line {found['line']}) announces {found['nv']} vertices and "
                             f"{found['nf']} faces, but {found['left']} more data line(s) follow them: are the "
                             "counts too small?") from None
        raise
    if found["left"] > 0:
        raise AssetError(f"{path}: the header (line {found['line']}) announces {found['nv']} vertices and "
                         f"{found['nf']} faces, but {found['left']} more data line(s) follow them: the counts are "
                         "too small (or the file has trailing data)")
    return asset


def _load_off(path, found):
    """:func:`load_off`'s work; fills ``found`` (nv, nf, their line, the data lines left after the faces) as soon
    as the header is read."""
    lines = _lines(path)
    if not lines:
        raise AssetError(f"{path}: empty OFF file")
    k0, head = lines[0]
    m = _HEADER.match(head)
    if m is None:
        raise AssetError(f"{path}: line {k0}: not an OFF header ({head[:40]!r}; expected OFF, COFF, NOFF, STOFF ...)")
    st, has_c, has_n, four, ndim, rest = m.groups()
    if four or ndim:
        raise AssetError(f"{path}: line {k0}: {head.split()[0]!r}: 4D and n-dimensional OFF files are not read")
    if rest.strip().upper().startswith("BINARY"):
        raise AssetError(f"{path}: binary OFF files are not read (only the ASCII format)")
    body = lines[1:]
    if rest.strip():                                  # counts glued to the keyword (ModelNet)
        body = [(k0, rest.strip())] + body
    if not body:
        raise AssetError(f"{path}: no vertex / face counts after the header")
    kc, counts = body[0]
    try:
        nv, nf = (int(x) for x in counts.split()[:2])
    except ValueError:
        raise AssetError(f"{path}: line {kc}: expected the vertex and face counts, got {counts[:40]!r}") from None
    if nv <= 0 or nf <= 0:
        raise AssetError(f"{path}: line {kc}: {nv} vertices and {nf} faces: no triangles")
    found.update(nv=nv, nf=nf, line=kc, left=len(body) - (1 + nv + nf))
    if len(body) < 1 + nv + nf:
        raise AssetError(f"{path}: the header announces {nv} vertices and {nf} faces but the file has "
                         f"{len(body) - 1} data lines (truncated?)")
    warnings = []
    # ---- vertices: one block of numbers
    vrows = body[1:1 + nv]
    vals = _numbers(path, vrows, "vertex")
    ncol = len(vrows[0][1].split())
    if ncol < 3 or vals.size != nv * ncol:
        raise AssetError(f"{path}: vertex lines {vrows[0][0]}-{vrows[-1][0]} do not all have the same number (>= 3) "
                         "of values")
    vals = vals.reshape(nv, ncol)
    v = vals[:, :3]
    if not np.all(np.isfinite(v)):
        bad = int(np.flatnonzero(~np.isfinite(v).all(axis=1))[0])
        raise AssetError(f"{path}: line {vrows[bad][0]}: vertex {bad} is not finite (NaN or Inf coordinates)")
    col = 3 + (3 if has_n else 0)
    n_colour = ncol - col - (2 if st else 0)
    colors = None
    if has_c and n_colour in (3, 4):
        colors = _colour(path, vrows[0][1].split()[col:col + n_colour], vals[:, col:col + n_colour], "vertex")
    elif has_c:
        warnings.append(f"{path}: COFF vertex lines have {n_colour} colour values (expected 3 or 4): colours ignored")
    # ---- faces: grouped by (tokens per line, polygon size), each group parsed as one block and fanned at once
    frows = body[1 + nv:1 + nv + nf]
    faces, owner, line, extra, extra_tokens = _polygons(path, frows, warnings)
    f = faces.astype(np.int64)
    if np.any(f != faces) or f.min() < 0 or f.max() >= nv:
        bad = int(np.flatnonzero(((f != faces) | (f < 0) | (f >= nv)).any(axis=1))[0])
        k, t = frows[line[bad]]
        raise AssetError(f"{path}: line {k}: face {t[:60]!r} refers to a vertex that does not exist (indices must "
                         f"be integers in [0, {nv}))")
    face_colors = None
    if extra.shape[1] in (3, 4) and colors is None:
        face_colors = _colour(path, extra_tokens, extra, "face")[owner]
    elif extra.shape[1] == 1:
        warnings.append(f"{path}: faces carry colour-map indices (Geomview's colour map is not known): ignored")
    elif extra.shape[1] not in (0, 3, 4):
        warnings.append(f"{path}: faces carry {extra.shape[1]} values after their indices (expected a colour of 3 "
                        "or 4): ignored")
    normals = None
    if has_n:
        nrm = vals[:, 3:6]
        if np.all(np.isfinite(nrm)) and np.all(dot(nrm, nrm) > 0):
            normals = normalize(nrm)
        else:
            warnings.append(f"{path}: NOFF normals that are zero or not finite: normals computed instead")
    asset = Asset(path=path, format="off")
    asset.warnings.extend(warnings)
    name = os.path.basename(path)
    asset.meshes.append(AssetMesh(name=name, vertices=np.ascontiguousarray(v), faces=f, normals=normals,
                                  colors=colors, face_colors=face_colors, material=-1))
    asset.instances.append(AssetInstance(mesh=0, world_from_object=np.eye(4), node=name))
    return asset


def _polygons(path, frows, warnings):
    """The triangles of the face lines ``frows`` (fans), the polygon each comes from (its rank among the polygons
    kept) and its face line (an index into ``frows``), the values after each kept polygon's indices (kept polygons x
    columns; no columns when they differ in number) and the first kept polygon's tokens of them (the colour scale)."""
    parts = [t.split() for _, t in frows]
    try:
        sizes = np.fromiter((int(p[0]) for p in parts), dtype=np.int64, count=len(parts))
    except ValueError:
        k, t = next((k, t) for (k, t), p in zip(frows, parts) if not p[0].lstrip("-").isdigit())
        raise AssetError(f"{path}: line {k}: face {t[:60]!r} is not 'n i_1 ... i_n [colour]'") from None
    widths = np.fromiter((len(p) for p in parts), dtype=np.int64, count=len(parts))
    short = widths < sizes + 1
    if short.any():
        j = int(np.flatnonzero(short)[0])
        raise AssetError(f"{path}: line {frows[j][0]}: face announces {sizes[j]} vertices but lists {widths[j] - 1}")
    keep = sizes >= 3
    if not keep.all():
        warnings.append(f"{path}: {int((~keep).sum())} face(s) with fewer than 3 vertices skipped")
    if not keep.any():
        raise AssetError(f"{path}: no faces with 3 or more vertices")
    rank = np.cumsum(keep) - 1                     # polygon -> its rank among the kept ones
    n_extra = widths - 1 - sizes
    same_extra = np.unique(n_extra[keep]).size == 1
    if not same_extra:
        warnings.append(f"{path}: faces carry colours of different lengths: face colours ignored")
    ne = int(n_extra[keep][0]) if same_extra else 0
    extra = np.zeros((int(keep.sum()), ne))
    tris, owner, poly, corner = [], [], [], []
    for w, n in sorted(set(zip(widths[keep].tolist(), sizes[keep].tolist()))):
        rows = np.flatnonzero(keep & (widths == w) & (sizes == n))
        block = _numbers(path, [frows[j] for j in rows], "face").reshape(rows.size, w)
        idx = block[:, 1:1 + n]
        for i in range(1, n - 1):                  # fan (i_1, i_k, i_k+1), in the polygon's order
            tris.append(idx[:, [0, i, i + 1]])
            owner.append(rank[rows])
            poly.append(rows)
            corner.append(np.full(rows.size, i))
        if ne:
            extra[rank[rows]] = block[:, 1 + n:]
    poly = np.concatenate(poly)
    sort = np.lexsort((np.concatenate(corner), poly))     # polygon by polygon, fan by fan
    first = int(np.flatnonzero(keep)[0])
    return (np.concatenate(tris)[sort], np.concatenate(owner)[sort], poly[sort], extra,
            parts[first][1 + int(sizes[first]):])
