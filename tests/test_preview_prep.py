"""What the previewer's preparation cut keeps exactly: the model mask traced only inside the model's projected bounds
(in blocks of rays) is the full-frame trace; the PBR Neutral tone map that compresses only the highlights gives the
formula's numbers; PNGs at the faster zlib level hold the same pixels; OpenEXR is imported only where an EXR is read
or written, and still reads and writes."""
from __future__ import annotations

from contextlib import closing
import io
import os
import subprocess
import sys

import numpy as np
import pytest
from PIL import Image

import pyrt
from pyrt.apps import preview as P
from pyrt.apps.preview.render import PreviewScene
from pyrt.core.image_io import encode_png
from pyrt.io.assets import load_asset
from pyrt.shaders import tonemap as T

ROOT = os.path.join(os.path.dirname(__file__), "..")
SAMPLE = os.path.join(ROOT, "assets", "models", "studio_sample.glb")


def _full_mask(ps):
    """The model mask as one trace of every pixel centre (what model_mask gave before the window)."""
    cam = ps.scene.camera
    ys, xs = np.mgrid[0:cam.height, 0:cam.width]
    d = cam.directions(xs.ravel() + 0.5, ys.ravel() + 0.5)
    hits = ps.prepared.accel.intersect(np.broadcast_to(cam.position, d.shape), d)
    return (hits.hit & np.isin(hits.mesh_id, ps.model_meshes)).reshape(cam.height, cam.width)


@pytest.fixture(scope="module")
def sample():
    return load_asset(SAMPLE)


@pytest.mark.parametrize("view", [dict(azimuth=35.0), dict(azimuth=0.0, elevation=60.0), dict(azimuth=200.0),
                                  dict(azimuth=90.0, framing="sphere", fov=20.0)])
def test_model_mask_is_the_full_frame_trace(sample, view):
    opts = P.PreviewOptions(width=200, height=150, **view)
    with closing(PreviewScene(sample, opts)) as ps:
        ps._set_view(ps.azimuth)
        x0, x1, y0, y1 = ps.model_window()
        mask = ps.model_mask()
        assert np.array_equal(mask, _full_mask(ps))
        assert mask.any() and (x1 - x0) * (y1 - y0) < 200 * 150       # fewer rays traced
        assert not mask[:, :x0].any() and not mask[:, x1:].any() and not mask[:y0].any() and not mask[y1:].any()


def test_model_window_is_the_whole_image_when_the_camera_is_inside_the_bounds(sample):
    with closing(PreviewScene(sample, P.PreviewOptions(width=40, height=30))) as ps:
        ps._set_view(ps.azimuth)
        cam = ps.scene.camera
        cam.position = 0.5 * (ps.bounds[0] + ps.bounds[1])
        cam.target = cam.position + np.array([0.0, 0.0, -1.0])
        assert ps.model_window() == (0, 40, 0, 30)
        assert np.array_equal(ps.model_mask(), _full_mask(ps))


def _pbr_neutral_reference(L, exposure=0.0):
    """The PBR Neutral formula as written in the specification, every branch evaluated everywhere."""
    c = np.maximum(L, 0.0) * (2.0 ** exposure)
    x = np.min(c, axis=-1, keepdims=True)
    f = np.where(x <= 2 * T.PBR_NEUTRAL_F90, x - x * x / (4 * T.PBR_NEUTRAL_F90), T.PBR_NEUTRAL_F90)
    c = c - f
    p = np.max(c, axis=-1, keepdims=True)
    d = 1.0 - T.PBR_NEUTRAL_KS
    pn = 1.0 - d * d / (p + d - T.PBR_NEUTRAL_KS)
    g = 1.0 / (T.PBR_NEUTRAL_KD * (p - pn) + 1.0)
    ratio = np.divide(pn, p, out=np.ones_like(p), where=p > 0)
    out = np.where(p <= T.PBR_NEUTRAL_KS, c, c * ratio * g + pn * (1.0 - g))
    return np.clip(out, 0.0, 1.0).astype(c.dtype, copy=False)


@pytest.mark.filterwarnings("ignore::RuntimeWarning")
@pytest.mark.parametrize("scale", [0.05, 1.0, 30.0])
def test_pbr_neutral_gives_the_formulas_numbers_bit_for_bit(rng, dtype, scale):
    L = (rng.random((37, 53, 3)) ** 3 * scale).astype(dtype)
    L[0, :4] = [[np.nan, 0.2, 0.3], [-0.0, 0.0, -1.0], [np.inf, 1.0, 1.0], [0.76, 0.76, 0.76]]
    for exposure in (-2.0, 0.0, 1.5):
        got, want = T.pbr_neutral(L, exposure), _pbr_neutral_reference(L, exposure)
        assert got.dtype == want.dtype == dtype
        assert np.array_equal(got, want, equal_nan=True)
    before = L.copy()
    T.pbr_neutral(L)
    assert np.array_equal(L, before, equal_nan=True)          # the input is not written


def test_png_holds_the_pixels_exactly(rng):
    img = (rng.random((48, 64, 3)) * 255).astype(np.uint8)
    img[:16] = 128                                            # compressible rows too
    back = np.asarray(Image.open(io.BytesIO(encode_png(img))))
    assert np.array_equal(back, img)


def test_previewer_imports_openexr_only_for_exr(tmp_path):
    code = "import sys, pyrt.apps.preview.cli; print('OpenEXR' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "False"
    img = np.random.default_rng(0).random((6, 8, 3)).astype(np.float32)
    pyrt.write_exr(tmp_path / "a.exr", img)
    assert np.array_equal(pyrt.read_exr(tmp_path / "a.exr")[..., :3], img)
