"""The inference core's shape (issue 41): every fit's result shares one base, noise models
are objects whose names one library file spells, and writers are chosen by type."""

import ast
from pathlib import Path

from gyroid.inference import BenchFit, FitResult, PoolFit, RollFit
from gyroid.inference._noise_fit import NoiseFit
from gyroid.inference._noise_model_fit import NoiseModelFit
from gyroid.noise import NOISE_MODELS

SOURCE = Path(__file__).resolve().parents[1] / "src" / "gyroid"


def test_every_fit_result_shares_one_base():
    for kind in (BenchFit, RollFit, PoolFit, NoiseFit, NoiseModelFit):
        assert issubclass(kind, FitResult), kind
        assert not getattr(kind.summary, "__isabstractmethod__", False)


def test_every_result_reads_its_problem_by_its_concrete_type():
    """A result reads its problem's own attributes (the log, the model, the segments): its
    ``problem`` field has the problem's concrete type, which a type checker follows (typed
    as AbstractProblem, 69 reads were of attributes the abstract class never declares)."""
    import typing

    from gyroid.inference import BenchProblem, PoolProblem, RollProblem
    from gyroid.inference._fit import RESULTS

    for result, problem in ((BenchFit, BenchProblem), (RollFit, RollProblem),
                            (PoolFit, PoolProblem)):
        assert typing.get_type_hints(result)["problem"] is problem, result
    assert set(RESULTS) >= {BenchProblem, RollProblem, PoolProblem}


def test_one_library_file_spells_the_noise_models_names():
    """Outside cli/ (whose --help lists the choices without importing JAX) and plotting/
    (where "white" is a colour), the names appear as string constants in noise/_kinds.py
    only: everything else reads the noise model through its interface."""
    spelling = set()
    for path in SOURCE.rglob("*.py"):
        relative = path.relative_to(SOURCE)
        if relative.parts[0] in ("cli", "plotting"):
            continue
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Constant) and node.value in NOISE_MODELS:
                spelling.add(str(relative))
    assert spelling == {"noise/_kinds.py"}, spelling


def test_writers_are_chosen_by_type_not_by_a_class_path():
    text = (SOURCE / "reports" / "_write.py").read_text()
    assert "__qualname__" not in text and "gyroid.inference._bench_fit.BenchFit\"" not in text


def test_optimisers_are_run_from_the_mode_module_only():
    """Every optimiser the inference runs is a finder of inference/_mode.py (one answer, one
    solver message, one inverse); noise/ sits below inference/, so the rate-error process's
    own match is the one other place. An import of optimistix or scipy.optimize anywhere
    else is a second mode-finder."""
    allowed = {"inference/_mode.py", "noise/_rate_error_process.py"}
    found = set()
    for path in SOURCE.rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            names = ([alias.name for alias in node.names] if isinstance(node, ast.Import)
                     else [f"{node.module}.{a.name}" for a in node.names]
                     if isinstance(node, ast.ImportFrom) and node.module else [])
            if any(n.split(".")[0] == "optimistix" or n.startswith("scipy.optimize")
                   for n in names):
                found.add(str(path.relative_to(SOURCE)))
    assert found <= allowed, found - allowed
    assert "inference/_mode.py" in found


#: A module longer than this does more than one job; a function longer, more than one step.
MAX_MODULE_LINES = 400
MAX_FUNCTION_LINES = 80


def test_modules_and_functions_stay_short():
    long = []
    for path in sorted(SOURCE.rglob("*.py")):
        text = path.read_text()
        relative = path.relative_to(SOURCE)
        if len(text.splitlines()) > MAX_MODULE_LINES:
            long.append(f"{relative}: {len(text.splitlines())} lines")
        for node in ast.walk(ast.parse(text)):
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
                length = node.end_lineno - node.lineno + 1
                if length > MAX_FUNCTION_LINES:
                    long.append(f"{relative}:{node.lineno} {node.name}: {length} lines")
    assert not long, "\n".join(long)


def test_the_command_line_only_parses_calls_and_prints():
    """No command writes a file or stages an output folder itself: the pipeline does."""
    writing = []
    for path in sorted((SOURCE / "cli").glob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            name = (node.func.attr if isinstance(node, ast.Call)
                    and isinstance(node.func, ast.Attribute) else
                    node.func.id if isinstance(node, ast.Call)
                    and isinstance(node.func, ast.Name) else None)
            if name in ("output_dir", "write_text", "write_bytes", "write", "save"):
                writing.append(f"{path.name}:{node.lineno} {name}")
    assert not writing, "\n".join(writing)
