"""The package's layers: no import circles between its modules, and the command line on top.

The import graph is read from the sources with :mod:`ast` (imports inside functions count
too, so a lazy import does not hide a circle). ``from gyrodrift.x import y`` counts as an
import of the module ``gyrodrift.x.y`` when that is a module, else of ``gyrodrift.x``.
Importing a package's submodule runs the package's ``__init__`` first, so that counts too,
but for the top package ``gyrodrift`` (every import runs it; naming it counts) and the
packages above the importer (they are already running).
"""

from __future__ import annotations

import ast
from pathlib import Path

import gyrodrift

SRC = Path(gyrodrift.__file__).resolve().parent
PACKAGE = "gyrodrift"


def _modules() -> dict[str, Path]:
    modules = {}
    for path in sorted(SRC.rglob("*.py")):
        parts = list(path.relative_to(SRC.parent).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts.pop()
        modules[".".join(parts)] = path
    return modules


def _resolve(module: str, path: Path, node: ast.ImportFrom) -> str:
    if node.level == 0:
        return node.module or ""
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    for _ in range(node.level - 1):
        package = package.rpartition(".")[0]
    return f"{package}.{node.module}" if node.module else package


def _with_parents(name: str, modules: dict[str, Path]) -> set[str]:
    """``name`` and the packages above it (importing it runs their ``__init__``); ``gyrodrift``
    itself only when it is ``name``: every import of the package runs it first."""
    parts = name.split(".")
    prefixes = {".".join(parts[:i]) for i in range(2, len(parts) + 1)} | ({name} if name == PACKAGE else set())
    return prefixes & modules.keys()


def import_graph() -> dict[str, set[str]]:
    modules = _modules()
    graph: dict[str, set[str]] = {m: set() for m in modules}
    for module, path in modules.items():
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), str(path))):
            targets: list[str] = []
            if isinstance(node, ast.Import):
                targets = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom):
                base = _resolve(module, path, node)
                targets = [f"{base}.{a.name}" if f"{base}.{a.name}" in modules else base for a in node.names]
            for target in targets:
                if target == PACKAGE or target.startswith(PACKAGE + "."):
                    # the packages above the importer are already loading: reaching a sibling
                    # through them is no import of their __init__, naming one itself is
                    above = _with_parents(module, modules) - {target}
                    graph[module] |= _with_parents(target, modules) - above
        graph[module].discard(module)
    return graph


def strongly_connected(graph: dict[str, set[str]]) -> list[list[str]]:
    """Tarjan's algorithm, iterative; the components of more than one module."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []
    counter = 0
    for root in sorted(graph):
        if root in index:
            continue
        work = [(root, iter(sorted(graph[root])))]
        index[root] = low[root] = counter
        counter += 1
        stack.append(root)
        on_stack.add(root)
        while work:
            node, children = work[-1]
            for child in children:
                if child not in index:
                    index[child] = low[child] = counter
                    counter += 1
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(graph[child]))))
                    break
                if child in on_stack:
                    low[node] = min(low[node], index[child])
            else:
                work.pop()
                if work:
                    parent = work[-1][0]
                    low[parent] = min(low[parent], low[node])
                if low[node] == index[node]:
                    component = []
                    while True:
                        member = stack.pop()
                        on_stack.discard(member)
                        component.append(member)
                        if member == node:
                            break
                    if len(component) > 1:
                        found.append(sorted(component))
    return found


def test_the_graph_sees_function_level_imports():
    graph = import_graph()
    assert "gyrodrift.cli" in graph["gyrodrift.__main__"]
    assert "gyrodrift.evaluate.paper" in graph["gyrodrift.cli.commands"]  # imported inside _cmd_paper only
    assert "gyrodrift.evaluate" in graph["gyrodrift.cli.commands"]  # the package above it runs first


def test_circles_are_found():
    assert strongly_connected({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]
    assert strongly_connected({"a": {"b"}, "b": set()}) == []


def test_no_import_circles_between_modules():
    assert strongly_connected(import_graph()) == []


def test_nothing_below_the_command_line_imports_it():
    offenders = {
        module: sorted(t for t in targets if t == "gyrodrift.cli" or t.startswith("gyrodrift.cli."))
        for module, targets in import_graph().items()
        if not (module == "gyrodrift.cli" or module.startswith("gyrodrift.cli.") or module == "gyrodrift.__main__")
    }
    assert {m: t for m, t in offenders.items() if t} == {}
