"""A benchmark's results: printed as JSON, and written atomically where ``--json`` asks."""

from __future__ import annotations

import json
from pathlib import Path


def report(results: dict, path: str | None) -> None:
    """Print ``results`` as indented JSON and, if ``path`` is given, write it there."""
    text = json.dumps(results, indent=2)
    print(text)
    if path:
        from gyroid.io import atomic_write_text

        atomic_write_text(Path(path), text + "\n")
