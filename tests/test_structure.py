"""The inference core's shape: every fit's result shares one base, few places outside noise/
choose by the noise model, writers are chosen by type, optimisers run from one module."""

import ast
import collections
from pathlib import Path

from gyroid.allan._fit import NoiseFit
from gyroid.allan._model_fit import NoiseModelFit
from gyroid.bench import BenchFit
from gyroid.inference import FitResult
from gyroid.pool import PoolFit
from gyroid.roll import RollFit

SOURCE = Path(__file__).resolve().parents[1] / "src" / "gyroid"


def test_every_fit_result_shares_one_base():
    for kind in (BenchFit, RollFit, PoolFit, NoiseFit, NoiseModelFit):
        assert issubclass(kind, FitResult), kind
        assert not getattr(kind.summary, "__isabstractmethod__", False)


def test_every_problem_builds_its_result_which_reads_it_by_its_concrete_type():
    """A result reads its problem's own attributes (the log, the model, the segments): it is
    a ``Fit`` of the problem's concrete type, which a type checker follows (typed as
    AbstractProblem, 69 reads were of attributes the abstract class never declares). The
    problem builds it (``result``, typed with the concrete result), so ``fit`` needs no
    table of kinds; the result names its problem for the type checker only."""
    import inspect
    import typing

    from gyroid.allan import NoiseProblem
    from gyroid.bench import BenchProblem
    from gyroid.inference._result import Fit
    from gyroid.pool import PoolProblem
    from gyroid.roll import RollProblem

    for result, problem in ((BenchFit, BenchProblem), (RollFit, RollProblem),
                            (PoolFit, PoolProblem), (NoiseModelFit, NoiseProblem)):
        base = next(b for b in result.__orig_bases__ if typing.get_origin(b) is Fit)
        (argument,) = typing.get_args(base)
        assert argument == typing.ForwardRef(problem.__name__), result
        assert (f"from {problem.__module__} import {problem.__name__}"
                in inspect.getsource(inspect.getmodule(result))), result
        assert typing.get_type_hints(problem.result)["return"] is result, problem


#: Places outside noise/ that choose by the noise model rather than through it: a model's or
#: a term's name, ``"auto"``, or a kind flag (``.correlated``, ``.wanders``, ``.codes``).
#: Issue 60 asks for at most 5; most of these choose between the bench posterior's forms
#: (sufficient statistics or a filter). The counts only go down.
KIND_SITES = {
    "bench/_density.py": 1,
    "bench/_options.py": 2,  # the default, "auto"; a burst log under a wander
    "bench/_problem.py": 5,
    "inference/_collapsed.py": 1,
    "bench/_rate_window.py": 1,
    "bench/_rate_window_marginal.py": 1,
    "workflows/_discrepancy.py": 1,
}


def test_few_places_outside_noise_choose_by_the_noise_model():
    """Outside noise/, cli/ (whose --help lists the choices without importing JAX) and
    plotting/ (where "white" is a colour), code reads the noise model through its
    interface: each place that names a model or term, spells "auto" or reads a kind flag
    is counted, per file, against :data:`KIND_SITES`."""
    from gyroid.noise import NOISE_MODELS, _terms

    terms = {name for name, value in vars(_terms).items()
             if isinstance(value, type) and issubclass(value, _terms.AbstractNoiseTerm)}
    flags = {"correlated", "wanders", "codes", "on_block_means"}
    found = collections.Counter()
    for path in SOURCE.rglob("*.py"):
        relative = path.relative_to(SOURCE)
        if relative.parts[0] in ("noise", "cli", "plotting"):
            continue
        for node in ast.walk(ast.parse(path.read_text())):
            if ((isinstance(node, ast.Constant) and isinstance(node.value, str)
                 and (node.value in NOISE_MODELS or node.value == "auto"))
                    or (isinstance(node, ast.Attribute) and node.attr in flags)
                    or (isinstance(node, ast.Name) and node.id in terms)):
                found[relative.as_posix()] += 1
    over = {f: (n, KIND_SITES.get(f, 0)) for f, n in found.items() if n > KIND_SITES.get(f, 0)}
    assert not over, f"more places choose by the noise model than listed: {over}"
    assert sum(found.values()) <= sum(KIND_SITES.values())


def test_writers_are_chosen_by_type_not_by_a_class_path():
    text = (SOURCE / "reports" / "_write.py").read_text()
    assert "__qualname__" not in text and "gyroid.bench._fit.BenchFit\"" not in text


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
