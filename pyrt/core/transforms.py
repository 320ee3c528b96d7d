"""Transforms: the 4x4 ``world_from_object`` matrix from translate / rotate / scale."""
from __future__ import annotations

import math

import numpy as np
import trimesh

from pyrt.core.errors import Error


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
        m = np.asarray(matrix, dtype=np.float64)
        if m.shape != (4, 4) or not np.all(np.isfinite(m)):
            raise SceneError(f"transform matrix must be 4x4 finite, got shape {m.shape}")
        return m
    m = np.eye(4)
    if scale is not None:
        s = np.broadcast_to(np.asarray(scale, dtype=np.float64), (3,))
        if np.any(s == 0) or not np.all(np.isfinite(s)):
            raise SceneError(f"scale must be finite and non-zero, got {scale!r}")
        m = np.diag([*s, 1.0]) @ m
    if rotate is not None:
        rots = rotate if (len(rotate) and isinstance(rotate[0], (list, tuple))) else [rotate]
        for angle, axis in rots:
            ax = np.asarray(axis, dtype=np.float64)
            if ax.shape != (3,) or np.linalg.norm(ax) == 0:
                raise SceneError(f"rotation axis must be a non-zero 3-vector, got {axis!r}")
            m = trimesh.transformations.rotation_matrix(math.radians(angle), ax) @ m
    if translate is not None:
        t = np.asarray(translate, dtype=np.float64)
        if t.shape != (3,) or not np.all(np.isfinite(t)):
            raise SceneError(f"translate must be 3 finite numbers, got {translate!r}")
        m = trimesh.transformations.translation_matrix(t) @ m
    return m
