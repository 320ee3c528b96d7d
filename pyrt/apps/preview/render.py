"""The preview scene (an asset in the studio, views at any azimuth) and :func:`render_preview`, which
renders one view or a turntable into encoded files (PNG, EXR, AOV previews, contact sheet)."""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
import math
import os
import tempfile
import time
import warnings as _warnings

import numpy as np

from pyrt.shaders import color as _color
from pyrt.shaders.vec import dot

from pyrt.core.camera import Camera
from pyrt.core.transforms import apply_matrix
from pyrt.core.image_io import encode_png, tonemap_to_display, write_bytes, write_exr
from pyrt.integrators import PreparedScene
from pyrt.render import Execution, Glossy, Output, Sampling, render_full
from pyrt.lights import LatLongEnvironment, set_environment
from pyrt.materials import Lambert
from pyrt.scene import Scene
from pyrt.io.assets import Asset, load_asset
from pyrt.apps.preview.options import (ADAPTIVE_MAX_SPP, BACK_FACE_GRID, BACK_FACE_WARNING, BOARD_DEPTH_RATIO,
                                       BVH_LOW_TRIANGLES, DEFAULT_AZIMUTH, EMISSIVE_POWER_RATIO, BudgetExceeded,
                                       PreviewError, PreviewInterrupted, PreviewOptions)
from pyrt.apps.preview.studio import STUDIO_PREVIEW_SAMPLES, StudioEnvironment, camera_rotation
from pyrt.apps.preview.rig import (auto_exposure, bounding_sphere, detect_up_axis, frame_camera, frame_points,
                                   framing_points, ground_radiance, hull_points, limit_backdrop, lit_white_radiance,
                                   studio_rig, up_transform)


# ============================================================================ the preview scene

class PreviewScene:
    """An asset placed in a studio: geometry prepared once, views rendered at any azimuth."""

    def __init__(self, asset, options=None):
        self.options = o = (options or PreviewOptions()).validate()
        self.asset = asset
        self.warnings = list(asset.warnings)
        t0 = time.perf_counter()
        #: seconds per preparation phase: "frame" (up axis, bounds), "normals", "tangents", "scene", "emitters" (the
        #: emissive-mesh light, when the model emits), "geometry", "bvh"; "mask" (the back-face check and the exposure's
        #: model mask, added by :meth:`render_view`)
        self.timings = {}
        if o.up == "auto":
            self.up_axis, self.up_reason = detect_up_axis(up_axis_sample(asset))
        else:
            self.up_axis, self.up_reason = o.up, "given"
        self.up_matrix = up_transform(self.up_axis)
        v = asset.world_vertices()
        v = apply_matrix(v, self.up_matrix)
        self.center, self.radius = bounding_sphere(v)
        if not self.radius > 0:
            raise PreviewError(f"{asset.path}: the model has zero size")
        self.hull = framing_points(v)           # what the framing fits (the model's projection lies inside)
        #: the model's axis-aligned bounds (2, 3) in the scene (after the up axis): the model mask traces only the
        #: pixels their projection covers (:meth:`model_window`)
        self.bounds = np.stack([v.min(axis=0), v.max(axis=0)])
        ext = self.bounds[1] - self.bounds[0]
        #: True for a thin "board" (z extent <= BOARD_DEPTH_RATIO x extent): viewed face-on when azimuth is automatic
        self.board = bool(ext[2] <= BOARD_DEPTH_RATIO * ext[0])
        #: the azimuth of the (first) view in degrees: the option's, or the automatic one (PreviewOptions.azimuth)
        self.azimuth = float(o.azimuth) if o.azimuth is not None else (0.0 if self.board else DEFAULT_AZIMUTH)
        if o.turntable > 1:                     # every view fits all views' hulls: a turntable does not breathe
            self.hull = hull_points(np.concatenate([(self.hull - self.center) @ camera_rotation(360.0 * k / o.turntable).T
                                                    + self.center for k in range(o.turntable)]))
        self.ground_y = float(v[:, 1].min())
        del v
        self.timings["frame"] = time.perf_counter() - t0
        self.scene = Scene(Camera())
        with _warnings.catch_warnings(record=True) as caught:
            _warnings.simplefilter("always")
            self.model_meshes = asset.add_to_scene(self.scene, transform=self.up_matrix,
                                                   crease_angle=o.crease_angle, lights=o.lights in ("asset", "both"),
                                                   timings=self.timings)
        self.warnings += [str(w.message) for w in caught]
        self._n_triangles = asset.n_triangles
        if o.double_sided:        # both sides of every model face (PreviewOptions.double_sided)
            for mid in sorted({self.scene.meshes[k].material_id for k in self.model_meshes}):
                self.scene.materials[mid].set_coverage(double_sided=True)
        self._back_faces_checked = False
        #: the model's emissive meshes as a light (PreviewOptions.emissive_lights), None when off or nothing emits
        self.emissive_light = None
        if o.emissive_lights == "auto":
            t_em = time.perf_counter()
            # only a light source, not decorative glow (EMISSIVE_POWER_RATIO of the key light onto the model)
            rig_power = o.key * math.pi * self.radius ** 2 if o.lights in ("studio", "both") else 0.0
            self.emissive_light = self.scene.add_emissive_lights(n_samples=o.emissive_samples,
                                                                 selection=o.emissive_selection,
                                                                 min_power=EMISSIVE_POWER_RATIO * rig_power)
            self.timings["emitters"] = time.perf_counter() - t_em
        self.asset_lights = list(self.scene.lights)
        self.ground_mesh = None
        if o.ground:
            g = Lambert(o.ground_albedo, name="ground")
            foot = (self.center[0], self.ground_y - 1e-4 * self.radius, self.center[2])
            self.ground_mesh = self.scene.add_plane(foot, 100.0 * self.radius, g, name="ground")
        self.environment = None
        self.studio_environment = False
        if o.environment:
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
        if self._use_rig and o.studio_env and self.environment is None and self.ambient_radiance > 0:
            # the studio environment replaces the constant ambient term with the same mean radiance (studio.py)
            self.environment = StudioEnvironment(intensity=self.ambient_radiance)
            set_environment(self.scene, self.environment, lighting="preview", preview_samples=STUDIO_PREVIEW_SAMPLES)
            self.asset_lights = list(self.scene.lights)
            self.studio_environment = True
            self.ambient_radiance = 0.0
        self.scene.ambient = np.full(3, self.ambient_radiance)
        quality = o.bvh_quality
        if quality == "auto":
            quality = "low" if asset.n_triangles >= BVH_LOW_TRIANGLES else "medium"
        with _warnings.catch_warnings(record=True) as caught:   # (PrecisionWarning: one line of the summary)
            _warnings.simplefilter("always")
            self.prepared = PreparedScene(self.scene, threads=o.threads, build_quality=quality)
        self.warnings += [str(w.message) for w in caught]
        self.timings.update(self.prepared.timings)
        self.exposure = o.exposure
        self.white = None

    @property
    def n_triangles(self):
        return self._n_triangles

    def forget_model_arrays(self):
        """Drop the loaded model's own arrays (:attr:`asset` keeps its path, cameras, lights, warnings and
        substitutions, not its meshes): the scene holds the model from here on. :func:`render_preview` calls it on
        an asset it loaded itself: the loader's meshes were 0.3 GB of the 5.24 M-triangle mesh's 2.1 GB peak
        (tools/big_mesh.py)."""
        self.asset = dataclasses.replace(self.asset, meshes=[], instances=[])

    def camera(self, azimuth):
        o = self.options
        if o.camera == "asset":
            if not self.asset.cameras:
                raise PreviewError(f"{self.asset.path}: camera='asset' but the file has no perspective camera")
            ac = self.asset.cameras[0]
            R = self.up_matrix[:3, :3]
            cam = dataclasses.replace(ac, position=R @ ac.position, forward=R @ ac.forward, up=R @ ac.up)
            return cam.to_pyrt(o.width, o.height, spp=o.spp or o.min_spp)
        if o.framing == "sphere":
            return frame_camera(self.center, self.radius, fov=o.fov, azimuth=azimuth, elevation=o.elevation,
                                width=o.width, height=o.height, margin=o.margin, spp=o.spp or o.min_spp)
        return frame_points(self.hull, fov=o.fov, azimuth=azimuth, elevation=o.elevation, width=o.width,
                            height=o.height, margin=o.margin, spp=o.spp or o.min_spp)

    def _set_view(self, azimuth):
        o = self.options
        self.scene.camera = self.camera(azimuth)
        rig = studio_rig(azimuth, o) if self._use_rig else []
        bg = np.zeros(3)
        if self.studio_environment:     # turns with the camera, as the rig does; camera rays see the backdrop
            self.environment.rotation = camera_rotation(azimuth)
        if o.ground:
            foot = (self.center[0], self.ground_y, self.center[2])
            bg = ground_radiance(list(self.asset_lights) + rig, o.ground_albedo, self.ambient_radiance, at=foot)
            if self.environment is not None:  # + the map's (SH, unshadowed) irradiance on the ground
                up = np.array([[0.0, 1.0, 0.0]])
                bg = bg + o.ground_albedo / math.pi * np.maximum(self.environment.irradiance_sh(up)[0], 0.0)
        if self.environment is not None:
            # with a ground, camera rays see the matched backdrop; without one, the map itself (the studio: the
            # backdrop, always)
            self.environment.hide_background = bool(o.ground) or self.studio_environment
            self.environment.background = bg
        self.scene.background = bg
        self.scene.lights[:] = list(self.asset_lights) + rig

    def back_face_fraction(self, camera=None, grid=BACK_FACE_GRID):
        """``(fraction, n)``: of the ``n`` rays of a ``grid = (columns, rows)`` of pixel centres over the view whose
        first surface (culling off) is a model face of a material that culls back faces
        (:attr:`pyrt.materials.Material.culls_back_faces`), the fraction that reach that face from behind (its
        winding normal, counter-clockwise = front, points away from the camera). Near 1 for a closed model wound
        inside out: culled, its near side vanishes and the inside of its far side shows."""
        cam = camera or self.scene.camera
        gw, gh = min(grid[0], cam.width), min(grid[1], cam.height)
        xs = (np.arange(gw) + 0.5) * (cam.width / gw)
        ys = (np.arange(gh) + 0.5) * (cam.height / gh)
        X, Y = np.meshgrid(xs, ys)
        d = cam.directions(X.ravel(), Y.ravel())
        hits = self.prepared.accel.intersect(np.broadcast_to(cam.position, d.shape), d)
        geo = self.prepared.geo
        culls = np.array([m.culls_back_faces for m in self.scene.materials], dtype=bool)
        h = np.flatnonzero(hits.hit & np.isin(hits.mesh_id, self.model_meshes))
        face = geo.face_offset[hits.mesh_id[h]] + hits.prim_id[h]
        sel = culls[geo.face_material[face]]
        if not sel.any():
            return 0.0, 0
        back = dot(geo.face_normals[face[sel]], d[h[sel]]) > 0
        return float(back.mean()), int(sel.sum())

    def model_window(self, camera=None):
        """``(x0, x1, y0, y1)``: the pixel columns ``[x0, x1)`` and rows ``[y0, y1)`` outside which no pixel-centre ray
        can reach the model: the bounding rectangle of its bounding box's projected corners, one pixel wider on
        every side (rounding); the whole image when a corner is not in front of the camera."""
        cam = camera or self.scene.camera
        corners = np.array([[self.bounds[i, 0], self.bounds[j, 1], self.bounds[k, 2]]
                            for i in (0, 1) for j in (0, 1) for k in (0, 1)]) - cam.position
        z = corners @ cam.forward
        scale = np.max(np.abs(corners)) + 1e-300
        if not np.all(z > 1e-9 * scale):
            return 0, cam.width, 0, cam.height
        th = cam.tan_half
        # the inverse of Camera.directions: sx = (2 x / W - 1) th W / H, sy = (1 - 2 y / H) th
        x = ((corners @ cam.right) / z / (th * cam.width / cam.height) + 1.0) * (0.5 * cam.width)
        y = (1.0 - (corners @ cam.up_ortho) / z / th) * (0.5 * cam.height)
        x0, x1 = (int(np.clip(f(v), 0, cam.width)) for f, v in ((math.floor, x.min() - 1), (math.ceil, x.max() + 1)))
        y0, y1 = (int(np.clip(f(v), 0, cam.height)) for f, v in ((math.floor, y.min() - 1), (math.ceil, y.max() + 1)))
        return x0, max(x0, x1), y0, max(y0, y1)

    def model_mask(self, camera=None):
        """(H, W) bool: pixel-centre rays that hit the model (not the ground, not the background). Only the pixels of
        :meth:`model_window` are traced (each ray as :meth:`pyrt.Camera.directions` gives it); the others are False."""
        cam = camera or self.scene.camera
        x0, x1, y0, y1 = self.model_window(cam)
        mask = np.zeros((cam.height, cam.width), dtype=bool)
        if x1 > x0 and y1 > y0:
            ys, xs = np.mgrid[y0:y1, x0:x1]
            xs, ys = xs.ravel() + 0.5, ys.ravel() + 0.5
            # in blocks of MASK_BLOCK rays: the (n, 3) x (3, 3) product inside Camera.directions then runs on one BLAS
            # thread (OpenBLAS threads a GEMM from 2^18 multiply-adds on); the same numbers, row for row
            d = np.concatenate([cam.directions(xs[i:i + MASK_BLOCK], ys[i:i + MASK_BLOCK])
                                for i in range(0, xs.size, MASK_BLOCK)])
            hits = self.prepared.accel.intersect(np.broadcast_to(cam.position, d.shape), d)
            model = hits.hit & np.isin(hits.mesh_id, self.model_meshes)
            mask[y0:y1, x0:x1] = model.reshape(y1 - y0, x1 - x0)
        return mask

    def render_view(self, azimuth, *, aovs=False):
        """Render one view; the first call fixes the exposure (unless given). Returns a RenderResult."""
        o = self.options
        self._set_view(azimuth)
        t_mask = time.perf_counter()
        if not self._back_faces_checked:      # once per model, at its first view
            self._back_faces_checked = True
            frac, n = self.back_face_fraction()
            if frac > BACK_FACE_WARNING:
                self.warnings.append(
                    f"{self.asset.path}: {100 * frac:.0f}% of the single-sided surface in view is seen from behind "
                    "(faces wound clockwise seen from outside, or normals inverted?): back faces are culled as the "
                    "file asks (glTF doubleSided false), so the model looks hollow; --double-sided renders both sides")
        t_mask = time.perf_counter() - t_mask
        with _warnings.catch_warnings(record=True) as caught:
            _warnings.simplefilter("always")
            glass = bool(self.prepared.dielectric.any())
            depth = max(o.max_depth, o.dielectric_depth) if glass else o.max_depth
            cutoff = o.dielectric_cutoff if glass else 1e-4
            scale = 0.0 if o.glossy_clamp is None else lit_white_radiance(self.scene.lights, self.center)
            clamp = o.glossy_clamp * scale if scale > 0 else None      # (no light to scale it by: no clamp)
            integ = Glossy(max_depth=depth, transparent_shadows=True, throughput_cutoff=cutoff,
                           roulette=o.dielectric_roulette and glass,
                           light_select_depth=o.light_select_depth, samples=o.glossy_samples, depth=o.glossy_depth,
                           threshold=o.glossy_threshold, clamp=clamp,
                           batch_rays=(o.dielectric_batch_rays or o.batch_rays) if glass else o.batch_rays,
                           **({"split_depth": o.split_depth} if glass else {}))
            sampling = Sampling(sampler=o.sampler) if o.spp is not None else Sampling(
                target_error=o.target_error, time_budget=o.render_budget, max_spp=o.max_spp or ADAPTIVE_MAX_SPP,
                min_spp=o.min_spp, sampler=o.sampler)
            res = render_full(self.scene, seed=o.seed, integrator=integ, sampling=sampling, output=Output(aovs=aovs),
                              execution=Execution(progress=False, prepared=self.prepared, threads=o.threads,
                                                  backend=o.backend,
                                                  parallel=o.parallel, chunk_samples=o.dielectric_chunk_samples
                                                  if glass else o.chunk_samples))
        self.warnings += [str(w.message) for w in caught]
        if self.exposure is None:
            t0 = time.perf_counter()
            mask = self.model_mask()
            t_mask += time.perf_counter() - t0
            self.exposure, self.white = auto_exposure(res.image, mask)
            if o.ground:     # the shadow catcher's backdrop stays grey (rig.limit_backdrop)
                self.exposure, self.white = limit_backdrop(self.exposure, self.white, self.scene.background, o.tonemap)
        self.timings["mask"] = self.timings.get("mask", 0.0) + t_mask
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
    #: seconds per phase, in :data:`PHASES` order (those that happened; "write" and "start" are added by whoever
    #: writes the files)
    phases: dict = field(default_factory=dict)
    #: the loader's substitutions (:attr:`pyrt.io.assets.Asset.substitutions`; also in ``warnings``)
    substitutions: list = field(default_factory=list)
    #: per view: camera samples per pixel reached (the mean over the pixels)
    spp: list = field(default_factory=list)
    #: per view: the estimated relMSE an adaptive render reached (:attr:`pyrt.RenderResult.estimated_error`), None
    #: at a fixed spp
    estimated_errors: list = field(default_factory=list)
    #: per view: the render path taken (:attr:`pyrt.RenderStats.backend`: ``"compiled"`` or ``"numpy"``)
    backends: list = field(default_factory=list)
    #: per view: why its adaptive passes stopped (:attr:`pyrt.RenderResult.stop_reason`: ``"target_error"``,
    #: ``"time_budget"``, ``"max_spp"``), None at a fixed spp
    stop_reasons: list = field(default_factory=list)

    @property
    def mean_spp(self):
        """Samples per pixel reached, the mean over the views (0 without views)."""
        return float(np.mean(self.spp)) if self.spp else 0.0

    @property
    def worst_error(self):
        """The largest estimated relMSE of the views (None at a fixed spp)."""
        errs = [e for e in self.estimated_errors if e is not None]
        return max(errs) if errs else None

    @property
    def backend(self):
        """The render path of the views: ``"numpy"`` when any view took the NumPy path, else ``"compiled"``; ""
        without views."""
        if not self.backends:
            return ""
        return "numpy" if "numpy" in self.backends else "compiled"

    @property
    def stop_reason(self):
        """Why the adaptive passes stopped: the reason of the first view that stopped short of the target
        (``"time_budget"``, ``"max_spp"``, ``"cancelled"``), else ``"target_error"``; None at a fixed spp."""
        reasons = [r for r in self.stop_reasons if r is not None]
        short = [r for r in reasons if r != "target_error"]
        return short[0] if short else (reasons[0] if reasons else None)


def format_sampling(result, target_error=None):
    """``"4 spp, compiled path"`` at a fixed spp; ``"5.3 spp (mean), estimated relMSE 9.6e-04 (target 0.001),
    compiled path"`` for adaptive renders (the views' mean spp and their largest estimated error; ``"target 0.001,
    stopped by the render budget"`` or ``"by max_spp"`` when some view stopped before the target): what the
    previewer reached, and the render path its views took (``NumPy path`` where one took it; none said without
    views)."""
    text = f"{result.mean_spp:.3g} spp"
    err = result.worst_error
    if err is not None:
        stops = set(result.stop_reasons) - {None, "target_error"}
        why = "".join(f", stopped by {_STOPS.get(r, r)}" for r in sorted(stops))
        target = "" if target_error is None else f" (target {target_error:g}{why})"
        text = f"{text} (mean), estimated relMSE {err:.2g}{target}"
    if result.backend:
        text += ", NumPy path" if result.backend == "numpy" else ", compiled path"
    return text


#: how :func:`format_sampling` names an adaptive view's stop reason
_STOPS = {"time_budget": "the render budget", "max_spp": "max_spp", "cancelled": "a cancellation"}


#: The phases a preview reports (:attr:`PreviewResult.phases`, the ``pyrt-preview`` summary line, the batch summary),
#: each where it happened: the interpreter's start and the imports (``pyrt-preview`` only: :func:`pyrt.apps.common.
#: process_age`); reading the file (its images' decoding apart); decoding the texture images (glTF); up axis and
#: bounds; welding + crease-angle normals (meshes without normals); vertex tangents generated from the UVs (meshes with
#: a normal map and no tangents); materials and :meth:`pyrt.Scene.add_mesh`; the emissive-mesh light; the flat
#: geometry table, float32 range check and handing the arrays to Embree; Embree's BVH build; the MIP pyramids built
#: ahead of forked render workers (:meth:`pyrt.PreparedScene.before_fork`; with threads a pyramid level is built by
#: the render that reads it); an environment's irradiance grid; packing the compiled kernel's flat tables and loading
#: the kernel from its cache (compiled renders); the back-face check and the exposure's model mask; rendering every
#: view (nothing of the phases before it); tone mapping and encoding the files; writing them.
PHASES = ("start", "load", "decode", "frame", "normals", "tangents", "scene", "emitters", "geometry", "bvh", "mip",
          "irradiance", "tables", "kernel", "mask", "render", "encode", "write")
#: The phases between loading and rendering (:attr:`pyrt.apps.preview.AssetReport.prepare_time` sums them)
PREPARE_PHASES = ("frame", "normals", "tangents", "scene", "emitters", "geometry", "bvh", "mip", "irradiance", "tables",
                  "kernel", "mask")
#: The phases that happen inside the views' renders: :attr:`pyrt.PreparedScene.timings` key -> phase
_IN_RENDER = {"mip_levels": "mip", "irradiance": "irradiance", "tables": "tables", "kernel": "kernel"}


def format_phases(phases):
    """``"load 0.19 s, frame 0.40 s, ..., write 0.01 s"`` for the phases present (in :data:`PHASES` order)."""
    return ", ".join(f"{'BVH' if k == 'bvh' else k} {phases[k]:.2f} s" for k in PHASES if k in phases)


#: Rays per call of :meth:`pyrt.Camera.directions` in :meth:`PreviewScene.model_mask`: below OpenBLAS's threshold for
#: threading the product with the camera frame (threaded, on a loaded 2-core machine the 307,200 rays of a 640x480 view
#: took 84 ms of CPU against 4.8 ms on one thread)
MASK_BLOCK = 1 << 14


#: Faces the up-axis guess looks at: bigger meshes are subsampled (see :func:`up_axis_sample`)
UP_AXIS_MAX_FACES = 200_000


def up_axis_sample(asset, max_faces=UP_AXIS_MAX_FACES):
    """``asset``, or for more than ``max_faces`` triangles (instances counted) a shallow copy for
    :func:`detect_up_axis` whose meshes keep a random share ``max_faces / triangles`` of their faces (fixed seed,
    in file order) and all their vertices. The guess compares areas (a base's share of the total), which a
    uniform random sample estimates without bias, to a relative error ~ 1/sqrt(faces of the base sampled); a
    stride (every k-th face) is biased on meshes whose faces are stored in a regular order (subdivision levels)."""
    n = asset.n_triangles
    if n <= max_faces:
        return asset
    rng = np.random.default_rng(0)
    share = max_faces / n
    meshes = [dataclasses.replace(m, faces=m.faces[np.sort(rng.choice(m.faces.shape[0],
                                                                       max(1, round(share * m.faces.shape[0])),
                                                                       replace=False))])
              for m in asset.meshes]
    return dataclasses.replace(asset, meshes=meshes)


def _png_bytes(arr):
    """8-bit RGB PNG bytes (:func:`pyrt.core.image_io.encode_png`; deterministic for a given array)."""
    return encode_png(np.ascontiguousarray(arr, dtype=np.uint8))


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


def render_preview(model, options=None, *, name="preview", deadline=None, cancel=None):
    """Load (if given a path), set up and render a preview; encoded outputs in ``result.files``.

    ``result.files`` maps names to bytes: ``NAME.png``/``NAME.exr`` (+ ``NAME_depth.png`` etc. with
    ``aovs``) for a single view; ``NAME_turntable/frame_###.png`` (/``.exr``) and ``NAME_sheet.png``
    for a turntable. ``deadline`` (a ``time.perf_counter()`` value) raises :class:`BudgetExceeded`
    before a view that would not finish in time (estimated from the previous view). ``cancel`` (a
    :class:`threading.Event`) is checked before every view: once set, the view in progress finishes and
    :class:`PreviewInterrupted` is raised before the next one (nothing is returned for an unfinished asset).
    """
    o = (options or PreviewOptions()).validate()
    t0 = time.perf_counter()
    asset = model if isinstance(model, Asset) else load_asset(model, max_texture=o.texture_budget(), root=o.root)
    load_time = asset.load_time if isinstance(model, Asset) else time.perf_counter() - t0
    phases = {"load": load_time - asset.decode_time}
    if asset.decode_time > 0:
        phases["decode"] = asset.decode_time
    if deadline is not None and time.perf_counter() > deadline:
        raise BudgetExceeded(f"time budget exceeded while loading ({load_time:.2f} s)")
    ps = PreviewScene(asset, o)
    if not isinstance(model, Asset):
        ps.forget_model_arrays()
        asset = ps.asset
    try:
        n_views = max(1, o.turntable)
        az = [ps.azimuth + 360.0 * k / n_views for k in range(n_views)] if o.turntable else [ps.azimuth]
        images, aovs, spp, errors, backends, stops = [], [], [], [], [], []
        files = {}
        t_render = 0.0
        last = None
        for k, a in enumerate(az):
            if cancel is not None and cancel.is_set():
                raise PreviewInterrupted(f"interrupted after {k}/{n_views} views")
            if deadline is not None and last is not None and time.perf_counter() + last > deadline:
                raise BudgetExceeded(f"time budget exceeded after {k}/{n_views} views "
                                     f"({t_render:.2f} s rendering, {last:.2f} s per view)")
            t1 = time.perf_counter()
            res = ps.render_view(a, aovs=o.aovs)
            last = time.perf_counter() - t1
            t_render += last
            images.append(res.image)
            aovs.append(res.aovs)
            spp.append(res.samples_done / max(res.image.shape[0] * res.image.shape[1], 1))
            errors.append(res.estimated_error)
            backends.append(res.stats.backend)
            stops.append(res.stop_reason)
        phases.update(ps.timings)
        for key, phase in _IN_RENDER.items():       # done during the first view's render: not rendering
            if ps.prepared.timings.get(key):
                phases[phase] = ps.prepared.timings[key]
        t_render -= sum(phases.get(p, 0.0) for p in ("mask", *_IN_RENDER.values()))
        phases["render"] = t_render
        t_enc = time.perf_counter()
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
        phases["encode"] = time.perf_counter() - t_enc
        return PreviewResult(images=images, aovs=aovs, azimuths=az, exposure=ps.exposure, white=ps.white,
                             up_axis=ps.up_axis, up_reason=ps.up_reason, center=ps.center, radius=ps.radius,
                             camera=ps.camera(az[0]), triangles=ps.n_triangles, load_time=load_time,
                             render_time=t_render, warnings=ps.warnings, files=files, phases=phases,
                             substitutions=list(asset.substitutions), spp=spp, estimated_errors=errors,
                             backends=backends, stop_reasons=stops)
    finally:
        ps.close()


def write_files(files, out_dir):
    """Write ``{relative name: bytes}`` under ``out_dir`` (each file atomically); returns the paths written."""
    paths = []
    for rel, data in files.items():
        p = os.path.join(out_dir, rel)
        os.makedirs(os.path.dirname(os.path.abspath(p)), exist_ok=True)
        write_bytes(p, data)
        paths.append(p)
    return paths
