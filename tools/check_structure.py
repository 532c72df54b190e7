"""Reading the tree: import circles, private names reached across modules, long files.

    python tools/check_structure.py          # prints what it finds; exit 1 if anything

Imports are read with ``ast`` from ``src/gyrodrift`` (module level and inside functions);
``tests/test_layering.py`` asserts on the same graph (:func:`import_graph`).
A private name is one starting with ``_`` imported from another gyrodrift module
(``from gyrodrift.x import _y``) or used as an attribute of one (``x._y``); importing a
public name from a private module (``from gyrodrift._atomic import atomic_path``) is fine.
"""

from __future__ import annotations

import ast
import sys
from pathlib import Path

SRC = Path(__file__).resolve().parents[1] / "src"
PACKAGE = "gyrodrift"
MAX_LINES = 700


def modules() -> dict[str, Path]:
    found = {}
    for path in sorted((SRC / "gyrodrift").rglob("*.py")):
        parts = list(path.relative_to(SRC).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        found[".".join(parts)] = path
    return found


def _resolve_name(name: str, mods: dict[str, Path]) -> str | None:
    while name and name not in mods:
        name = name.rpartition(".")[0]
    return name or None


def imports(mods: dict[str, Path]):
    """(importer, imported module, names imported from it, aliases) for every gyrodrift import."""
    for mod, path in mods.items():
        tree = ast.parse(path.read_text(encoding="utf-8"))
        for node in ast.walk(tree):
            if isinstance(node, ast.Import):
                for a in node.names:
                    if a.name.startswith("gyrodrift"):
                        yield mod, _resolve_name(a.name, mods), [], a.asname or a.name, tree
            elif isinstance(node, ast.ImportFrom):
                base = _resolve(mod, path, node)
                if not base.startswith("gyrodrift"):
                    continue
                for a in node.names:
                    sub = f"{base}.{a.name}"
                    if sub in mods:  # a submodule
                        yield mod, sub, [], a.asname or a.name, tree
                    else:
                        yield mod, _resolve_name(base, mods), [a.name], None, tree


def _resolve(module: str, path: Path, node: ast.ImportFrom) -> str:
    """The absolute module a ``from ... import`` in ``module`` (at ``path``) names."""
    if node.level == 0:
        return node.module or ""
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    for _ in range(node.level - 1):
        package = package.rpartition(".")[0]
    return f"{package}.{node.module}" if node.module else package


def _with_parents(name: str, mods: dict[str, Path]) -> set[str]:
    """``name`` and the packages above it (importing it runs their ``__init__``); ``gyrodrift``
    itself only when it is ``name``: every import of the package runs it first."""
    parts = name.split(".")
    prefixes = {".".join(parts[:i]) for i in range(2, len(parts) + 1)} | ({name} if name == PACKAGE else set())
    return prefixes & mods.keys()


def import_graph() -> dict[str, set[str]]:
    """Module -> the gyrodrift modules its imports run (module level and inside functions).
    ``from gyrodrift.x import y`` imports ``gyrodrift.x.y`` when that is a module, else
    ``gyrodrift.x``; a package's ``__init__`` runs before its submodules, except ``gyrodrift``
    itself (every import runs it; naming it counts) and the packages above the importer
    (already running)."""
    mods = modules()
    graph: dict[str, set[str]] = {m: set() for m in mods}
    for module, path in mods.items():
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), str(path))):
            targets: list[str] = []
            if isinstance(node, ast.Import):
                targets = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom):
                base = _resolve(module, path, node)
                targets = [f"{base}.{a.name}" if f"{base}.{a.name}" in mods else base for a in node.names]
            for target in targets:
                if target == PACKAGE or target.startswith(PACKAGE + "."):
                    # the packages above the importer are already loading: reaching a sibling
                    # through them is no import of their __init__, naming one itself is
                    above = _with_parents(module, mods) - {target}
                    graph[module] |= _with_parents(target, mods) - above
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


def main() -> int:
    mods = modules()
    problems = []
    for mod, target, names, alias, tree in imports(mods):
        if target is None or target == mod:
            continue
        for name in names:
            if name.startswith("_") and not name.startswith("__"):
                problems.append(f"{mod} imports the private name {name} of {target}")
        if alias:  # attribute access on an imported module: alias._name
            for node in ast.walk(tree):
                if (isinstance(node, ast.Attribute) and node.attr.startswith("_") and not node.attr.startswith("__")
                        and isinstance(node.value, ast.Name) and node.value.id == alias.split(".")[-1]):
                    problems.append(f"{mod} uses the private name {alias}.{node.attr}")
    problems += [f"import circle: {' <-> '.join(c)}" for c in strongly_connected(import_graph())]
    for mod, path in mods.items():
        n = len(path.read_text(encoding="utf-8").splitlines())
        if n > MAX_LINES:
            problems.append(f"{path.relative_to(SRC)}: {n} lines (over {MAX_LINES})")
    total = sum(len(p.read_text(encoding="utf-8").splitlines()) for p in mods.values())
    for line in sorted(set(problems)):
        print(line)
    print(f"{len(mods)} modules, {total} lines in src/gyrodrift; {len(set(problems))} problems")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
