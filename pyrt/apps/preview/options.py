"""What a preview can be told (:class:`PreviewOptions`) and the previewer's errors."""
from __future__ import annotations

import os
from dataclasses import dataclass

from pyrt.core.errors import Error
from pyrt.core.image_io import TONEMAPS
from pyrt.integrators.compiled import BACKENDS
from pyrt.render.pool import PARALLEL


class PreviewError(Error, ValueError):
    """Invalid preview options or an asset that cannot be previewed."""


class BudgetExceeded(Error, RuntimeError):
    """The per-asset time budget ran out (the message says after what)."""


class PreviewInterrupted(Error, RuntimeError):
    """The preview was cancelled (``cancel`` set) before all its views were rendered (the message says when)."""


@dataclass
class PreviewOptions:
    """Everything a preview can be told. Angles in degrees, irradiance in W/m^2, times in seconds."""

    width: int = 640
    height: int = 480
    #: a fixed number of samples per pixel; None (the default): adaptive passes to ``target_error`` (below)
    spp: int | None = None
    fov: float = 35.0                    # vertical field of view
    #: camera azimuth around the up axis in degrees (0 = from +z, glTF's front). None: automatic, 35 degrees, or 0
    #: (face-on) for a thin "board" model whose depth (z extent) is at most BOARD_DEPTH_RATIO of its width (x extent)
    #: once its up axis is +y: test panels and signs, whose oblique view hides parts behind their own dividers
    azimuth: float | None = None
    elevation: float = 20.0              # camera elevation above the ground plane
    margin: float = 1.1                  # framing margin: the model spans 1 / margin of the frame
    framing: str = "fit"                 # "fit" (projected hull fills the frame) or "sphere" (bounding sphere)
    up: str = "auto"                     # "auto" or one of "+x", "-x", "+y", "-y", "+z", "-z"
    camera: str = "auto"                 # "auto" (framed) or "asset" (the file's first camera)
    lights: str = "studio"               # "studio", "asset" or "both"
    key: float = 3.0                     # key-light irradiance (W/m^2)
    fill_ratio: float = 0.35
    rim_ratio: float = 0.7
    ambient: float = 0.1                 # ambient radiance as a fraction of key / pi (the studio env's mean)
    studio_env: bool = True              # the procedural studio environment replaces the constant ambient
    ground: bool = True
    ground_albedo: float = 0.5
    environment: str | None = None       # lat-long map: OpenEXR or Radiance .hdr
    environment_intensity: float = 1.0
    environment_lighting: str = "mis"    # EnvironmentLight strategy ("mis", "preview" = no shadows, no noise, ...)
    #: environment light samples per hit (with environment_lighting "mis": as many BSDF samples). 1: the least
    #: error for the time (tools/preview_quality.py with a sun-and-sky map at 4 spp, true relMSE x render seconds,
    #: 1 / 2 / 4 / 8 samples: Duck 3.1 / 3.4 / 5.1 / 8.7e-3, Avocado 1.6 / 2.5 / 4.6 / 7.0e-3; docs/preview.md): the
    #: pixel's samples stratify the light samples (the padded sampler) and the adaptive passes add where needed
    environment_samples: int = 1
    #: "auto": the model's emissive meshes are a light source (Scene.add_emissive_lights: every lit hit samples them
    #: with shadow rays, MIS with the glossy rays) when it has emissive materials; "off": they light other surfaces
    #: only through the glossy rays (pyrt.render's default)
    emissive_lights: str = "auto"
    emissive_samples: int = 1            # shadow rays per hit toward the emissive triangles (docs/preview.md)
    emissive_selection: str = "oriented"  # how they are chosen: "power" or "oriented" (per shading point)
    exposure: float | None = None        # stops; None = automatic
    #: the folder a loose model may read its files from (pyrt.load_asset's root=: it must contain the model); None:
    #: the model's own folder and its subfolders. A model in a ZIP archive reads only the archive whatever it says
    root: str | None = None
    #: any of pyrt.core.image_io.TONEMAPS; default Khronos PBR Neutral, decided on the shared Khronos set
    #: (docs/preview.md, tools/tonemap_choice.py: no channel clipped on any of the 24 models, highlights toward white)
    tonemap: str = "pbr_neutral"
    turntable: int = 0                   # number of views (0 = a single view)
    formats: tuple = ("png",)            # any of "png", "exr"
    aovs: bool = False
    seed: int = 0
    max_depth: int = 4
    #: the bounce limit where the model has a dielectric (glass, glTF transmission): a ray through a thick glass
    #: wall crosses four interfaces before it reaches what is behind (only delta rays go that deep)
    dielectric_depth: int = 10
    #: the throughput cutoff where the model has a dielectric (elsewhere pyrt.render's 1e-4): rays whose max-channel
    #: throughput falls below it continue by Russian roulette (dielectric_roulette) or are dropped. 0.01 keeps glass's
    #: paths with one reflection (~0.04) whole and plays roulette with those of two or more (~0.0016), whose number
    #: grows with the depth
    dielectric_cutoff: float = 0.01
    #: where the model has a dielectric: rays below dielectric_cutoff continue by Russian roulette (pyrt.render_full's
    #: roulette: unbiased) instead of being dropped (False: dropped, a bias of -1.8 to -2.5 % on thick glass,
    #: docs/preview.md)
    dielectric_roulette: bool = True
    #: where the model has a dielectric: from this bounce on, a glass hit continues along one of its reflected and
    #: refracted rays (chosen by weight, weighted 1 / probability: unbiased, noisier) instead of both
    #: (pyrt.render_full's split_depth). Default None: both at every bounce (measured, docs/preview.md: 1 saves
    #: ~15% of GlassVaseFlowers' render for 1.5x its RMSE, a loss at equal time)
    split_depth: int | None = None
    #: from this bounce on, the hits of glossy (BSDF-sampled) rays are lit by one of the delta lights (the studio
    #: rig's, the file's), chosen by its irradiance there (pyrt.render_full's light_select_depth: one shadow ray and
    #: BSDF query instead of three, unbiased); camera hits and what mirrors and glass show keep every light.
    #: None: every light at every hit
    light_select_depth: int | None = 1
    #: camera samples per render chunk where the model has a dielectric (elsewhere chunk_samples below): past
    #: the first bounce the shading cost is mostly per batch (a texture lookup, a BSDF or shadow query per material
    #: and light) and the glass rays' batches are small; bigger chunks make fewer, bigger ones (docs/preview.md:
    #: TransmissionTest's render CPU x 0.71 with the light selection, peak RSS 539 -> 718 MB)
    dielectric_chunk_samples: int = 1 << 16
    #: glossy reflection rays (pyrt.render_full's integrator="glossy"): BSDF samples per glossy camera hit, the
    #: bounces that spawn them (rays at bounces 0 .. glossy_depth - 1; 0 turns them off: direct light and the
    #: environment estimate only) and the GGX alpha above which a lobe counts as diffuse
    glossy_samples: int = 4
    glossy_depth: int = 2
    glossy_threshold: float = 0.4
    #: the clamp of the direct light at hits of glossy rays (pyrt.render_full's glossy_clamp), in units of the
    #: lighting's radiance scale (rig.lit_white_radiance: what a white Lambertian surface facing every light
    #: reflects): a glossy ray's sample may add at most this many times it. It removes the fireflies of
    #: glossy -> sharp -> light paths (a sharp highlight seen in a glossy reflection), a bias (docs/preview.md);
    #: None: unbiased
    glossy_clamp: float | None = 4.0
    #: the default quality (``spp`` None): adaptive passes (pyrt.render's target_error / max_spp / min_spp /
    #: time_budget, docs/preview.md) until the estimated relMSE of the view is at most ``target_error``, every pixel
    #: has ``max_spp`` samples or ``render_budget`` seconds of the view's render have passed, whichever comes
    #: first; the base pass (``min_spp`` everywhere) always completes. Chosen on the shared Khronos models
    #: (tools/preview_quality.py, docs/preview_quality.md): the estimate at 1e-3 gave a true relMSE against
    #: 128-spp references of at most 2e-3 on every model that reached it
    target_error: float = 1e-3
    max_spp: int | None = None
    min_spp: int = 4
    render_budget: float | None = 1.5
    crease_angle: float = 30.0
    #: render both sides of every model face (False: as the file says, glTF's doubleSided; back faces of single-sided
    #: materials are culled). The previewer warns when most of the single-sided surface a view sees is back faces
    #: (BACK_FACE_WARNING: inverted winding or normals, the model looks hollow); this is the remedy it names
    double_sided: bool = False
    time_budget: float | None = None     # seconds per asset
    threads: int | None = None           # Embree/shading workers per render (None = all cores)
    #: what the workers are: pyrt.render_full's parallel ("auto": forked processes on Linux for renders of at least
    #: pyrt.render.pool.PROCESS_MIN_CHUNKS chunks, else threads)
    parallel: str = "auto"
    #: the render path (pyrt.render_full's backend: "auto" the compiled kernel where it covers the model, "compiled"
    #: an error where it does not, "numpy" the reference path)
    backend: str = "auto"
    #: camera samples per render chunk (pyrt.render's chunk_samples, the same 32768 by default): a chunk's working
    #: set is ~4-6 kB per sample and each thread holds one. 16384 keeps the helmet-like model of
    #: tools/make_textured_model.py under 500 MB peak RSS on 2 threads (~450 against ~620 MB) but doubles the
    #: per-batch cost of models with many materials (ClearCoatTest render 13.1-14.9 s against 6.8-8.4 s at 32768,
    #: docs/preview.md), so it is not the default (batch_rays below bounds the working set instead). Chunks draw their
    #: own random streams: the noise (not the estimate) depends on it
    chunk_samples: int = 32768
    #: rays shaded at once per bounce (pyrt.render_full's batch_rays): a chunk's bounce is cut into slices of at most
    #: this many, the rays they spawn make one batch at the next bounce; None: a bounce at once. The glossy rays'
    #: bounce holds up to glossy_samples rays per camera hit, the working-set peak: sliced, the helmet-like model
    #: of tools/make_textured_model.py peaks at 469 MB against 597 MB (tools/bench_textured.py --set, 2 runs each,
    #: the process tree's PSS), ClearCoatTest renders x1.05 of 32768's time and 32768 x1.07 of None's, Fox and
    #: OrientationTest x0.92 and x0.85 (docs/preview.md)
    batch_rays: int | None = 24576
    #: batch_rays where the model has a dielectric (None: batch_rays): its chunks' size, so that the camera rays
    #: are shaded at once (glass models pay per batch at every bounce)
    dielectric_batch_rays: int | None = 1 << 16
    #: Embree's BVH build quality ("low", "medium", "high"; pyrt.geometry.Accel): "auto" builds models of at least
    #: BVH_LOW_TRIANGLES triangles at "low" (the 5.24 M-triangle mesh of tools/big_mesh.py: 2.0 s of CPU instead
    #: of 3.9 s, the same image, no render-time change measurable), smaller ones at Embree's default "medium"
    #: (their render dominates, and "low" traces up to ~1.5x slower)
    bvh_quality: str = "auto"
    #: the texture budget (pyrt.io.assets.texture_budget): glTF images and OBJ colour / normal maps longer than this
    #: many texels are reduced by a power of two as they are decoded; "auto": the power of two at or above 3 x the
    #: longer output side (2048 at 640 x 480; docs/preview.md, "texture budget"); None or 0: every image whole
    max_texture: int | str | None = "auto"
    #: pyrt.render_full's sampler: "padded" (a pixel's light and BSDF samples stratified over its samples) or
    #: "independent"
    sampler: str = "padded"

    def validate(self):
        if self.emissive_lights not in ("auto", "off"):
            raise PreviewError(f"emissive_lights must be 'auto' or 'off', got {self.emissive_lights!r}")
        if self.emissive_selection not in ("power", "oriented"):
            raise PreviewError(f"emissive_selection must be 'power' or 'oriented', got {self.emissive_selection!r}")
        if self.spp is not None and (int(self.spp) != self.spp or self.spp < 1):
            raise PreviewError(f"spp must be a positive integer or None (adaptive), got {self.spp!r}")
        for name in ("width", "height", "chunk_samples", "dielectric_chunk_samples", "emissive_samples"):
            v = getattr(self, name)
            if int(v) != v or v < 1:
                raise PreviewError(f"{name} must be a positive integer, got {v!r}")
        for name in ("batch_rays", "dielectric_batch_rays"):
            v = getattr(self, name)
            if v is not None and (int(v) != v or v < 1):
                raise PreviewError(f"{name} must be a positive integer or None, got {v!r}")
        if int(self.glossy_samples) != self.glossy_samples or self.glossy_samples < 1:
            raise PreviewError(f"glossy_samples must be a positive integer, got {self.glossy_samples!r}")
        if int(self.glossy_depth) != self.glossy_depth or self.glossy_depth < 0:
            raise PreviewError(f"glossy_depth must be an integer >= 0, got {self.glossy_depth!r}")
        if not self.glossy_threshold >= 0:
            raise PreviewError(f"glossy_threshold must be >= 0, got {self.glossy_threshold}")
        if self.glossy_clamp is not None and not (isinstance(self.glossy_clamp, (int, float))
                                                  and 0 < self.glossy_clamp < float("inf")):
            raise PreviewError(f"glossy_clamp must be a positive number or None, got {self.glossy_clamp!r}")
        if self.target_error is not None and not (isinstance(self.target_error, (int, float))
                                                  and 0 < self.target_error < float("inf")):
            raise PreviewError(f"target_error must be a number > 0, got {self.target_error!r}")
        if self.spp is None and self.target_error is None and self.render_budget is None:
            raise PreviewError("adaptive sampling (spp None) needs target_error or render_budget; give spp for a "
                               "fixed count")
        if self.render_budget is not None and not (isinstance(self.render_budget, (int, float))
                                                   and 0 < self.render_budget < float("inf")):
            raise PreviewError(f"render_budget must be a number of seconds > 0 or None, got {self.render_budget!r}")
        if self.max_spp is not None and (int(self.max_spp) != self.max_spp or self.max_spp < 1):
            raise PreviewError(f"max_spp must be a positive integer, got {self.max_spp!r}")
        if int(self.min_spp) != self.min_spp or self.min_spp < 2 or self.min_spp % 2:
            raise PreviewError(f"min_spp must be an even integer >= 2, got {self.min_spp!r}")
        if self.max_spp is not None and self.max_spp < self.min_spp:
            raise PreviewError(f"max_spp {self.max_spp} is below min_spp {self.min_spp}")
        if not 0 < self.fov < 180:
            raise PreviewError(f"fov must be in (0, 180) degrees, got {self.fov}")
        if not -89.0 <= self.elevation <= 89.0:
            raise PreviewError(f"elevation must be in [-89, 89] degrees, got {self.elevation}")
        if not self.margin > 0:
            raise PreviewError(f"margin must be > 0, got {self.margin}")
        if self.up != "auto" and self.up not in AXES:
            raise PreviewError(f"up must be 'auto' or one of {sorted(AXES)}, got {self.up!r}")
        if self.framing not in ("fit", "sphere"):
            raise PreviewError(f"framing must be 'fit' or 'sphere', got {self.framing!r}")
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
        if self.tonemap not in TONEMAPS:
            raise PreviewError(f"tonemap must be one of {', '.join(TONEMAPS)}, got {self.tonemap!r}")
        if not isinstance(self.dielectric_roulette, bool):
            raise PreviewError(f"dielectric_roulette must be True or False, got {self.dielectric_roulette!r}")
        if not 0 <= self.dielectric_cutoff < 1:
            raise PreviewError(f"dielectric_cutoff must be in [0, 1), got {self.dielectric_cutoff}")
        for name in ("split_depth", "light_select_depth"):
            v = getattr(self, name)
            if v is not None and (int(v) != v or v < 0):
                raise PreviewError(f"{name} must be None or an integer >= 0, got {v!r}")
        if self.parallel not in PARALLEL:
            raise PreviewError(f"parallel must be one of {list(PARALLEL)}, got {self.parallel!r}")
        if self.backend not in BACKENDS:
            raise PreviewError(f"backend must be one of {list(BACKENDS)}, got {self.backend!r}")
        if self.bvh_quality not in ("auto", "low", "medium", "high"):
            raise PreviewError(f"bvh_quality must be 'auto', 'low', 'medium' or 'high', got {self.bvh_quality!r}")
        if self.time_budget is not None and not self.time_budget > 0:
            raise PreviewError(f"time_budget must be > 0 seconds, got {self.time_budget}")
        if self.root is not None and not (isinstance(self.root, (str, os.PathLike)) and os.path.isdir(self.root)):
            raise PreviewError(f"root must be an existing folder, got {self.root!r}")
        mt = self.max_texture
        if not (mt in ("auto", None) or (isinstance(mt, int) and not isinstance(mt, bool) and mt >= 0)):
            raise PreviewError(f"max_texture must be 'auto', None or an integer >= 0, got {self.max_texture!r}")
        return self

    def texture_budget(self):
        """The ``max_texture`` of :func:`pyrt.io.assets.load_asset` for these options (None: no reduction)."""
        if self.max_texture == "auto":
            need = 3 * max(int(self.width), int(self.height))
            return 1 << max(0, need - 1).bit_length()
        return self.max_texture or None


#: ``emissive_lights="auto"`` samples the model's emitters as a light only when their estimated power
#: (:attr:`pyrt.EmissiveMeshLight.power`) is at least this fraction of the studio key light's power onto the model
#: (``key x pi R^2``, R its bounding radius): light sources, not glowing labels, logos and displays (0.02-0.14 of the
#: key in the compliance set and the sample assets; EmissiveStrengthTest's cubes 0.33), whose sampling cost 1.2-1.9x
#: the render (ClearCoatTest 10.2 -> 15.7 s, MultiUVTest 1.52 -> 2.91 s, docs/preview.md). Below it their light on
#: other surfaces arrives only through glossy rays (Lambertian surfaces get none of it: a documented bias)
EMISSIVE_POWER_RATIO = 0.25

#: ``max_spp`` of an adaptive preview (``spp`` None) when it is not given
ADAPTIVE_MAX_SPP = 64

#: ``azimuth=None`` views a model face-on (azimuth 0) when its z extent is at most this fraction of its x extent
BOARD_DEPTH_RATIO = 0.25
#: ``azimuth=None`` views every other model from this azimuth (degrees)
DEFAULT_AZIMUTH = 35.0

#: the previewer warns when more than this fraction of the single-sided model surface a view's first rays reach
#: (culling off, a BACK_FACE_GRID of pixel-centre rays) is back faces: a model whose faces are wound clockwise seen
#: from outside (or whose normals point inward) looks hollow when they are culled as glTF's doubleSided=false asks
BACK_FACE_WARNING = 0.5
#: the pixel-centre rays of that check (columns, rows), spread over the view
BACK_FACE_GRID = (64, 48)

#: ``bvh_quality="auto"`` builds models of at least this many triangles (instances counted) at Embree's "low" quality
BVH_LOW_TRIANGLES = 1_000_000

AXES = {"+x": (1, 0, 0), "-x": (-1, 0, 0), "+y": (0, 1, 0), "-y": (0, -1, 0), "+z": (0, 0, 1), "-z": (0, 0, -1)}
