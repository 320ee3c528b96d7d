"""The previewer's render chunks: ``PreviewOptions.chunk_samples`` bounds the camera samples a thread shades at once.

Ground truth: the chunk sizes the render actually shades (counted at the chunk function) and the option's checks.
"""
import os

import pytest

import pyrt.apps.preview as P
from pyrt.apps.preview import render as R

ASSETS = os.path.join(os.path.dirname(__file__), "..", "assets", "models")


def test_default_chunk_is_32768_samples_and_is_checked():
    assert P.PreviewOptions().chunk_samples == 32768
    for bad in (0, -5, 1.5):
        with pytest.raises(P.PreviewError, match="chunk_samples"):
            P.PreviewOptions(chunk_samples=bad).validate()


def test_preview_render_uses_the_chunk_size(monkeypatch):
    seen = []
    real = R.render_full

    def spy(*a, **k):
        seen.append(k["execution"].chunk_samples)
        return real(*a, **k)

    monkeypatch.setattr(R, "render_full", spy)
    o = P.PreviewOptions(width=40, height=30, spp=4, chunk_samples=1000, exposure=0.0)
    res = P.render_preview(os.path.join(ASSETS, "studio_sample.glb"), o)
    assert seen == [1000] and res.images[0].shape[:2] == (30, 40)
