"""Reading the tree: import circles, private names reached across modules, long files.

    python tools/check_structure.py          # prints what it finds; exit 1 if anything

Imports are read with ``ast`` from ``src/gyrodrift`` (module level and inside functions).
A private name is one starting with ``_`` imported from another gyrodrift module
(``from gyrodrift.x import _y``) or used as an attribute of one (``x._y``); importing a
public name from a private module (``from gyrodrift._atomic import atomic_path``) is fine.
"""

from __future__ import annotations

import ast
import sys
from pathlib import Path

SRC = Path(__file__).resolve().parents[1] / "src"
MAX_LINES = 800


def modules() -> dict[str, Path]:
    found = {}
    for path in sorted((SRC / "gyrodrift").rglob("*.py")):
        parts = list(path.relative_to(SRC).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        found[".".join(parts)] = path
    return found


def _resolve(name: str, mods: dict[str, Path]) -> str | None:
    while name and name not in mods:
        name = name.rpartition(".")[0]
    return name or None


def imports(mods: dict[str, Path]):
    """(importer, imported module, names imported from it, aliases) for every gyrodrift import."""
    for mod, path in mods.items():
        tree = ast.parse(path.read_text(encoding="utf-8"))
        package = mod if path.name == "__init__.py" else mod.rpartition(".")[0]
        for node in ast.walk(tree):
            if isinstance(node, ast.Import):
                for a in node.names:
                    if a.name.startswith("gyrodrift"):
                        yield mod, _resolve(a.name, mods), [], a.asname or a.name, tree
            elif isinstance(node, ast.ImportFrom):
                base = node.module or ""
                if node.level:
                    base = ".".join(package.split(".")[: len(package.split(".")) - node.level + 1] + ([base] if base else []))
                if not base.startswith("gyrodrift"):
                    continue
                for a in node.names:
                    sub = f"{base}.{a.name}"
                    if sub in mods:  # a submodule
                        yield mod, sub, [], a.asname or a.name, tree
                    else:
                        yield mod, _resolve(base, mods), [a.name], None, tree


def main() -> int:
    mods = modules()
    problems = []
    graph: dict[str, set[str]] = {m: set() for m in mods}
    for mod, target, names, alias, tree in imports(mods):
        if target is None or target == mod:
            continue
        if not mod.startswith(target + "."):  # a package importing its own submodule is no circle
            graph[mod].add(target)
        for name in names:
            if name.startswith("_") and not name.startswith("__"):
                problems.append(f"{mod} imports the private name {name} of {target}")
        if alias:  # attribute access on an imported module: alias._name
            for node in ast.walk(tree):
                if (isinstance(node, ast.Attribute) and node.attr.startswith("_") and not node.attr.startswith("__")
                        and isinstance(node.value, ast.Name) and node.value.id == alias.split(".")[-1]):
                    problems.append(f"{mod} uses the private name {alias}.{node.attr}")
    # circles: strongly connected components of the module graph
    index, low, stack, on, sccs, counter = {}, {}, [], set(), [], [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                sccs.append(sorted(comp))

    sys.setrecursionlimit(10000)
    for v in graph:
        if v not in index:
            visit(v)
    problems += [f"import circle: {' <-> '.join(c)}" for c in sccs]
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
