"""The package's shape (issue 23, "Done when"), read from the source with ``ast``: no import
cycle, no import from a lower layer to a higher one, the package never imports ``agents``, no
private name imported across modules, no module over ~400 lines, and no function over 80 lines
in the package, ``agents/``, ``benchmarks/`` or ``train.py``.

Imports under ``if TYPE_CHECKING:`` do not count; imports inside functions (lazy ones) do. Where
code of another engineer breaks a rule today, the allow-lists below name it with its owner;
they only shrink.
"""

from __future__ import annotations

import ast
from functools import cache
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "modquad_gym"

LAYERS = (
    "proofcheck_format", "proofcheck_shapes", "proofcheck", "core", "geometry", "oracle",
    "dynamics", "tasks", "search", "viz", "envs", "policy", "methods", "solvers", "sim",
    "scoring", "cli",
)  # fmt: skip
"""Bottom to top: a module may import its own layer and those below it (the certificate
checker, ``proofcheck``, imports no other module of the package but its format,
``proofcheck_format``, and its shapes, ``proofcheck_shapes``, which import none)."""
ROOT_LAYER = "envs"
"""``modquad_gym/__init__.py`` (the public names) imports up to the envs (it registers them)."""

MAX_MODULE_LINES = 400
MAX_FUNCTION_LINES = 80
CODE_DIRS = ("modquad_gym", "agents", "benchmarks")
"""Where the module and function lengths are checked (and in ``train.py``): the package, the
training code, the benchmarks."""

ALLOWED_CYCLES: set[frozenset[str]] = set()
ALLOWED_LONG_MODULES = {
    "modquad_gym.geometry.structure": 425,  # geometry (layout; dynamics' inertia): on the board
}
ALLOWED_LONG_FUNCTIONS: set[str] = set()
ALLOWED_PRIVATE = {
    "modquad_gym.sim.track_pictures -> modquad_gym.sim.pictures._plt",  # dynamics: on the board
}
ALLOWED_UP = {
    # dynamics: DynamicTask.save imports tasks.files.jsonable lazily (tasks loads dynamic tasks)
    "modquad_gym.dynamics.task -> modquad_gym.tasks.files",
}


def module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


@cache
def modules() -> dict[str, Path]:
    return {module_name(p): p for p in sorted(PACKAGE.rglob("*.py"))}


def type_checking(node: ast.AST) -> bool:
    return isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test)


@cache
def imports(name: str) -> tuple[tuple[str, str, int], ...]:
    """(imported module, imported name or "", line) of every import of module ``name``,
    relative imports resolved, ``from pkg import mod`` read as the module pkg.mod."""
    path = modules()[name]
    package = name.split(".") if path.name == "__init__.py" else name.split(".")[:-1]
    found: list[tuple[str, str, int]] = []

    def visit(node: ast.AST) -> None:
        for child in ast.iter_child_nodes(node):
            if type_checking(child):
                for c in child.orelse:
                    visit(c)
                continue
            if isinstance(child, ast.Import):
                found.extend((a.name, "", child.lineno) for a in child.names)
            elif isinstance(child, ast.ImportFrom):
                base = child.module or ""
                if child.level:
                    parts = package[: len(package) - child.level + 1]
                    base = ".".join(parts + ([child.module] if child.module else []))
                for a in child.names:
                    sub = f"{base}.{a.name}"
                    found.append((sub, "", child.lineno) if sub in modules() else
                                 (base, a.name, child.lineno))  # fmt: skip
            visit(child)

    visit(ast.parse(path.read_text()))
    return tuple(found)


def graph() -> dict[str, set[str]]:
    mods = modules()
    return {n: {m for m, _, _ in imports(n) if m in mods and m != n} for n in mods}


def layer(name: str) -> int:
    parts = name.split(".")
    return LAYERS.index(parts[1] if len(parts) > 1 else ROOT_LAYER)


def cycles(edges: dict[str, set[str]]) -> list[frozenset[str]]:
    """The strongly connected components with more than one module (Tarjan, iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[frozenset[str]] = []
    for root in edges:
        if root in index:
            continue
        work = [(root, iter(sorted(edges[root])))]
        index[root] = low[root] = len(index)
        stack.append(root)
        on_stack.add(root)
        while work:
            v, children = work[-1]
            w = next(children, None)
            if w is not None:
                if w not in index:
                    index[w] = low[w] = len(index)
                    stack.append(w)
                    on_stack.add(w)
                    work.append((w, iter(sorted(edges[w]))))
                elif w in on_stack:
                    low[v] = min(low[v], index[w])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[v])
            if low[v] == index[v]:
                component = set()
                while True:
                    w = stack.pop()
                    on_stack.discard(w)
                    component.add(w)
                    if w == v:
                        break
                if len(component) > 1:
                    found.append(frozenset(component))
    return found


def test_every_part_of_the_package_has_a_layer():
    parts = {name.split(".")[1] for name in modules() if "." in name}
    assert parts <= set(LAYERS), sorted(parts - set(LAYERS))


def test_the_cycle_finder_finds_cycles():
    edges = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}, "e": set()}
    assert cycles(edges) == [frozenset("abc")]
    assert cycles({"a": {"b"}, "b": set()}) == []


def test_no_import_cycles():
    found = set(cycles(graph()))
    assert found <= ALLOWED_CYCLES, sorted(map(sorted, found - ALLOWED_CYCLES))
    assert ALLOWED_CYCLES <= found, "a cycle is gone: remove it from ALLOWED_CYCLES"


def test_no_import_goes_up_the_layers():
    up = [
        f"{n} -> {m}"
        for n, targets in graph().items()
        for m in sorted(targets)
        if layer(m) > layer(n)
    ]
    assert set(up) <= ALLOWED_UP, sorted(set(up) - ALLOWED_UP)
    assert ALLOWED_UP <= set(up), "an upward import is gone: remove it from ALLOWED_UP"


def private(name: str) -> bool:
    return name.startswith("_") and not (name.startswith("__") and name.endswith("__"))


def test_the_package_never_imports_agents_or_private_names():
    agents = [
        f"{n} -> {m}" for n in modules() for m, _, _ in imports(n) if m.split(".")[0] == "agents"
    ]
    assert not agents, agents
    reached = {
        f"{n} -> {m}.{what}"
        for n in modules()
        for m, what, _ in imports(n)
        if m.startswith("modquad_gym") and private(what)
    }
    assert reached <= ALLOWED_PRIVATE, sorted(reached - ALLOWED_PRIVATE)
    assert ALLOWED_PRIVATE <= reached, "a private import is gone: remove it from ALLOWED_PRIVATE"


def code_files() -> list[Path]:
    """``train.py`` and every Python file under :data:`CODE_DIRS`."""
    return [ROOT / "train.py", *(p for d in CODE_DIRS for p in sorted((ROOT / d).rglob("*.py")))]


def test_modules_stay_short():
    long_modules = {}
    for path in code_files():
        name = module_name(path)
        lines = len(path.read_text().splitlines())
        if lines > ALLOWED_LONG_MODULES.get(name, MAX_MODULE_LINES):
            long_modules[name] = lines
    assert not long_modules, long_modules


def long_functions(paths, root: Path = ROOT) -> dict[str, int]:
    """``file: function`` -> lines (``def`` to its last line) of each function over
    ``MAX_FUNCTION_LINES`` in ``paths`` (files named relative to ``root``), nested ones
    included."""
    found = {}
    for path in paths:
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                length = node.end_lineno - node.lineno + 1
                if length > MAX_FUNCTION_LINES:
                    found[f"{path.relative_to(root).as_posix()}: {node.name}"] = length
    return found


def test_the_length_check_counts_from_def_to_the_last_line(tmp_path):
    """A function of exactly 80 lines passes; one more line, nested or not, is reported."""
    body = "".join(f"        x{i} = {i}\n" for i in range(MAX_FUNCTION_LINES - 3))
    code = tmp_path / "code.py"
    code.write_text(f"def outer():\n    def inner():\n{body}    return inner\n")
    assert long_functions([code], tmp_path) == {}  # outer: 80 lines, inner: 78
    code.write_text(f"def outer():\n    def inner():\n{body}        z = 0\n    return inner\n")
    assert long_functions([code], tmp_path) == {"code.py: outer": MAX_FUNCTION_LINES + 1}
    body += "".join(f"        y{i} = {i}\n" for i in range(3))
    code.write_text(f"def outer():\n    def inner():\n{body}    return inner\n")
    assert long_functions([code], tmp_path) == {
        "code.py: outer": MAX_FUNCTION_LINES + 3,
        "code.py: inner": MAX_FUNCTION_LINES + 1,
    }


def test_no_function_is_over_80_lines():
    found = long_functions(code_files())
    assert set(found) <= ALLOWED_LONG_FUNCTIONS, {
        k: v for k, v in found.items() if k not in ALLOWED_LONG_FUNCTIONS
    }
    assert ALLOWED_LONG_FUNCTIONS <= set(found), "a long function is gone: remove it from the list"
