"""Profile the compiled kernel with ``perf``, by function: renders a bench scene in a loop and writes the kernel's
symbols to ``/tmp/perf-PID.map`` (perf's map of JIT code), so that ``perf report`` names the kernel's functions
(``compiled_lighting.env_stage``, ``compiled_kernel.shade_packet``, ...) instead of ``[JIT] tid``.

    perf record -F 4000 -o /tmp/k.data python tools/kernel_profile.py sky --spp 16 --renders 6
    perf report -i /tmp/k.data --no-children --sort sym

Why a tool: Numba loads the kernel from its cache as object code that no debugger or profiler sees. The object code
is kept when Numba unpickles it, its symbols listed with ``nm`` (binutils) and placed at the address the JIT linker
gave the kernel's entry. Functions that LLVM inlined count as their caller (the stages of ``compiled_env_stage`` run
inside ``env_stage``); ``objdump -d`` of the kept object (``--object``) shows the instructions behind hot addresses.
The kernel must be in the cache (render once first): a compile in this process leaves no object to read. Prints the
CPU nanoseconds per sample of the loop (one thread, Python's start excluded).
"""
from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import tempfile
import time

from numba.core import codegen

_OBJECTS = []
_unserialize = codegen.CPUCodeLibrary._unserialize.__func__


def _keep_object(cls, cg, state):
    lib = _unserialize(cls, cg, state)
    if state[1] == "object":
        _OBJECTS.append((lib, state[2][0]))
    return lib


codegen.CPUCodeLibrary._unserialize = classmethod(_keep_object)

import pyrt  # noqa: E402  (after the hook: the kernel is loaded by the first render)

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import _mitsuba_scenes as ms  # noqa: E402


def readable(symbol):
    """``module.function`` of a Numba mangled symbol (``_ZN4pyrt11integrators17compiled_lighting9env_stage...``)."""
    rest = symbol[symbol.find("_ZN") + 3:] if "_ZN" in symbol else symbol
    parts = []
    while rest and rest[0].isdigit():
        k = len(rest) - len(rest.lstrip("0123456789"))
        n = int(rest[:k])
        parts.append(rest[k:k + n])
        rest = rest[k + n:]
    name = ".".join(parts[-2:]) if parts else symbol
    return name + (" [gufunc]" if symbol.startswith("__gufunc__") else "")


def write_map(path, keep_object=None):
    """The perf map of every kernel library loaded so far; returns the number of symbols written."""
    lines = []
    for lib, obj in _OBJECTS:
        with tempfile.NamedTemporaryFile(suffix=".o", delete=False) as fh:
            fh.write(obj)
        if keep_object:
            with open(keep_object, "wb") as out:
                out.write(obj)
        table = subprocess.run(["nm", "-S", "--defined-only", fh.name], capture_output=True, text=True,
                               check=True).stdout
        os.unlink(fh.name)
        syms = []
        for line in table.splitlines():
            f = line.split()
            if len(f) == 4 and f[2] in "tTW":
                syms.append((int(f[0], 16), int(f[1], 16), f[3]))
        base = None
        for off, _size, name in syms:       # the entry the JIT linker placed (a weak symbol may resolve elsewhere)
            if re.match(r"_ZN4pyrt", name):
                try:
                    addr = lib.get_pointer_to_function(name)
                except Exception:           # noqa: BLE001 (a symbol the linker does not export)
                    addr = 0
                if addr:
                    base = addr - off
                    break
        if base is None:
            continue
        lines += [f"{base + off:x} {size:x} {readable(name)}" for off, size, name in syms]
    with open(path, "w") as fh:
        fh.write("\n".join(lines) + "\n")
    return len(lines)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("scene", choices=sorted(ms.SCENES), help="a scene of tools/bench_mitsuba.py")
    ap.add_argument("--spp", type=int, default=16)
    ap.add_argument("--renders", type=int, default=6)
    ap.add_argument("--target-error", type=float, default=None,
                    help="render adaptively to this relMSE instead (the adaptive passes' kernel entry)")
    ap.add_argument("--object", default=None, help="also write the kernel's object code here (for objdump -d)")
    args = ap.parse_args(argv)
    scene = ms.SCENES[args.scene][0](tempfile.mkdtemp())
    prepared = pyrt.PreparedScene(scene)

    def render(spp, seed):
        sampling = None if args.target_error is None or spp == 1 else pyrt.Sampling(
            target_error=args.target_error, time_budget=600.0, max_spp=4096)
        return pyrt.render_full(scene, spp=None if sampling else spp, seed=seed, sampling=sampling,
                                execution=pyrt.Execution(prepared=prepared, progress=False, threads=1),
                                **ms.PYRT_OPTIONS)

    render(1, 0)
    if args.target_error is not None:
        render(args.spp, 0)         # the adaptive entry loaded before the map is written
    n = write_map(f"/tmp/perf-{os.getpid()}.map", args.object)
    if not n:
        raise SystemExit("kernel_profile: error: no kernel loaded from the cache (render once first, then profile)")
    t, samples = time.process_time(), 0
    for seed in range(args.renders):
        samples += render(args.spp, seed).samples_done
    what = f"at {args.spp} spp" if args.target_error is None else f"adaptive to {args.target_error:g}"
    per = (time.process_time() - t) / samples
    print(f"{args.scene}: {per * 1e9:.1f} CPU ns per sample ({args.renders} renders {what}, one thread, "
          f"{samples / args.renders:.0f} samples a render); {n} kernel symbols in /tmp/perf-{os.getpid()}.map")


if __name__ == "__main__":
    main()
