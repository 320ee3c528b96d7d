"""The previewer's phase times: every step of loading and preparing a model has its own phase on the summary line
(decode, tangents, MIP pyramids, the exposure's mask, the compiled tables and the kernel load, the process's start),
none of them counted in the render phase; and one compiled kernel serves every model (no compile per model)."""
from __future__ import annotations

import os
import subprocess
import sys
import time
import types

import numpy as np
import pytest

import pyrt
from pyrt.apps import preview as P
from pyrt.apps.common import process_age
from pyrt.apps.preview.render import PHASES, PREPARE_PHASES
from pyrt.io.assets import load_asset
from pyrt.render import Execution

ROOT = os.path.join(os.path.dirname(__file__), "..")
SAMPLE = os.path.join(ROOT, "assets", "models", "studio_sample.glb")     # five embedded PNG textures
BLOB = os.path.join(ROOT, "assets", "models", "blob.ply")


def _phases(line):
    """``{phase: seconds}`` of a summary line, in the line's order."""
    body = line.split("), ", 1)[1].split(" (total ")[0]
    out = {}
    for part in body.split(", "):
        name, value, unit = part.rsplit(" ", 2)
        assert unit == "s", part
        out["bvh" if name == "BVH" else name] = float(value)
    return out


def test_summary_line_times_decode_tangents_and_mask_in_phase_order(tmp_path, capsys):
    assert P.main([SAMPLE, "-o", str(tmp_path / "v.png"), "--width", "32", "--height", "24", "--spp", "1"]) == 0
    line = [ln for ln in capsys.readouterr().out.splitlines() if "triangles" in ln][0]
    ph = _phases(line)
    assert {"load", "decode", "tangents", "mask", "render", "encode", "write"} <= set(ph), line
    assert list(ph) == [k for k in PHASES if k in ph]           # the order of PHASES
    assert "start" not in ph                                    # main() called from Python: no process start
    total = float(line.split(" (total ")[1].split(" s)")[0])
    assert abs(total - sum(ph.values())) < 0.005 * len(ph) + 1e-9


def test_render_phase_excludes_the_mip_pyramids_and_the_mask(tmp_path):
    """Forked render workers (the NumPy path's: the sample's normal-mapped mesh with vertex tangents would take the
    compiled one): the pyramids are built before the fork, timed as "mip", not as rendering."""
    opts = P.PreviewOptions(width=64, height=48, spp=1, parallel="processes", threads=2, chunk_samples=256,
                            backend="numpy")
    res = P.render_preview(SAMPLE, opts)
    assert res.phases["mip"] > 0 and res.phases["mask"] > 0 and res.phases["decode"] > 0
    assert res.render_time == res.phases["render"] > 0
    assert res.phases["load"] + res.phases["decode"] == pytest.approx(res.load_time)


def test_the_console_script_reports_the_process_start(tmp_path):
    out = tmp_path / "v.png"
    proc = subprocess.run([sys.executable, "-m", "pyrt.apps.preview", BLOB, "-o", str(out), "--width", "16",
                           "--height", "12", "--spp", "1"], capture_output=True, text=True, timeout=300, cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    ph = _phases([ln for ln in proc.stdout.splitlines() if "triangles" in ln][0])
    assert list(ph)[0] == "start" and 0 < ph["start"] < 120


def test_process_age_grows_with_the_process():
    a = process_age()
    time.sleep(0.1)
    b = process_age()
    assert a is not None and a > 0
    assert 0.05 <= b - a < 5.0          # /proc's 10 ms ticks


def test_decode_time_is_part_of_the_load_time():
    a = load_asset(SAMPLE)
    assert 0 < a.decode_time <= a.load_time


def test_tangents_are_timed_apart_from_normals_and_scene():
    t = {}
    load_asset(SAMPLE).add_to_scene(pyrt.Scene(pyrt.Camera()), timings=t)
    assert set(t) == {"normals", "tangents", "scene"} and all(v >= 0 for v in t.values())


def test_prepare_time_sums_the_phases_between_load_and_render():
    phases = {k: 1.0 for k in PHASES}
    rep = P.AssetReport(path="a.glb", name="a_glb", phases=phases)
    assert rep.prepare_time == len(PREPARE_PHASES)
    assert not {"start", "load", "decode", "render", "encode", "write"} & set(PREPARE_PHASES)


def test_load_kernel_times_only_a_kernel_not_loaded_yet():
    from pyrt.integrators import compiled

    calls = []
    cs = types.SimpleNamespace(prepared=types.SimpleNamespace(timings={}))
    loaded = types.SimpleNamespace(overloads={"(int64,)": None})
    compiled.load_kernel(cs, loaded, lambda: calls.append("loaded"))
    assert calls == [] and cs.prepared.timings == {}
    fresh = types.SimpleNamespace(overloads={})
    compiled.load_kernel(cs, fresh, lambda: calls.append("fresh"))
    assert calls == ["fresh"] and cs.prepared.timings["kernel"] >= 0


def _compiled_scenes():
    """Two scenes of different families (constant Lambert + point light; MIP image texture, mirror, directional light
    and a lat-long environment), both on the compiled path."""
    a = pyrt.Scene(pyrt.Camera((0, 1, 5), (0, 0, 0), (0, 1, 0), width=24, height=16, spp=2))
    a.add_sphere((0, 0, 0), 1.0, pyrt.Lambert(0.5))
    a.add_light(pyrt.PointLight((2, 4, 3), intensity=30.0))
    b = pyrt.Scene(pyrt.Camera((0, 1, 6), (0, 0, 0), (0, 1, 0), width=20, height=12, spp=2))
    tex = pyrt.ImageTexture(np.random.default_rng(1).random((64, 64, 3)).astype(np.float32))
    b.add_box((0, 0, 0), (1, 1, 1), pyrt.Lambert(tex))
    b.add_sphere((1.5, 0, 0), 0.5, pyrt.Mirror())
    b.add_light(pyrt.DirectionalLight((1, -1, -1), irradiance=2.0))
    sky = np.random.default_rng(2).random((16, 32, 3)).astype(np.float32)
    pyrt.set_environment(b, pyrt.LatLongEnvironment(sky), lighting="mis")
    return a, b


def test_one_compiled_kernel_serves_scenes_of_every_family():
    """The kernel's argument types do not depend on the scene: a second model of other families renders with the
    kernel already loaded (one specialisation, no compile per model), its tables packed and timed."""
    from pyrt.integrators import compiled_kernel as K

    for scene in _compiled_scenes():
        with pyrt.PreparedScene(scene) as ps:
            res = pyrt.render_full(scene, seed=0, execution=Execution(prepared=ps, progress=False,
                                                                      backend="compiled"))
            assert res.stats.backend == "compiled"
            assert ps.timings["tables"] > 0
    assert len(K.render_tiles.overloads) == 1


def test_bench_tool_reads_every_phase_of_a_summary_line(tmp_path):
    sys.path.insert(0, os.path.join(ROOT, "tools"))
    import bench_preview_phases as B

    line = ("12 triangles, up +y (gltf defines +y as up), start 0.35 s, load 0.02 s, decode 0.10 s, BVH 0.01 s, "
            "mask 0.04 s, render 1.50 s, encode 0.03 s, write 0.00 s (total 2.05 s), 4 spp, exposure -0.74 stops")
    ph = B.parse_phases(line)
    assert list(ph) == ["start", "load", "decode", "bvh", "mask", "render", "encode", "write"]
    assert ph["render"] == 1.5 and B.parse_phases("pyrt-preview: error: x") == {}
    text = B.table({("a.glb", "exe"): [(2.2, {**ph, "exit": 0.15}), (2.4, {**ph, "exit": 0.2})]}, markdown=True)
    assert text.splitlines()[2].startswith("| a.glb | exe | 2 | 2.30 | 0.35 |")
    (tmp_path / "m").mkdir()
    for name in ("b.glb", "a.gltf", "notes.md"):
        (tmp_path / "m" / name).write_text("")
    assert [os.path.basename(p) for p in B.collect([str(tmp_path / "m")])] == ["a.gltf", "b.glb"]
