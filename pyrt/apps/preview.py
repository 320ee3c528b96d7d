"""Asset preview: "show me this model, properly lit".

``render_preview(path_or_asset, options)`` loads a model (:mod:`pyrt.io.assets`), turns it so that
its up axis is +y, frames it, lights it with a studio rig over a shadow-catcher ground, picks an
exposure and renders one view or a turntable. :func:`preview_batch` does that for a folder or glob
of models, locally or on a Dask cluster, and :func:`main` is the ``pyrt-preview`` command.

The pieces, each a function that can be used and tested alone
------------------------------------------------------------
- **Up axis** (:func:`detect_up_axis`): glTF is +y by specification. For OBJ/PLY/STL the candidate
  ups +y and +z are scored by the area of downward-facing triangles within 1% of the model's extent
  from its lowest point along that axis (the base a model stands on); the larger base wins; with no
  base on either, STL (a CAD / 3D-printing format) is taken as +z and the others as +y. Override
  with ``up="+z"`` etc.
- **Framing** (:func:`frame_camera`): the bounding sphere (centre of the bounding box, radius to the
  farthest vertex) is seen at ``azimuth``/``elevation`` (degrees; azimuth 0 looks from +z toward -z,
  positive azimuth moves the camera toward +x) from the distance ``d = margin R / sin(a)``, where
  ``a`` is the smaller of the vertical and horizontal half fields of view: the sphere's silhouette
  cone (half-angle ``asin(R / d)``) then fits inside the image on both axes.
- **Studio rig** (:func:`studio_rig`): key, fill and rim *directional* lights placed relative to the
  camera (key high on the camera's left, fill low on its right, rim behind), irradiance in W/m^2.
  Directional lights make the rig independent of the model's size and position (what "scaled to
  the model" needs: the same picture at any scale) and give a ground that is lit uniformly, which
  is what the shadow catcher needs.
- **Shadow-catcher ground**: a Lambertian plane of albedo ``rho`` just below the model (100 radii
  wide). Its unshadowed radiance is the constant ``L_g = rho / pi * sum_i E_i max(0, sin el_i) +
  rho * L_a`` (:func:`ground_radiance`, the integrator's own formula), and the background (what
  misses see) is set to exactly ``L_g``: the ground disappears into the backdrop and only the
  shadows it catches remain. The asset's own point/spot lights (``lights="asset"/"both"``) light
  the ground unevenly; the backdrop then matches the ground under the model's centre. With an
  environment map (``environment=``, an OpenEXR lat-long map, used as a light with
  ``environment_lighting``/``environment_samples``) camera rays see the backdrop plus the map's
  unshadowed SH irradiance on the ground (``rho / pi * E_sh(+y)``); without a ground they see the map.
- **Exposure** (:func:`auto_exposure`): Reinhard et al. 2002's photographic key over the pixels that
  see the model (pixel-centre rays against the model only): ``scale = 0.18 / exp(mean(log(1e-4 +
  Y)))``, white point ``L_white = max(scale * Y_99.9, 1)`` for the extended Reinhard operator, so
  the model's log-average maps to mid-grey and at most 0.1% of its pixels clip. Fixed once per
  asset (turntables do not flicker); ``exposure=`` overrides it.
- **Outputs**: PNG (tone-mapped, sRGB) and/or EXR (linear radiance, optional depth/normal/albedo
  channels); with ``aovs`` also ``_depth/_normal/_albedo.png`` previews. A turntable of N views
  writes ``NAME_turntable/frame_###.png`` and a contact sheet ``NAME_sheet.png``.

Batches and scale-out
---------------------
:func:`preview_batch` expands folders and globs, renders every asset with :func:`preview_asset`
(which never raises: a failing asset becomes a report with status ``failed`` and its message) and
returns one :class:`AssetReport` per asset (triangles, load and render time, warnings). With
``dask=True`` (a ``distributed.LocalCluster``) or ``dask="tcp://host:8786"`` (an existing scheduler)
each asset is one task; workers send the encoded files back and the client writes them, so a real
cluster needs no shared output folder (the models must be readable by the workers). The work per
asset is the same function with the same seeds, so the files are identical to a local run.
``time_budget`` (s per asset) is checked before the load and before every view: a turntable stops
with status ``timeout`` when the next view would exceed it (a single long view is not interrupted).
"""
from __future__ import annotations

import argparse
import csv
import dataclasses
from dataclasses import dataclass, field
import glob
import io
import math
import os
import sys
import tempfile
import time
import traceback
import warnings as _warnings

import numpy as np

from pyrt.shaders import color as _color

from pyrt.core.camera import Camera
from pyrt.integrators import PreparedScene
from pyrt.render import render_full
from pyrt.io.assets import Asset, AssetError, FORMATS, load_asset
from pyrt.core.image_io import tonemap_to_display, write_exr
from pyrt.lights.punctual import DirectionalLight
from pyrt.materials import Lambert
from pyrt.scene import Scene
from pyrt.core.errors import Error


class PreviewError(Error, ValueError):
    """Invalid preview options or an asset that cannot be previewed."""


class BudgetExceeded(Error, RuntimeError):
    """The per-asset time budget ran out (the message says after what)."""


@dataclass
class PreviewOptions:
    """Everything a preview can be told. Angles in degrees, irradiance in W/m^2, times in seconds."""

    width: int = 640
    height: int = 480
    spp: int = 4
    fov: float = 35.0                    # vertical field of view
    azimuth: float = 35.0                # camera azimuth around the up axis (0 = from +z)
    elevation: float = 20.0              # camera elevation above the ground plane
    margin: float = 1.05                 # bounding-sphere radius multiplier for framing
    up: str = "auto"                     # "auto" or one of "+x", "-x", "+y", "-y", "+z", "-z"
    camera: str = "auto"                 # "auto" (framed) or "asset" (the file's first camera)
    lights: str = "studio"               # "studio", "asset" or "both"
    key: float = 3.0                     # key-light irradiance (W/m^2)
    fill_ratio: float = 0.35
    rim_ratio: float = 0.7
    ambient: float = 0.1                 # constant ambient radiance as a fraction of key / pi
    ground: bool = True
    ground_albedo: float = 0.5
    environment: str | None = None       # OpenEXR lat-long map
    environment_intensity: float = 1.0
    environment_lighting: str = "mis"    # EnvironmentLight strategy ("mis", "preview" = no shadows, no noise, ...)
    environment_samples: int = 8         # environment light samples per hit
    exposure: float | None = None        # stops; None = automatic
    tonemap: str = "reinhard"
    turntable: int = 0                   # number of views (0 = a single view)
    formats: tuple = ("png",)            # any of "png", "exr"
    aovs: bool = False
    seed: int = 0
    max_depth: int = 4
    crease_angle: float = 30.0
    time_budget: float | None = None     # seconds per asset
    threads: int | None = None           # Embree/shading threads per render (None = all cores)

    def validate(self):
        for name in ("width", "height", "spp"):
            v = getattr(self, name)
            if int(v) != v or v < 1:
                raise PreviewError(f"{name} must be a positive integer, got {v!r}")
        if not 0 < self.fov < 180:
            raise PreviewError(f"fov must be in (0, 180) degrees, got {self.fov}")
        if not -89.0 <= self.elevation <= 89.0:
            raise PreviewError(f"elevation must be in [-89, 89] degrees, got {self.elevation}")
        if not self.margin > 0:
            raise PreviewError(f"margin must be > 0, got {self.margin}")
        if self.up != "auto" and self.up not in AXES:
            raise PreviewError(f"up must be 'auto' or one of {sorted(AXES)}, got {self.up!r}")
        if self.camera not in ("auto", "asset"):
            raise PreviewError(f"camera must be 'auto' or 'asset', got {self.camera!r}")
        if self.lights not in ("studio", "asset", "both"):
            raise PreviewError(f"lights must be 'studio', 'asset' or 'both', got {self.lights!r}")
        bad = set(self.formats) - {"png", "exr"}
        if bad or not self.formats:
            raise PreviewError(f"formats must be a non-empty subset of ('png', 'exr'), got {self.formats!r}")
        if int(self.turntable) != self.turntable or self.turntable < 0:
            raise PreviewError(f"turntable must be an integer >= 0 (number of views), got {self.turntable!r}")
        if not 0 <= self.ground_albedo <= 1:
            raise PreviewError(f"ground_albedo must be in [0, 1], got {self.ground_albedo}")
        for name in ("key", "fill_ratio", "rim_ratio", "ambient"):
            if not getattr(self, name) >= 0:
                raise PreviewError(f"{name} must be >= 0, got {getattr(self, name)}")
        if self.time_budget is not None and not self.time_budget > 0:
            raise PreviewError(f"time_budget must be > 0 seconds, got {self.time_budget}")
        return self


AXES = {"+x": (1, 0, 0), "-x": (-1, 0, 0), "+y": (0, 1, 0), "-y": (0, -1, 0), "+z": (0, 0, 1), "-z": (0, 0, -1)}


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
    import trimesh

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
        E = o.key if share == "key" else o.key * getattr(o, share)
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
        if not getattr(lt, "delta", True):
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


# ============================================================================ the preview scene

class PreviewScene:
    """An asset placed in a studio: geometry prepared once, views rendered at any azimuth."""

    def __init__(self, asset, options=None):
        self.options = o = (options or PreviewOptions()).validate()
        self.asset = asset
        self.warnings = list(asset.warnings)
        if o.up == "auto":
            self.up_axis, self.up_reason = detect_up_axis(asset)
        else:
            self.up_axis, self.up_reason = o.up, "given"
        self.up_matrix = up_transform(self.up_axis)
        v = asset.world_vertices()
        v = v @ self.up_matrix[:3, :3].T
        self.center, self.radius = bounding_sphere(v)
        if not self.radius > 0:
            raise PreviewError(f"{asset.path}: the model has zero size")
        self.ground_y = float(v[:, 1].min())
        self.scene = Scene(Camera())
        with _warnings.catch_warnings(record=True) as caught:
            _warnings.simplefilter("always")
            self.model_meshes = asset.add_to_scene(self.scene, transform=self.up_matrix,
                                                   crease_angle=o.crease_angle, lights=o.lights in ("asset", "both"))
        self.warnings += [str(w.message) for w in caught]
        self.asset_lights = list(self.scene.lights)
        self.ground_mesh = None
        if o.ground:
            g = Lambert(o.ground_albedo, name="ground")
            foot = (self.center[0], self.ground_y - 1e-4 * self.radius, self.center[2])
            self.ground_mesh = self.scene.add_plane(foot, 100.0 * self.radius, g, name="ground")
        self.environment = None
        if o.environment:
            from pyrt.lights.environment import LatLongEnvironment, set_environment
            self.environment = LatLongEnvironment(o.environment, intensity=o.environment_intensity)
            set_environment(self.scene, self.environment, lighting=o.environment_lighting,
                            n_samples=o.environment_samples)
            self.asset_lights = list(self.scene.lights)
        if o.lights == "asset" and not asset.lights and self.environment is None:
            self.warnings.append("lights='asset' but the asset has no lights: the studio rig is used")
            self._use_rig = True
        else:
            self._use_rig = o.lights in ("studio", "both")
        self.ambient_radiance = o.ambient * o.key / math.pi if self._use_rig else 0.0
        self.scene.ambient = np.full(3, self.ambient_radiance)
        self.prepared = PreparedScene(self.scene, threads=o.threads)
        self.exposure = o.exposure
        self.white = None

    @property
    def n_triangles(self):
        return self.asset.n_triangles

    def camera(self, azimuth):
        o = self.options
        if o.camera == "asset":
            if not self.asset.cameras:
                raise PreviewError(f"{self.asset.path}: camera='asset' but the file has no perspective camera")
            ac = self.asset.cameras[0]
            R = self.up_matrix[:3, :3]
            cam = dataclasses.replace(ac, position=R @ ac.position, forward=R @ ac.forward, up=R @ ac.up)
            return cam.to_pyrt(o.width, o.height, spp=o.spp)
        return frame_camera(self.center, self.radius, fov=o.fov, azimuth=azimuth, elevation=o.elevation,
                            width=o.width, height=o.height, margin=o.margin, spp=o.spp)

    def _set_view(self, azimuth):
        o = self.options
        self.scene.camera = self.camera(azimuth)
        rig = studio_rig(azimuth, o) if self._use_rig else []
        bg = np.zeros(3)
        if o.ground:
            foot = (self.center[0], self.ground_y, self.center[2])
            bg = ground_radiance(list(self.asset_lights) + rig, o.ground_albedo, self.ambient_radiance, at=foot)
            if self.environment is not None:  # + the map's (SH, unshadowed) irradiance on the ground
                up = np.array([[0.0, 1.0, 0.0]])
                bg = bg + o.ground_albedo / math.pi * np.maximum(self.environment.irradiance_sh(up)[0], 0.0)
        if self.environment is not None:
            # with a ground, camera rays see the matched backdrop; without one, the map itself
            self.environment.hide_background = bool(o.ground)
            self.environment.background = bg
        self.scene.background = bg
        self.scene.lights[:] = list(self.asset_lights) + rig

    def model_mask(self, camera=None):
        """(H, W) bool: pixel-centre rays that hit the model (not the ground, not the background)."""
        cam = camera or self.scene.camera
        ys, xs = np.mgrid[0:cam.height, 0:cam.width]
        d = cam.directions(xs.ravel() + 0.5, ys.ravel() + 0.5)
        o = np.broadcast_to(cam.position, d.shape)
        hits = self.prepared.accel.intersect(o, d)
        model = hits.hit & np.isin(hits.mesh_id, self.model_meshes)
        return model.reshape(cam.height, cam.width)

    def render_view(self, azimuth, *, aovs=False):
        """Render one view; the first call fixes the exposure (unless given). Returns a RenderResult."""
        o = self.options
        self._set_view(azimuth)
        with _warnings.catch_warnings(record=True) as caught:
            _warnings.simplefilter("always")
            res = render_full(self.scene, seed=o.seed, max_depth=o.max_depth, aovs=aovs, progress=False,
                              prepared=self.prepared, threads=o.threads)
        self.warnings += [str(w.message) for w in caught]
        if self.exposure is None:
            self.exposure, self.white = auto_exposure(res.image, self.model_mask())
        return res

    def to_display(self, image):
        """Tone-mapped, sRGB-encoded uint8 (H, W, 3) with this preview's exposure."""
        o = self.options
        kw = {"L_white": self.white} if (o.tonemap == "reinhard" and self.white is not None) else {}
        disp = tonemap_to_display(image, tonemap_op=o.tonemap, exposure=self.exposure or 0.0, **kw)
        return np.round(_color.srgb_encode(disp) * 255).astype(np.uint8)

    def close(self):
        self.prepared.close()


# ============================================================================ rendering to files

@dataclass
class PreviewResult:
    """What :func:`render_preview` produced."""

    images: list                 # linear radiance (H, W, 3) float32 per view
    aovs: list                   # per view: dict or None
    azimuths: list
    exposure: float
    white: float | None
    up_axis: str
    up_reason: str
    center: np.ndarray
    radius: float
    camera: Camera
    triangles: int
    load_time: float
    render_time: float
    warnings: list
    files: dict = field(default_factory=dict)      # output name -> bytes (encoded files)


def _png_bytes(arr):
    """8-bit RGB PNG bytes (Pillow; deterministic for a given array)."""
    from PIL import Image

    buf = io.BytesIO()
    Image.fromarray(np.ascontiguousarray(arr, dtype=np.uint8)).save(buf, format="PNG")
    return buf.getvalue()


def _exr_bytes(image, aovs):
    with tempfile.TemporaryDirectory() as tmp:
        p = os.path.join(tmp, "x.exr")
        write_exr(p, image, aovs=aovs)
        with open(p, "rb") as fh:
            return fh.read()


def contact_sheet(tiles, *, cols=None, pad=4, fill=255):
    """Grid of equally sized uint8 (H, W, 3) tiles (row-major), ``pad`` pixels apart."""
    n = len(tiles)
    if n == 0:
        raise PreviewError("contact_sheet needs at least one image")
    h, w = tiles[0].shape[:2]
    cols = cols or int(math.ceil(math.sqrt(n)))
    rows = int(math.ceil(n / cols))
    sheet = np.full((rows * h + (rows + 1) * pad, cols * w + (cols + 1) * pad, 3), fill, dtype=np.uint8)
    for k, t in enumerate(tiles):
        r, c = divmod(k, cols)
        y, x = pad + r * (h + pad), pad + c * (w + pad)
        sheet[y:y + h, x:x + w] = t
    return sheet


def _aov_pngs(aov):
    out = {}
    n = np.asarray(aov["normal"], dtype=np.float64)
    out["normal"] = np.round(np.clip(0.5 * n + 0.5, 0, 1) * 255).astype(np.uint8)
    out["albedo"] = np.round(_color.srgb_encode(np.clip(aov["albedo"], 0, 1)) * 255).astype(np.uint8)
    z = np.asarray(aov["depth"], dtype=np.float64)
    fin = np.isfinite(z)
    if np.any(fin):
        lo, hi = z[fin].min(), z[fin].max()
        zz = np.where(fin, 1.0 - (z - lo) / max(hi - lo, 1e-300), 0.0)
    else:
        zz = np.zeros_like(z)
    out["depth"] = np.repeat(np.round(zz * 255).astype(np.uint8)[..., None], 3, axis=2)
    return out


def render_preview(model, options=None, *, name="preview", deadline=None):
    """Load (if given a path), set up and render a preview; encoded outputs in ``result.files``.

    ``result.files`` maps names to bytes: ``NAME.png``/``NAME.exr`` (+ ``NAME_depth.png`` etc. with
    ``aovs``) for a single view; ``NAME_turntable/frame_###.png`` (/``.exr``) and ``NAME_sheet.png``
    for a turntable. ``deadline`` (a ``time.perf_counter()`` value) raises :class:`BudgetExceeded`
    before a view that would not finish in time (estimated from the previous view).
    """
    o = (options or PreviewOptions()).validate()
    t0 = time.perf_counter()
    asset = model if isinstance(model, Asset) else load_asset(model)
    load_time = asset.load_time if isinstance(model, Asset) else time.perf_counter() - t0
    if deadline is not None and time.perf_counter() > deadline:
        raise BudgetExceeded(f"time budget exceeded while loading ({load_time:.2f} s)")
    ps = PreviewScene(asset, o)
    try:
        n_views = max(1, o.turntable)
        az = [o.azimuth + 360.0 * k / n_views for k in range(n_views)] if o.turntable else [o.azimuth]
        images, aovs = [], []
        files = {}
        t_render = 0.0
        last = None
        for k, a in enumerate(az):
            if deadline is not None and last is not None and time.perf_counter() + last > deadline:
                raise BudgetExceeded(f"time budget exceeded after {k}/{n_views} views "
                                     f"({t_render:.2f} s rendering, {last:.2f} s per view)")
            t1 = time.perf_counter()
            res = ps.render_view(a, aovs=o.aovs)
            last = time.perf_counter() - t1
            t_render += last
            images.append(res.image)
            aovs.append(res.aovs)
        disp = [ps.to_display(im) for im in images]
        for k, (im, ao, dsp) in enumerate(zip(images, aovs, disp)):
            stem = f"{name}_turntable/frame_{k:03d}" if o.turntable else name
            if "png" in o.formats:
                files[f"{stem}.png"] = _png_bytes(dsp)
                if ao is not None:
                    for kind, arr in _aov_pngs(ao).items():
                        files[f"{stem}_{kind}.png"] = _png_bytes(arr)
            if "exr" in o.formats:
                files[f"{stem}.exr"] = _exr_bytes(im, ao)
        if o.turntable:
            files[f"{name}_sheet.png"] = _png_bytes(contact_sheet(disp))
        return PreviewResult(images=images, aovs=aovs, azimuths=az, exposure=ps.exposure, white=ps.white,
                             up_axis=ps.up_axis, up_reason=ps.up_reason, center=ps.center, radius=ps.radius,
                             camera=ps.camera(az[0]), triangles=ps.n_triangles, load_time=load_time,
                             render_time=t_render, warnings=ps.warnings, files=files)
    finally:
        ps.close()


def write_files(files, out_dir):
    """Write ``{relative name: bytes}`` under ``out_dir``; returns the paths written."""
    paths = []
    for rel, data in files.items():
        p = os.path.join(out_dir, rel)
        os.makedirs(os.path.dirname(os.path.abspath(p)), exist_ok=True)
        with open(p, "wb") as fh:
            fh.write(data)
        paths.append(p)
    return paths


# ============================================================================ batches

@dataclass
class AssetReport:
    """One line of the batch summary."""

    path: str
    name: str
    status: str = "ok"                  # "ok" | "failed" | "timeout"
    triangles: int = 0
    load_time: float = 0.0
    render_time: float = 0.0
    warnings: list = field(default_factory=list)
    error: str = ""
    outputs: list = field(default_factory=list)
    exposure: float | None = None
    files: dict | None = None           # encoded outputs (Dask mode, before the client writes them)


def output_name(path, taken=None):
    """Output stem for a model path: ``duck.glb`` -> ``duck_glb`` (``_2``, ... if already ``taken``)."""
    base = os.path.basename(path).replace(".", "_")
    name, k = base, 2
    while taken is not None and name in taken:
        name, k = f"{base}_{k}", k + 1
    if taken is not None:
        taken.add(name)
    return name


def preview_asset(path, out_dir=None, options=None, *, name=None, return_files=False):
    """Preview one model for a batch; never raises. Writes under ``out_dir`` unless ``return_files``.

    Returns an :class:`AssetReport`; a failing asset has ``status="failed"`` and the error message,
    a budget overrun ``status="timeout"``.
    """
    o = options or PreviewOptions()
    name = name or output_name(path)
    rep = AssetReport(path=os.fspath(path), name=name)
    t0 = time.perf_counter()
    deadline = t0 + o.time_budget if o.time_budget else None
    try:
        res = render_preview(path, o, name=name, deadline=deadline)
    except BudgetExceeded as exc:
        rep.status, rep.error = "timeout", str(exc)
        rep.load_time = time.perf_counter() - t0
        return rep
    except (AssetError, PreviewError, ValueError, OSError) as exc:
        rep.status, rep.error = "failed", f"{type(exc).__name__}: {exc}"
        return rep
    except Exception as exc:  # a bug or an unexpected library error: report it, keep the batch going
        tb = traceback.extract_tb(exc.__traceback__)[-1]
        rep.status = "failed"
        rep.error = f"{type(exc).__name__}: {exc} (at {os.path.basename(tb.filename)}:{tb.lineno})"
        return rep
    rep.triangles, rep.load_time, rep.render_time = res.triangles, res.load_time, res.render_time
    rep.warnings, rep.exposure = list(dict.fromkeys(res.warnings)), res.exposure
    if return_files:
        rep.files = res.files
        rep.outputs = sorted(res.files)
    else:
        rep.outputs = write_files(res.files, out_dir or ".")
    return rep


def collect_inputs(specs):
    """Expand files, folders (their supported models, sorted) and glob patterns into model paths."""
    out = []
    for s in specs:
        s = os.fspath(s)
        if os.path.isdir(s):
            out += sorted(os.path.join(s, f) for f in os.listdir(s)
                          if os.path.splitext(f)[1].lower() in FORMATS and os.path.isfile(os.path.join(s, f)))
        elif any(ch in s for ch in "*?["):
            out += sorted(p for p in glob.glob(s, recursive=True) if os.path.isfile(p))
        else:
            out.append(s)
    return list(dict.fromkeys(out))


def preview_batch(inputs, out_dir, options=None, *, dask=None, n_workers=2, processes=False, progress=True):
    """Preview every model of ``inputs`` (files, folders, globs) into ``out_dir``.

    Parameters
    ----------
    dask : None, True, str or distributed.Client
        None: render here, one asset after another. True: a ``distributed.LocalCluster`` with
        ``n_workers`` single-threaded workers (``processes`` as given). A string: the address of an
        existing scheduler. A Client: use it. Each asset is one task.
    progress : bool
        A tqdm progress bar over the assets.

    Returns
    -------
    list of AssetReport, in input order. The summary table is also written to
    ``out_dir/summary.csv`` and ``out_dir/summary.txt``.
    """
    from tqdm.auto import tqdm

    o = (options or PreviewOptions()).validate()
    paths = collect_inputs(inputs)
    taken = set()
    names = [output_name(p, taken) for p in paths]
    os.makedirs(out_dir, exist_ok=True)
    if dask is None or dask is False:
        reports = []
        for p, nm in tqdm(list(zip(paths, names)), desc="preview", unit="asset", disable=not progress):
            reports.append(preview_asset(p, out_dir, o, name=nm))
    else:
        reports = _batch_dask(paths, names, out_dir, o, dask, n_workers, processes, progress)
    write_summary(reports, out_dir)
    return reports


def _batch_dask(paths, names, out_dir, o, dask, n_workers, processes, progress):
    from distributed import Client, LocalCluster, as_completed
    from tqdm.auto import tqdm

    cluster = client = None
    own = True
    if isinstance(dask, Client):
        client, own = dask, False
    elif dask is True:
        cluster = LocalCluster(n_workers=n_workers, threads_per_worker=1, processes=processes,
                               dashboard_address=None)
        client = Client(cluster)
    else:
        client = Client(str(dask))
    try:
        futures = [client.submit(preview_asset, os.path.abspath(p), None, o, name=nm, return_files=True,
                                 key=f"pyrt-preview-{k}-{nm}", pure=False)
                   for k, (p, nm) in enumerate(zip(paths, names))]
        index = {f.key: k for k, f in enumerate(futures)}
        reports = [None] * len(futures)
        for fut in tqdm(as_completed(futures), total=len(futures), desc="preview (dask)", unit="asset",
                        disable=not progress):
            k = index[fut.key]
            try:
                rep = fut.result()
            except Exception as exc:  # the task itself died (worker lost, ...)
                rep = AssetReport(path=paths[k], name=names[k], status="failed",
                                  error=f"task failed: {type(exc).__name__}: {exc}")
            if rep.files is not None:
                rep.outputs = write_files(rep.files, out_dir)
                rep.files = None
            rep.path = paths[k]
            reports[k] = rep
        return reports
    finally:
        if own:
            client.close()
            if cluster is not None:
                cluster.close()


def summary_rows(reports):
    """The summary table as rows of strings (header first)."""
    rows = [["asset", "status", "triangles", "load s", "render s", "warnings", "message"]]
    for r in reports:
        msg = r.error or (r.warnings[0] if r.warnings else "")
        rows.append([os.path.basename(r.path), r.status, str(r.triangles), f"{r.load_time:.2f}",
                     f"{r.render_time:.2f}", str(len(r.warnings)), msg])
    return rows


def format_summary(reports, *, width=60):
    """A fixed-width text table of :func:`summary_rows` (messages cut to ``width`` characters)."""
    rows = [r[:-1] + [r[-1] if len(r[-1]) <= width else r[-1][:width - 3] + "..."] for r in summary_rows(reports)]
    w = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
    lines = ["  ".join(c.ljust(w[i]) if i in (0, 1, 6) else c.rjust(w[i]) for i, c in enumerate(r)) for r in rows]
    lines.insert(1, "  ".join("-" * x for x in w))
    ok = sum(r.status == "ok" for r in reports)
    lines.append(f"{ok}/{len(reports)} assets ok")
    return "\n".join(lines)


def write_summary(reports, out_dir):
    with open(os.path.join(out_dir, "summary.csv"), "w", newline="") as fh:
        wr = csv.writer(fh)
        wr.writerow(["asset", "status", "triangles", "load_s", "render_s", "n_warnings", "error", "warnings"])
        for r in reports:
            wr.writerow([r.path, r.status, r.triangles, f"{r.load_time:.4f}", f"{r.render_time:.4f}",
                         len(r.warnings), r.error, " | ".join(r.warnings)])
    with open(os.path.join(out_dir, "summary.txt"), "w") as fh:
        fh.write(format_summary(reports) + "\n")


# ============================================================================ command line

def _parser():
    ap = argparse.ArgumentParser(prog="pyrt-preview", description="Preview 3D models (glTF/GLB, OBJ, PLY, STL) "
                                 "with a studio rig, auto-framing and auto-exposure.")
    ap.add_argument("models", nargs="+", help="model files, folders or glob patterns")
    ap.add_argument("-o", "--output", action="append",
                    help="output file for a single model (.png and/or .exr; may be repeated)")
    ap.add_argument("--out-dir", help="output folder (batch mode; default: preview_out)")
    ap.add_argument("--width", type=int, default=640)
    ap.add_argument("--height", type=int, default=480)
    ap.add_argument("--spp", type=int, default=4)
    ap.add_argument("--fov", type=float, default=35.0, help="vertical field of view (degrees)")
    ap.add_argument("--azimuth", type=float, default=35.0)
    ap.add_argument("--elevation", type=float, default=20.0)
    ap.add_argument("--up", default="auto", choices=["auto", *AXES])
    ap.add_argument("--camera", default="auto", choices=["auto", "asset"])
    ap.add_argument("--lights", default="studio", choices=["studio", "asset", "both"])
    ap.add_argument("--no-ground", action="store_true", help="no shadow-catcher ground plane")
    ap.add_argument("--env", help="lat-long environment map (OpenEXR)")
    ap.add_argument("--env-lighting", default="mis", help="environment light strategy (mis, map, bsdf, preview, ...)")
    ap.add_argument("--env-samples", type=int, default=8, help="environment light samples per hit")
    ap.add_argument("--exposure", type=float, help="exposure in stops (default: automatic)")
    ap.add_argument("--tonemap", default="reinhard", choices=["linear", "film", "reinhard"])
    ap.add_argument("--turntable", type=int, default=0, metavar="N", help="render N views around the model")
    ap.add_argument("--format", default=None, help="batch output formats, e.g. png,exr (default png)")
    ap.add_argument("--aovs", action="store_true", help="also write depth/normal/albedo")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--budget", type=float, help="time budget per asset (s)")
    ap.add_argument("--threads", type=int, help="render threads per asset")
    ap.add_argument("--dask", nargs="?", const="local", default=None, metavar="SCHEDULER",
                    help="run the batch on Dask: a LocalCluster, or the given scheduler address")
    ap.add_argument("--workers", type=int, default=2, help="LocalCluster workers (with --dask)")
    ap.add_argument("--quiet", action="store_true")
    return ap


def main(argv=None):
    """``pyrt-preview MODEL -o out.png`` (one model) or ``pyrt-preview FOLDER/ --out-dir out`` (batch)."""
    args = _parser().parse_args(argv)
    formats = tuple(args.format.split(",")) if args.format else ("png",)
    opts = PreviewOptions(width=args.width, height=args.height, spp=args.spp, fov=args.fov, azimuth=args.azimuth,
                          elevation=args.elevation, up=args.up, camera=args.camera, lights=args.lights,
                          ground=not args.no_ground, environment=args.env, environment_lighting=args.env_lighting,
                          environment_samples=args.env_samples, exposure=args.exposure,
                          tonemap=args.tonemap, turntable=args.turntable, formats=formats, aovs=args.aovs,
                          seed=args.seed, time_budget=args.budget, threads=args.threads)
    try:
        opts.validate()
    except PreviewError as exc:
        print(f"pyrt-preview: error: {exc}", file=sys.stderr)
        return 2
    paths = collect_inputs(args.models)
    single = args.output and len(paths) == 1 and os.path.isfile(paths[0])
    if args.output and not single:
        print("pyrt-preview: error: -o needs exactly one model file; use --out-dir for batches", file=sys.stderr)
        return 2
    if single:
        return _main_single(paths[0], args.output, opts, args.quiet)
    out_dir = args.out_dir or "preview_out"
    dask = None if args.dask is None else (True if args.dask == "local" else args.dask)
    reports = preview_batch(paths, out_dir, opts, dask=dask, n_workers=args.workers, progress=not args.quiet)
    print(format_summary(reports))
    return 0 if all(r.status == "ok" for r in reports) else 1


def _main_single(path, outputs, opts, quiet):
    for out in outputs:
        if not out.lower().endswith((".png", ".exr")):
            print(f"pyrt-preview: error: output must end in .png or .exr: {out}", file=sys.stderr)
            return 2
    fmts = tuple(sorted({os.path.splitext(out)[1].lower()[1:] for out in outputs}))
    opts = dataclasses.replace(opts, formats=fmts)
    deadline = time.perf_counter() + opts.time_budget if opts.time_budget else None
    name = "view"
    try:
        res = render_preview(path, opts, name=name, deadline=deadline)
    except (AssetError, PreviewError, BudgetExceeded, ValueError, OSError) as exc:
        print(f"pyrt-preview: error: {exc}", file=sys.stderr)
        return 1
    for out in outputs:
        stem, ext = os.path.splitext(out)
        base = os.path.basename(stem)
        # "view.png" -> "OUT.png"; also OUT_depth.png, OUT_turntable/frame_000.png, OUT_sheet.png
        sel = {base + k[len(name):]: v for k, v in res.files.items() if k.endswith(ext.lower())}
        for p in write_files(sel, os.path.dirname(stem) or "."):
            if not quiet:
                print(f"wrote {p}")
    for w in dict.fromkeys(res.warnings):
        print(f"warning: {w}", file=sys.stderr)
    if not quiet:
        print(f"{res.triangles} triangles, up {res.up_axis} ({res.up_reason}), load {res.load_time:.2f} s, "
              f"render {res.render_time:.2f} s, exposure {res.exposure:+.2f} stops")
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
