"""Wall time and peak memory of ``pyrt-preview MODEL -o out.png`` at its defaults, interleaved between checkouts.

Issue 14's targets are end-to-end: "a textured model like the 15 k-triangle helmet with five 2048^2 textures
<= 3 s and <= 500 MB" -- the whole process (imports, load, preparation, render, PNG), so each run is a fresh
``pyrt-preview`` process under ``/usr/bin/time -v`` (wall clock, maximum resident set size). Rounds alternate the
order of the checkouts (A B, B A, ...); the load average is printed before every run (this machine is shared).
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


def run_once(preview, model, out, extra=()):
    """One ``pyrt-preview`` run under ``/usr/bin/time -v``: (wall s, peak RSS MB, summary line, load average)."""
    with open("/proc/loadavg") as fh:
        load = float(fh.read().split()[0])
    proc = subprocess.run(["/usr/bin/time", "-v", preview, model, "-o", out, *extra], capture_output=True, text=True)
    err = proc.stderr + proc.stdout
    m = re.search(r"Elapsed \(wall clock\) time \(h:mm:ss or m:ss\): (?:(\d+):)?(\d+):([\d.]+)", err)
    wall = (int(m.group(1) or 0) * 3600 + int(m.group(2)) * 60 + float(m.group(3))) if m else float("nan")
    m = re.search(r"Maximum resident set size \(kbytes\): (\d+)", err)
    rss = int(m.group(1)) / 1024 if m else float("nan")
    line = next((ln for ln in err.splitlines() if "triangles," in ln), err.strip().splitlines()[-1] if err else "")
    return wall, rss, line, load


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
                    wall, rss, line, load = run_once(exe, model, out, extra)
                    res.setdefault((model, exe), []).append((wall, rss))
                    print(f"round {r + 1} {exe} {os.path.basename(model)} (load {load:.2f}): wall {wall:.2f} s, "
                          f"peak RSS {rss:.0f} MB\n    {line}", flush=True)
    print("\nmedians")
    for (model, exe), v in res.items():
        print(f"{os.path.basename(model):28s} {exe:50s} wall {statistics.median(x[0] for x in v):6.2f} s   "
              f"peak RSS {statistics.median(x[1] for x in v):5.0f} MB   ({len(v)} runs)")


if __name__ == "__main__":
    main()
