"""Output files: checked by creating the write's temporary file before the render (``/proc``, ``/sys``), errors that
name the target and not the temporary file, stale temporaries of killed writes removed by the next write (not those
of a write in progress), ``--aovs`` refused without an EXR output."""
import fcntl
import os
import pathlib

import numpy as np
import pytest

import pyrt
from pyrt.apps import cli
from pyrt.apps.common import OutputPathError, check_outputs
from pyrt.core.atomic import ImageWriteError, atomic_write, remove_stale_temporaries

SCENE = str(pathlib.Path(__file__).resolve().parents[1] / "assets/default_scene.toml")
IMG = np.full((4, 4, 3), 0.5, np.float32)


@pytest.mark.parametrize("target", ["/proc/pyrt-test.png", "/sys/pyrt-test.exr"])
def test_an_output_where_no_file_can_be_created_is_refused_before_rendering(target, capsys):
    with pytest.raises(OutputPathError, match=f"cannot write {target}: cannot create a file in its folder"):
        check_outputs([target])
    assert cli.main(["render", SCENE, "-o", target]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"pyrt: error: cannot write {target}") and ".tmp" not in err[0]


def test_a_failed_write_names_the_target_not_the_temporary_file():
    with pytest.raises(ImageWriteError) as e:
        atomic_write("/proc/pyrt-test.png", lambda tmp: None)
    assert "/proc/pyrt-test.png" in str(e.value) and ".tmp" not in str(e.value)


def test_the_next_write_removes_stale_temporaries_but_not_a_write_in_progress(tmp_path):
    target = tmp_path / "x.png"
    stale = [tmp_path / ".x.png.0badf00d.tmp", tmp_path / ".x.png.deadbeef.tmp"]
    for s in stale:
        s.write_bytes(b"half a PNG")                 # what a killed writer leaves
    busy = tmp_path / ".x.png.12345678.tmp"
    busy.write_bytes(b"being written")
    other = tmp_path / ".y.png.deadbeef.tmp"          # another target's: not touched
    other.write_bytes(b"y")
    fd = os.open(busy, os.O_RDONLY)
    fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)    # a writer holding its lock (another open file: a conflict)
    try:
        pyrt.write_png(target, IMG)
    finally:
        os.close(fd)
    assert sorted(p.name for p in tmp_path.iterdir()) == [".x.png.12345678.tmp", ".y.png.deadbeef.tmp", "x.png"]
    assert remove_stale_temporaries(target) == 1      # its writer is gone now
    assert sorted(p.name for p in tmp_path.iterdir()) == [".y.png.deadbeef.tmp", "x.png"]


def test_aovs_without_an_exr_output_is_an_error(tmp_path, capsys):
    with pytest.raises(SystemExit) as e:
        cli.main(["render", SCENE, "-o", str(tmp_path / "x.png"), "--aovs"])
    err = capsys.readouterr().err
    assert e.value.code == 2 and "--aovs writes depth, normal and albedo channels into EXR outputs" in err
    assert not (tmp_path / "x.png").exists()
