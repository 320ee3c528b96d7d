"""What the previewer says it did (issue 33): samples per pixel and estimated error on the summary line and in the
batch table, the render path and stop reason its report carries, whole messages, one-line precision warnings (none
for a thin board), folders searched recursively, and ``--help`` naming what ``-o X.png --turntable N`` writes."""
from __future__ import annotations

import os
import shutil
import warnings

import numpy as np
import pytest

import pyrt
from pyrt.apps import preview as P
from pyrt.apps.preview import batch as P_batch
from pyrt.apps.preview.render import format_sampling
from pyrt.geometry.precision import PrecisionWarning

BLOB = os.path.join(os.path.dirname(__file__), "..", "assets", "models", "blob.ply")


def _line(capsys):
    return [ln for ln in capsys.readouterr().out.splitlines() if "triangles" in ln][0]


def test_summary_line_gives_the_spp_of_a_fixed_render(tmp_path, capsys):
    assert P.main([BLOB, "-o", str(tmp_path / "v.png"), "--width", "24", "--height", "18", "--spp", "2"]) == 0
    line = _line(capsys)
    assert (", 2 spp, compiled path, exposure" in line or ", 2 spp, NumPy path, exposure" in line) and "relMSE" not in line


def test_summary_line_gives_the_spp_and_error_an_adaptive_render_reached(tmp_path, capsys):
    assert P.main([BLOB, "-o", str(tmp_path / "v.png"), "--width", "24", "--height", "18", "--target-error", "1e-9",
                   "--min-spp", "2", "--max-spp", "4"]) == 0
    line = _line(capsys)
    part = line.split(" spp (mean), estimated relMSE ")
    assert len(part) == 2, line
    spp = float(part[0].rsplit(", ", 1)[1])
    err = float(part[1].split(" ")[0])
    assert 2 <= spp <= 4 and err > 1e-9          # the target is out of reach: max_spp stops it
    assert "(target 1e-09, stopped by max_spp)" in line


def test_the_default_is_adaptive_and_says_why_it_stopped(tmp_path, capsys):
    """No --spp: adaptive passes to the default target within the render budget; a budget too short for a second
    pass stops after the base pass and the line says so."""
    assert P.main([BLOB, "-o", str(tmp_path / "v.png"), "--width", "24", "--height", "18"]) == 0
    line = _line(capsys)
    assert f"(target {P.PreviewOptions.target_error:g}" in line and " spp (mean), estimated relMSE " in line
    assert P.main([BLOB, "-o", str(tmp_path / "w.png"), "--width", "24", "--height", "18", "--target-error", "1e-9",
                   "--render-budget", "1e-6"]) == 0
    line = _line(capsys)
    assert ", 4 spp (mean), " in line and "(target 1e-09, stopped by the render budget)" in line


def test_spp_and_an_adaptive_target_exclude_each_other(tmp_path, capsys):
    assert P.main([BLOB, "-o", str(tmp_path / "v.png"), "--spp", "2", "--target-error", "1e-3"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("pyrt-preview: error: --spp") and err.count("\n") == 1
    assert not (tmp_path / "v.png").exists()


def test_batch_summary_has_spp_error_and_whole_messages(tmp_path):
    long = "x" * 150 + " the end"
    reps = [P_batch.AssetReport(path="a.ply", name="a_ply", warnings=[long], spp=4.0),
            P_batch.AssetReport(path="b.ply", name="b_ply", spp=5.25, estimated_error=0.00123)]
    table = P.format_summary(reps)
    assert long in table
    head = table.splitlines()[0].split()
    assert "spp" in head and "err." in head
    rows = table.splitlines()[2:4]
    assert " 4 " in rows[0] and " - " in rows[0]
    assert " 5.25 " in rows[1] and " 0.0012 " in rows[1]
    P_batch.write_summary(reps, str(tmp_path))
    header = (tmp_path / "summary.csv").read_text().splitlines()[0].split(",")
    assert header[-2:] == ["spp", "estimated_relmse"]


def test_a_folder_of_model_folders_is_searched_recursively(tmp_path):
    (tmp_path / "Blob" / "ply").mkdir(parents=True)
    (tmp_path / "Other").mkdir()
    (tmp_path / ".hidden").mkdir()
    shutil.copy(BLOB, tmp_path / "Blob" / "ply" / "blob.ply")
    shutil.copy(BLOB, tmp_path / "Other" / "b.ply")
    shutil.copy(BLOB, tmp_path / ".hidden" / "c.ply")
    (tmp_path / "Other" / "README.md").write_text("not a model")
    found = P.collect_inputs([str(tmp_path)])
    assert found == [str(tmp_path / "Blob" / "ply" / "blob.ply"), str(tmp_path / "Other" / "b.ply")]


def test_help_says_what_a_turntable_writes(capsys):
    with pytest.raises(SystemExit):
        P.main(["--help"])
    out = " ".join(capsys.readouterr().out.split())
    assert "X_turntable/frame_000.png" in out and "X_sheet.png" in out


def _board_scene(thickness, offset=0.0):
    s = pyrt.Scene(pyrt.Camera((offset, 0, 5), (offset, 0, 0), (0, 1, 0), width=8, height=8))
    s.add_box((offset, 0, 0), (1.0, 1.0, thickness), pyrt.Lambert(0.8), name="board")
    return s


def test_a_thin_board_is_no_precision_risk():
    """A board 1e-7 thick at unit coordinates (2 float32 steps thick; a step is 1e-7 of its size) is not warned about;
    the same board far from the origin (1e7: a step is half its size) is."""
    with warnings.catch_warnings():
        warnings.simplefilter("error", PrecisionWarning)
        pyrt.PreparedScene(_board_scene(1e-7)).close()
    with pytest.warns(PrecisionWarning, match="float32 steps"):
        pyrt.PreparedScene(_board_scene(1e-7, offset=1e7)).close()


def test_previewer_reports_precision_warnings_as_its_own_lines(tmp_path):
    """A model far from the origin: the PrecisionWarning is one of the preview's warnings, not a Python warning."""
    import trimesh
    mesh = trimesh.creation.icosphere(subdivisions=2)
    mesh.apply_scale(4.0)
    mesh.apply_translation((4e6, 0, 0))          # float32 step 0.25 there: 32 steps across its size 8
    path = tmp_path / "far.ply"
    mesh.export(path)
    with warnings.catch_warnings():
        warnings.simplefilter("error", PrecisionWarning)
        ps = P.PreviewScene(pyrt.load_asset(str(path)), P.PreviewOptions(width=8, height=8, spp=1))
        ps.close()
    assert any("float32 steps" in w for w in ps.warnings)


def test_summary_line_names_the_render_path(tmp_path, capsys):
    """A model the compiled kernel covers (an OBJ under the studio rig) says so on the summary line."""
    obj = tmp_path / "tri.obj"
    obj.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\nf 1 3 4\nf 1 4 2\nf 2 4 3\n")
    assert P.main([str(obj), "-o", str(tmp_path / "v.png"), "--width", "16", "--height", "12", "--spp", "1"]) == 0
    line = _line(capsys)
    assert ", 1 spp, compiled path, exposure" in line, line


def test_backend_option_picks_the_render_path(tmp_path, capsys):
    obj = tmp_path / "tri.obj"
    obj.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\nf 1 3 4\nf 1 4 2\nf 2 4 3\n")
    assert P.main([str(obj), "-o", str(tmp_path / "v.png"), "--width", "16", "--height", "12", "--spp", "1",
                   "--backend", "numpy"]) == 0
    assert ", 1 spp, NumPy path, exposure" in _line(capsys)
    with pytest.raises(P.PreviewError, match="backend must be one of"):
        P.PreviewOptions(backend="gpu").validate()


def _result(**views):
    """A :class:`PreviewResult` of two views (no images: what the report reads of it)."""
    return P.PreviewResult(images=[], aovs=[], azimuths=[0.0, 180.0], exposure=1.0, white=None, up_axis="+y",
                           up_reason="glTF", center=np.zeros(3), radius=1.0, camera=None, triangles=12,
                           load_time=0.25, render_time=0.5, warnings=[], **views)


@pytest.mark.parametrize("backends, stops, backend, stop", [
    (["compiled", "compiled"], ["target_error", "target_error"], "compiled", "target_error"),
    (["compiled", "numpy"], ["target_error", "time_budget"], "numpy", "time_budget"),    # any NumPy view; short stop
    (["numpy", "numpy"], ["max_spp", "time_budget"], "numpy", "max_spp"),              # the first short stop
    (["compiled", "compiled"], [None, None], "compiled", None),                       # a fixed spp
    ([], [], "", None),                                                                # nothing rendered
])
def test_preview_result_names_its_render_path_and_stop_reason(backends, stops, backend, stop):
    res = _result(backends=backends, stop_reasons=stops)
    assert (res.backend, res.stop_reason) == (backend, stop)


def test_asset_report_carries_path_spp_error_and_stop_reason_of_the_views(monkeypatch):
    res = _result(spp=[4.0, 6.0], estimated_errors=[8e-4, 1.5e-3], backends=["compiled", "numpy"],
                  stop_reasons=["target_error", "time_budget"])
    monkeypatch.setattr(P_batch, "render_preview", lambda *args, **kwargs: res)
    rep = P.preview_asset("m.glb", None, return_files=True)
    assert rep.status == "ok"
    assert (rep.spp, rep.estimated_error, rep.backend, rep.stop_reason) == (5.0, 1.5e-3, "numpy", "time_budget")
    assert P.format_summary([rep]).splitlines()[2].split()[6:8] == ["5", "0.0015"]    # the summary's columns as before
    assert format_sampling(res, 1e-3) == ("5 spp (mean), estimated relMSE 0.0015 (target 0.001, stopped by the render "
                                          "budget), NumPy path")
    assert P_batch.AssetReport(path="x", name="x").backend == ""                     # not rendered: no path
