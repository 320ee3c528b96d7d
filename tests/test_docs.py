"""README and docs/ stay true to the tree: README within its length, its test command the CI's, every relative link
and image pointing at a file that exists, no development log (stops, issue numbers) in the pages, and every script
in tools/ listed in docs/tools.md with a ``--help``."""
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGES = [ROOT / "README.md"] + sorted((ROOT / "docs").glob("*.md"))
LINK = re.compile(r"\]\(([^)\s]+)\)")
HISTORY = re.compile(r"\b[Ss]top \d+\b|\b[Ii]ssues? \d+\b|\b[Ss]top \d+'s\b")
TOOLS = ROOT / "tools"
#: modules of tools/ that other scripts and the tests import; not run themselves
MODULES = {"scan_shapes.py"}


def test_readme_is_short():
    assert len((ROOT / "README.md").read_text().splitlines()) <= 300


def test_readme_test_command_is_the_ci_command():
    ci = [ln for ln in (ROOT / ".ci" / "run").read_text().splitlines() if "pytest" in ln]
    assert ci == [".venv/bin/python -m pytest -q"]
    blocks = re.findall(r"```bash\n(.*?)```", (ROOT / "README.md").read_text(), re.S)
    assert blocks[1].strip() == ci[0]
    assert "pip install -e '.[test]'" in blocks[0]


@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.name)
def test_relative_links_exist(page):
    missing = []
    for target in LINK.findall(page.read_text()):
        if re.match(r"[a-z]+://|#|mailto:", target):
            continue
        path = target.split("#")[0]
        if path and not (page.parent / path).exists():
            missing.append(target)
    assert not missing, f"{page.name} links to missing files: {missing}"


@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.name)
def test_pages_hold_no_development_log(page):
    hits = [m.group(0) for m in HISTORY.finditer(page.read_text())]
    assert not hits, f"{page.name}: {hits} (git log keeps the history; pages are reference)"


def _scripts():
    for folder in (TOOLS, TOOLS / "experiments"):
        for p in sorted(folder.iterdir()):
            if p.suffix in (".py", ".mjs") and not p.name.startswith("_"):
                yield p


def test_every_tool_is_listed_in_docs_tools_md():
    listed = (ROOT / "docs" / "tools.md").read_text()
    missing = [p.name for p in _scripts() if f"`{p.name}`" not in listed]
    assert not missing, f"docs/tools.md does not list {missing}"
    named = set(re.findall(r"`([a-z_]+\.(?:py|mjs))`", listed))
    assert named <= {p.name for p in _scripts()}, named - {p.name for p in _scripts()}


def test_every_python_tool_has_help():
    """Each script parses its options with argparse (``--help``); ``preview.py`` hands them to ``pyrt-preview``."""
    no_help = [p.name for p in _scripts() if p.suffix == ".py" and p.name not in MODULES
               and "ArgumentParser" not in p.read_text() and "apps.preview import main" not in p.read_text()]
    assert not no_help
