"""The package's layers: no import circles between its modules, and the command line on top.

The import graph is ``import_graph`` of ``tools/check_structure.py``: read from the sources with
:mod:`ast`, imports inside functions included (a lazy import does not hide a circle), a
package's ``__init__`` counted where importing a submodule runs it.
"""

from __future__ import annotations

import importlib.util
from pathlib import Path

_TOOL = Path(__file__).resolve().parents[1] / "tools" / "check_structure.py"
_spec = importlib.util.spec_from_file_location("check_structure", _TOOL)
check_structure = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(check_structure)
import_graph, strongly_connected = check_structure.import_graph, check_structure.strongly_connected


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
