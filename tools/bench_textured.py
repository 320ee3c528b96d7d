"""Wall time and peak memory of ``pyrt-preview MODEL -o out.png`` at its defaults, interleaved between checkouts.

Issue 14's targets are end-to-end: "a textured model like the 15 k-triangle helmet with five 2048^2 textures
<= 3 s and <= 500 MB" -- the whole process (imports, load, preparation, render, PNG), so each run is a fresh
``pyrt-preview`` process: its wall clock, the peak memory of its process tree (the summed PSS of the preview and
its forked render workers, :mod:`_usage`: what the machine holds) and, beside it, the largest single process's
peak resident set (``ru_maxrss``, what ``/usr/bin/time`` reports; it counts only one of the processes, but
counts the pages they share in full). Rounds alternate the order of the checkouts (A B, B A, ...); the load average is printed before every run (this machine is shared).
Prints every run's summary line and the medians per model and checkout.

``--set FIELD=VALUE,...`` renders through :func:`pyrt.apps.preview.render_preview` with those
:class:`~pyrt.apps.preview.PreviewOptions` fields changed instead of the command line (a fresh ``python`` of the
executable's environment per run, the same imports; for settings the command line does not offer).

Usage::

    python tools/make_textured_model.py /tmp/helmet/helmet.glb
    python tools/bench_textured.py /tmp/helmet/helmet.glb Avocado.gltf --preview /work/main/.venv/bin/pyrt-preview \\
        --preview .venv/bin/pyrt-preview --rounds 3
"""
from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import tempfile
import time

from _usage import TreeMemory


SNIPPET = r"""
import sys
sys.path.insert(0, sys.argv[4])
from preview_variants import parse_fields
from pyrt.apps.preview import PreviewOptions, render_preview
from pyrt.apps.preview.render import format_phases
r = render_preview(sys.argv[1], PreviewOptions(**parse_fields(sys.argv[3])))
open(sys.argv[2], "wb").write(r.files["preview.png"])
print("triangles, options", sys.argv[3], format_phases(r.phases))
"""


def run_once(preview, model, out, extra=(), fields=None):
    """One ``pyrt-preview`` run (with ``fields``, ``--set``'s text: ``render_preview`` in the executable's
    ``python``): (wall s, peak tree PSS MB, largest process's max RSS MB, summary line, load average)."""
    with open("/proc/loadavg") as fh:
        load = float(fh.read().split()[0])
    cmd = [preview, model, "-o", out, *extra]
    if fields:
        cmd = [os.path.join(os.path.dirname(preview), "python"), "-c", SNIPPET, model, out, fields,
               os.path.dirname(os.path.abspath(__file__))]
    with tempfile.TemporaryFile("w+") as log:
        t0 = time.monotonic()
        proc = subprocess.Popen(cmd, stdout=log, stderr=subprocess.STDOUT, text=True)
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
    ap.add_argument("--set", dest="fields", action="append", default=None,
                    help="PreviewOptions fields FIELD=VALUE,... (render_preview instead of the command line); "
                         "repeat to compare settings (each a variant of every --preview)")
    a = ap.parse_args(argv)
    extra = a.extra.split()
    variants = [(exe, f) for exe in a.preview for f in (a.fields or [None])]
    res = {}
    with tempfile.TemporaryDirectory() as tmp:
        for r in range(a.rounds):
            order = variants if r % 2 == 0 else variants[::-1]
            for model in a.models:
                for i, (exe, fields) in enumerate(order):
                    out = os.path.join(tmp, f"{i}.png")
                    wall, pss, rss, line, load = run_once(exe, model, out, extra, fields)
                    name = exe if fields is None else f"{exe} --set {fields}"
                    res.setdefault((model, name), []).append((wall, pss, rss))
                    print(f"round {r + 1} {name} {os.path.basename(model)} (load {load:.2f}): wall {wall:.2f} s, "
                          f"peak memory {pss:.0f} MB (largest process {rss:.0f} MB)\n    {line}", flush=True)
    print("\nmedians")
    for (model, exe), v in res.items():
        print(f"{os.path.basename(model):28s} {exe:60s} wall {statistics.median(x[0] for x in v):6.2f} s   "
              f"peak memory {statistics.median(x[1] for x in v):5.0f} MB   "
              f"(largest process {statistics.median(x[2] for x in v):5.0f} MB; {len(v)} runs)")


if __name__ == "__main__":
    main()
