"""The package imports in one direction: a layer uses the layers below it, never above.

The graph is computed from the source with :mod:`ast`, not by importing it: every
``import`` and ``from ... import`` counts, at module level, under ``if TYPE_CHECKING:`` and
inside functions alike (a type-only or a deferred import is still a dependency a reader
has to hold in mind, and the one that turns into a runtime import next).  Two rules:

* no circle between modules (a package's ``__init__`` is a module too);
* no edge upward in :data:`LAYERS`: a module may import its own unit (cycle-free) and
  units of lower rank; units of the same rank do not import each other.

``docs/architecture.md`` explains the layers; a new subpackage or top-level module must be
placed in the table (the test says so) before it can be imported at all.
"""

from __future__ import annotations

import ast
from collections.abc import Iterable, Mapping
from pathlib import Path

import pytest

PACKAGE = "arduinoio_async"
ROOT = Path(__file__).resolve().parent.parent / PACKAGE

#: The layers, lowest first.  Each entry is one rank; a unit is a subpackage or a module
#: directly under the package ("" is the package's own ``__init__``).
LAYERS: list[tuple[str, ...]] = [
    # The exception tree every layer raises; the registry of address schemes opened above
    # the board (arduinoio_async._schemes); the version.
    ("errors", "_schemes", "_version"),
    ("protocol",),  # sans-IO: command table, codec, session; no asyncio, no subprocess
    ("_resources",),  # the shipped data files, the toolchain and the harness build
    ("_port_registry",),  # the per-user registry of running virtual Unos
    ("transport",),  # byte streams and the request/response engine
    ("_event_queue",),  # bounded queues of pushed events, shared by the board's watches
    ("testing",),  # FakeBoard: a board in memory, on the transport's stream interface
    ("board",),  # Board over BoardCore; handles, changes, streams, transactions, failsafe
    # one board's life on one link: attach, keepalive, restore, retry; device drivers on
    # the board's bridges (the MCP3008 on SPI)
    ("_supervisor", "devices"),
    ("manager", "sim"),  # boards by ID (discovery, restore); virtual Unos and their demo
    ("scan_options",),  # the options every command that looks for boards shares
    ("network",),  # boards served over Zenoh and the client
    ("opener",),  # one entry for every kind of address: serial ports, sims, zenoh://
    ("blocking", "bench"),  # the blocking API; the shipped benchmark
    ("monitor", "ros2"),  # the live monitor page; every board a ROS 2 node (rmw_zenoh)
    ("cli",),  # the arduinoio command
    # The package facade, ``python -m arduinoio_async`` and the old import paths.
    ("", "__main__", "handles", "changes", "streaming", "transactions", "motors", "sync"),
]

#: Back edges still to be removed, each with who removes it.  Listed edges are left out
#: of both checks; a test fails once one is gone, so the list only shrinks.
KNOWN_BACK_EDGES: set[tuple[str, str]] = set()  # none left (the last two went with the
# ServedBoard split: it and its failsafe owner no longer name the BoardServer that builds them)

Graph = Mapping[str, Iterable[str]]


def modules(root: Path = ROOT) -> dict[str, Path]:
    """Every module of the package by dotted name (packages by their own name)."""
    found = {}
    for path in sorted(root.rglob("*.py")):
        parts = [PACKAGE, *path.relative_to(root).with_suffix("").parts]
        if parts[-1] == "__init__":
            parts.pop()
        found[".".join(parts)] = path
    return found


def imports_of(name: str, path: Path, known: Iterable[str]) -> set[str]:
    """The package's modules that ``name`` (at ``path``) imports, anywhere in its body."""
    known = set(known)
    is_package = path.name == "__init__.py"
    here = name.split(".") if is_package else name.split(".")[:-1]
    found: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = here[: len(here) - node.level + 1]
                module = ".".join([*base, *([node.module] if node.module else [])])
            else:
                module = node.module or ""
            for alias in node.names:  # ``from . import errors`` imports a module
                child = f"{module}.{alias.name}"
                found.add(child if child in known else module)
    return {m for m in found if m in known and m != name}


def import_graph(root: Path = ROOT) -> dict[str, set[str]]:
    """Module -> the package's modules it imports."""
    found = modules(root)
    return {name: imports_of(name, path, found) for name, path in found.items()}


def checked_graph() -> dict[str, set[str]]:
    """The package's graph without :data:`KNOWN_BACK_EDGES`."""
    graph = import_graph()
    for module, target in KNOWN_BACK_EDGES:
        graph[module].discard(target)
    return graph


def cycles(graph: Graph) -> list[list[str]]:
    """The strongly connected components with more than one module (Tarjan), sorted."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []

    def visit(node: str) -> None:  # the package is shallow: recursion is fine
        index[node] = low[node] = len(index)
        stack.append(node)
        on_stack.add(node)
        for nxt in graph.get(node, ()):
            if nxt not in index:
                visit(nxt)
                low[node] = min(low[node], low[nxt])
            elif nxt in on_stack:
                low[node] = min(low[node], index[nxt])
        if low[node] == index[node]:
            component = []
            while True:
                top = stack.pop()
                on_stack.discard(top)
                component.append(top)
                if top == node:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for node in sorted(graph):
        if node not in index:
            visit(node)
    return sorted(found)


def unit_of(module: str) -> str:
    """``arduinoio_async.board.handles`` -> ``board``; the package itself -> ``""``."""
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else ""


def rank_table(layers: list[tuple[str, ...]] = LAYERS) -> dict[str, int]:
    return {unit: rank for rank, units in enumerate(layers) for unit in units}


def upward_edges(graph: Graph, ranks: Mapping[str, int]) -> list[str]:
    """Every edge into a unit of the same or a higher rank than its own (own unit aside)."""
    bad = []
    for module, targets in sorted(graph.items()):
        for target in sorted(targets):
            here, there = unit_of(module), unit_of(target)
            if here != there and ranks.get(there, -1) >= ranks.get(here, -1):
                bad.append(
                    f"{module} -> {target} ({here!r} rank {ranks.get(here)}, "
                    f"{there!r} rank {ranks.get(there)})"
                )
    return bad


def test_every_unit_has_a_layer() -> None:
    """A new subpackage or module is placed in the table before it counts as layered."""
    ranks = rank_table()
    missing = sorted({unit_of(m) for m in modules()} - set(ranks))
    assert not missing, f"add these to LAYERS in {__file__}: {missing}"


def test_the_package_has_no_import_cycle() -> None:
    assert cycles(checked_graph()) == []


def test_no_module_imports_upward() -> None:
    assert upward_edges(checked_graph(), rank_table()) == []


def test_known_back_edges_still_exist() -> None:
    """An edge removed from the code is removed from the list too."""
    graph = import_graph()
    gone = sorted(edge for edge in KNOWN_BACK_EDGES if edge[1] not in graph.get(edge[0], ()))
    assert not gone, f"remove from KNOWN_BACK_EDGES: {gone}"


def test_type_checking_and_function_imports_count(tmp_path: Path) -> None:
    """The parser sees the imports a type-only or deferred back edge hides in."""
    pkg = tmp_path / PACKAGE
    (pkg / "low").mkdir(parents=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "low" / "__init__.py").write_text("")
    (pkg / "high.py").write_text("from .low import thing\n")
    (pkg / "low" / "thing.py").write_text(
        "from typing import TYPE_CHECKING\n"
        "if TYPE_CHECKING:\n    from ..high import X\n"
        "def f():\n    import arduinoio_async.high\n    from .. import high\n"
    )
    graph = import_graph(pkg)
    assert graph[f"{PACKAGE}.low.thing"] == {f"{PACKAGE}.high"}
    assert graph[f"{PACKAGE}.high"] == {f"{PACKAGE}.low.thing"}
    assert cycles(graph) == [[f"{PACKAGE}.high", f"{PACKAGE}.low.thing"]]
    ranks = rank_table([("low",), ("high",)])
    assert upward_edges(graph, ranks) == [
        f"{PACKAGE}.low.thing -> {PACKAGE}.high ('low' rank 0, 'high' rank 1)"
    ]


@pytest.mark.parametrize(
    ("graph", "expected"),
    [
        ({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}, [["a", "b", "c"]]),
        ({"a": {"b"}, "b": {"c"}, "c": set()}, []),
        ({"a": {"b"}, "b": {"a"}, "c": {"d"}, "d": {"c"}}, [["a", "b"], ["c", "d"]]),
    ],
)
def test_cycle_finder(graph: dict[str, set[str]], expected: list[list[str]]) -> None:
    """The cycle check can fail: a synthetic circle is found, a chain is not one."""
    assert cycles(graph) == expected


def test_same_rank_units_are_independent() -> None:
    graph = {f"{PACKAGE}.manager": {f"{PACKAGE}.sim"}, f"{PACKAGE}.sim": set()}
    assert upward_edges(graph, rank_table()) == [
        f"{PACKAGE}.manager -> {PACKAGE}.sim ('manager' rank 9, 'sim' rank 9)"
    ]
