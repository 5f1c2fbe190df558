"""Run every figure script (after `gyroid demo --out paper_figures/data`)."""

import runpy
from pathlib import Path

HERE = Path(__file__).resolve().parent
for script in sorted(HERE.glob("*.py")):
    if script.name not in {"paths.py", "make_all.py"}:
        print(f"-- {script.name}")
        runpy.run_path(str(script), run_name="__main__")
