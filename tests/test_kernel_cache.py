"""The kernel cache's housekeeping: directories of other kernel sources are removed once unused for
``STALE_DAYS`` days (or at once by ``pyrt compile --prune``), never the one in use nor anything not named like a
kernel directory."""
from __future__ import annotations

import os
import time

import pyrt
from pyrt.apps import cli
from pyrt.integrators import compiled, kernel_cache

DAY = 86400.0
NOW = time.time()


def _kernel_dir(base, digits, days_ago, payload=1000, stamp=True):
    path = base / f"kernels-{digits * 16}"
    (path / "sub").mkdir(parents=True)
    (path / "sub" / "k.nbc").write_bytes(b"x" * payload)
    if stamp:
        (path / kernel_cache.STAMP).write_bytes(b"")
        os.utime(path / kernel_cache.STAMP, (NOW - days_ago * DAY, NOW - days_ago * DAY))
    else:
        os.utime(path, (NOW - days_ago * DAY, NOW - days_ago * DAY))
    return path


def test_prune_removes_only_other_kernel_directories_unused_for_the_stale_days(tmp_path):
    current = _kernel_dir(tmp_path, "a", 400)                   # in use: kept however old its stamp
    recent = _kernel_dir(tmp_path, "b", kernel_cache.STALE_DAYS - 1)
    old = _kernel_dir(tmp_path, "c", kernel_cache.STALE_DAYS + 1, payload=5000)
    unstamped = _kernel_dir(tmp_path, "d", 90, payload=300, stamp=False)      # its own mtime counts
    lookalike = tmp_path / "kernels-old"                         # not 16 hex digits: not ours
    lookalike.mkdir()
    os.utime(lookalike, (0, 0))
    (tmp_path / "notes.txt").write_text("a user's file")

    removed = kernel_cache.prune(path=str(current), now=NOW)

    assert sorted(removed) == sorted([(str(old), 5000), (str(unstamped), 300)])
    assert current.is_dir() and recent.is_dir() and lookalike.is_dir() and (tmp_path / "notes.txt").is_file()
    assert not old.exists() and not unstamped.exists()

    removed = kernel_cache.prune(days=0, path=str(current), now=NOW)       # pyrt compile --prune: every other one
    assert removed == [(str(recent), 1000)]
    assert current.is_dir() and lookalike.is_dir()


def test_mark_used_stamps_the_directory_and_last_used_reads_it(tmp_path):
    path = _kernel_dir(tmp_path, "e", 100)
    assert abs(kernel_cache.last_used(str(path)) - (NOW - 100 * DAY)) < 1.0
    kernel_cache.mark_used(str(path))
    assert kernel_cache.last_used(str(path)) > NOW - 1 * DAY
    kernel_cache.mark_used(str(tmp_path / "missing"))      # an unwritable or vanished directory is not an error


def test_a_compile_prunes_and_a_load_marks_used(tmp_path, monkeypatch):
    """:func:`pyrt.integrators.compiled.announce_compile` stamps the directory in use, and before a compile removes
    stale ones (a warm cache prunes nothing)."""
    current = _kernel_dir(tmp_path, "1", 100)
    old = _kernel_dir(tmp_path, "2", kernel_cache.STALE_DAYS + 5)
    monkeypatch.setattr(kernel_cache, "cache_dir", lambda: str(current))
    monkeypatch.setattr(compiled, "_announced", [])
    (current / "sub" / "compiled_kernel.render_tiles-1.py311.nbi").write_bytes(b"")
    compiled.announce_compile("render_tiles", open(os.devnull, "w"))
    assert old.is_dir()                                     # warm: nothing compiles, nothing pruned
    assert kernel_cache.last_used(str(current)) > NOW - DAY
    compiled.announce_compile("render_pixels", open(os.devnull, "w"))
    assert not old.exists()


def test_cli_compile_prune_reports_what_it_removed(tmp_path, monkeypatch, capsys):
    current = _kernel_dir(tmp_path, "3", 0)
    other = _kernel_dir(tmp_path, "4", 1, payload=3 * 2**20)
    monkeypatch.setattr(pyrt, "compile_kernels", lambda: (0.5, True, str(current)))
    assert cli.main(["compile", "--prune"]) == 0
    out = capsys.readouterr().out
    assert "loaded from the cache" in out and "removed 1 other kernel cache(s), 3 MB" in out
    assert current.is_dir() and not other.exists()
