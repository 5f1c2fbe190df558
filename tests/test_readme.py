"""The README's quick start and the documentation's tour (docs/tour.md), read as one
sequence, hang together: every file or folder a command reads is in the repository or
written by an earlier command's --out, every command and option exists, and (slow) every
command runs as written with the exit code it announces."""

import json
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest
from click.testing import CliRunner

from gyroid.cli import cli

ROOT = Path(__file__).parent.parent
#: What a user runs in order: the README's quick start, then the tour.
WALKED = ("README.md", "docs/tour.md")
README = "\n".join((ROOT / name).read_text() for name in WALKED)


def _commands(with_exit: bool = False) -> list:
    """Every `gyroid ...` command of the README's bash blocks, as argument lists (with the
    exit code a trailing comment ``# exit N ...`` announces, else 0)."""
    commands = []
    for block in re.findall(r"```bash\n(.*?)```", README, flags=re.S):
        text = block.replace("\\\n", " ")
        for line in text.splitlines():
            line, _, comment = line.partition("  #")
            announced = re.match(r"\s*exit (\d)", comment)
            for part in line.strip().split("&&"):
                words = shlex.split(part.strip())
                if words and words[0] == "gyroid":
                    code = int(announced.group(1)) if announced else 0
                    commands.append((words[1:], code) if with_exit else words[1:])
    return commands


def _reads(args: list[str]) -> list[str]:
    """The paths a command reads: positional arguments that look like files or folders, and
    --fit."""
    reads, skip = [], False
    for i, word in enumerate(args):
        if skip:
            skip = False
            continue
        if word.startswith("--"):
            if word == "--fit":
                reads.append(args[i + 1])
            skip = "=" not in word and not word.startswith("--no-")
            continue
        if "/" in word or word.endswith((".csv", ".gz", ".parquet")):
            reads.append(word)
    return reads


def test_every_path_a_readme_command_reads_exists_or_was_written_before():
    commands = _commands()
    assert len(commands) >= 10
    written: list[str] = []
    for args in commands:
        for path in _reads(args):
            made = any(path == out or path.startswith(out.rstrip("/") + "/") for out in written)
            assert made or (ROOT / path).exists(), f"gyroid {' '.join(args)}: reads {path}"
        if "--out" in args:
            written.append(args[args.index("--out") + 1])


def test_every_readme_command_and_option_exists():
    runner = CliRunner()
    for args in _commands():
        words = [w for w in args if not w.startswith("-")]
        group = words[:2] if words[:1] == ["roll"] else words[:1]
        result = runner.invoke(cli, [*group, "--help"])
        assert result.exit_code == 0, f"gyroid {' '.join(group)}: {result.output}"
        for option in (w.split("=")[0] for w in args if w.startswith("--")):
            assert option in result.output, f"gyroid {' '.join(group)} has no {option}"


def test_every_repository_path_the_readme_and_docs_name_exists():
    tops = ("gyroid/", "tests/", "experiments/", "benchmarks/", "paper_figures/", ".ci/",
            "docs/")
    texts = [README, *(p.read_text() for p in (ROOT / "docs").glob("*.md"))]
    words = {w.rstrip(".,:;)") for text in texts for code in re.findall(r"`([^`]+)`", text)
             for w in code.split()}
    paths = {w for w in words if w.startswith(tops)}
    assert paths, "the README names no repository paths"
    missing = sorted(p for p in paths if not (ROOT / p).exists())
    assert not missing, f"the README names paths that are not in the repository: {missing}"


#: The tour, run in a fresh interpreter (argv: a JSON list of [args, expected exit]): a
#: command that kills its process fails this test instead of the pytest-xdist worker.
_TOUR = r"""
import glob, json, re, sys
from gyroid.cli import main
for args, expected in json.loads(sys.argv[1]):
    # the shell would expand a glob such as runs/lot/run_*/bench.csv
    expanded = [m for w in args for m in (sorted(glob.glob(w)) if "*" in w else [w])]
    code = main(expanded)
    if code != expected:
        sys.exit(f"gyroid {' '.join(args)}: exit {code}, the README says {expected}")
for name in sys.argv[2:]:
    for block in re.findall(r"```python\n(.*?)```", open(name).read(), flags=re.S):
        exec(compile(block, name, "exec"), {})
"""


@pytest.mark.slow
def test_the_tour_runs_as_written(tmp_path):
    """Every command of the README's quick start and the tour, top to bottom, in a fresh
    folder, with the exit code the text announces for it (``# exit 3``: a self-check
    refuses the result); the Python blocks too. In its own interpreter, as a user runs it
    (and so that a crash is this test's failure, with its output: workers that had run
    other tests used to abort inside XLA when they ran out of memory mappings,
    :mod:`gyroid._compiled_programs`)."""
    for folder in ("tests", "docs"):  # the repository files the README reads
        (tmp_path / folder).symlink_to(ROOT / folder)
    commands = [[args, expected] for args, expected in _commands(with_exit=True)
                if args[:1] != ["demo"]]  # the first set-up command; test_demo covers it
    done = subprocess.run([sys.executable, "-c", _TOUR, json.dumps(commands),
                           *(str(ROOT / name) for name in WALKED)], cwd=tmp_path,
                          capture_output=True, text=True)
    assert done.returncode == 0, (f"exit {done.returncode}\n{done.stdout[-3000:]}\n"
                                  f"{done.stderr[-3000:]}")
