"""The command line ``python -m pyrt render``: bad option values, one-line errors before any rendering,
exit codes, and SIGINT / SIGTERM keeping the finished part of the image."""
import os
import pathlib
import re
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

import pyrt
from pyrt.apps import cli

ROOT = pathlib.Path(__file__).resolve().parents[1]
SCENE = str(ROOT / "assets/default_scene.toml")
SMALL = ["--width", "16", "--height", "12", "--spp", "1"]
INTERRUPTED = re.compile(r"pyrt: interrupted: (\d+)/(\d+) chunks \((\d+) % of the pixels\) rendered at \d+ spp; "
                         r"(the rest is black|the other pixels got 1 sample each \(noisier\)|\d+ % of the other pixels "
                         r"got 1 sample each \(noisier\), the rest is black \(the fill's time was up\))")


def _env():
    return dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))


@pytest.mark.parametrize("option, value", [
    ("--spp", "0"), ("--spp", "-3"), ("--spp", "2.5"), ("--spp", "many"),
    ("--width", "0"), ("--width", "-10"), ("--height", "0"), ("--height", "-1"),
    ("--max-depth", "-1"), ("--seed", "-1"), ("--seed", "x"),
    ("--exposure", "nan"), ("--exposure", "inf"), ("--exposure", "abc"),
    ("--white", "0"), ("--white", "-1"), ("--white", "nan"), ("--white", "inf"),
    ("--offset", "bogus"),
])
def test_cli_rejects_bad_option_values(tmp_path, capsys, option, value):
    out = tmp_path / "x.png"
    with pytest.raises(SystemExit) as exc:
        cli.main(["render", SCENE, "-o", str(out), option, value])
    err = capsys.readouterr().err
    assert exc.value.code == 2
    assert f"argument {option}" in err and "Traceback" not in err
    lines = err.strip().splitlines()                 # one line, no usage block: "pyrt: error: argument ..."
    assert len(lines) == 1 and lines[0].startswith("pyrt: error: argument "), lines
    assert not out.exists()


def test_acne_cli_bad_arguments_are_one_line(capsys):
    from pyrt.apps.acne.cli import main as acne_main
    with pytest.raises(SystemExit) as exc:
        acne_main(["--bogus"])
    lines = capsys.readouterr().err.strip().splitlines()
    assert exc.value.code == 2 and len(lines) == 1 and lines[0].startswith("pyrt-acne: error: "), lines


def test_cli_white_applies_to_reinhard_only(tmp_path, capsys):
    with pytest.raises(SystemExit) as exc:
        cli.main(["render", SCENE, "-o", str(tmp_path / "x.png"), "--tonemap", "film", "--white", "2"])
    assert exc.value.code == 2 and "--white applies to --tonemap reinhard only" in capsys.readouterr().err


def test_cli_accepts_max_depth_zero_and_every_offset(tmp_path, capsys):
    out = tmp_path / "x.png"
    assert cli.main(["render", SCENE, "-o", str(out), *SMALL, "--max-depth", "0", "--offset", "none",
                     "--seed", "0"]) == 0
    assert out.stat().st_size > 0


def _write_corrupt_exr_scene(tmp_path):
    (tmp_path / "sky.exr").write_bytes(b"v/1\x01 not an EXR file at all")
    text = (ROOT / "assets/ibl_scene.toml").read_text()
    (tmp_path / "ibl.toml").write_text(text)
    return str(tmp_path / "ibl.toml")


def _error_cases(tmp_path):
    empty = tmp_path / "empty.toml"
    empty.write_text("[camera]\nwidth = 8\nheight = 6\n")
    (tmp_path / "folder.png").mkdir()
    (tmp_path / "a_file").write_text("not a folder")
    out = str(tmp_path / "x.png")
    return {
        "empty scene": (["render", str(empty), "-o", out], "the scene has no meshes"),
        "unreadable EXR": (["render", _write_corrupt_exr_scene(tmp_path), "-o", out], "sky.exr"),
        "missing scene": (["render", str(tmp_path / "none.toml"), "-o", out], "scene file not found"),
        "output folder cannot be made": (["render", SCENE, "-o", str(tmp_path / "a_file" / "no" / "x.png")],
                                         "cannot create output folder"),
        "output is a folder": (["render", SCENE, "-o", str(tmp_path / "folder.png")], "output is a folder"),
        "unknown extension": (["render", SCENE, "-o", str(tmp_path / "x.jpg")], "output must end in .exr or .png"),
        "same output twice": (["render", SCENE, "-o", out, "-o", str(tmp_path / "." / "x.png")],
                              "the same output file is given twice"),
    }


@pytest.mark.parametrize("case", ["empty scene", "unreadable EXR", "missing scene", "output folder cannot be made",
                                  "output is a folder", "unknown extension", "same output twice"])
def test_cli_errors_are_one_line_exit_2_before_rendering(tmp_path, capsys, case, monkeypatch):
    argv, message = _error_cases(tmp_path)[case]

    def no_render(*a, **k):
        raise AssertionError("rendered although the run could not succeed")

    monkeypatch.setattr(pyrt, "render_full", no_render)
    assert cli.main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith("pyrt: error: ") and message in err, err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err
    assert not (tmp_path / "x.png").exists()


def test_cli_debug_shows_the_traceback(tmp_path, capsys):
    argv, _ = _error_cases(tmp_path)["empty scene"]
    assert cli.main(["--debug", *argv]) == 2
    err = capsys.readouterr().err
    assert "Traceback" in err and "pyrt: error: " in err
    assert cli.main([*argv, "--debug"]) == 2                 # after the subcommand too
    assert "Traceback" in capsys.readouterr().err


def _start_render(tmp_path, outputs, spp="16"):
    """A ~5 s render in a subprocess on the NumPy path (its chunks go top down; the compiled path renders this scene
    in well under a second: tests/test_compiled_render.py cancels it); returns it once the progress bar shows that
    chunks are running."""
    errf = open(tmp_path / "stderr.txt", "w+")
    args = [sys.executable, "-m", "pyrt", "render", SCENE, "--spp", spp, "--backend", "numpy"]
    for o in outputs:
        args += ["-o", str(o)]
    p = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=errf, text=True, env=_env(), cwd=tmp_path)
    t_end = time.monotonic() + 60
    while "chunk/s" not in (tmp_path / "stderr.txt").read_text() and time.monotonic() < t_end:
        time.sleep(0.05)
    time.sleep(0.3)
    return p, errf


def test_cli_sigint_writes_the_finished_chunks_and_exits_130(tmp_path):
    exr, png = tmp_path / "a.exr", tmp_path / "a.png"
    p, errf = _start_render(tmp_path, [exr, png])
    t0 = time.monotonic()
    p.send_signal(signal.SIGINT)
    out, _ = p.communicate(timeout=60)
    stopped = time.monotonic() - t0
    err = (tmp_path / "stderr.txt").read_text()
    errf.close()
    assert p.returncode == 130, err
    m = INTERRUPTED.search(err)
    assert m, err
    done, total, pct = map(int, m.groups()[:3])
    filled = m.group(4).startswith("the other pixels")
    black = m.group(4) == "the rest is black"
    assert 0 < done < total and 0 < pct < 100
    assert "Traceback" not in err and f"wrote {exr}" in out and f"wrote {png}" in out
    # not a speed test: the render left would take minutes; stopping well before says the interrupt was honoured
    # (chunks of ~50 ms, a fill pass of at most ~2 s, two small writes; generous for a loaded machine)
    assert stopped < 30.0
    img = pyrt.read_exr(exr)
    assert img.shape == (480, 640, 3)
    rows = img.reshape(480, -1).any(axis=1)
    if filled:                                # the unfinished pixels got one sample each: no black rows
        assert rows.all()
    elif black:                               # chunks are rendered top down: the bottom is black
        assert rows[0] and not rows[-1] and abs(rows.mean() - pct / 100) < 0.05
    else:                                     # the fill's deadline came first: part of the rest is filled
        assert rows[0] and rows.mean() > pct / 100
    from PIL import Image
    assert Image.open(png).size == (640, 480)
    assert sorted(os.listdir(tmp_path)) == ["a.exr", "a.png", "stderr.txt"]   # no temporary file left


def test_cli_second_sigint_aborts_and_keeps_the_previous_file(tmp_path):
    png = tmp_path / "a.png"
    pyrt.write_png(png, np.full((4, 4, 3), 0.5, np.float32))
    before = png.read_bytes()
    p, errf = _start_render(tmp_path, [png])
    p.send_signal(signal.SIGINT)
    time.sleep(0.02)
    p.send_signal(signal.SIGINT)
    p.communicate(timeout=60)
    err = (tmp_path / "stderr.txt").read_text()
    errf.close()
    assert p.returncode == 130, err
    assert "pyrt: aborted" in err and "Traceback" not in err
    assert png.read_bytes() == before
    assert sorted(os.listdir(tmp_path)) == ["a.png", "stderr.txt"]


@pytest.mark.slow
def test_cli_sigterm_is_an_interrupt(tmp_path):
    exr = tmp_path / "a.exr"
    p, errf = _start_render(tmp_path, [exr])
    p.send_signal(signal.SIGTERM)
    p.communicate(timeout=60)
    err = (tmp_path / "stderr.txt").read_text()
    errf.close()
    assert p.returncode == 130 and INTERRUPTED.search(err), err
    assert pyrt.read_exr(exr).shape == (480, 640, 3)


def test_cli_creates_a_missing_output_folder(tmp_path, capsys):
    """README's first command writes into out/ on a fresh checkout: a missing output folder is created."""
    from pyrt.apps.cli import main
    out = tmp_path / "new" / "sub" / "x.png"
    assert main(["render", SCENE, "-o", str(out), "--width", "16", "--height", "12", "--spp", "1"]) == 0
    assert out.is_file()


def _signal_large_render(tmp_path, backend):
    """Start a 1280x960, 256-spp render of the default scene (minutes of work), send SIGINT once its chunks run;
    ``(seconds from the signal to the exit, stderr, exr path)``."""
    exr, png = tmp_path / "big.exr", tmp_path / "big.png"
    errf = open(tmp_path / "stderr.txt", "w+")
    args = [sys.executable, "-m", "pyrt", "render", SCENE, "--width", "1280", "--height", "960", "--spp", "256",
            "--backend", backend, "-o", str(exr), "-o", str(png)]
    p = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=errf, text=True, env=_env(), cwd=tmp_path)
    t_end = time.monotonic() + 120
    while "/s]" not in (tmp_path / "stderr.txt").read_text() and time.monotonic() < t_end:
        time.sleep(0.05)
    time.sleep(1.0)
    t0 = time.monotonic()
    p.send_signal(signal.SIGINT)
    p.communicate(timeout=120)
    stopped = time.monotonic() - t0
    err = (tmp_path / "stderr.txt").read_text()
    errf.close()
    assert p.returncode == 130, err
    return stopped, err, exr


@pytest.mark.slow
def test_cli_first_sigint_ends_a_large_numpy_render_within_seconds(tmp_path):
    """README: the first Ctrl-C ends the command ~2 s later with a readable image (the chunks in progress, the fill
    of the pixels not rendered for at most 1 s, the writes). Before the fill ran in jobs of whole pixel chunks it
    took ~20 s here (9,000 fill jobs of 128 pixels). The bound is generous: the machine may be shared."""
    stopped, err, exr = _signal_large_render(tmp_path, "numpy")
    assert INTERRUPTED.search(err) and "Traceback" not in err, err
    assert stopped < 6.0, (stopped, err)
    img = pyrt.read_exr(exr)
    assert img.shape == (960, 1280, 3) and np.isfinite(img).all() and img.reshape(960, -1).any(axis=1)[0]


@pytest.mark.slow
def test_cli_first_sigint_ends_a_large_compiled_render_within_seconds(tmp_path):
    """The same on the compiled path (it looks at the cancel event every ~0.25 s of kernel work)."""
    stopped, err, exr = _signal_large_render(tmp_path, "compiled")
    assert INTERRUPTED.search(err) and "Traceback" not in err, err
    assert stopped < 6.0, (stopped, err)
    assert pyrt.read_exr(exr).shape == (960, 1280, 3)
