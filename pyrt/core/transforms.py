"""Transforms: the 4x4 ``world_from_object`` matrix from translate / rotate / scale, and the rotation, translation,
quaternion and vector-alignment matrices pyrt builds (:func:`rotation_matrix`, :func:`translation_matrix`,
:func:`quaternion_matrix`, :func:`align_vectors`). They are the same NumPy operations as the trimesh functions of
those names (Gohlke's ``transformations``, trimesh's ``geometry.align_vectors``), so the matrices are bit-identical
to the ones pyrt used to take from trimesh, without importing trimesh (~0.2 s and its scipy / networkx imports: a
glTF preview never needs it)."""
from __future__ import annotations

import math

import numpy as np

from pyrt.core.checks import numbers_array
from pyrt.core.errors import Error
from pyrt.shaders.vec import divide_rows, norm


class SceneError(Error, ValueError):
    """Invalid scene content."""



def transform_matrix(*, translate=None, rotate=None, scale=None, matrix=None):
    """4x4 ``world_from_object``: ``matrix`` or ``T @ R @ S``.

    Parameters
    ----------
    translate : (3,) float, optional
    rotate : (angle_degrees, axis) or a list of them, optional
        Applied in order (right-handed, degrees).
    scale : float or (3,) float, optional
        Non-zero.
    matrix : (4, 4) float, optional
        Used as given (then the others are ignored).

    Returns
    -------
    (4, 4) float64 ndarray

    Raises
    ------
    SceneError
        On a non-finite or malformed argument.
    """
    if matrix is not None:
        m = numbers_array("transform", "matrix", matrix, SceneError)
        if m.shape != (4, 4) or not np.all(np.isfinite(m)):
            raise SceneError(f"transform matrix must be 4x4 finite, got shape {m.shape}")
        return m
    m = np.eye(4)
    if scale is not None:
        s = numbers_array("transform", "scale", scale, SceneError)
        if s.shape not in ((), (3,)):
            raise SceneError(f"scale must be a number or 3 numbers, got {scale!r}")
        s = np.broadcast_to(s, (3,))
        if np.any(s == 0) or not np.all(np.isfinite(s)):
            raise SceneError(f"scale must be finite and non-zero, got {scale!r}")
        m = np.diag([*s, 1.0]) @ m
    if rotate is not None:
        try:
            rots = rotate if (len(rotate) and isinstance(rotate[0], (list, tuple))) else [rotate]
            pairs = [(float(angle), numbers_array("transform", "rotation axis", axis, SceneError))
                     for angle, axis in rots]
        except (TypeError, ValueError, IndexError):
            raise SceneError(f"rotate must be (angle_degrees, [x, y, z]) or a list of them, got {rotate!r}") from None
        for angle, ax in pairs:
            if not math.isfinite(angle) or ax.shape != (3,) or not np.all(np.isfinite(ax)) or np.linalg.norm(ax) == 0:
                raise SceneError(f"rotation must be a finite angle (degrees) and a finite non-zero 3-vector axis, "
                                 f"got {angle!r}, {ax.tolist()!r}")
            m = rotation_matrix(math.radians(angle), ax) @ m
    if translate is not None:
        t = numbers_array("transform", "translate", translate, SceneError)
        if t.shape != (3,) or not np.all(np.isfinite(t)):
            raise SceneError(f"translate must be 3 finite numbers, got {translate!r}")
        m = translation_matrix(t) @ m
    return m


#: quaternions of squared norm below this give the identity (Gohlke's ``_EPS``)
_QUAT_EPS = np.finfo(float).eps * 4.0


def rotation_matrix(angle, direction):
    """4x4 rotation by ``angle`` radians about the axis ``direction`` (3,) through the origin (right-handed)."""
    sina = np.sin(angle)
    cosa = np.cos(angle)
    direction = np.array(direction[:3], dtype=np.float64)
    direction /= np.sqrt(np.dot(direction, direction))
    m = np.diag([cosa, cosa, cosa, 1.0])
    m[:3, :3] += np.outer(direction, direction) * (1.0 - cosa)
    direction = direction * sina
    m[:3, :3] += np.array([[0.0, -direction[2], direction[1]],
                           [direction[2], 0.0, -direction[0]],
                           [-direction[1], direction[0], 0.0]])
    return m


def translation_matrix(offset):
    """4x4 translation by ``offset`` (3,)."""
    m = np.eye(4)
    m[:3, 3] = np.asarray(offset)[:3]
    return m


def quaternion_matrix(quaternion):
    """4x4 rotation of the quaternion ``(w, x, y, z)`` (normalised here; the identity for a zero quaternion)."""
    q = np.array(quaternion, dtype=np.float64).reshape(4)
    n = np.dot(q * q, [1.0] * 4)
    if n < _QUAT_EPS:
        return np.eye(4)
    q *= np.sqrt(2.0 / n)
    q = np.outer(q, q)
    return np.array([[1.0 - q[2, 2] - q[3, 3], q[1, 2] - q[3, 0], q[1, 3] + q[2, 0], 0.0],
                     [q[1, 2] + q[3, 0], 1.0 - q[1, 1] - q[3, 3], q[2, 3] - q[1, 0], 0.0],
                     [q[1, 3] - q[2, 0], q[2, 3] + q[1, 0], 1.0 - q[1, 1] - q[2, 2], 0.0],
                     [0.0, 0.0, 0.0, 1.0]])


def align_vectors(a, b):
    """4x4 rotation taking the direction of ``a`` (3,) to that of ``b`` (3,) (an orthonormal basis of each from the
    SVD of the vector, turned right-handed; the rotation maps one basis onto the other)."""
    a = np.array(a, dtype=np.float64)
    b = np.array(b, dtype=np.float64)
    if a.shape != (3,) or b.shape != (3,):
        raise ValueError("align_vectors: vectors must be (3,)")
    au = np.linalg.svd(a.reshape((-1, 1)))[0]
    bu = np.linalg.svd(b.reshape((-1, 1)))[0]
    if np.linalg.det(au) < 0:
        au[:, -1] *= -1.0
    if np.linalg.det(bu) < 0:
        bu[:, -1] *= -1.0
    m = np.eye(4)
    m[:3, :3] = bu.dot(au.T)
    return m


def apply_matrix(points, matrix):
    """``points @ matrix[:3, :3].T + matrix[:3, 3]`` for (N, 3) rows and a (4, 4) (or (3, 3): no translation) matrix.

    Bitwise the matmul's values (float64), faster where the matrix allows: a linear part that is a signed
    permutation (each row one entry +-1, the others 0: the identity, axis swaps, the previewer's up-axis turns)
    moves and negates columns, exactly as the matmul's sums of one product and zeros do (tested, -0.0 included);
    any other matrix goes through ``@``. (NumPy's BLAS matmul of (N, 3) by (3, 3) costs ~0.6 s of CPU for 2.6 M rows
    on this machine, about 8x the column arithmetic, and its extra threads compete on a busy machine.)
    """
    v = np.asarray(points, dtype=np.float64)
    m = np.asarray(matrix, dtype=np.float64)
    lin = m[:3, :3]
    t = m[:3, 3] if m.shape == (4, 4) else np.zeros(3)
    nz = lin != 0
    if not (np.all(nz.sum(axis=1) == 1) and np.all(np.abs(lin[nz]) == 1)):
        return v @ lin.T + t
    out = np.empty(v.shape)
    for k in range(3):
        j = int(np.flatnonzero(nz[k])[0])
        if lin[k, j] > 0:
            np.add(v[:, j], 0.0, out=out[:, k])         # + 0.0: a zero is +0.0, as the matmul's sum of zeros
        else:
            np.subtract(0.0, v[:, j], out=out[:, k])
        out[:, k] += t[k]
    return out


def transform_normals(normals, matrix):
    """Unit normals (N, 3) carried by ``matrix`` ((4, 4) or (3, 3)): the inverse transpose of its linear part, then
    renormalised (zero rows stay zero; bitwise ``np.divide`` by the length). How :meth:`pyrt.Scene.add_mesh` moves a
    mesh's vertex normals to the world."""
    m = np.asarray(matrix, dtype=np.float64)
    out = apply_matrix(normals, np.linalg.inv(m[:3, :3]).T)
    return divide_rows(out, norm(out))


def transform_tangents(tangents, matrix):
    """Vertex tangents (N, 4) carried by ``matrix`` ((4, 4) or (3, 3)): ``xyz`` by its linear part, then renormalised
    (zero rows stay zero), ``w`` (the bitangent's sign, glTF ``TANGENT``) times the sign of its determinant, so
    that ``w (n x t)`` in the world is the image of the object's bitangent (a mirror reverses the cross product)."""
    m = np.asarray(matrix, dtype=np.float64)
    t = np.asarray(tangents, dtype=np.float64)
    xyz = apply_matrix(t[:, :3], m[:3, :3])
    out = np.empty_like(t)
    out[:, :3] = divide_rows(xyz, norm(xyz))
    out[:, 3] = t[:, 3] * (-1.0 if np.linalg.det(m[:3, :3]) < 0 else 1.0)
    return out


def rewound(faces, matrix):
    """``faces`` (F, 3), re-wound ``[0, 2, 1]`` when ``matrix`` mirrors (negative determinant of its linear part), so
    that a face keeps facing the side its normals do (glTF's rule; :meth:`pyrt.Scene.add_mesh`)."""
    m = np.asarray(matrix, dtype=np.float64)
    return faces[:, [0, 2, 1]] if np.linalg.det(m[:3, :3]) < 0 else faces
