"""What the compiled path costs before it renders: kernel compilation (cold cache) and loading (warm cache).

Usage::

    python tools/bench_compile.py [--rounds 2] [--scenes default,diffuse,shadowed,mirror_glass,sky]

Each measurement is a fresh Python process with its own kernel cache directory (``XDG_CACHE_HOME`` pointed at a
temporary folder, ``NUMBA_CACHE_DIR`` unset): *cold* starts from an empty cache (the kernel is compiled), *warm*
from the cache the cold run left (the kernel is loaded). In each process: ``import pyrt``, then the scene's first
compiled render at 1 spp (compile or load + render), then a second identical render (render alone); the overhead of
the first render is the difference. One kernel serves every scene (the scene is data: flat tables), so the cold
compile is paid once per installation and pyrt version, not per scene: the per-scene rows show that. Prints a
markdown table; rounds are interleaved (cold, warm, cold, warm, ...) and medians reported, with the machine's load.
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))

_CHILD = r"""
import json, sys, time
t0 = time.perf_counter()
import pyrt
t1 = time.perf_counter()
sys.path.insert(0, {tools!r})
import _mitsuba_scenes as ms
scene = ms.SCENES[{scene!r}][0]({work!r})
kw = dict(spp=1, seed=0, progress=False, backend="auto", **ms.PYRT_OPTIONS)
t2 = time.perf_counter()
r = pyrt.render_full(scene, **kw)
t3 = time.perf_counter()
pyrt.render_full(scene, **kw)
t4 = time.perf_counter()
print(json.dumps({{"import": t1 - t0, "first": t3 - t2, "second": t4 - t3, "backend": r.stats.backend}}))
"""


def run(scene, cache, work):
    """One child process: its timings (dict)."""
    env = dict(os.environ, XDG_CACHE_HOME=cache)
    env.pop("NUMBA_CACHE_DIR", None)
    code = _CHILD.format(tools=HERE, scene=scene, work=work)
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--rounds", type=int, default=2)
    ap.add_argument("--scenes", default="default,diffuse,shadowed,mirror_glass,sky")
    args = ap.parse_args(argv)
    scenes = [s for s in args.scenes.split(",") if s]
    rows = {}
    with tempfile.TemporaryDirectory() as tmp:
        work = os.path.join(tmp, "work")
        for rnd in range(args.rounds):
            for scene in scenes:
                cache = os.path.join(tmp, f"cache-{rnd}-{scene}")
                cold = run(scene, cache, work)
                warm = run(scene, cache, work)
                rows.setdefault(scene, []).append((cold, warm))
                print(f"round {rnd + 1} {scene}: cold first {cold['first']:.2f} s, warm first {warm['first']:.3f} s, "
                      f"render {warm['second']:.3f} s ({cold['backend']}), load {os.getloadavg()[0]:.1f}",
                      file=sys.stderr, flush=True)
    med = statistics.median
    print("| scene | path | import pyrt s | cold: first render s | warm: first render s | render alone s | "
          "compile (cold - render) s | load from cache (warm - render) s |")
    print("|---|---|---:|---:|---:|---:|---:|---:|")
    for scene, rr in rows.items():
        imp = med(w["import"] for _c, w in rr)
        cf, wf = med(c["first"] for c, _w in rr), med(w["first"] for _c, w in rr)
        rend = med(w["second"] for _c, w in rr)
        print(f"| {scene} | {rr[0][0]['backend']} | {imp:.2f} | {cf:.2f} | {wf:.3f} | {rend:.3f} | {cf - rend:.1f} | "
              f"{wf - rend:.3f} |")
    print(f"\n{args.rounds} rounds, medians; {os.cpu_count()} cores, load {os.getloadavg()[0]:.1f} at the end.")
    return 0


if __name__ == "__main__":
    sys.exit(main())
