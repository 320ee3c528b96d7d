"""Asset preview: "show me this model, properly lit".

``render_preview(path_or_asset, options)`` loads a model (:mod:`pyrt.io.assets`), turns it so that
its up axis is +y, frames it, lights it with a studio rig over a shadow-catcher ground, picks an
exposure and renders one view or a turntable. :func:`preview_batch` does that for a folder or glob
of models, locally or on a Dask cluster, and :func:`main` is the ``pyrt-preview`` command.

The pieces, each a function that can be used and tested alone
------------------------------------------------------------
- **Up axis** (:func:`detect_up_axis`): glTF is +y by specification; a PLY header or OBJ comment that names
  the up axis is obeyed (:func:`metadata_up_axis`). Otherwise :func:`guess_up_axis` stands the model on its
  convex hull for +y and +z: the support polygon (hull vertices within 2% of the size of the lowest) scored
  by its area, penalised when the surface centroid would tip over its edge or when the candidate's normal
  plane is a mirror symmetry and the other's is not; a 1.5x lead wins, else STL (a CAD / 3D-printing
  format) is taken as +z and the others as +y. Override with ``up="+z"`` etc.
- **Framing** (:func:`frame_points`, ``framing="fit"``): seen at ``azimuth``/``elevation`` (degrees; azimuth
  0 looks from +z toward -z, positive azimuth moves the camera toward +x; ``azimuth=None``, the default: 0 for a
  thin board, z extent <= ``BOARD_DEPTH_RATIO`` x extent, else 35), the camera is moved sideways
  until the projection of the model's convex hull is centred, and along the view axis until it spans
  ``1 / margin`` of the frame in its limiting dimension (nothing is clipped: the model projects inside its
  hull). ``framing="sphere"`` (:func:`frame_camera`): the bounding sphere (centre of the bounding box,
  radius to the farthest vertex) from the distance ``d = margin R / sin(a)``, where ``a`` is the smaller of
  the vertical and horizontal half fields of view.
- **Studio rig** (:func:`studio_rig`): key, fill and rim *directional* lights placed relative to the
  camera (key high on the camera's left, fill low on its right, rim behind), irradiance in W/m^2.
  Directional lights make the rig independent of the model's size and position (what "scaled to
  the model" needs: the same picture at any scale) and give a ground that is lit uniformly, which
  is what the shadow catcher needs. The ambient light is a procedural studio environment
  (:mod:`~pyrt.apps.preview.studio`, ``studio_env=True``) that metals and glossy surfaces reflect, with the
  constant ambient's mean radiance; ``studio_env=False`` gives the constant ambient term ``L_a``.
- **Shadow-catcher ground**: a Lambertian plane of albedo ``rho`` just below the model (100 radii
  wide). Its unshadowed radiance is the constant ``L_g = rho / pi * sum_i E_i max(0, sin el_i) +
  rho * L_a`` (:func:`ground_radiance`, the integrator's own formula), and the background (what
  misses see) is set to exactly ``L_g``: the ground disappears into the backdrop and only the
  shadows it catches remain. The asset's own point/spot lights (``lights="asset"/"both"``) light
  the ground unevenly; the backdrop then matches the ground under the model's centre. With an
  environment map (``environment=``, an OpenEXR or Radiance .hdr lat-long map, used as a light with
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
``cancel`` (a threading.Event, set by the first Ctrl-C of ``pyrt-preview``) is checked before every asset and
view: the view in progress finishes, an unfinished asset is reported ``interrupted`` (no files), the assets not
started ``skipped``, and the summary is written. ``time_budget`` (s per asset) is checked before the load and
before every view: a turntable stops
with status ``timeout`` when the next view would exceed it (a single long view is not interrupted).

Modules: :mod:`~pyrt.apps.preview.options` (options, errors), :mod:`~pyrt.apps.preview.rig` (up axis,
framing, studio rig, ground, exposure), :mod:`~pyrt.apps.preview.render` (the preview scene, files),
:mod:`~pyrt.apps.preview.studio` (the studio environment), :mod:`~pyrt.apps.preview.batch` (batches, Dask), :mod:`~pyrt.apps.preview.cli` (``pyrt-preview``).
"""
from pyrt.apps.preview.options import AXES, BudgetExceeded, PreviewError, PreviewInterrupted, PreviewOptions
from pyrt.apps.preview.rig import (RIG, auto_exposure, bounding_sphere, detect_up_axis, frame_camera, frame_points,
                                   framing_points, ground_radiance, guess_up_axis, hull_points, metadata_up_axis,
                                   studio_rig, up_transform)
from pyrt.apps.preview.render import PreviewResult, PreviewScene, contact_sheet, render_preview, write_files
from pyrt.apps.preview.batch import (AssetReport, collect_inputs, format_summary, output_name, preview_asset,
                                     preview_batch, summary_rows, write_summary)
from pyrt.apps.preview.cli import main

__all__ = [
    "AXES", "BudgetExceeded", "PreviewError", "PreviewInterrupted", "PreviewOptions", "RIG", "auto_exposure", "bounding_sphere",
    "detect_up_axis", "frame_camera", "frame_points", "framing_points", "ground_radiance", "guess_up_axis",
    "hull_points",
    "metadata_up_axis", "studio_rig", "up_transform", "PreviewResult", "PreviewScene",
    "contact_sheet", "render_preview", "write_files", "AssetReport", "collect_inputs", "format_summary",
    "output_name", "preview_asset", "preview_batch", "summary_rows", "write_summary", "main",
]
