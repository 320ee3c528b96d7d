"""Placing a model in the studio: up axis, framing camera, key/fill/rim rig, the shadow catcher's
radiance and the automatic exposure (see :mod:`pyrt.apps.preview` for the formulas)."""
from __future__ import annotations

import math

import numpy as np

from pyrt.shaders import color as _color

from pyrt.core.camera import Camera
from pyrt.core.image_io import tonemap_to_display
from pyrt.core.transforms import apply_matrix, rotation_matrix
from pyrt.io.assets.common import metadata_up_axis
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
        m = rotation_matrix(math.pi, [1, 0, 0])
    else:
        m = rotation_matrix(math.pi / 2, np.cross(a, [0.0, 1.0, 0.0]))
    # exact: the entries are 0 and +-1 (cos(pi / 2) is 6.1e-17 in floating point), so the turn moves coordinates
    # without rounding them (pyrt.core.transforms.apply_matrix)
    return np.round(m) + 0.0


#: above this many faces the up-axis guess samples the surface from a deterministic random subset of them
MAX_POINTS = 200_000
#: the convex hull is taken of at most this many points (a deterministic random subset plus the six points
#: extreme along x, y, z, so the bounding box stays exact): qhull on 50k scan points takes ~0.2 s here, on
#: 200k ~0.9 s (a 2-core machine under load)
HULL_POINTS = 50_000
#: at most this many steps of :func:`frame_points`' fixed-point iteration (10-22 on the 23 shared .glb models and the
#: helmet-like model)
FRAME_MAX_STEPS = 200
#: contact band of the support polygon, as a fraction of the model's largest extent
SUPPORT_BAND = 0.02
#: the projected centroid must lie this far (fraction of the largest extent) inside the support polygon
SUPPORT_MARGIN = 0.02
#: a mirror plane counts as a symmetry when the median mirrored-point distance is below this fraction of the size
SYMMETRY_TOL = 0.01
#: the winner's score must beat the other candidate's by this factor, else the format's default is kept
UP_CONFIDENCE = 1.5
#: a point set whose smallest principal extent is at most this fraction of its largest is planar (a 2-D outline,
#: z = 0 everywhere): :func:`guess_up_axis` stands it up to face the camera
PLANAR_TOL = 1e-3
#: a flat base (:func:`flat_bases`): hull facets within this angle (degrees) and distance (x size) are one plane,
#: and the model's faces and open boundary within that distance of it lie on it
FLAT_ANGLE, FLAT_DIST = 1.0, 1e-3
#: a flat base counts when the model covers at least this share of its hull plane, its area is at least this
#: fraction of size^2, and its outward normal is within FLAT_TILT degrees of a candidate's "down"
FLAT_BACKED, FLAT_MIN_AREA, FLAT_TILT = 0.9, 0.01, 45.0

def _subsample(p, n, rng):
    return p if p.shape[0] <= n else p[np.sort(rng.choice(p.shape[0], n, replace=False))]


def _surface_samples(v, f, n, rng):
    """``n`` area-weighted random points on the triangles (the vertices themselves without faces)."""
    if f is None or len(f) == 0:
        return _subsample(v, n, rng)
    if f.shape[0] > MAX_POINTS:              # big meshes: area-weighted sampling over a uniform subset of faces
        f = f[np.sort(rng.choice(f.shape[0], MAX_POINTS, replace=False))]
    tri = v[f]
    a = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    if not a.sum() > 0:
        return _subsample(v, n, rng)
    k = rng.choice(len(f), n, p=a / a.sum())
    r = rng.random((n, 2))
    flip = r.sum(axis=1) > 1
    r[flip] = 1 - r[flip]
    t = tri[k]
    return t[:, 0] + r[:, :1] * (t[:, 1] - t[:, 0]) + r[:, 1:] * (t[:, 2] - t[:, 0])


def framing_points(points, *, rng=None):
    """What the framing fits: ``points`` (N, 3) as float64, or above :data:`HULL_POINTS` points a deterministic
    random subset of them plus the six axis-extreme points (so the bounding box stays exact).

    :func:`frame_points` on these gives the camera it gives on their convex hull (:func:`hull_points`): the
    quantities it fits (the projected bounding box, the distance at which every point is in the frame, the
    bounding sphere) are maxima of quasi-convex functions of the point, reached at hull vertices; the hull is
    only worth taking for many views at once (turntables). Without it the previewer needs no Qhull and no
    ``scipy.spatial`` import (~0.27 s of every command's start-up on a 2-core VM)."""
    p = np.asarray(points, dtype=np.float64)
    if p.shape[0] > HULL_POINTS:
        ext = p[np.concatenate([np.argmin(p, axis=0), np.argmax(p, axis=0)])]
        p = np.concatenate([_subsample(p, HULL_POINTS, rng or np.random.default_rng(0)), ext])
    return p


def convex_hull(points, *, rng=None):
    """scipy's ``ConvexHull`` of :func:`framing_points` of ``points`` (N, 3), or None for a flat or degenerate set."""
    from scipy.spatial import ConvexHull, QhullError     # ~0.27 s to import: only where a hull is taken

    try:
        return ConvexHull(framing_points(points, rng=rng))
    except (QhullError, ValueError):
        return None


def hull_points(points, *, rng=None):
    """The convex-hull vertices of ``points`` (N, 3); above :data:`HULL_POINTS` points, of a deterministic random
    subset of them plus the six axis-extreme points (then a close inner approximation of the true hull)."""
    h = convex_hull(points, rng=rng)
    return framing_points(points, rng=rng) if h is None else h.points[h.vertices]


def _in_plane(up):
    a = np.array([1.0, 0.0, 0.0]) if abs(up[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = np.cross(up, a)
    e1 /= np.linalg.norm(e1)
    return e1, np.cross(up, e1)


def support_score(hull, centroid, up, size):
    """``(area, inside)``: the support polygon standing on ``up``, and how far the centroid is inside it.

    The support polygon is the 2D convex hull of the hull vertices within ``SUPPORT_BAND * size`` of the
    lowest one along ``up`` (what the model would rest on: rounded hooves and feet count, not only flat
    triangles); ``area`` is in units of ``size^2``, ``inside`` is the signed distance (units of ``size``) of
    the projected ``centroid`` from the polygon's nearest edge, positive inside.
    """
    from scipy.spatial import ConvexHull, QhullError

    h = hull @ up
    e1, e2 = _in_plane(up)
    q = np.column_stack([hull @ e1, hull @ e2])[h <= h.min() + SUPPORT_BAND * size]
    if q.shape[0] < 3:
        return 0.0, -1.0
    try:
        hb = ConvexHull(q)
    except (QhullError, ValueError):
        return 0.0, -1.0
    c = np.array([centroid @ e1, centroid @ e2])
    inside = -float(np.max(hb.equations[:, :2] @ c + hb.equations[:, 2])) / size
    return float(hb.volume) / size ** 2, inside


def mirror_asymmetry(samples, axis_index):
    """Median distance (units of the largest extent) from the samples mirrored in the plane through the bbox
    centre normal to coordinate axis ``axis_index`` to the nearest sample: ~0 for a mirror-symmetric shape."""
    lo, hi = samples.min(axis=0), samples.max(axis=0)
    size = float(np.max(hi - lo))
    q = samples.copy()
    q[:, axis_index] = (lo[axis_index] + hi[axis_index]) - q[:, axis_index]
    from scipy.spatial import cKDTree

    d, _ = cKDTree(samples).query(q)
    return float(np.median(d)) / max(size, 1e-300)


def planar_normal(points):
    """The unit normal of a planar point set (N, 3) — its smallest principal extent at most :data:`PLANAR_TOL` of its
    largest — or None."""
    p = np.asarray(points, dtype=np.float64)
    c = p - p.mean(axis=0)
    _, _, vt = np.linalg.svd(c[:: max(1, c.shape[0] // 20000)], full_matrices=False)
    proj = c @ vt.T
    ext = proj.max(axis=0) - proj.min(axis=0)
    return vt[2] if ext[0] > 0 and ext[2] <= PLANAR_TOL * ext[0] else None


def flat_bases(vertices, faces, hull=None):
    """The planes of the convex hull that the model itself lies on: ``[(area, backed, normal)]``, largest first.

    Hull facets within :data:`FLAT_ANGLE` degrees and :data:`FLAT_DIST` x size of each other are one plane of ``area``
    (units of size^2) and outward unit ``normal``; ``backed`` is the share of it the model covers: the area of its
    faces lying in the plane, plus the area inside its open boundary edges lying there (the 2-D hull of their
    vertices), at most 1. A bust's or a scan's cut is such a plane, capped (faces) or open (a boundary loop), whatever
    its tilt; the plane across a quadruped's hooves is not (backed ~0). ``hull``: the points' :func:`convex_hull`,
    if already taken."""
    from scipy.spatial import ConvexHull, QhullError

    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces)
    size = float(np.max(v.max(axis=0) - v.min(axis=0)))
    hull = convex_hull(v) if hull is None else hull
    if hull is None:
        return []
    eq = hull.equations
    tri = hull.points[hull.simplices]
    area = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    used, f = np.unique(f, return_inverse=True)        # the faces' own vertices (a face sample keeps all of them)
    f = f.reshape(-1, 3)
    v = v[used]
    tv = v[f]
    fn = np.cross(tv[:, 1] - tv[:, 0], tv[:, 2] - tv[:, 0])
    fa = 0.5 * np.linalg.norm(fn, axis=1)
    fn /= np.maximum(2.0 * fa, 1e-300)[:, None]
    key = np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]).astype(np.int64), axis=1)
    key = key[:, 0] * (int(v.shape[0]) + 1) + key[:, 1]
    uk, count = np.unique(key, return_counts=True)
    edge = uk[count == 1]                                   # edges of one face: the open boundary
    bnd = np.stack([edge // (v.shape[0] + 1), edge % (v.shape[0] + 1)], axis=1)
    cos_tol, tol = math.cos(math.radians(FLAT_ANGLE)), FLAT_DIST * size
    f0, f1, f2, b0, b1 = (np.ascontiguousarray(c) for c in (f[:, 0], f[:, 1], f[:, 2], bnd[:, 0], bnd[:, 1]))
    # hull facets grouped by plane (normal to ~FLAT_ANGLE / 2, offset to FLAT_DIST): a planar region is triangulated
    # into many small facets; only groups of at least FLAT_MIN_AREA are looked at
    q = np.column_stack([np.round(eq[:, :3] / math.radians(0.5 * FLAT_ANGLE)), np.round(eq[:, 3] / tol)])
    _, group = np.unique(q, axis=0, return_inverse=True)
    group = group.ravel()
    g_area = np.bincount(group, weights=area)
    out = []
    for g in np.flatnonzero(g_area >= FLAT_MIN_AREA * size * size):
        i = np.flatnonzero(group == g)
        n = eq[i, :3].mean(axis=0)
        n /= np.linalg.norm(n)
        d = float(eq[i, 3].mean())
        a = float(g_area[g])
        near = np.abs(v @ n + d) < tol                # vertices in the plane (once each, not once per face)
        on = near[f0] & near[f1] & near[f2]           # (not .all(axis=1): slow over an axis of 3)
        on[on] = np.abs(fn[on] @ n) > cos_tol
        covered = float(fa[on].sum())
        loop = bnd[near[b0] & near[b1]]
        if loop.shape[0] >= 3:
            e1, e2 = _in_plane(n)
            q = v[np.unique(loop)]
            try:
                covered += ConvexHull(np.column_stack([q @ e1, q @ e2])).volume
            except (QhullError, ValueError):
                pass
        out.append((a / size ** 2, min(1.0, covered / a), n))
    return sorted(out, key=lambda r: -r[0])


def guess_up_axis(vertices, faces=None, *, default="+y", candidates=("+y", "+z")):
    """Up axis from geometry alone: ``(axis, reason, scores)``.

    A planar model (:func:`planar_normal`: a 2-D outline, z = 0 everywhere) stands up: the candidate most
    perpendicular to its normal, so that it faces the camera. A model with a flat base (:func:`flat_bases`: a hull
    plane covered at least :data:`FLAT_BACKED` by the model's own faces or open boundary, at least
    :data:`FLAT_MIN_AREA` size^2, outward normal within :data:`FLAT_TILT` degrees of a candidate's down: a bust's or a
    scan's cut, oblique or not, open or capped) stands on it when the largest such base of one candidate is
    :data:`UP_CONFIDENCE` x the other's (a cube's are equal: no decision there). Otherwise, for each candidate the model stands on its convex hull (:func:`support_score`); the score is the support
    polygon's area, times 0.05 when the surface centroid does not project at least ``SUPPORT_MARGIN`` inside
    it (the model would tip over), times 0.25 when the plane normal to the candidate is a mirror symmetry
    of the shape and the plane normal to the other one is not (animals, people, vehicles and vases stand
    with their symmetry planes vertical: a quadruped lying on its side has its symmetry plane horizontal).
    The best candidate wins when it beats the other by ``UP_CONFIDENCE``; else ``default``. ``vertices``
    (N, 3) of any size (the hull of at most :data:`HULL_POINTS`, 20,000 surface samples from at most
    :data:`MAX_POINTS` faces), ``faces`` (F, 3) optional (area-weighted centroid and symmetry samples;
    without them the points are used).
    """
    v = np.asarray(vertices, dtype=np.float64)
    if v.ndim != 2 or v.shape[1] != 3 or v.shape[0] == 0:
        raise PreviewError(f"vertices must have shape (N, 3) with N > 0, got {v.shape}")
    rng = np.random.default_rng(0)
    f = None if faces is None else np.asarray(faces)
    samples = _surface_samples(v, f, min(20000, max(2000, v.shape[0])), rng)
    size = float(np.max(v.max(axis=0) - v.min(axis=0)))
    if not size > 0:
        return default, "zero-size model; format default", {}
    n = planar_normal(v)
    if n is not None:
        best = min(candidates, key=lambda a: abs(float(n @ AXES[a])))
        return best, f"planar (a 2-D outline): stood up along {best} to face the camera", {}
    chull = convex_hull(v, rng=rng)
    if f is not None:       # the largest flat base per candidate; one clearly larger than the other's wins
        base = {}
        for area, backed, n in flat_bases(v, f, chull):
            down = {a: -float(n @ AXES[a]) for a in candidates}
            best = max(candidates, key=lambda a: down[a])
            if (backed >= FLAT_BACKED and area >= FLAT_MIN_AREA and down[best] >= math.cos(math.radians(FLAT_TILT))
                    and area > base.get(best, (0.0,))[0]):
                base[best] = (area, math.degrees(math.acos(min(down[best], 1.0))))
        if base:
            best = max(base, key=lambda a: base[a][0])
            if base[best][0] > UP_CONFIDENCE * max((base[a][0] for a in base if a != best), default=0.0):
                return best, f"stands on a flat base or cut along {best} ({base[best][1]:.0f} degrees off)", {}
    hull = hull_points(v, rng=rng) if chull is None else chull.points[chull.vertices]
    centroid = samples.mean(axis=0)
    sym = {ax: mirror_asymmetry(samples, int(np.flatnonzero(AXES[ax])[0])) < SYMMETRY_TOL for ax in candidates}
    scores = {}
    for ax in candidates:
        area, inside = support_score(hull, centroid, np.asarray(AXES[ax], dtype=np.float64), size)
        s = area * (1.0 if inside >= SUPPORT_MARGIN else 0.05)
        if sym[ax] and not all(sym[o] for o in candidates if o != ax):
            s *= 0.25
        scores[ax] = s
    best = max(candidates, key=lambda a: scores[a])
    rest = max((scores[a] for a in candidates if a != best), default=0.0)
    if scores[best] > 0 and scores[best] > UP_CONFIDENCE * rest:
        if rest > 0:
            ratio = scores[best] / rest
            return best, f"stands on its hull along {best} (support score {ratio:.1f}x the other axis)", scores
        return best, f"stands on its hull along {best} (no support along the other axis)", scores
    return default, "no clear base", scores


def detect_up_axis(asset):
    """Up axis of an asset and the reason: the format's definition (glTF: +y), a header comment (PLY/OBJ), or
    :func:`guess_up_axis` on the instanced geometry (default when unsure: +z for STL, +y for the others)."""
    if asset.up_axis is not None:
        return asset.up_axis, f"{asset.format} defines {asset.up_axis} as up"
    meta = asset.stated_up_axis or metadata_up_axis(asset.path, asset.format)
    if meta is not None:
        return meta, f"the {asset.format.upper()} file's comment says {meta} is up"
    v, f = [], []
    off = 0
    for inst in asset.instances:
        m = inst.world_from_object
        am = asset.meshes[inst.mesh]
        v.append(apply_matrix(am.vertices, m))
        f.append(am.faces + off)
        off += am.vertices.shape[0]
    if not v:
        raise PreviewError(f"{asset.path}: the asset has no geometry")
    default = "+z" if asset.format == "stl" else "+y"
    axis, reason, _ = guess_up_axis(np.concatenate(v), np.concatenate(f), default=default)
    if reason == "no clear base":
        reason = f"no clear base; {'STL defaults to z-up' if default == '+z' else 'defaulting to y-up'}"
    return axis, reason


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


def frame_points(points, *, fov=35.0, azimuth=35.0, elevation=20.0, width=640, height=480, margin=1.05,
                 spp=1, jitter=True, iterations=None):
    """A camera looking from ``azimuth``/``elevation`` that fits the projection of ``points`` to the frame.

    The view direction is fixed; the camera is moved sideways until the points' projected bounding box is
    centred and along the view axis until its limiting dimension spans ``1 / margin`` of the frame
    (every point at ``|x_ndc|, |y_ndc| <= 1 / margin``; in closed form per step: the distance at which
    the farthest-out point touches the limit). ``iterations=None`` steps until the sideways step is below
    ``1e-12`` of the bounding radius (at most :data:`FRAME_MAX_STEPS`), so the camera is the fixed point's,
    the same for any point set with the same convex hull; an integer takes exactly that many steps (10 are
    within ~0.01 pixel of it). Give the points (:func:`framing_points`), their hull vertices
    (:func:`hull_points`) or the 8 bounding-box corners: the model's projection lies inside theirs, so
    nothing is clipped, and a flat or thin model fills the frame (a bounding sphere leaves 30-40 % of it).
    Points behind the starting position are handled by the closed form (the camera backs away until all
    are in front).
    """
    p = np.asarray(points, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 3 or p.shape[0] == 0:
        raise PreviewError(f"points must have shape (N, 3) with N > 0, got {p.shape}")
    if not margin > 0:
        raise PreviewError(f"margin must be > 0, got {margin}")
    center, radius = bounding_sphere(p)
    if not radius > 0:
        raise PreviewError(f"the points span zero size (all at {center.tolist()})")
    tv = math.tan(math.radians(fov) / 2)
    th = tv * width / height
    az, el = math.radians(azimuth), math.radians(elevation)
    back = np.array([math.sin(az) * math.cos(el), math.sin(el), math.cos(az) * math.cos(el)])
    fwd = -back
    right = np.cross(fwd, [0.0, 1.0, 0.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, fwd)
    rel = p - center
    x, y, z = rel @ right, rel @ up, rel @ fwd           # camera frame with the origin at the centre
    ox = oy = 0.0                                        # sideways offset of the camera
    near = 1e-3 * radius                                 # every point at least this far in front

    def distance():
        """How far back from the centre every point fits: ``|x - ox| <= (z + d) th / margin`` (and for y)."""
        need = np.maximum(np.abs(x - ox) * margin / th, np.abs(y - oy) * margin / tv)
        return float(np.max(np.maximum(need, near) - z))

    for _ in range(FRAME_MAX_STEPS if iterations is None else iterations):
        d = distance()
        zc = z + d
        sx, sy = (x - ox) / (zc * th), (y - oy) / (zc * tv)
        cx, cy = 0.5 * (sx.max() + sx.min()), 0.5 * (sy.max() + sy.min())
        zm = float(np.median(zc))
        step_x, step_y = cx * zm * th, cy * zm * tv
        ox, oy = ox + step_x, oy + step_y
        if iterations is None and abs(step_x) + abs(step_y) <= 1e-12 * radius:
            break
    d = distance()
    eye = center + ox * right + oy * up - d * fwd
    return Camera(eye, eye + fwd, (0, 1, 0), fov=fov, width=width, height=height, spp=spp, jitter=jitter)


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


def lit_white_radiance(lights, at=(0.0, 0.0, 0.0), n_directions=1024):
    """The radiance scale of a scene's lighting at the point ``at``: the largest channel of what a white Lambertian
    surface would reflect facing every delta light head-on at once (``sum_i E_i / pi``), plus the mean radiance of
    every environment light (over ``n_directions`` directions spread evenly over the sphere). A float; the unit of
    the previewer's ``glossy_clamp``."""
    p = np.asarray(at, dtype=np.float64).reshape(1, 3)
    total = np.zeros(3)
    for lt in lights:
        if lt.delta:
            _, _, E = lt.sample(p, np.zeros((1, 2)))
            total += E[0] / math.pi
        elif lt.environment is not None:
            i = np.arange(n_directions) + 0.5           # a Fibonacci sphere: even, deterministic
            z = 1.0 - 2.0 * i / n_directions
            phi = math.pi * (3.0 - math.sqrt(5.0)) * i
            r = np.sqrt(1.0 - z * z)
            d = np.stack([r * np.cos(phi), z, r * np.sin(phi)], axis=1)
            total += np.asarray(lt.environment.radiance(d)).mean(axis=0)
    return float(total.max())


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



#: the brightest the backdrop may be shown (display-linear, before sRGB encoding: 0.8 is sRGB 231 of 255) by the
#: automatic exposure (:func:`limit_backdrop`)
BACKDROP_MAX = 0.8


def limit_backdrop(exposure, white, backdrop, tonemap="reinhard", *, limit=BACKDROP_MAX):
    """``(exposure, white)`` lowered, when needed, until the ``backdrop`` radiance (RGB) shows at most ``limit``
    (display-linear, the largest channel) with the ``tonemap`` operator; the white point (reinhard's, in scaled units)
    scales with the exposure, at least 1. The automatic exposure brings a dark model's log-average to the key: on the
    shared Khronos set it ranged -1.6 to +2.3 stops, and at +2.3 (VertexColorTest, a dark model) the grey backdrop was
    pure white (255); the limit keeps it grey (231) and changes 4 of the 23 measured (those above 231: VertexColorTest,
    SpecularTest, BoxVertexColors, ClearCoatTest)."""
    bg = np.asarray(backdrop, dtype=np.float64).reshape(1, 1, 3)
    if not np.any(bg > 0):
        return exposure, white

    def shown(e):
        w = None if white is None else max(white * 2.0 ** (e - exposure), 1.0)
        kw = {"L_white": w} if tonemap == "reinhard" and w is not None else {}
        return float(tonemap_to_display(bg, tonemap_op=tonemap, exposure=e, **kw).max()), w

    if shown(exposure)[0] <= limit:
        return exposure, white
    lo, hi = exposure - 30.0, exposure          # shown(lo) ~ 0 <= limit < shown(hi): bisect to 1e-4 stops
    while hi - lo > 1e-4:
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if shown(mid)[0] <= limit else (lo, mid)
    return lo, shown(lo)[1]