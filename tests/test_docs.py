"""The documentation site builds with every warning an error (a broken link, a page left
out of the navigation, an API entry whose object moved), as a user's `mkdocs build` would;
and the README stays a front page."""

import importlib.util
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def test_the_documentation_site_builds_with_warnings_as_errors(tmp_path):
    if importlib.util.find_spec("mkdocs") is None:
        pytest.skip("mkdocs is not installed: pip install -e '.[docs]'")
    built = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir",
                            str(tmp_path / "site")], cwd=ROOT, capture_output=True, text=True,
                           timeout=300)
    assert built.returncode == 0, built.stderr[-3000:]
    for page in ("index.html", "tour/index.html", "checks/index.html", "api/index.html"):
        assert (tmp_path / "site" / page).exists(), page
    assert "fit_log" in (tmp_path / "site" / "api" / "index.html").read_text()


def test_the_readme_is_a_front_page_with_the_two_set_up_commands_first():
    lines = (ROOT / "README.md").read_text().splitlines()
    assert len(lines) <= 300
    first = "\n".join(lines[:8])
    assert "python3 -m pip install -e . && gyroid demo" in first
    assert "python3 -m pip install -e '.[test]' && python3 -m pytest -q" in first
