"""The library under a type checker: basedpyright in basic mode on src/gyroid (its settings
in pyproject.toml) finds no error and no warning. Where a third party's annotations are
narrower than its documented use (blackjax's protocols, NumPy's stub of ``qr(mode="r")``,
dask's ``dashboard_address=None``), the line says so and ignores that one rule only.
The checker's version is pinned in the test extras: a new one reads differently."""

import importlib.util
import json
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.slow
def test_the_library_type_checks():
    if importlib.util.find_spec("basedpyright") is None:
        pytest.skip("basedpyright is not installed: pip install -e '.[test]'")
    run = subprocess.run([sys.executable, "-m", "basedpyright", "--outputjson"], cwd=ROOT,
                         capture_output=True, text=True, timeout=600)
    report = json.loads(run.stdout)
    library = ROOT / "src" / "gyroid"
    found = [f"{Path(d['file']).resolve().relative_to(library)}:"
             f"{d['range']['start']['line'] + 1}: {d['message'].splitlines()[0]}"
             for d in report["generalDiagnostics"]  # this checkout's, not an installed copy's
             if d["severity"] in ("error", "warning")
             and Path(d["file"]).resolve().is_relative_to(library)]
    assert report["summary"]["filesAnalyzed"] > 150
    assert not found, "basedpyright (basic) finds:\n" + "\n".join(found)


def test_every_ignored_type_rule_is_named_on_its_line():
    """A ``pyright: ignore`` silences one named rule on one line, never a whole line's
    findings (a new error there would go unseen)."""
    bare = [f"{path.relative_to(ROOT)}:{number}"
            for path in (ROOT / "src" / "gyroid").rglob("*.py")
            for number, line in enumerate(path.read_text().splitlines(), start=1)
            if "pyright: ignore" in line and "pyright: ignore[" not in line]
    assert not bare, f"ignores without a rule: {bare}"
