"""gyroid's packages are layers that point down, and importing gyroid has no side effects."""

import ast
import subprocess
import sys
from pathlib import Path

import pytest

SOURCE = Path(__file__).resolve().parents[1] / "src" / "gyroid"

#: Each package may import from its own package and from packages of a lower rank only.
RANKS = {
    "_compile_cache": -1, "_compiled_programs": -1, "_exported": -0.5, "errors": 0,
    "_config": 0,
    "models": 1,
    "noise": 1.5,
    "io": 2,
    "simulation": 3, "inference": 3,
    "bench": 3.2, "roll": 3.2, "allan": 3.2,  # one kind of fit each, on inference
    "pool": 3.4,  # built from each run's bench fit
    "workflows": 4, "papers": 4,
    "plotting": 5,
    "reports": 6,
    "pipeline": 7,
    "cli": 8, "__main__": 9,
}


def _package(module: str) -> str:
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else ""


def _imports() -> list[tuple[str, str, int]]:
    """(importing module, imported gyroid module, line) for every import in the source,
    inside functions too (a deferred import is still a dependency)."""
    found = []
    for path in sorted(SOURCE.rglob("*.py")):
        parts = path.relative_to(SOURCE.parent).with_suffix("").parts
        module = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
                names = [node.module]
            elif isinstance(node, ast.Import):
                names = [alias.name for alias in node.names]
            else:
                continue
            found += [(module, name, node.lineno) for name in names
                      if name == "gyroid" or name.startswith("gyroid.")]
    return found


def test_every_import_points_down_the_layers():
    upward = []
    for module, imported, line in _imports():
        source, target = _package(module), _package(imported)
        if module == "gyroid" or source == target:
            continue  # the top-level package re-exports lazily, by name
        assert source in RANKS, f"{module}: package {source!r} has no layer"
        assert target in RANKS, f"{imported}: package {target!r} has no layer"
        if RANKS[target] >= RANKS[source]:
            upward.append(f"{module}:{line} imports {imported}")
    assert not upward, "imports that do not point down:\n" + "\n".join(upward)


def test_generic_inference_imports_no_kind_of_fit():
    """``inference/`` fits any problem: a kind's package (bench, roll, pool, allan) builds on
    it, and a new kind adds a package without a line changed there (its problem builds its
    own result). The ranks above say so; this names the rule where it would break."""
    kinds = {"bench", "roll", "pool", "allan"}
    found = [f"{m}:{line} imports {i}" for m, i, line in _imports()
             if _package(m) == "inference" and _package(i) in kinds]
    assert not found, "\n".join(found)
    assert all(_package(m) != "inference" for m, i, _ in _imports()
               if _package(i) in kinds)


def test_the_layering_test_sees_deferred_imports():
    imports = _imports()
    assert len(imports) > 200
    assert any(m.startswith("gyroid.cli") and i.startswith("gyroid.bench")
               for m, i, _ in imports)


@pytest.mark.parametrize("probe", [
    "import sys, gyroid; bad = [m for m in ('matplotlib', 'dask', 'jax', 'arviz', 'emcee') "
    "if m in sys.modules]; assert not bad, bad",
    "import gyroid; print(sorted(n for n in gyroid.__all__ if n not in dir(gyroid)))",
])
def test_importing_gyroid_loads_nothing_heavy_and_dir_lists_every_public_name(probe):
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True,
                         check=True)
    assert out.stdout.strip() in ("", "[]"), out.stdout


def _type_only(tree: ast.Module) -> set[int]:
    """The ids of import nodes under ``if TYPE_CHECKING:`` (read by a type checker only)."""
    found = set()
    for node in ast.walk(tree):
        if (isinstance(node, ast.If) and isinstance(node.test, ast.Name)
                and node.test.id == "TYPE_CHECKING"):
            found |= {id(n) for stmt in node.body for n in ast.walk(stmt)
                      if isinstance(n, ast.Import | ast.ImportFrom)}
    return found


def _module_graph() -> dict[str, set[str]]:
    """Which gyroid module imports which, module by module (``from package import name``
    counted as the submodule ``name`` when there is one, else the package), every import
    counted: deferred and relative ones too, and ``TYPE_CHECKING`` ones that leave their
    package. A ``TYPE_CHECKING`` import inside one package is left out: it runs never, and
    it is how a kind's result and checks read the problem that builds them by its concrete
    type (the problem imports them; they name it for the type checker)."""
    modules = {}
    for path in sorted(SOURCE.rglob("*.py")):
        parts = path.relative_to(SOURCE.parent).with_suffix("").parts
        package = parts[-1] == "__init__"
        modules[".".join(parts[:-1] if package else parts)] = (path, package)

    def known(name: str) -> str:
        while name and name not in modules:
            name = name.rpartition(".")[0]
        return name

    graph: dict[str, set[str]] = {m: set() for m in modules}
    for module, (path, package) in modules.items():
        here = module if package else module.rpartition(".")[0]
        tree = ast.parse(path.read_text())
        type_only = _type_only(tree)
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom):
                base = node.module or ""
                if node.level:
                    anchor = here
                    for _ in range(node.level - 1):
                        anchor = anchor.rpartition(".")[0]
                    base = ".".join(p for p in (anchor, node.module) if p)
                targets = [f"{base}.{a.name}" if f"{base}.{a.name}" in modules else base
                           for a in node.names]
            elif isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            else:
                continue
            targets = {known(t) for t in targets if t.startswith("gyroid")} - {module, ""}
            if id(node) in type_only:
                targets = {t for t in targets if _package(t) != _package(module)}
            graph[module] |= targets
    return graph


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    found: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        for w in sorted(graph[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return found


def test_no_module_imports_itself_through_others():
    cycles = _cycles(_module_graph())
    assert not cycles, "import cycles (break one edge of each):\n" + "\n".join(
        " <-> ".join(c) for c in cycles)


def test_the_cycle_test_finds_a_cycle_and_reads_relative_and_deferred_imports():
    assert _cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]
    graph = _module_graph()
    assert "gyroid.inference._problem" in graph["gyroid.inference._fit"]
    assert "gyroid.inference._emcee" in graph["gyroid.bench._problem"]
    assert "gyroid.bench._result" in graph["gyroid.bench._problem"]
    # the result names its problem for the type checker only: not a run-time edge
    assert "gyroid.bench._problem" not in graph["gyroid.bench._result"]
