"""ruff is part of the test command: the tree stays lint-clean."""

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def test_ruff_check_is_clean():
    # The interpreter's own ruff, so an un-activated virtual environment finds it too.
    found = subprocess.run([sys.executable, "-m", "ruff", "--version"], capture_output=True,
                           check=False)
    if found.returncode != 0:
        pytest.fail("ruff is not installed: pip install -e '.[test]'")
    result = subprocess.run([sys.executable, "-m", "ruff", "check", str(ROOT)],
                            capture_output=True, text=True, check=False)
    assert result.returncode == 0, result.stdout + result.stderr
