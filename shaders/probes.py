"""Light-probe mappings: angular map (Debevec) and mirror ball (sphere map), direction <-> texel.

Pure functions of NumPy arrays. Directions are unit ``(N, 3)`` vectors in the environment frame
(right-handed, **y up**, as in :mod:`shaders.envmap`). ``(u, v)`` are texture coordinates of the
square probe image in ``[0, 1]^2`` with ``u`` to the right and ``v`` **up** (the
:mod:`shaders.textures` convention: texel row ``(1 - v) H``, row 0 at the top). Write
``(a, b) = (2u - 1, 2v - 1)`` for the centred disc coordinates, ``rho = sqrt(a^2 + b^2) <= 1``.

Both probes share one frame: the image centre is the direction **-z** (the direction a camera
looking down -z sees straight ahead, +x to the right, +y up), the rim circle is **+z**.

Angular map (Debevec's light-probe format, http://www.pauldebevec.com/Probes/)
------------------------------------------------------------------------------
The distance from the centre is proportional to the angle from -z::

    r = acos(-z) / (pi sqrt(x^2 + y^2)),    (a, b) = (x r, y r),    (u, v) = (1/2 + a/2, 1/2 + b/2)

and back: ``theta = pi rho``, ``d = (sin(theta) a / rho, sin(theta) b / rho, -cos(theta))``. Debevec's
page describes the direction as ``(0, 0, -1)`` rotated by ``phi = pi rho`` (centre = -z, as here) but
writes the forward formula with ``acos(Dz)``; that is the same mapping with z negated (a mirrored
world), so pyrt follows the rotation description. Solid angle per unit ``(u, v)`` area:
``dw / du dv = 4 pi sin(pi rho) / rho`` (``-> 4 pi^2`` at the centre; integrates to 4 pi over the disc).

Mirror ball (sphere map)
------------------------
The photograph of a mirrored sphere seen from far away along the view direction +z (the camera at
-z): the ball's normal at disc point ``(a, b)`` is ``n = (a, b, -sqrt(1 - rho^2))`` and it reflects
the direction ``d = 2 (n . c) n - c`` with ``c = (0, 0, -1)`` (back toward the camera). Inverse::

    n = (d + c) / |d + c|,    (a, b) = (n_x, n_y),    i.e.  (u, v) = 1/2 + (x, y) / (2 sqrt(x^2 + y^2 + (1 - z)^2))

so ``rho = sin(theta / 2)`` with ``theta`` the angle from -z. This is OpenGL's ``GL_SPHERE_MAP``
(``m = 2 sqrt(r_x^2 + r_y^2 + (r_z + 1)^2)``, ``s = r_x / m + 1/2``; OpenGL 2.1 spec, 2.11.4) with z
negated, so both probes put the same direction at the centre. Solid angle per unit ``(u, v)`` area
is the constant ``16`` (``4`` per unit ``(a, b)`` area: the sphere map is equal-area in the disc).
"""
import numpy as np

PROBE_KINDS = ("angular", "mirror_ball")


def _disc(uv):
    """``(a, b, rho)`` of texture coordinates ``uv`` (N, 2), float64."""
    uv = np.asarray(uv, dtype=np.float64)
    a = 2.0 * uv[:, 0] - 1.0
    b = 2.0 * uv[:, 1] - 1.0
    return a, b, np.sqrt(a * a + b * b)


def angular_dir_to_uv(d):
    """Angular-map texture coordinates ``(N, 2)`` in [0, 1]^2 of unit directions ``d`` (N, 3).

    ``-z`` maps to the centre (0.5, 0.5); ``+z`` to the rim (there to (1, 0.5)).
    """
    d = np.asarray(d, dtype=np.float64)
    s = np.sqrt(d[:, 0] ** 2 + d[:, 1] ** 2)
    theta = np.arccos(np.clip(-d[:, 2], -1.0, 1.0))
    r = np.divide(theta, np.pi * s, out=np.zeros_like(s), where=s > 0)
    a = np.where(s > 0, d[:, 0] * r, np.where(d[:, 2] > 0, 1.0, 0.0))   # +z: a point on the rim
    b = d[:, 1] * r
    return np.stack([0.5 + 0.5 * a, 0.5 + 0.5 * b], axis=1)


def angular_uv_to_dir(uv):
    """Unit directions ``(N, 3)`` of angular-map texture coordinates ``uv`` (N, 2); rho > 1 is clamped to the rim."""
    a, b, rho = _disc(uv)
    theta = np.pi * np.minimum(rho, 1.0)
    k = np.divide(np.sin(theta), rho, out=np.full_like(rho, np.pi), where=rho > 0)   # sin(pi rho)/rho -> pi
    return np.stack([a * k, b * k, -np.cos(theta)], axis=1)


def angular_jacobian(uv):
    """Solid angle per unit texture area ``dw / (du dv) = 4 pi sin(pi rho) / rho`` (N,); 0 outside the disc."""
    _, _, rho = _disc(uv)
    k = np.divide(np.sin(np.pi * rho), rho, out=np.full_like(rho, np.pi), where=rho > 0)
    return np.where(rho <= 1.0, 4.0 * np.pi * k, 0.0)


def mirror_ball_dir_to_uv(d):
    """Mirror-ball texture coordinates ``(N, 2)`` of unit directions ``d`` (N, 3).

    ``-z`` maps to the centre, ``+z`` (behind the ball, singular) to the rim point (1, 0.5).
    """
    d = np.asarray(d, dtype=np.float64)
    m = np.sqrt(d[:, 0] ** 2 + d[:, 1] ** 2 + (1.0 - d[:, 2]) ** 2)
    ok = m > 0
    a = np.where(ok, np.divide(d[:, 0], m, out=np.zeros_like(m), where=ok), 1.0)
    b = np.divide(d[:, 1], m, out=np.zeros_like(m), where=ok)
    return np.stack([0.5 + 0.5 * a, 0.5 + 0.5 * b], axis=1)


def mirror_ball_uv_to_dir(uv):
    """Unit directions ``(N, 3)`` reflected by the mirror ball at ``uv`` (N, 2); rho > 1 is clamped to the rim."""
    a, b, rho = _disc(uv)
    scale = np.where(rho > 1.0, 1.0 / np.maximum(rho, 1.0), 1.0)
    a, b = a * scale, b * scale
    nz = -np.sqrt(np.maximum(0.0, 1.0 - a * a - b * b))       # normal toward the camera (-z)
    ndc = -nz                                                  # n . c with c = (0, 0, -1)
    return np.stack([2 * ndc * a, 2 * ndc * b, 2 * ndc * nz + 1.0], axis=1)


def mirror_ball_jacobian(uv):
    """Solid angle per unit texture area of the mirror ball: 16 inside the disc, 0 outside (N,)."""
    _, _, rho = _disc(uv)
    return np.where(rho <= 1.0, 16.0, 0.0)


#: kind -> (dir_to_uv, uv_to_dir, jacobian)
PROBE_MAPPINGS = {
    "angular": (angular_dir_to_uv, angular_uv_to_dir, angular_jacobian),
    "mirror_ball": (mirror_ball_dir_to_uv, mirror_ball_uv_to_dir, mirror_ball_jacobian),
}


def probe_texel_solid_angle(kind, size, n_sub=4):
    """Solid angle (sr) of each texel of a ``size x size`` probe, ``(size, size)`` float64, row 0 at the top.

    Midpoint rule on ``n_sub x n_sub`` points per texel of :data:`PROBE_MAPPINGS` ``[kind]``'s Jacobian
    (texels cut by the rim get their inside part, to ``1 / n_sub^2``); sums to ~4 pi.
    """
    jac = PROBE_MAPPINGS[kind][2]
    n = size * n_sub
    c = (np.arange(n) + 0.5) / n
    uu, vv = np.meshgrid(c, 1.0 - c)            # row 0 = top = v near 1
    j = jac(np.stack([uu.ravel(), vv.ravel()], axis=1)).reshape(size, n_sub, size, n_sub)
    return j.mean(axis=(1, 3)) / (size * size)
