"""Every location the figure scripts use.

The scripts only read saved results: run `gyroid demo --out paper_figures/data` first
(about a minute); figures go to `paper_figures/figures/` as PNG and PDF.
"""

from pathlib import Path

ROOT = Path(__file__).resolve().parent
DATA = ROOT / "data"
FIGURES = ROOT / "figures"


def data(*parts: str) -> Path:
    path = DATA.joinpath(*parts)
    if not path.exists():
        raise SystemExit(f"{path} is missing: run `gyroid demo --out {DATA}` first")
    return path


def figure(stem: str) -> Path:
    FIGURES.mkdir(parents=True, exist_ok=True)
    return FIGURES / stem
