"""The stress cases: :class:`Case` (geometry x light x scale x translation x incidence), the default and
quick matrices, and :func:`build_case` (the pyrt scene and its exact truth)."""
from __future__ import annotations

from dataclasses import dataclass
import math

import numpy as np
import trimesh

from pyrt.core.camera import Camera
from pyrt.lights import DirectionalLight, PointLight, SpotLight
from pyrt.materials import Glass, Lambert, Mirror
from pyrt.scene import Scene
from pyrt.apps.acne.truth import Box, LightTruth, Sphere, Truth, _ulp32

#: Side of the floor in scene units (the "scene size" that scale and thicknesses refer to).
SCENE_SIZE = 4.0
#: Thin walls and panels are this fraction of the scene size thick.
THIN = 1e-4
#: The light is a ball of this radius (fraction of the scene size) for the truth's shadow segments.
LIGHT_RADIUS = 1e-3
#: Distance of point and spot lights from the scene centre (scene units).
LIGHT_DISTANCE = 6.0

GEOMETRIES = ("plane", "sphere_fine", "sphere_lowpoly", "sphere_flat", "thin_wall", "contact", "corner",
              "mirror", "glass", "wall_lamp")
LIGHTS = ("directional", "point", "spot")


@dataclass(frozen=True)
class Case:
    """One scene of the matrix: geometry, light type, scale, translation, light incidence (degrees)."""

    geometry: str
    light: str = "directional"
    scale: float = 1.0
    translation: float = 0.0
    incidence: float = 45.0

    def __post_init__(self):
        if self.geometry not in GEOMETRIES:
            raise ValueError(f"Case: unknown geometry {self.geometry!r}; choose from {GEOMETRIES}")
        if self.light not in LIGHTS:
            raise ValueError(f"Case: unknown light {self.light!r}; choose from {LIGHTS}")
        if not (self.scale > 0 and math.isfinite(self.scale)):
            raise ValueError(f"Case: scale must be > 0, got {self.scale!r}")
        if not 0 <= self.incidence < 90:
            raise ValueError(f"Case: incidence must be in [0, 90) degrees, got {self.incidence!r}")
        if self.geometry == "wall_lamp" and self.light == "directional":
            raise ValueError("Case: wall_lamp needs a point or spot light (the light is mounted on the wall)")

    @property
    def id(self):
        return (f"{self.geometry}-{self.light}-s{self.scale:g}-t{self.translation:g}-i{self.incidence:g}")


def default_matrix():
    """The matrix: every geometry x light at the base (scale 1, at the origin, 45 deg), then sweeps.

    Sweeps (directional light; wall_lamp: point light): scale 1e-4, 1e-2, 1e2, 1e4; translation
    (t, t, t) for t = 1e2, 1e4, 1e5 at scale 1 and t = 1e6 at scale 1e2 (at scale 1 float32 cannot hold
    a 1-unit sphere 1e6 from the origin: its ulp, 0.06, is 12 % of the radius); incidence 0, 70, 85,
    89.9 deg; grazing 89.9 deg with a point light; and the combinations 89.9 deg at t = 1e4 (the floor
    at y = 0 is the easy case: floats near 0 are dense), scale 1e-4 at t = 1 (a millimetre part one unit
    from the origin) and scale 1e4 at t = 1e6.
    """
    cases = []
    for g in GEOMETRIES:
        for lt in LIGHTS:
            if g == "wall_lamp" and lt == "directional":
                continue
            cases.append(Case(g, lt))
    for g in GEOMETRIES:
        lt = "point" if g == "wall_lamp" else "directional"
        for s in (1e-4, 1e-2, 1e2, 1e4):
            cases.append(Case(g, lt, scale=s))
        for t in (1e2, 1e4, 1e5):
            if g == "wall_lamp" and t == 1e5:
                continue   # float32 places the wall to 0.008: more than the lamp's radius, nothing is decidable
            cases.append(Case(g, lt, translation=t))
        cases.append(Case(g, lt, scale=1e2, translation=1e6))
        if g != "wall_lamp":
            for inc in (0.0, 70.0, 85.0, 89.9):
                cases.append(Case(g, lt, incidence=inc))
            cases.append(Case(g, "point", incidence=89.9))
        # combined extremes: grazing light off the origin, a millimetre scene 1 unit from the origin, a
        # large scene far away
        if g != "wall_lamp":
            cases.append(Case(g, lt, translation=1e4, incidence=89.9))
        cases.append(Case(g, lt, scale=1e-4, translation=1.0))
        cases.append(Case(g, lt, scale=1e4, translation=1e6))
    return cases


def quick_matrix():
    """A subset for the default test run: the base cases and the extreme of every sweep."""
    keep = []
    for c in default_matrix():
        base = c.scale == 1 and c.translation == 0 and c.incidence == 45
        extreme = (c.scale in (1e-4, 1e4) or c.translation in (1e5, 1e6) or c.incidence == 89.9) and \
            c.light == ("point" if c.geometry == "wall_lamp" else "directional")
        if base or extreme:
            keep.append(c)
    return keep


def _icosphere_bounds(subdiv, smooth):
    """In-ball radius (unit sphere) and the normal tolerance (rad) of a trimesh icosphere."""
    m = trimesh.creation.icosphere(subdivisions=subdiv, radius=1.0)
    centres = m.triangles_center
    r_in = float(np.abs((centres * m.face_normals).sum(1)).min())
    v = m.vertices / np.linalg.norm(m.vertices, axis=1, keepdims=True)
    if smooth:
        vn = m.vertex_normals
        ang = float(np.arccos(np.clip((vn * v).sum(1), -1, 1)).max())
    else:
        tri = v[m.faces]                                              # (F, 3, 3) radial dirs at corners
        ang = float(np.arccos(np.clip(np.einsum("fk,fjk->fj", m.face_normals, tri), -1, 1)).max())
    edge = float(m.edges_unique_length.min())
    return r_in, ang, edge


_GEOM = {
    # name: (shapes in scene units, light azimuth (x, z) of the direction toward the light, camera)
    # shape: ("box", lo, hi, material) | ("sphere", centre, r, subdiv, smooth, material)
    "plane": ([], (1.0, -1.0)),
    "sphere_fine": ([("sphere", (0, 0.9, 0), 0.5, 4, True, "diffuse")], (1.0, 0.25)),
    "sphere_lowpoly": ([("sphere", (0, 0.9, 0), 0.5, 1, True, "diffuse")], (1.0, 0.25)),
    "sphere_flat": ([("sphere", (0, 0.9, 0), 0.5, 2, False, "diffuse")], (1.0, 0.25)),
    "thin_wall": ([("box", (-0.8, 0.25, -0.8), (0.8, 0.25 + THIN * SCENE_SIZE, 0.8), "diffuse")], (0.3, -0.95)),
    "contact": ([("sphere", (-0.7, 0.5, 0.0), 0.5, 3, True, "diffuse"),
                 ("box", (0.35, 0.0, -0.35), (1.05, 0.7, 0.35), "diffuse")], (0.8, -0.6)),
    "corner": ([("box", (-2.0, 0.0, -0.3 - THIN * SCENE_SIZE), (2.0, 1.2, -0.3), "diffuse")], (0.35, -0.94)),
    "mirror": ([("box", (-1.6, 0.0, -1.3), (1.6, 1.6, -1.2), "mirror"),
                ("sphere", (0.35, 0.6, 0.1), 0.35, 3, True, "diffuse")], (0.5, 0.866)),
    "glass": ([("box", (-1.0, 0.5, -1.0), (1.0, 0.6, 1.0), "glass"),
               ("box", (-0.2, 0.0, -0.2), (0.2, 0.3, 0.2), "diffuse")], (1.0, 0.0)),
    "wall_lamp": ([("box", (-2.0, 0.0, -1.5), (2.0, 2.0, -1.2), "diffuse"),
                   ("sphere", (0.4, 0.45, -0.4), 0.3, 3, True, "diffuse")], None),
}
_CAMERA = {"default": ((0.0, 2.6, 4.2), (0.0, 0.2, 0.0)), "mirror": ((0.0, 1.4, 3.6), (0.0, 0.5, -1.0)),
           "glass": ((0.0, 3.2, 1.6), (0.0, 0.0, 0.0))}
_LAMP = (0.0, 1.0, -1.2)          # on the wall's front face z = -1.2
_LAMP_TARGET = (0.0, 0.0, 0.6)


@dataclass
class BuiltCase:
    case: Case
    scene: Scene
    truth: Truth
    max_depth: int


def build_case(case, width=64, height=48):
    """Scene (for pyrt) and exact truth (for the labels) of ``case``; world = scale * local + translation."""
    s, T = float(case.scale), float(case.translation)
    shift = np.full(3, T)

    def W(p):
        return s * np.asarray(p, dtype=np.float64) + shift

    cam_key = case.geometry if case.geometry in _CAMERA else "default"
    cp, ct = _CAMERA[cam_key]
    cam = Camera(position=W(cp), target=W(ct), fov=42.0, width=width, height=height, spp=1, jitter=False)
    scene = Scene(cam)
    xf = np.diag([s, s, s, 1.0])
    xf[:3, 3] = shift
    mats = {"diffuse": Lambert(albedo=0.8), "mirror": Mirror(reflectance=1.0), "glass": Glass(ior=1.5)}

    def tol_of(vertices_world):
        return _ulp32(np.max(np.abs(vertices_world))) + 1e-12 * s

    shapes = []
    # the floor: a 2-triangle rectangle at y = 0
    h = SCENE_SIZE / 2
    fv = np.array([[-h, 0, h], [h, 0, h], [h, 0, -h], [-h, 0, -h]])
    scene.add_mesh((fv, np.array([[0, 1, 2], [0, 2, 3]])), mats["diffuse"], transform=xf, smooth=False, name="floor")
    ftol = tol_of(W(fv))
    shapes.append(Box(W((-h, 0, -h)), W((h, 0, h)), ftol, normal_tol=2 * ftol / (s * SCENE_SIZE)))
    spec, az = _GEOM[case.geometry]
    for i, sp in enumerate(spec):
        if sp[0] == "box":
            _, lo, hi, mat = sp
            lo, hi = np.asarray(lo, float), np.asarray(hi, float)
            m = trimesh.creation.box(bounds=np.stack([lo, hi]))
            scene.add_mesh(m, mats[mat], transform=xf, smooth=False, name=f"box{i}")
            tol = tol_of(W(m.vertices))
            ext = np.sort(hi - lo)
            face_min = max(ext[1], 1e-300) * s       # the smaller side of the largest faces
            tilt = math.atan(2 * tol / face_min)
            shapes.append(Box(W(lo), W(hi), tol, normal_tol=tilt, material=mat, dir_tol=2 * tilt + 1e-9))
        else:
            _, c, r, sub, smooth, mat = sp
            m = trimesh.creation.icosphere(subdivisions=sub, radius=r)
            m.apply_translation(c)
            scene.add_mesh(m, mats[mat], transform=xf, smooth=smooth, name=f"sphere{i}")
            tol = tol_of(W(m.vertices))
            r_in, ang, edge = _icosphere_bounds(sub, smooth)
            tilt = math.atan(2 * tol / (edge * r * s))
            shapes.append(Sphere(W(c), r * s, r_in * r * s, tol, normal_tol=ang + tilt + 1e-9, material=mat,
                                 dir_tol=2 * (ang + tilt)))
    pos_tol = max(sh.tol for sh in shapes)
    # the light
    theta = math.radians(case.incidence)
    if case.geometry == "wall_lamp":
        lp = W(_LAMP)
        axis = W(_LAMP_TARGET) - lp
        axis /= np.linalg.norm(axis)
        dist_c = s * float(np.linalg.norm(np.subtract(_LAMP_TARGET, _LAMP)))
    else:
        ax, az_ = az
        nz = math.hypot(ax, az_)
        omega = np.array([math.sin(theta) * ax / nz, math.cos(theta), math.sin(theta) * az_ / nz])
        lp = shift + s * LIGHT_DISTANCE * omega
        axis = -omega
        dist_c = s * LIGHT_DISTANCE
    radius = LIGHT_RADIUS * SCENE_SIZE * s
    I = dist_c ** 2
    if case.light == "directional":
        light = DirectionalLight(axis, irradiance=1.0)
        lt = LightTruth("directional", direction=axis.copy(), tol=pos_tol)
    elif case.light == "point":
        light = PointLight(lp, intensity=I)
        lt = LightTruth("point", position=lp, radius=radius, tol=pos_tol)
    else:
        outer, inner = (70.0, 60.0) if case.geometry == "wall_lamp" else (55.0, 45.0)
        light = SpotLight(lp, axis, intensity=I, inner_angle=inner, outer_angle=outer)
        lt = LightTruth("spot", position=lp, axis=axis, cos_outer=math.cos(math.radians(outer)), radius=radius,
                        tol=pos_tol)
    scene.add_light(light)
    max_depth = 2 if case.geometry == "glass" else 1
    return BuiltCase(case, scene, Truth(shapes, lt), max_depth)


def camera_rays32(cam):
    """The camera's pixel-centre rays as Embree sees them (float32), in float64, row-major."""
    n = cam.width * cam.height
    rays = cam.generate_rays(0, n, np.random.default_rng(0))
    o, d = rays.origins, rays.directions
    o32 = np.ascontiguousarray(o, dtype=np.float32).astype(np.float64)
    d32 = np.ascontiguousarray(d, dtype=np.float32).astype(np.float64)
    return o32, d32 / np.linalg.norm(d32, axis=1, keepdims=True)


def truth_labels(built):
    """(H, W) int8 ground-truth labels of a built case."""
    cam = built.scene.camera
    o, d = camera_rays32(cam)
    return built.truth.trace(o, d).reshape(cam.height, cam.width)
