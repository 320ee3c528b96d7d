"""Wall time and peak memory of ``pyrt-preview MODEL -o out.png`` at its defaults, interleaved between checkouts.

Issue 14's targets are end-to-end: "a textured model like the 15 k-triangle helmet with five 2048^2 textures
<= 3 s and <= 500 MB" -- the whole process (imports, load, preparation, render, PNG), so each run is a fresh
``pyrt-preview`` process: its wall clock, the peak memory of its process tree (the summed PSS of the preview and
its forked render workers, :mod:`_usage`: what the machine holds) and, beside it, the largest single process's
peak resident set (``ru_maxrss``, what ``/usr/bin/time`` reports; it counts only one of the processes, but
counts the pages they share in full). Rounds alternate the order of the checkouts (A B, B A, ...); the load average is printed before every run (this machine is shared).
Prints every run's summary line and the medians per model and checkout.

Usage::

    python tools/make_textured_model.py /tmp/helmet/helmet.glb
    python tools/bench_textured.py /tmp/helmet/helmet.glb Avocado.gltf --preview /work/main/.venv/bin/pyrt-preview \\
        --preview .venv/bin/pyrt-preview --rounds 3
"""
from __future__ import annotations

import argparse
import os
import re
import statistics
import subprocess
import tempfile
import time

from _usage import TreeMemory


def run_once(preview, model, out, extra=()):
    """One ``pyrt-preview`` run: (wall s, peak tree PSS MB, largest process's max RSS MB, summary line, load)."""
    with open("/proc/loadavg") as fh:
        load = float(fh.read().split()[0])
    with tempfile.TemporaryFile("w+") as log:
        t0 = time.monotonic()
        proc = subprocess.Popen([preview, model, "-o", out, *extra], stdout=log, stderr=subprocess.STDOUT, text=True)
        with TreeMemory(proc.pid) as mem:
            _, status, ru = os.wait4(proc.pid, 0)
        wall = time.monotonic() - t0
        proc.returncode = os.waitstatus_to_exitcode(status)
        log.seek(0)
        err = log.read()
    line = next((ln for ln in err.splitlines() if "triangles," in ln), err.strip().splitlines()[-1] if err else "")
    return wall, mem.peak_mb, ru.ru_maxrss / 1024, line, load


def main(argv=None):
    """Command line (module docstring)."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("models", nargs="+")
    ap.add_argument("--preview", action="append", required=True,
                    help="a pyrt-preview executable (one per checkout, e.g. OTHER/.venv/bin/pyrt-preview); repeat")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--extra", default="", help="further pyrt-preview options, e.g. '--threads 1'")
    a = ap.parse_args(argv)
    extra = a.extra.split()
    res = {}
    with tempfile.TemporaryDirectory() as tmp:
        for r in range(a.rounds):
            order = a.preview if r % 2 == 0 else a.preview[::-1]
            for model in a.models:
                for i, exe in enumerate(order):
                    out = os.path.join(tmp, f"{i}.png")
                    wall, pss, rss, line, load = run_once(exe, model, out, extra)
                    res.setdefault((model, exe), []).append((wall, pss, rss))
                    print(f"round {r + 1} {exe} {os.path.basename(model)} (load {load:.2f}): wall {wall:.2f} s, "
                          f"peak memory {pss:.0f} MB (largest process {rss:.0f} MB)\n    {line}", flush=True)
    print("\nmedians")
    for (model, exe), v in res.items():
        print(f"{os.path.basename(model):28s} {exe:50s} wall {statistics.median(x[0] for x in v):6.2f} s   "
              f"peak memory {statistics.median(x[1] for x in v):5.0f} MB   "
              f"(largest process {statistics.median(x[2] for x in v):5.0f} MB; {len(v)} runs)")


if __name__ == "__main__":
    main()
