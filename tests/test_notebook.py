"""docs/example.ipynb runs from top to bottom (nbclient, the ``notebook`` extra) and shows its renders as PNGs;
RenderResult and pyrt.show give Jupyter the PNG that write_png writes."""
from pathlib import Path

import numpy as np
import pytest

import pyrt
from pyrt.core.image_io import png_bytes

ROOT = Path(__file__).resolve().parents[1]
PNG = b"\x89PNG\r\n\x1a\n"


def _result():
    cam = pyrt.Camera(position=(0, 0, 3), target=(0, 0, 0), width=12, height=8, spp=1)
    scene = pyrt.Scene(cam, background=(0.2, 0.3, 0.4))
    scene.add_sphere((0, 0, 0), 1.0, pyrt.Lambert(albedo=0.5), subdivisions=1)
    scene.add_light(pyrt.PointLight((2, 2, 2), intensity=10.0))
    return pyrt.render_full(scene, execution=pyrt.Execution(backend="numpy", threads=1, progress=False))


def test_render_result_displays_as_the_default_png(tmp_path):
    res = _result()
    data = res._repr_png_()
    pyrt.write_png(tmp_path / "a.png", res.image)
    assert data.startswith(PNG) and data == (tmp_path / "a.png").read_bytes()
    assert repr(res).startswith("RenderResult(12x8, numpy path, 1 pass(es), complete")


def test_show_uses_the_tone_map_and_exposure_it_is_given(tmp_path):
    img = _result().image
    shown = pyrt.show(img, tonemap="aces", exposure=1.0)
    pyrt.write_png(tmp_path / "b.png", img, tonemap="aces", exposure=1.0)
    assert shown._repr_png_() == (tmp_path / "b.png").read_bytes() != png_bytes(img)
    with pytest.raises(ValueError, match="tonemap"):
        pyrt.show(img, tonemap="bogus")
    with pytest.raises(ValueError, match=r"\(H, W, 3\) float"):
        pyrt.show(np.zeros((4, 4), dtype=np.float32))


def test_example_notebook_runs_and_shows_its_images():
    nbformat = pytest.importorskip("nbformat", reason="the notebook extra: pip install -e '.[notebook]'")
    nbclient = pytest.importorskip("nbclient", reason="the notebook extra: pip install -e '.[notebook]'")
    pytest.importorskip("ipykernel", reason="the notebook extra: pip install -e '.[notebook]'")
    nb = nbformat.read(ROOT / "docs" / "example.ipynb", as_version=4)
    client = nbclient.NotebookClient(nb, timeout=600, kernel_name="python3", resources={"metadata": {"path": ROOT}})
    client.execute()
    outputs = [o for cell in nb.cells if cell.cell_type == "code" for o in cell.outputs]
    assert not [o for o in outputs if o.output_type == "error"]
    pngs = [o for o in outputs if "image/png" in o.get("data", {})]
    assert len(pngs) == 3          # the result, pyrt.show, the adaptive result
    texts = "".join(o.get("text", "") for o in outputs if o.output_type == "stream")
    assert "RenderResult(160x120, numpy path" in texts and "passes" in texts
