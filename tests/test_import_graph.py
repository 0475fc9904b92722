"""The library's and the compendium's modules import each other in layers: no cycle, no private name across modules.

The graph is read from the source with ``ast``, not by importing it: every ``import`` and ``from ... import`` of the
package's own modules, at module level and inside functions alike (a function-level import hides a cycle, it does
not break one), those under ``if TYPE_CHECKING:`` left out (they never run). :func:`import_graph` takes a package and
its source folder, so that the same checks can be pointed at ``ocpkit``.
"""

from __future__ import annotations

import ast
from dataclasses import dataclass
from pathlib import Path

SRC = Path(__file__).resolve().parents[1] / "src"


@dataclass(frozen=True)
class Import:
    """One import of a module of the package: who imports, what, where (``line``) and which names."""

    source: str
    target: str
    line: int
    names: tuple[str, ...] = ()


def modules_of(package: str, src: Path) -> dict[str, Path]:
    """Every module of ``package`` (dotted name -> file), packages by their ``__init__.py``."""
    out = {}
    for path in sorted((src / package).rglob("*.py")):
        parts = list(path.relative_to(src).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts.pop()
        out[".".join(parts)] = path
    return out


def _type_checking(test: ast.expr) -> bool:
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING"
    )


def _statements(tree: ast.AST):
    """Every node of ``tree`` but the bodies of ``if TYPE_CHECKING:`` (their ``else`` runs, and is kept)."""
    stack = [tree]
    while stack:
        node = stack.pop()
        yield node
        if isinstance(node, ast.If) and _type_checking(node.test):
            stack.extend(node.orelse)
        else:
            stack.extend(ast.iter_child_nodes(node))


def _absolute(module: str, is_package: bool, level: int, name: str | None) -> str:
    """The dotted name a relative import of ``module`` names."""
    if level == 0:
        return name or ""
    base = module.split(".") if is_package else module.split(".")[:-1]
    base = base[: len(base) - (level - 1)]
    return ".".join(base + ([name] if name else []))


def imports_of(package: str, src: Path) -> list[Import]:
    """Every import by a module of ``package`` of a module of ``package`` (``TYPE_CHECKING`` blocks aside).

    ``from .x import y`` where ``x.y`` is a module is an import of ``x.y`` (``names`` empty); otherwise of ``x``,
    with the names it takes. ``import a.b`` is an import of ``a.b``.
    """
    modules = modules_of(package, src)
    out = []
    for module, path in modules.items():
        is_package = path.name == "__init__.py"
        for node in _statements(ast.parse(path.read_text(), str(path))):
            if isinstance(node, ast.Import):
                out += [Import(module, a.name, node.lineno) for a in node.names if a.name in modules]
            elif isinstance(node, ast.ImportFrom):
                target = _absolute(module, is_package, node.level, node.module)
                if target not in modules:
                    continue
                submodules = [a.name for a in node.names if f"{target}.{a.name}" in modules]
                out += [Import(module, f"{target}.{name}", node.lineno) for name in submodules]
                names = tuple(a.name for a in node.names if a.name not in submodules)
                if names:
                    out.append(Import(module, target, node.lineno, names))
    return out


def import_graph(package: str, src: Path) -> dict[str, set[str]]:
    """Module -> the modules of ``package`` it imports (at any level of the module, ``TYPE_CHECKING`` aside)."""
    graph: dict[str, set[str]] = {m: set() for m in modules_of(package, src)}
    for imp in imports_of(package, src):
        if imp.target != imp.source:
            graph[imp.source].add(imp.target)
    return graph


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan), each sorted: a cycle lives in each."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return found


def _private(name: str) -> bool:
    return name.startswith("_") and not (name.startswith("__") and name.endswith("__"))


def private_uses(package: str, src: Path) -> list[str]:
    """Where a module of ``package`` takes a private name of another: ``from .x import _y``, or ``x._y`` of a
    module ``x`` it imported (``from . import x``, ``import package.x as x``, ``package.x._y``)."""
    modules = modules_of(package, src)
    found = []
    for module, path in modules.items():
        is_package = path.name == "__init__.py"
        tree = ast.parse(path.read_text(), str(path))
        where = f"{path.relative_to(src)}"
        aliases: dict[str, str] = {}  # a local name -> the module of the package it is
        for node in _statements(tree):
            if isinstance(node, ast.ImportFrom):
                target = _absolute(module, is_package, node.level, node.module)
                if target not in modules:
                    continue
                for a in node.names:
                    if f"{target}.{a.name}" in modules:
                        aliases[a.asname or a.name] = f"{target}.{a.name}"
                    elif _private(a.name) and target != module:
                        found.append(f"{where}:{node.lineno} from {target} import {a.name}")
            elif isinstance(node, ast.Import):
                for a in node.names:
                    if a.name in modules and a.asname:  # import pkg.x as y: y is pkg.x
                        aliases[a.asname] = a.name
                    elif a.name in modules:  # import pkg.x: pkg is bound, pkg.x read through it
                        aliases[a.name.split(".")[0]] = a.name.split(".")[0]
        for node in _statements(tree):
            if not (isinstance(node, ast.Attribute) and _private(node.attr)):
                continue
            chain, value = [], node.value
            while isinstance(value, ast.Attribute):
                chain.append(value.attr)
                value = value.value
            if not isinstance(value, ast.Name) or value.id not in aliases:
                continue
            owner = ".".join([aliases[value.id], *reversed(chain)])
            if owner in modules and owner != module:
                found.append(f"{where}:{node.lineno} {owner}.{node.attr}")
    return found


def private_attributes(package: str, src: Path) -> list[str]:
    """Where a module of ``package`` reads a private attribute (``thing._name``, ``thing`` not ``self`` nor ``cls``)
    that no code of its own module defines: a function, class, method, assignment or attribute of that name there.
    Stricter than :func:`private_uses` (it sees an object's private member too: another module's helper, another
    class's state), by name: what one module keeps private, no other reads."""
    modules = modules_of(package, src)
    defined: dict[str, set[str]] = {}
    trees = {m: ast.parse(path.read_text(), str(path)) for m, path in modules.items()}
    for module, tree in trees.items():
        names: set[str] = set()
        for node in ast.walk(tree):
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef):
                names.add(node.name)
            elif isinstance(node, ast.Attribute) and isinstance(node.ctx, ast.Store):
                names.add(node.attr)
            elif isinstance(node, ast.Name) and isinstance(node.ctx, ast.Store):
                names.add(node.id)
            elif isinstance(node, ast.Constant) and isinstance(node.value, str) and _private(node.value):
                names.add(node.value)  # object.__setattr__(self, "_name", ...) on a frozen object
        defined[module] = names
    found = []
    for module, tree in trees.items():
        for node in ast.walk(tree):
            if not (isinstance(node, ast.Attribute) and _private(node.attr)):
                continue
            if isinstance(node.value, ast.Name) and node.value.id in ("self", "cls", "sys"):
                continue  # its own members; sys._getframe is the interpreter's
            if node.attr not in defined[module]:
                found.append(f"{modules[module].relative_to(src)}:{node.lineno} ._{node.attr.lstrip('_')}")
    return found


# -- the library ------------------------------------------------------------------------------------------------------


def test_the_library_imports_without_a_cycle():
    """Module-level and function-level imports alike: the statement below the program, the program below the
    schemes, nothing that reaches back (a scheme bound to a problem imports the program, never the reverse)."""
    graph = import_graph("ocpkit", SRC)
    assert graph["ocpkit.transcription.base"] and cycles(graph) == []
    below = {
        "ocpkit.statement": ("ocpkit.program", "ocpkit.transcription"),
        "ocpkit.program": ("ocpkit.transcription",),
    }
    for module, targets in graph.items():
        for layer, above in below.items():
            if module.startswith(layer):
                assert not [t for t in targets if t.startswith(above)], f"{module} imports a layer above it"


def test_no_library_module_takes_a_private_name_of_another():
    assert private_uses("ocpkit", SRC) == []
    assert private_attributes("ocpkit", SRC) == []


# -- the compendium --------------------------------------------------------------------------------------------------


def test_the_compendium_imports_without_a_cycle():
    """Function-level imports included: the layers (paths < notebook_source < provenance < outputs, report <
    notebooks) hold, and no module needs to hide an import inside a function to be importable."""
    graph = import_graph("compendium", SRC)
    assert "compendium.notebooks" in graph and graph["compendium.notebooks"], "the graph reads the compendium"
    assert cycles(graph) == []


def test_no_compendium_module_takes_a_private_name_of_another():
    assert private_uses("compendium", SRC) == []


def test_the_run_machinery_imports_only_downward_and_at_module_level():
    """notebooks, outputs and report import the compendium's modules at module level only (third-party imports
    may stay lazy), and never upward nor sideways: outputs and report share a layer, and import neither each
    other nor notebooks."""
    layer = {"paths": 0, "notebook_source": 1, "provenance": 2, "outputs": 3, "report": 3, "notebooks": 4}
    modules = modules_of("compendium", SRC)
    for name in ("notebooks", "outputs", "report"):
        module = f"compendium.{name}"
        tree = ast.parse(modules[module].read_text())
        functions = [n for n in ast.walk(tree) if isinstance(n, ast.FunctionDef | ast.AsyncFunctionDef)]
        lazy = {n.lineno for f in functions for n in ast.walk(f) if isinstance(n, ast.Import | ast.ImportFrom)}
        for imp in (i for i in imports_of("compendium", SRC) if i.source == module):
            assert imp.line not in lazy, f"{module}:{imp.line} imports {imp.target} inside a function"
            other = imp.target.removeprefix("compendium.")
            if other in layer:
                assert layer[other] < layer[name], f"{module} imports {imp.target}, a layer above or beside it"


# -- the checks themselves -------------------------------------------------------------------------------------------


def test_the_checks_find_a_cycle_hidden_in_a_function_and_a_private_name(tmp_path):
    pkg = tmp_path / "pkg"
    (pkg / "sub").mkdir(parents=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "sub" / "__init__.py").write_text("")
    (pkg / "a.py").write_text("from .b import thing\n")
    (pkg / "b.py").write_text("def f():\n    from .sub import c\n    return c\nthing = 1\n")
    (pkg / "sub" / "c.py").write_text(
        "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from ..d import Hint\nfrom .. import a\n"
    )
    (pkg / "d.py").write_text("from .a import thing\nfrom . import b\nimport pkg.b as bee\nb._x, bee._y\n")
    (pkg / "e.py").write_text("from .b import _private\nfrom .sub.c import __name__\n")
    graph = import_graph("pkg", tmp_path)
    assert graph["pkg.b"] == {"pkg.sub.c"} and graph["pkg.sub.c"] == {"pkg.a"}  # TYPE_CHECKING left out
    assert cycles(graph) == [["pkg.a", "pkg.b", "pkg.sub.c"]]
    assert sorted(x.split(" ", 1)[1] for x in private_uses("pkg", tmp_path)) == [
        "from pkg.b import _private",
        "pkg.b._x",
        "pkg.b._y",
    ]
    (pkg / "f.py").write_text("class A:\n    def _own(self):\n        return self._own, other._state\n")
    assert [x.split(" ", 1)[1] for x in private_attributes("pkg", tmp_path)] == ["._state", "._x", "._y"] or sorted(
        x.split(" ", 1)[1] for x in private_attributes("pkg", tmp_path)
    ) == ["._state", "._x", "._y"]
