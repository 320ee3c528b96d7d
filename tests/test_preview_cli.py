"""``pyrt-preview``: bad option values, one-line errors before rendering, and interrupts that keep the
finished assets and write the summary."""
import os
import shutil
import signal
import subprocess
import sys
import time

import pytest

from pyrt.apps import preview as P
from render_helpers import CancelAfter

ROOT = os.path.join(os.path.dirname(__file__), "..")
BLOB = os.path.join(ROOT, "assets", "models", "blob.ply")
TINY = dict(width=24, height=18, spp=1)



@pytest.mark.parametrize("option, value", [
    ("--width", "0"), ("--width", "-10"), ("--height", "0"), ("--spp", "0"), ("--seed", "-1"),
    ("--exposure", "nan"), ("--turntable", "-1"), ("--budget", "0"), ("--threads", "0"), ("--env-samples", "0"),
    ("--fov", "nan"), ("--glossy-clamp", "0"), ("--glossy-clamp", "-2"), ("--glossy-clamp", "inf"),
])
def test_preview_cli_rejects_bad_option_values(tmp_path, capsys, option, value):
    with pytest.raises(SystemExit) as exc:
        P.main([BLOB, "-o", str(tmp_path / "v.png"), option, value])
    err = capsys.readouterr().err
    assert exc.value.code == 2 and f"argument {option}" in err and "Traceback" not in err


def test_preview_cli_errors_are_one_line(tmp_path, capsys):
    (tmp_path / "empty").mkdir()
    (tmp_path / "a_file").write_text("not a folder")
    cases = [
        ([str(tmp_path / "empty"), "--out-dir", str(tmp_path / "o")], "no models found"),
        ([str(tmp_path / "none.glb"), "-o", str(tmp_path / "v.png")], "no such model file"),
        ([BLOB, "-o", str(tmp_path / "a_file" / "v.png")], "output folder is not a folder"),
        ([BLOB, "-o", str(tmp_path / "v.png"), "-o", str(tmp_path / "v.png")], "the same output file is given twice"),
        ([BLOB, "--out-dir", str(tmp_path / "a_file" / "b")], "output folder is not a folder"),
        ([BLOB, "-o", str(tmp_path / "v.png"), "--fov", "0"], "fov must be in"),
    ]
    for argv, message in cases:
        assert P.main(argv + ["--quiet"]) == 2, argv
        err = capsys.readouterr().err
        assert err.startswith("pyrt-preview: error: ") and message in err, err
        assert len(err.strip().splitlines()) == 1
    assert sorted(os.listdir(tmp_path)) == ["a_file", "empty"]       # nothing rendered, nothing written


def test_preview_cli_errors_after_the_load_name_the_file(tmp_path, capsys):
    # a mesh that loads but cannot be rendered: the scene's error names the mesh, the CLI adds the file
    bad = tmp_path / "collinear.obj"
    bad.write_text("v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n")
    assert P.main([str(bad), "-o", str(tmp_path / "v.png"), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"pyrt-preview: error: {bad}: ") and "degenerate" in err, err
    assert len(err.strip().splitlines()) == 1
    assert not (tmp_path / "v.png").exists()


def test_preview_batch_cancel_keeps_finished_assets_and_writes_the_summary(tmp_path):
    d = tmp_path / "models"
    d.mkdir()
    for n in ("a", "b", "c"):
        shutil.copy(BLOB, d / f"{n}.ply")
    o = P.PreviewOptions(turntable=2, **TINY)
    # checks: asset a, view 0, view 1 (3), asset b, view 0 (5) -> b is cut after one view, c not started
    reps = P.preview_batch([str(d)], str(tmp_path / "out"), o, progress=False, cancel=CancelAfter(5))
    assert [r.status for r in reps] == ["ok", "interrupted", "skipped"]
    assert reps[1].error == "interrupted after 1/2 views"
    files = sorted(os.listdir(tmp_path / "out"))
    assert files == ["a_ply_sheet.png", "a_ply_turntable", "summary.csv", "summary.txt"]
    assert "1/3 assets ok" in (tmp_path / "out" / "summary.txt").read_text()


def test_render_preview_cancelled_between_views_raises():
    o = P.PreviewOptions(turntable=3, **TINY)
    with pytest.raises(P.PreviewInterrupted, match="after 1/3 views"):
        P.render_preview(BLOB, o, cancel=CancelAfter(1))


def test_preview_cli_sigint_exits_130_with_the_summary(tmp_path):
    d = tmp_path / "models"
    d.mkdir()
    for k in range(40):
        shutil.copy(BLOB, d / f"m{k:02d}.ply")
    env = dict(os.environ, PYTHONPATH=os.path.abspath(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    out = tmp_path / "out"
    p = subprocess.Popen([sys.executable, "-m", "pyrt.apps.preview", str(d), "--out-dir", str(out), "--width", "96",
                          "--height", "72", "--spp", "2", "--quiet"], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                         text=True, env=env)
    t_end = time.monotonic() + 60
    while not (out.exists() and any(f.endswith(".png") for f in os.listdir(out))) and time.monotonic() < t_end:
        time.sleep(0.05)
    p.send_signal(signal.SIGINT)
    stdout, err = p.communicate(timeout=60)
    assert p.returncode == 130, err
    assert "pyrt-preview: interrupted: " in err and "Traceback" not in err
    summary = (out / "summary.txt").read_text()
    assert "skipped" in summary
    ok = [f for f in os.listdir(out) if f.endswith(".png")]
    assert 0 < len(ok) < 40 and f"{len(ok)}/40 assets ok" in summary


@pytest.mark.parametrize("module, args, code, out_name", [
    ("pyrt.apps.preview.cli", [BLOB, "--width", "24", "--height", "18", "--spp", "1"], 0, "v.png"),
    ("pyrt.apps.preview.cli", ["missing.glb"], 2, None),
    ("pyrt.apps.cli", ["render", os.path.join(ROOT, "assets", "default_scene.toml"), "--width", "32", "--height",
                       "24", "--spp", "1"], 0, "r.png"),
])
def test_console_scripts_exit_with_main_s_code_and_keep_their_output(tmp_path, module, args, code, out_name):
    """The console scripts (``console_main``: ``main`` then ``os._exit`` without the interpreter's teardown) exit
    with main's code, with stdout / stderr flushed and the files written."""
    argv = list(args) + (["-o", str(tmp_path / out_name)] if out_name else ["-o", str(tmp_path / "x.png")])
    prog = f"import sys; sys.argv = ['prog'] + {argv!r}; from {module} import console_main; console_main()"
    proc = subprocess.run([sys.executable, "-c", prog], capture_output=True, text=True, timeout=300, cwd=str(tmp_path))
    assert proc.returncode == code, proc.stderr
    if out_name:
        assert (tmp_path / out_name).stat().st_size > 0
        assert proc.stdout.strip()                    # the summary line, flushed before os._exit
    else:
        assert proc.stderr.strip().startswith("pyrt-preview: error: ")


def _shared_buffer_model(tmp_path):
    """``tmp_path/models/a.gltf``, a triangle whose buffer is ``../shared/tri.bin`` (a model pack's shared folder)."""
    import json
    import numpy as np
    binary = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], np.float32).tobytes()
    header = {"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
              "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
              "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                             "min": [0, 0, 0], "max": [1, 1, 0]}],
              "bufferViews": [{"buffer": 0, "byteLength": len(binary)}],
              "buffers": [{"byteLength": len(binary), "uri": "../shared/tri.bin"}]}
    (tmp_path / "shared").mkdir()
    (tmp_path / "shared" / "tri.bin").write_bytes(binary)
    (tmp_path / "models").mkdir()
    (tmp_path / "models" / "a.gltf").write_text(json.dumps(header))
    return str(tmp_path / "models" / "a.gltf")


def test_preview_cli_root_widens_the_folder_a_loose_model_reads(tmp_path, capsys):
    """The root rule of pyrt.io.assets.find_file from the command line: a URI leaving the model's folder is a
    one-line error (exit 2, nothing written); --root naming a folder that contains the model and the file reads it;
    a --root that is not a folder or does not contain the model is an error before anything is read."""
    model = _shared_buffer_model(tmp_path)
    out = tmp_path / "v.png"
    tiny = ["--width", "24", "--height", "18", "--spp", "1", "--quiet"]
    assert P.main([model, "-o", str(out)] + tiny) == 2
    err = capsys.readouterr().err
    assert err.startswith("pyrt-preview: error: ") and "'../shared/tri.bin' leaves the model's folder" in err, err
    assert len(err.strip().splitlines()) == 1 and not out.exists()
    (tmp_path / "elsewhere").mkdir()
    for root, message in ((tmp_path / "nothing", "root must be an existing folder"),
                          (tmp_path / "elsewhere", "does not contain the model")):
        assert P.main([model, "-o", str(out), "--root", str(root)] + tiny) == 2
        err = capsys.readouterr().err
        assert err.startswith("pyrt-preview: error: ") and message in err, err
        assert len(err.strip().splitlines()) == 1 and not out.exists()
    assert P.main([model, "-o", str(out), "--root", str(tmp_path)] + tiny) == 0
    assert out.stat().st_size > 0
