"""Where a ``pyrt-preview`` process spends its time, phase by phase, over a set of models.

Each run is a fresh ``pyrt-preview MODEL -o out.png`` process (so the interpreter's start, the imports and the kernel
load are paid as a user pays them); its wall clock and the phases of its summary line (``start`` = interpreter start
and imports, ``load``, ``decode``, ``frame``, ``normals``, ``tangents``, ``scene``, ``emitters``, ``geometry``,
``BVH``, ``mip``, ``tables``, ``kernel``, ``mask``, ``render``, ``encode``, ``write``: :data:`pyrt.apps.preview.
render.PHASES`) are recorded, and ``exit`` = wall - the phases' sum (argument parsing, the process's end). Rounds
alternate the order of the models and of the executables; the load average is printed before every run (a shared
machine: compare medians of interleaved runs). Prints the median of every phase per model and executable, as a
plain or Markdown (``--markdown``) table. ``--imports`` adds the heaviest imports of ``import pyrt.apps.preview.cli``
(``python -X importtime``, self time summed per top-level package, medians over ``--rounds`` runs).

Usage::

    python tools/make_textured_model.py /tmp/helmet/helmet.glb
    python tools/bench_preview_phases.py ../shared/khronos-gltf /tmp/helmet/helmet.glb --rounds 3
    python tools/bench_preview_phases.py Duck.glb --preview OTHER/.venv/bin/pyrt-preview --preview .venv/bin/pyrt-preview
"""
from __future__ import annotations

import argparse
import collections
import os
import re
import statistics
import subprocess
import sys
import tempfile
import time

MODEL_EXT = (".glb", ".gltf", ".obj", ".ply", ".stl", ".off")


def collect(paths):
    """Model files of ``paths`` (files, or folders searched recursively; hidden folders skipped), sorted by name."""
    out = []
    for p in paths:
        if os.path.isfile(p):
            out.append(p)
            continue
        for root, dirs, files in os.walk(p):
            dirs[:] = sorted(d for d in dirs if not d.startswith("."))
            out += [os.path.join(root, f) for f in sorted(files) if f.lower().endswith(MODEL_EXT)]
    return sorted(out, key=lambda m: os.path.basename(m).lower())


def parse_phases(line):
    """``{phase: seconds}`` of a ``pyrt-preview`` summary line, in its order (``BVH`` as ``bvh``); {} without one."""
    m = re.search(r"\), (.*?) \(total ", line)
    if not m:
        return {}
    out = {}
    for part in m.group(1).split(", "):
        name, value, unit = part.rsplit(" ", 2)
        if unit == "s":
            out["bvh" if name == "BVH" else name] = float(value)
    return out


def load_average():
    with open("/proc/loadavg") as fh:
        return float(fh.read().split()[0])


def run_once(preview, model, out, extra=()):
    """One ``pyrt-preview`` process: ``(wall s, phases dict, summary line or the error's last line)``."""
    t0 = time.monotonic()
    proc = subprocess.run([preview, model, "-o", out, *extra], capture_output=True, text=True)
    wall = time.monotonic() - t0
    line = next((ln for ln in proc.stdout.splitlines() if " triangles, " in ln), "")
    if proc.returncode != 0 or not line:
        return wall, {}, (proc.stderr.strip().splitlines() or ["failed"])[-1]
    ph = parse_phases(line)
    ph["exit"] = max(0.0, wall - sum(ph.values()))
    return wall, ph, line


def import_profile(python, rounds, top=12):
    """Medians of ``python -X importtime -c 'import pyrt.apps.preview.cli'``: total self time (s) and the ``top``
    top-level packages by self time (``pyrt.X`` kept apart)."""
    totals, per = [], collections.defaultdict(list)
    for _ in range(rounds):
        err = subprocess.run([python, "-X", "importtime", "-c", "import pyrt.apps.preview.cli"], capture_output=True,
                             text=True).stderr
        agg = collections.Counter()
        for ln in err.splitlines():
            parts = ln.split("|")
            if not ln.startswith("import time:") or len(parts) != 3 or "self" in parts[0]:
                continue
            name = parts[2].strip()
            pkg = ".".join(name.split(".")[:2]) if name.startswith("pyrt.") else name.split(".")[0]
            agg[pkg] += int(parts[0].split(":")[1]) / 1e6
        totals.append(sum(agg.values()))
        for k, v in agg.items():
            per[k].append(v)
    med = {k: statistics.median(v + [0.0] * (rounds - len(v))) for k, v in per.items()}
    return statistics.median(totals), sorted(med.items(), key=lambda kv: -kv[1])[:top]


def table(results, markdown):
    """Rows of medians: model, executable, runs, wall, then every phase seen (in the order first seen)."""
    phases = list(dict.fromkeys(k for runs in results.values() for _, ph in runs for k in ph))
    head = ["model", "preview", "runs", "wall", *phases]
    rows = []
    for (model, exe), runs in results.items():
        ok = [(w, ph) for w, ph in runs if ph]
        if not ok:
            rows.append([os.path.basename(model), exe, "0", "failed"] + [""] * len(phases))
            continue
        rows.append([os.path.basename(model), exe, str(len(ok)), f"{statistics.median(w for w, _ in ok):.2f}"]
                    + [f"{statistics.median(ph.get(k, 0.0) for _, ph in ok):.2f}" for k in phases])
    if markdown:
        return "\n".join(["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
                         + ["| " + " | ".join(r) + " |" for r in rows])
    width = [max(len(str(x)) for x in col) for col in zip(head, *rows)]
    return "\n".join("  ".join(str(x).rjust(w) if i >= 2 else str(x).ljust(w) for i, (x, w) in
                               enumerate(zip(r, width))) for r in [head, *rows])


def main(argv=None):
    """Command line (module docstring)."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("models", nargs="+", help="model files or folders (searched recursively)")
    ap.add_argument("--preview", action="append",
                    help="a pyrt-preview executable (repeat to compare checkouts; default: the one beside this Python)")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--extra", default="", help="further pyrt-preview options, e.g. '--spp 1'")
    ap.add_argument("--markdown", action="store_true", help="print the medians as a Markdown table")
    ap.add_argument("--imports", action="store_true", help="also profile the imports (python -X importtime)")
    a = ap.parse_args(argv)
    exes = a.preview or [os.path.join(os.path.dirname(sys.executable), "pyrt-preview")]
    models = collect(a.models)
    if not models:
        ap.error("no models found")
    results = {(m, e): [] for m in models for e in exes}
    with tempfile.TemporaryDirectory() as tmp:
        out = os.path.join(tmp, "out.png")
        for r in range(a.rounds):
            order = [(m, e) for m in models for e in exes]
            for model, exe in (order if r % 2 == 0 else order[::-1]):
                load = load_average()
                wall, ph, line = run_once(exe, model, out, a.extra.split())
                results[(model, exe)].append((wall, ph))
                print(f"round {r + 1} {os.path.basename(model)} {exe} (load {load:.2f}): wall {wall:.2f} s\n    {line}",
                      flush=True)
    print(f"\nmedians (s; exit = wall - the phases' sum), load average now {load_average():.2f}")
    print(table(results, a.markdown))
    if a.imports:
        for exe in exes:      # the Python beside the executable (a venv's bin/), else this one
            python = os.path.join(os.path.dirname(exe), "python")
            total, top = import_profile(python if os.path.exists(python) else sys.executable, a.rounds)
            print(f"\nimports of pyrt.apps.preview.cli ({exe}): {total:.3f} s self time in all; "
                  + ", ".join(f"{k} {v:.3f}" for k, v in top))


if __name__ == "__main__":
    main()
