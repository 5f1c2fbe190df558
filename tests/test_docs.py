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


def test_the_console_links_each_check_to_its_entry_in_the_check_table():
    """``warning: NAME [docs/checks.md#ANCHOR]: ...``: every check the console links, for
    each command (a bench fit's, a compensation's, a pool's, a static noise fit's), has an
    anchor in docs/checks.md, and every anchor there is linked."""
    import re

    from gyroid.cli.report import DOCUMENTED_CHECKS, check_lines
    from gyroid.inference import Check, CheckReport

    anchors = set(re.findall(r'<a id="([a-z_-]+)"></a>',
                             (ROOT / "docs" / "checks.md").read_text()))
    linked = {a for command in DOCUMENTED_CHECKS.values() for a in command.values()}
    assert anchors == linked
    failed = CheckReport((Check("outliers", False, "warning", 1.0, 0.5, "two spikes"),
                          Check("window_bands", False, "error", 0.5, 0.8, "bands missed")))
    assert check_lines(failed, "fit") == [
        "error: window_bands: bands missed",
        "warning: outliers [docs/checks.md#outliers]: two spikes"]
    assert check_lines(failed, "compensate") == [
        "error: window_bands [docs/checks.md#compensate-window_bands]: bands missed",
        "warning: outliers: two spikes"]
    assert check_lines(failed, "noise")[1] == (
        "warning: outliers [docs/checks.md#noise-outliers]: two spikes")


def test_a_long_check_message_is_one_line_of_what_was_found_in_the_console():
    """The console cuts a long warning at its first clause (not inside a parenthesis) and
    says where the full text is; a short one, and an error, stand whole."""
    from gyroid.cli.report import CONSOLE_MESSAGE, check_lines, first_clause
    from gyroid.inference import Check, CheckReport

    found = ("at noise levels this log does not rule out (N_deg_sqrt_h = 0.0049 deg/sqrt(h), "
             "B_deg_h = 0.0025 deg/h) w0's sd is 2.9x its posterior sd (95 % range over such "
             "levels [1.154, 1.233])")
    message = found + ": the intervals rest on the noise levels' priors; give a datasheet"
    assert first_clause(message) == found
    line = check_lines(CheckReport((Check("noise_prior_dependence", False, "warning", 2.9,
                                          2.0, message),)), "fit")[0]
    assert line.endswith(f"{found} ... (in full: fit.json)") and "\n" not in line
    error = check_lines(CheckReport((Check("noise_prior_dependence", False, "error", 29.0,
                                           10.0, message),)), "fit")[0]
    assert error.endswith(message)
    no_clause = "w " * 150  # no clause break: cut at a space before the limit
    assert len(first_clause(no_clause)) <= CONSOLE_MESSAGE
    opened = "a finding of some length " * 5 + "(" + "x " * 100 + ") and more"
    assert first_clause(opened) == ("a finding of some length " * 5).rstrip()
    assert first_clause("short: whole") == "short: whole"


def test_the_readme_is_a_front_page_with_the_two_set_up_commands_first():
    lines = (ROOT / "README.md").read_text().splitlines()
    assert len(lines) <= 300
    first = "\n".join(lines[:8])
    assert "python3 -m pip install -e . && gyroid demo" in first
    assert "python3 -m pip install -e '.[test]' && python3 -m pytest -q" in first
