"""Placing a model in the studio: up axis, framing camera, key/fill/rim rig, the shadow catcher's
radiance and the automatic exposure (see :mod:`pyrt.apps.preview` for the formulas)."""
from __future__ import annotations

import math

import numpy as np
import trimesh

from pyrt.shaders import color as _color

from pyrt.core.camera import Camera
from pyrt.lights import DirectionalLight
from pyrt.apps.preview.options import AXES, PreviewError, PreviewOptions


# ============================================================================ geometry helpers

def bounding_sphere(points):
    """Centre of the bounding box and the distance to the farthest point: ``(center (3,), radius)``.

    Encloses every point exactly (not the minimal sphere; at most sqrt(3) times larger).
    """
    p = np.asarray(points, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 3 or p.shape[0] == 0:
        raise PreviewError(f"points must have shape (N, 3) with N > 0, got {p.shape}")
    c = 0.5 * (p.min(axis=0) + p.max(axis=0))
    r = float(np.sqrt(np.max(np.einsum("ij,ij->i", p - c, p - c))))
    return c, r


def up_transform(axis):
    """4x4 rotation taking the unit vector of ``axis`` ("+z", ...) to +y: the smallest rotation.

    A quarter turn about ``axis x y`` (so "+z" maps ``(x, y, z) -> (x, z, -y)``: a z-up model's
    front, -y, faces +z, the default camera side), half a turn about x for "-y", identity for "+y".
    """
    a = np.asarray(AXES[axis], dtype=np.float64)
    if axis == "+y":
        return np.eye(4)
    if axis == "-y":
        return trimesh.transformations.rotation_matrix(math.pi, [1, 0, 0])
    return trimesh.transformations.rotation_matrix(math.pi / 2, np.cross(a, [0.0, 1.0, 0.0]))


def _base_area(v, f, up):
    """Area of triangles facing down (-up within 10 degrees) lying within 1% of the extent of the lowest point."""
    h = v @ up
    lo, ext = h.min(), max(h.max() - h.min(), 1e-300)
    tri = v[f]
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    area2 = np.linalg.norm(n, axis=1)
    cos = np.divide(n @ up, area2, out=np.zeros_like(area2), where=area2 > 0)
    low = np.max(h[f], axis=1) <= lo + 0.01 * ext
    return 0.5 * float(np.sum(area2[(cos < -math.cos(math.radians(10))) & low]))


def detect_up_axis(asset):
    """Up axis of an asset and the reason: ``("+y", "glTF is y-up")`` etc. (see the module docstring)."""
    if asset.up_axis is not None:
        return asset.up_axis, f"{asset.format} defines {asset.up_axis} as up"
    v, f = [], []
    off = 0
    for inst in asset.instances:
        m = inst.world_from_object
        am = asset.meshes[inst.mesh]
        v.append(am.vertices @ m[:3, :3].T + m[:3, 3])
        f.append(am.faces + off)
        off += am.vertices.shape[0]
    v, f = np.concatenate(v), np.concatenate(f)
    area = {ax: _base_area(v, f, np.asarray(AXES[ax], dtype=np.float64)) for ax in ("+y", "+z")}
    total = 0.5 * float(np.sum(np.linalg.norm(np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]]), axis=1)))
    best = max(area, key=area.get)
    if area[best] > 1e-3 * total and area[best] > 1.5 * min(area.values()):
        return best, f"flat base facing -{best[1]} ({area[best] / max(total, 1e-300):.1%} of the area)"
    if asset.format == "stl":
        return "+z", "no clear base; STL defaults to z-up"
    return "+y", "no clear base; defaulting to y-up"


def frame_camera(center, radius, *, fov=35.0, azimuth=35.0, elevation=20.0, width=640, height=480, margin=1.05,
                 spp=1, jitter=True):
    """A camera that sees the whole sphere ``(center, radius)`` from the given direction.

    Distance ``d = margin * radius / sin(a)``, ``a = min(fov_v, fov_h) / 2`` with
    ``tan(fov_h / 2) = tan(fov_v / 2) * width / height`` (see the module docstring).
    """
    if not radius > 0:
        raise PreviewError(f"bounding sphere radius must be > 0, got {radius}")
    half_v = math.radians(fov) / 2
    half_h = math.atan(math.tan(half_v) * width / height)
    a = min(half_v, half_h)
    d = margin * radius / math.sin(a)
    az, el = math.radians(azimuth), math.radians(elevation)
    direction = np.array([math.sin(az) * math.cos(el), math.sin(el), math.cos(az) * math.cos(el)])
    c = np.asarray(center, dtype=np.float64)
    return Camera(c + d * direction, c, (0, 1, 0), fov=fov, width=width, height=height, spp=spp, jitter=jitter)


# ============================================================================ lighting

#: (name, azimuth relative to the camera, elevation, share of the key irradiance) -- ratios from options
RIG = (("key", -40.0, 45.0, "key"), ("fill", 60.0, 15.0, "fill_ratio"), ("rim", 160.0, 35.0, "rim_ratio"))


def studio_rig(camera_azimuth, options=None):
    """Key, fill and rim :class:`DirectionalLight` s placed relative to the camera azimuth (degrees)."""
    o = options or PreviewOptions()
    lights = []
    for name, daz, el, share in RIG:
        E = o.key if share == "key" else o.key * {"fill_ratio": o.fill_ratio, "rim_ratio": o.rim_ratio}[share]
        if E <= 0:
            continue
        az, e = math.radians(camera_azimuth + daz), math.radians(el)
        toward = np.array([math.sin(az) * math.cos(e), math.sin(e), math.cos(az) * math.cos(e)])
        lights.append(DirectionalLight(-toward, E, name=name))
    return lights


def ground_radiance(lights, albedo, ambient, at=(0.0, 0.0, 0.0)):
    """Unshadowed radiance of a Lambertian ground (normal +y) of ``albedo`` at the point ``at``: RGB (3,).

    ``albedo / pi * sum_i E_i max(0, wi . y) + albedo * ambient`` with ``(wi, E)`` from each light's
    own ``sample`` (the integrator's ``f_cos * E`` plus its ambient term ``albedo * L_a``). For
    directional lights this is the same everywhere on the ground; point and spot lights make it
    vary, and the value at ``at`` is returned. Lights without a single sample direction
    (environment, area lights: ``delta = False``) are left out.
    """
    p = np.asarray(at, dtype=np.float64).reshape(1, 3)
    L = np.asarray(ambient, dtype=np.float64) * albedo * np.ones(3)
    for lt in lights:
        if not lt.delta:
            continue
        wi, _, E = lt.sample(p, np.zeros((1, 2)))
        L = L + albedo / math.pi * E[0] * max(0.0, float(wi[0, 1]))
    return L


def auto_exposure(image, mask=None, *, key=0.18, percentile=99.9):
    """Photographic exposure (Reinhard et al. 2002): ``(exposure_stops, L_white)``.

    ``scale = key / exp(mean(log(1e-4 + Y)))`` over the pixels in ``mask`` (all if None or empty),
    ``L_white = max(scale * percentile(Y), 1)`` in scaled units (the extended Reinhard white point).
    """
    Y = _color.luminance(np.asarray(image, dtype=np.float64))
    if mask is not None and np.any(mask):
        Y = Y[mask]
    Y = Y.ravel()
    if Y.size == 0 or not np.any(Y > 0):
        return 0.0, None
    log_avg = math.exp(float(np.mean(np.log(1e-4 + Y))))
    scale = key / log_avg
    white = max(scale * float(np.percentile(Y, percentile)), 1.0)
    return math.log2(scale), white
