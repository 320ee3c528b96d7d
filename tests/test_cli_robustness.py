"""Messages that name the culprit: pyrt-acne's arguments and the user's offset function (one line, exit 2), a
(vertices, faces) pair that is not one, an OFF header whose counts are too small, an image too large for memory."""
import pathlib
import textwrap

import numpy as np
import pytest

import pyrt
from pyrt.apps import cli
from pyrt.apps.acne.cli import main as acne_main
from pyrt.render import options

SCENE = str(pathlib.Path(__file__).resolve().parents[1] / "assets/default_scene.toml")


@pytest.fixture
def offset_module(tmp_path, monkeypatch):
    (tmp_path / "my_offsets.py").write_text(textwrap.dedent("""
        import numpy as np
        def wrong_shape(surf, w):
            return np.zeros(3)
        def nan(surf, w):
            return np.full((len(w), 3), np.nan)
        NOT_A_FUNCTION = 3
    """))
    monkeypatch.syspath_prepend(str(tmp_path))
    return "my_offsets"


@pytest.mark.parametrize("args, message", [
    (["--offset", "no_such_module_xyz:f"], "--offset no_such_module_xyz:f: cannot import module 'no_such_module_xyz'"),
    (["--offset", "my_offsets:missing"], "--offset my_offsets:missing: module 'my_offsets' has no function 'missing'"),
    (["--offset", "my_offsets:NOT_A_FUNCTION"], "my_offsets.NOT_A_FUNCTION is not a function"),
    (["--offset", "my_offsets"], "--offset must be module:function, got 'my_offsets'"),
    (["--offset", "my_offsets:wrong_shape", "--quick", "--match", "plane", "--size", "16x12"],
     r"offset function wrong_shape: returned an array of shape (3,), expected ("),
    (["--offset", "my_offsets:nan", "--quick", "--match", "plane", "--size", "16x12"],
     "offset function nan: returned"),
    (["--strategies", "robust,bogus"], "--strategies: unknown strategy name(s) ['bogus']"),
    (["--size", "64by48"], "--size must be WxH"),
])
def test_acne_cli_errors_are_one_line_exit_2(offset_module, capsys, args, message):
    assert acne_main(args) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("pyrt-acne: error: ") and message in lines[0], lines


def test_a_render_with_an_offset_function_returning_nan_names_it():
    scene, _ = pyrt.load_dict({"camera": {"width": 6, "height": 4},
                               "materials": {"m": {"type": "lambert"}},
                               "meshes": [{"primitive": "sphere", "material": "m"}],
                               "lights": [{"type": "point", "position": [2, 3, 2], "intensity": 20.0}]})

    def bad_origins(surf, w):
        return np.full((len(w), 3), np.nan)

    with pytest.raises(pyrt.RenderError, match="offset function bad_origins: returned .* non-finite origin"):
        pyrt.render(scene, offset=bad_origins, backend="numpy")


@pytest.mark.parametrize("mesh, message", [
    ([[0, 0, 0], [1, 0, 0], [0, 1, 0]], r"a \(vertices, faces\) pair, got a list of 3 items"),
    (([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, "a"]]), "faces must be integer indices"),
    (([[0, 0, 0], [1, 0, 0], [0, "x", 0]], [[0, 1, 2]]), "vertices and faces must be arrays of numbers"),
])
def test_add_mesh_with_something_that_is_not_a_pair_says_what_it_expected(mesh, message):
    with pytest.raises(pyrt.Error, match=message):
        pyrt.Scene().add_mesh(mesh, pyrt.Lambert(), name="tri")


@pytest.mark.parametrize("text", ["OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 1 2\n",
                                  "OFF\n4 1 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 1 2\n3 0 2 3\n"])
def test_an_off_header_with_too_small_counts_says_so(tmp_path, text):
    (tmp_path / "m.off").write_text(text)
    with pytest.raises(pyrt.AssetError, match=r"m\.off: .*the header \(line 2\) announces \d vertices and 1 faces, "
                                              r"but \d more data line\(s\) follow them"):
        pyrt.load_asset(str(tmp_path / "m.off"))


def test_an_image_too_large_for_memory_is_refused_naming_its_size(tmp_path, capsys, monkeypatch):
    cam = pyrt.Camera(width=100000, height=100000)
    scene = pyrt.Scene(cam)
    scene.add_sphere((0, 0, 0), 1.0, pyrt.Lambert())
    with pytest.raises(pyrt.RenderError, match=r"a 100000x100000 image needs about \d+\.\d GiB of memory"):
        pyrt.render(scene)
    assert cli.main(["render", SCENE, "-o", str(tmp_path / "x.png"), "--width", "100000", "--height", "100000"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "100000x100000 image needs about" in err[0], err
    monkeypatch.setattr(options, "available_memory", lambda: 1000)      # a tiny machine: even 64x48 is too much
    with pytest.raises(pyrt.RenderError, match=r"a 64x48 image .* more than the 0\.0 GiB available"):
        cam.width, cam.height = 64, 48
        pyrt.render(scene, spp=1)
