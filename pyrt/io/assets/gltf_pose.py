"""The pose a glTF file defines without animations: morph targets at their default weights, skins at their joints'
transforms.

A static renderer shows the file's own pose. The glTF 2.0 specification defines it as follows.

- **Morph targets**:
  - The rendered attribute is ``base + sum_i w_i target_i`` over the primitive's ``targets``. The same formula
    applies to ``POSITION`` and to ``NORMAL``; the normal is renormalised after the sum.
  - The weights are the node's ``weights``, else the mesh's ``weights``, else 0.
  - With all weights 0 the base mesh is the pose; that case reads no target at all.
- **Skins**:
  - A skinned mesh is drawn in the coordinates of its joints. Joint ``j`` has the matrix
    ``jointMatrix_j = worldTransform(joints[j]) inverseBindMatrices[j]``, where the inverse bind matrix defaults
    to the identity.
  - A vertex becomes ``sum_k WEIGHTS[k] jointMatrix_{JOINTS[k]} v``, summed over the influences of every
    ``JOINTS_n`` / ``WEIGHTS_n`` pair.
  - "Only the joint transforms are applied to the skinned mesh; the transform of the skinned mesh node MUST be
    ignored."
  - Normals go through the cofactor matrix of the blended matrix: ``det(M) M^-T``, the inverse transpose up to
    scale, with its sign kept so that normals keep their side.
  - The joints' transforms are those of the node hierarchy. Every joint node counts, whether the default scene
    reaches it or not.

Weights that do not sum to 1 are normalised; they should, by the specification, within ``2e-7`` per
non-zero weight. Vertices whose weights are all 0 keep their mesh coordinates and are named in a warning.
Where the blended matrix mirrors (negative determinant), the face's winding is reversed, as glTF's rule for a
node transform does.
"""
from __future__ import annotations

import numpy as np

from pyrt.io.assets.common import AssetError
from pyrt.shaders.vec import divide_rows, norm

__all__ = ["default_weights", "morph", "all_node_transforms", "joint_matrices", "skin"]


def default_weights(node, mesh, n_targets, where, path):
    """The morph weights (n_targets,) of ``mesh`` drawn by ``node`` (dicts): the node's ``weights``, else the
    mesh's, else zeros. A list of another length is an :class:`AssetError` naming ``where``."""
    w = node.get("weights", mesh.get("weights"))
    if w is None:
        return np.zeros(n_targets)
    try:
        arr = np.asarray(w, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError):
        raise AssetError(f"{path}: {where}: morph weights must be numbers, got {w!r}") from None
    if arr.size != n_targets or not np.all(np.isfinite(arr)):
        raise AssetError(f"{path}: {where}: {arr.size} morph weights for {n_targets} targets (finite numbers)")
    return arr


def morph(g, targets, weights, pos, normals, where):
    """``(pos, normals)`` with the morph ``targets`` (the primitive's list of {attribute: accessor}) added at
    ``weights``. The inputs are not modified; normals (or None) are renormalised, and a zero sum keeps its zero."""
    if not np.any(weights):
        return pos, normals
    pos = pos.copy()
    nrm = None if normals is None else normals.copy()
    for i, (t, w) in enumerate(zip(targets, weights)):
        if w == 0.0:
            continue
        if not isinstance(t, dict):
            raise AssetError(f"{g.path}: {where}: morph target {i} is not an object")
        for name, out in (("POSITION", pos), ("NORMAL", nrm)):
            if out is None or name not in t:
                continue
            d = g.accessor(t[name])
            if d.shape != (out.shape[0], 3):
                raise AssetError(f"{g.path}: {where}: morph target {i} {name} has shape {d.shape}, the primitive "
                                 f"{out.shape[0]} vertices")
            out += w * d
    if nrm is not None:
        nrm = divide_rows(nrm, norm(nrm))
    return pos, nrm


def all_node_transforms(header, local):
    """{node index: (4, 4) world_from_node} for every node of the file, through its parents (``local(node)`` gives
    a node's own matrix). A node reached from two parents, or a cycle, is an :class:`AssetError`."""
    nodes = header.get("nodes", [])
    parent = {}
    for i, n in enumerate(nodes):
        for c in n.get("children", []):
            if not isinstance(c, int) or not 0 <= c < len(nodes):
                raise AssetError(f"node {i}: child {c!r} is not a node")
            if c in parent:
                raise AssetError(f"node {c} has two parents ({parent[c]} and {i})")
            parent[c] = i
    out = {}
    for i in range(len(nodes)):
        chain = []
        j = i
        while j not in out:
            chain.append(j)
            j = parent.get(j)
            if j is None:
                break
            if len(chain) > len(nodes):
                raise AssetError(f"node {i}: its parents form a cycle")
        base = np.eye(4) if j is None else out[j]
        for k in reversed(chain):
            base = base @ local(nodes[k])
            out[k] = base
    return out


def joint_matrices(g, skin_index, world, where):
    """The skin's joint matrices (J, 4, 4): ``world[joint] @ inverseBindMatrix``."""
    skin = g.get("skins", skin_index)
    joints = skin.get("joints")
    if not isinstance(joints, list) or not joints:
        raise AssetError(f"{g.path}: {where}: skin {skin_index} has no joints")
    bad = [j for j in joints if j not in world]
    if bad:
        raise AssetError(f"{g.path}: {where}: skin {skin_index} names joints {bad[:5]} that are not nodes")
    jw = np.stack([world[j] for j in joints])
    if "inverseBindMatrices" not in skin:
        return jw
    ibm = g.accessor(skin["inverseBindMatrices"])
    if ibm.shape != (len(joints), 16):
        raise AssetError(f"{g.path}: {where}: skin {skin_index} inverseBindMatrices has shape {ibm.shape} for "
                         f"{len(joints)} joints (MAT4 each)")
    return jw @ ibm.reshape(-1, 4, 4).transpose(0, 2, 1)       # column-major MAT4s


def skin(pos, normals, faces, joints, weights, jm, where, warnings):
    """Linear blend skinning: ``(pos, normals, faces)`` in the joints' coordinates (module docstring).

    ``joints`` (V, K) integer joint indices and ``weights`` (V, K) (all ``JOINTS_n`` / ``WEIGHTS_n`` side by side),
    ``jm`` (J, 4, 4) from :func:`joint_matrices`. Faces whose first vertex's blended matrix mirrors are wound the
    other way."""
    nv = pos.shape[0]
    if joints.shape != weights.shape or joints.shape[0] != nv:
        raise AssetError(f"{where}: JOINTS {joints.shape} and WEIGHTS {weights.shape} do not match {nv} vertices")
    j = joints.astype(np.int64)
    used = weights != 0
    if np.any(used & ((j < 0) | (j >= jm.shape[0]))):
        raise AssetError(f"{where}: a vertex is weighted to joint {int(j[used].max())}, the skin has {jm.shape[0]}")
    w = np.where(used, weights, 0.0)
    total = w.sum(axis=1)
    loose = total <= 0
    w = np.divide(w, total[:, None], out=np.zeros_like(w), where=~loose[:, None])
    M = np.einsum("vk,vkij->vij", w, jm[np.where(used, j, 0)])     # (V, 4, 4) blended matrices
    M[loose] = np.eye(4)
    if np.any(loose):
        warnings.append(f"{where}: {int(loose.sum())} of {nv} vertices have no skin weight: left in mesh "
                        "coordinates")
    out = np.einsum("vij,vj->vi", M[:, :3, :3], pos) + M[:, :3, 3]
    A = M[:, :3, :3]
    det = np.einsum("vi,vi->v", A[:, :, 0], np.cross(A[:, :, 1], A[:, :, 2]))
    nrm = None
    if normals is not None:
        # cofactor matrix det(A) A^-T, columns (a1 x a2, a2 x a0, a0 x a1), times sign(det): the inverse
        # transpose up to a positive scale, defined for singular A too
        cof = np.stack([np.cross(A[:, :, 1], A[:, :, 2]), np.cross(A[:, :, 2], A[:, :, 0]),
                        np.cross(A[:, :, 0], A[:, :, 1])], axis=2)
        nrm = np.einsum("vij,vj->vi", cof, normals) * np.where(det < 0, -1.0, 1.0)[:, None]
        nrm = divide_rows(nrm, norm(nrm))
    flip = det[faces[:, 0]] < 0
    if np.any(flip):
        faces = faces.copy()
        faces[flip] = faces[flip][:, [0, 2, 1]]         # as pyrt.core.transforms.rewound
    return out, nrm, faces
