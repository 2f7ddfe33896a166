"""The package's shape: its import graph has no cycle, and every arrow points down the layers.

The graph is read from the source with ``ast`` (every ``import`` statement, those inside
functions included), not from what happens to be imported at run time.  Layers, bottom to top:

    result, validation  (the result contract and the bad-input error; under everything)
    models       describe: what the physics is
    discretise   how it becomes finitely many unknowns
    baselines    time-steppers kept for comparison
    solve        one NLP handed to Ipopt, its strategies, the entry point simulate
    inspect      studies, errors, pictures
    cli          argument parsing, the scene registry, the console command, the report
    problems     one script per scene

An arrow may stay inside its own room or point to a lower layer, never up and never sideways.
"""
from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "src" / "castrajectory"
PROBLEMS = ROOT / "problems"

LAYERS = ["result", "validation", "models", "discretise", "baselines", "solve", "inspect", "cli", "problems"]
RANK = {"result": 0, "validation": 0, "models": 1, "discretise": 2, "baselines": 3, "solve": 4,
        "inspect": 5, "cli": 6, "problems": 7}


def _modules():
    """Module name -> source path, for the package and the problem scripts (castrajectory.problems)."""
    out = {}
    for path in PACKAGE.rglob("*.py"):
        parts = list(path.relative_to(PACKAGE).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out[".".join(["castrajectory", *parts])] = path
    for path in PROBLEMS.glob("*.py"):
        stem = path.stem
        out["castrajectory.problems" + ("" if stem == "__init__" else f".{stem}")] = path
    return out


MODULES = _modules()


def _resolve(name: str) -> str | None:
    """The module of ours that an import of ``name`` loads (the longest known prefix), if any."""
    while name:
        if name in MODULES:
            return name
        name = name.rpartition(".")[0]
    return None


def _imports(module: str, path: Path):
    """Modules of ours imported anywhere in ``path``."""
    tree = ast.parse(path.read_text(), filename=str(path))
    is_pkg = path.name == "__init__.py"
    package = module if is_pkg else module.rpartition(".")[0]
    found = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package
                for _ in range(node.level - 1):
                    base = base.rpartition(".")[0]
                base = f"{base}.{node.module}" if node.module else base
            else:
                base = node.module or ""
            names = [f"{base}.{a.name}" for a in node.names]  # a name that is no module resolves to base
        else:
            continue
        for nm in names:
            if not nm.startswith("castrajectory"):
                continue
            target = _resolve(nm)
            if target is None:
                found.add(("unknown", nm))
            elif target != module:
                found.add(("ok", target))
    return found


GRAPH = {m: _imports(m, p) for m, p in MODULES.items()}


def _room(module: str) -> str:
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else ""


def test_every_module_has_a_layer():
    rooms = {_room(m) for m in MODULES} - {""}
    assert rooms <= set(LAYERS), f"modules outside the layers: {sorted(rooms - set(LAYERS))}"
    # the package keeps its shape: the layers as folders
    for room in ("models", "discretise", "baselines", "solve", "inspect", "cli"):
        assert (PACKAGE / room / "__init__.py").is_file()


def test_imports_name_modules_that_exist():
    """No import of the package goes through an old flat name (those are aliases for users only)."""
    bad = sorted((m, nm) for m, edges in GRAPH.items() for kind, nm in edges if kind == "unknown")
    assert not bad, bad
    flat = sorted((m, t) for m, edges in GRAPH.items() for _, t in edges
                  if t.count(".") == 1 and _room(t) not in RANK and t != "castrajectory")
    assert not flat, flat


def test_arrows_point_down_the_layers():
    wrong = []
    for src, edges in GRAPH.items():
        a = _room(src)
        if a == "":  # the package's __init__ (compat aliases) is not a layer
            continue
        for _, dst in edges:
            b = _room(dst)
            if b == "":
                wrong.append((src, dst, "imports the package root"))
            elif b != a and RANK[b] >= RANK[a]:
                wrong.append((src, dst, f"{a} (layer {RANK[a]}) -> {b} (layer {RANK[b]})"))
    assert not wrong, "\n".join(map(str, wrong))


def test_no_import_cycles():
    graph = {m: sorted(t for _, t in edges if _ != "unknown") for m, edges in GRAPH.items()}
    # a package's __init__ that re-exports its own submodules is not a cycle when they do not
    # import it back; everything else counts, function-level imports included
    state, stack, cycles = {}, [], []

    def visit(m):
        state[m] = 1
        stack.append(m)
        for t in graph.get(m, []):
            if state.get(t) == 1:
                cycles.append(stack[stack.index(t):] + [t])
            elif t not in state:
                visit(t)
        stack.pop()
        state[m] = 2

    for m in sorted(graph):
        if m not in state:
            visit(m)
    assert not cycles, "\n".join(" -> ".join(c) for c in cycles)


def test_matplotlib_only_in_inspect():
    users = []
    for m, path in MODULES.items():
        tree = ast.parse(path.read_text())
        for node in ast.walk(tree):
            names = ([a.name for a in node.names] if isinstance(node, ast.Import)
                     else [node.module or ""] if isinstance(node, ast.ImportFrom) and not node.level else [])
            if any(n == "matplotlib" or n.startswith("matplotlib.") for n in names):
                users.append(m)
    # the pictures' room: static figures and animations (split in two modules of one job each)
    assert set(users) <= {"castrajectory.inspect.plotting", "castrajectory.inspect.animation"}, users


@pytest.mark.parametrize("name", ["droplet", "nlp", "trajectory", "contact", "collision", "mechanics",
                                  "pendulum", "stepping", "simulate", "study", "discrete", "jit"])
def test_old_module_names_still_import(name):
    """The flat names of earlier versions are aliases of the modules that hold their contents now."""
    import importlib
    import sys

    sys.modules.pop(f"castrajectory.{name}", None)
    with pytest.warns(DeprecationWarning, match=f"castrajectory.{name} is deprecated and goes at castrajectory 1.0"):
        old = importlib.import_module(f"castrajectory.{name}")
    assert old.__name__.startswith("castrajectory.") and old.__name__.count(".") == 2
    assert importlib.import_module(old.__name__) is old
