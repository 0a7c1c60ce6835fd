"""The package's internal import graph has no cycle (function-level imports included)."""

from __future__ import annotations

import ast
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1] / "voxelmocap"


def _modules() -> dict[str, tuple[Path, bool]]:
    """Dotted module name → (file, is a package ``__init__``)."""
    out = {}
    for path in PACKAGE.rglob("*.py"):
        parts = list(path.relative_to(PACKAGE.parent).with_suffix("").parts)
        is_package = parts[-1] == "__init__"
        out[".".join(parts[:-1] if is_package else parts)] = (path, is_package)
    return out


def import_graph() -> dict[str, set[str]]:
    """Module → the package modules it imports anywhere in its body (not only at the top).

    ``from X import name`` is an edge to ``X.name`` when that is a module, else to ``X``; the
    implicit import of parent packages is not an edge (it cannot close a cycle by itself).
    """
    modules = _modules()
    graph = {}
    for name, (path, is_package) in modules.items():
        here = name.split(".") if is_package else name.split(".")[:-1]
        deps = set()
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Import):
                targets = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom):
                base = node.module or ""
                if node.level:
                    prefix = here[: len(here) - node.level + 1]
                    base = ".".join(prefix + ([node.module] if node.module else []))
                targets = [f"{base}.{alias.name}" if f"{base}.{alias.name}" in modules else base
                           for alias in node.names]
            else:
                continue
            deps.update(t for t in targets if t in modules and t != name)
        graph[name] = deps
    return graph


def find_cycle(graph: dict[str, set[str]]) -> list[str] | None:
    """One cycle ``[a, b, …, a]`` of a directed graph, or None (iterative depth-first search)."""
    state = dict.fromkeys(graph, 0)  # 0 new, 1 on the current path, 2 done
    for root in sorted(graph):
        if state[root]:
            continue
        path, stack = [root], [iter(sorted(graph[root]))]
        state[root] = 1
        while stack:
            nxt = next(stack[-1], None)
            if nxt is None:
                state[path.pop()] = 2
                stack.pop()
            elif state[nxt] == 1:
                return path[path.index(nxt):] + [nxt]
            elif state[nxt] == 0:
                state[nxt] = 1
                path.append(nxt)
                stack.append(iter(sorted(graph[nxt])))
    return None


def test_the_cycle_finder_finds_cycles():
    assert find_cycle({"a": {"b"}, "b": {"c"}, "c": set()}) is None
    assert find_cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]
    assert find_cycle({"a": {"a2"}, "a2": set(), "x": {"y"}, "y": {"x"}}) == ["x", "y", "x"]


def test_the_graph_sees_function_level_and_relative_imports():
    graph = import_graph()
    assert "voxelmocap.camera" in graph["voxelmocap.io.calibration"]
    # from . import X as Y
    assert "voxelmocap.measure._carving_kernels" in graph["voxelmocap.measure.carving"]
    assert "voxelmocap.io.body_file" in graph["voxelmocap.commands.info"]  # inside a function


def test_no_import_cycle_in_the_package():
    cycle = find_cycle(import_graph())
    assert cycle is None, " → ".join(cycle)


#: The layers, bottom up: a module imports only its own layer and the layers below it. The
#: foundations know no wing; ``io`` turns files into their objects; ``config`` (validated
#: settings, read through ``io.toml``; its schema machinery in ``_config_schema``) sits on
#: both; the science wings follow the data path (measure → score → pose); ``viz`` draws;
#: ``run`` loops over sequences and touches files; the command line is the top.
#: ``docs/architecture.md`` draws the same order.
LAYERS = (
    ("foundations", ("errors", "logs", "joints", "frames", "smoothing", "portable",
                     "_portable_kernels", "cpu_paths", "thread_waits", "camera", "grid", "evaluation", "body",
                     "tracking")),
    ("io", ("io",)),
    ("config", ("config", "_config_schema")),
    ("synth", ("synth",)),
    ("measure", ("measure",)),
    ("score", ("score",)),
    ("pose", ("pose",)),
    ("viz", ("viz",)),
    ("run", ("run",)),
    ("commands", ("commands", "cli")),
)


def layer_of(module: str) -> int:
    """The index in :data:`LAYERS` of a package module (``voxelmocap`` itself, which holds only
    its version and imports nothing, is a foundation)."""
    parts = module.split(".")
    if len(parts) == 1:
        return 0
    for i, (_, roots) in enumerate(LAYERS):
        if parts[1] in roots:
            return i
    raise AssertionError(f"{module} belongs to no layer: add it to LAYERS")


def test_the_layer_check_sees_an_upward_import():
    assert layer_of("voxelmocap.measure.carving") < layer_of("voxelmocap.run.pipeline")
    upward = {"voxelmocap.grid": {"voxelmocap.run.pipeline"}}
    assert upward_imports(upward) == ["voxelmocap.grid (foundations) imports "
                                      "voxelmocap.run.pipeline (run)"]


def upward_imports(graph: dict[str, set[str]]) -> list[str]:
    out = []
    for module, deps in sorted(graph.items()):
        for dep in sorted(deps):
            if layer_of(dep) > layer_of(module):
                out.append(f"{module} ({LAYERS[layer_of(module)][0]}) imports {dep} "
                           f"({LAYERS[layer_of(dep)][0]})")
    return out


def test_every_module_belongs_to_a_layer():
    graph = import_graph()
    assert graph["voxelmocap"] == set()  # the package's face: a foundation only while it is empty
    for module in graph:
        layer_of(module)


def test_imports_only_go_down_the_layers():
    assert upward_imports(import_graph()) == []
