"""No import cycle anywhere in the package, imports inside functions counted (issue 36 item 4).

grimp (import-linter's graph) reads every import statement of a module, at the top or inside a
function; a strongly connected component of more than one module is a cycle.
"""

from __future__ import annotations

import grimp


def _cycles(graph) -> list[list[str]]:
    """The strongly connected components with more than one module (Tarjan, iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    on_stack: set[str] = set()
    stack: list[str] = []
    found: list[list[str]] = []
    counter = 0
    for root in sorted(graph.modules):
        if root in index:
            continue
        work = [(root, iter(sorted(graph.find_modules_directly_imported_by(root))))]
        index[root] = low[root] = counter
        counter += 1
        stack.append(root)
        on_stack.add(root)
        while work:
            node, children = work[-1]
            child = next(children, None)
            if child is not None:
                if child not in index:
                    index[child] = low[child] = counter
                    counter += 1
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(graph.find_modules_directly_imported_by(
                        child)))))
                elif child in on_stack:
                    low[node] = min(low[node], index[child])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
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


def test_the_package_has_no_import_cycle():
    graph = grimp.build_graph("viscoforce", include_external_packages=False)
    assert _cycles(graph) == []


def test_the_cycle_finder_finds_a_cycle():
    class Graph:
        modules = {"a", "b", "c", "d"}
        edges = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}

        def find_modules_directly_imported_by(self, module):
            return self.edges.get(module, set())

    assert _cycles(Graph()) == [["a", "b", "c"]]


def test_the_cli_contract_names_every_private_module_of_the_packages_below():
    """The import-linter contract "the CLI uses only public modules …" lists them all (a new
    private module is covered the day it is written), and the CLI imports none of them."""
    import tomllib
    from pathlib import Path

    config = tomllib.loads((Path(__file__).resolve().parents[2] / "pyproject.toml").read_text(
        encoding="utf-8"))
    contract = next(c for c in config["tool"]["importlinter"]["contracts"]
                    if c["name"].startswith("the CLI uses only public modules"))
    graph = grimp.build_graph("viscoforce")
    private = {m for m in graph.modules if m.count(".") >= 2 and not m.startswith("viscoforce.cli")
               and any(p.startswith("_") and not p.startswith("__") for p in m.split(".")[2:])}
    top = {m for m in private if not any(m.startswith(o + ".") for o in private)}
    assert set(contract["forbidden_modules"]) == top
    used = {(m, i) for m in graph.modules if m.startswith("viscoforce.cli")
            for i in graph.find_modules_directly_imported_by(m) if i in private}
    assert not used
