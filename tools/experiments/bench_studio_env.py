"""Cost of the previewer's studio environment: render time with and without it, interleaved, medians.

For each model: the :class:`pyrt.apps.preview.PreviewScene` is built once per setting (``studio_env`` on /
off; building it, with the studio's prefiltered maps on first use, is timed separately as "setup"), then
single views at the previewer's defaults (640x480, 4 spp, glossy integrator) are rendered alternately
on, off, off, on, ... ``--rounds`` times; the medians and their ratio are printed with the machine's load
(``os.getloadavg``) before and after, since the machine may be shared.

Usage: python tools/experiments/bench_studio_env.py [MODEL ...] [--rounds 5] [--width 640 --height 480]
       (default models: the example glTF and three Khronos samples under ../shared/khronos-gltf if present)
"""
from __future__ import annotations

import argparse
import os
import platform
import statistics
import time

import numpy as np

from pyrt.apps import preview as P
from pyrt.io.assets import load_asset

HERE = os.path.dirname(os.path.abspath(__file__))
KHRONOS = os.path.join(HERE, "..", "..", "shared", "khronos-gltf")
DEFAULT_MODELS = [os.path.join(HERE, "..", "assets", "models", "studio_sample.glb")] + [
    os.path.join(KHRONOS, m, m + ".glb") for m in ("Duck", "CesiumMilkTruck", "SpecularTest")]


def _scene(asset, on, w, h):
    t = time.perf_counter()
    ps = P.PreviewScene(asset, P.PreviewOptions(width=w, height=h, studio_env=on, exposure=0.0))
    if ps.environment is not None:              # build the lazily made tables now, outside the timed renders
        d = np.array([[0.0, 1.0, 0.0]])
        ps.environment.prefiltered(d, np.array([0.3]))
        ps.environment.irradiance_sh(d)
    return ps, time.perf_counter() - t


def main(argv=None):
    """Run the benchmark and print one line per model (median seconds on / off and the ratio)."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("models", nargs="*")
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--width", type=int, default=640)
    ap.add_argument("--height", type=int, default=480)
    a = ap.parse_args(argv)
    models = [m for m in (a.models or DEFAULT_MODELS) if os.path.exists(m)]
    print(f"{platform.node()} {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
          f"load {os.getloadavg()[0]:.1f}; {a.width}x{a.height}, 4 spp, {a.rounds} interleaved rounds")
    print(f"{'model':<20} {'setup on':>9} {'on s':>7} {'off s':>7} {'on/off':>7}")
    for path in models:
        asset = load_asset(path)
        (on, t_on), (off, _) = _scene(asset, True, a.width, a.height), _scene(asset, False, a.width, a.height)
        times = {True: [], False: []}
        try:
            for r in range(a.rounds):
                for flag in ((True, False) if r % 2 == 0 else (False, True)):
                    ps = on if flag else off
                    t = time.perf_counter()
                    ps.render_view(ps.azimuth)
                    times[flag].append(time.perf_counter() - t)
        finally:
            on.close()
            off.close()
        m_on, m_off = statistics.median(times[True]), statistics.median(times[False])
        print(f"{os.path.basename(path):<20} {t_on:9.2f} {m_on:7.2f} {m_off:7.2f} {m_on / m_off:7.2f}")
    print(f"load after: {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
