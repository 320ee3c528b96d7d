"""The per-vertex attributes the compiled kernel reads beside the geometry: vertex colours and vertex tangent frames.

Vertex colours (glTF ``COLOR_0``) reach a material as a :class:`pyrt.io.assets.VertexColorTexture` bound to scene
meshes, multiplied into its colour slot 0 (:data:`pyrt.materials.compiled.VERTEX_COLOR` names the texture's row of
the texture table). :func:`vertex_colors` packs, for every mesh whose material reads such a texture, the colours
bound to that mesh into one (V, 3) table aligned with the geometry's vertices (white for a mesh the texture has no
colours for, as the texture's lookup gives); the kernel interpolates them at the hit
(:func:`pyrt.integrators.compiled_diffs.vertex_color`). Vertex tangent frames are the geometry's own
(:attr:`pyrt.geometry.GeometryTable.tangent_frames`, read by normal maps:
:func:`pyrt.integrators.compiled_diffs.vertex_tangents`).
"""
from __future__ import annotations

import numpy as np

from pyrt.materials import compiled as MC


def vertex_color_textures(records, texture_objects):
    """``{material index: vertex-colour texture}`` of the packed material ``records`` (``(tag, record)`` or None)
    whose :data:`pyrt.materials.compiled.VERTEX_COLOR` field names a texture (``texture_objects``: the texture
    table's objects by row)."""
    out = {}
    for k, packed in enumerate(records):
        if packed is not None and packed[1][MC.VERTEX_COLOR] > 0.0:
            out[k] = texture_objects[int(packed[1][MC.VERTEX_COLOR]) - 1]
    return out


def vertex_colors(meshes, textures):
    """``(table, reasons)``: the vertex colours of the meshes (each with ``material_id``, ``vertices`` and ``faces``,
    in the geometry's order) whose material reads some (``textures``: :func:`vertex_color_textures`), as a
    C-contiguous (V, 3) float64 table over all the meshes' vertices (ones elsewhere; one row of ones when no material
    reads any), and why the kernel cannot read them (an empty list when it can): colours bound with faces other
    than the mesh's or not one per vertex."""
    if not textures:
        return np.ones((1, 3)), []
    n = [m.vertices.shape[0] for m in meshes]
    table = np.ones((sum(n), 3))
    reasons = []
    at = 0
    for k, (m, nv) in enumerate(zip(meshes, n)):
        tex = textures.get(m.material_id)
        bound = None if tex is None else tex.bound(k)
        if bound is not None:
            faces, colors = bound
            if colors.shape != (nv, 3) or not (faces is m.faces or np.array_equal(faces, m.faces)):
                reasons.append(f"vertex colours of mesh {k} not one per vertex of its faces")
            else:
                table[at:at + nv] = colors
        at += nv
    return table, reasons


def tangent_frames(geo):
    """The geometry's vertex tangent frames as a C-contiguous (V, 6) float64 table (one row of zeros without
    them)."""
    fr = geo.tangent_frames
    return np.zeros((1, 6)) if fr is None else np.ascontiguousarray(fr, dtype=np.float64)
