"""The package's architecture, checked on the source: layers, import cycles, module size, privacy.

Every module of ``gymtrack`` is parsed (``ast``, nothing imported) and each import -- at module
level or inside a function (a lazy import is still a dependency) -- is resolved to the module it
names. Checked:

* layers: ``cli > batch > eval > analysis, export > pose, models > tracking, simulate > formats > geometry > core`` (core = the
  top-level modules ``gymtrack/*.py``); a package imports only from lower layers or itself, so
  ``tracking`` and ``simulate`` (one layer) do not import each other. ``gymtrack/__init__.py``
  is the public facade above every layer (it may re-export from any package; nothing inside
  the package imports it).
* no import cycle between packages, and none between modules (package ``__init__`` modules left
  out: a package that imports its submodules to register them is not a cycle that can bite);
* no module over 450 lines;
* no name starting with ``_`` imported from outside the package that owns it (a private module
  such as ``tracking._compiled`` belongs to ``tracking``; a private function to its module's package).

Offenders that other branches are removing are listed in :data:`ALLOWED`; each entry must still
be an offence (a stale entry fails), so the list only shrinks.
"""

from __future__ import annotations

import ast
from collections import defaultdict
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1] / "gymtrack"
MAX_LINES = 450

#: Layer of each package (higher imports lower); "core" = the top-level modules gymtrack/*.py.
LAYERS: dict[str, int] = {
    "core": 0,
    "geometry": 1,
    "formats": 2,
    "tracking": 3,
    "simulate": 3,
    "pose": 4,
    "models": 4,
    "analysis": 5,
    "export": 5,
    "eval": 6,
    "batch": 7,
    "cli": 8,
}
FACADE = "gymtrack"  # gymtrack/__init__.py: the public API, above every layer

#: Offenders tolerated for now (none now); an entry must still be an offence, so the list only shrinks.
ALLOWED: dict[str, set[str]] = {
    "size": set(),
    "private": set(),
    "layer": set(),
    "cycle": set(),
}


# ----------------------------------------------------------------------------- the import graph
def _modules() -> dict[str, Path]:
    out = {}
    for path in sorted(ROOT.rglob("*.py")):
        rel = path.relative_to(ROOT.parent).with_suffix("")
        parts = list(rel.parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out[".".join(parts)] = path
    return out


MODULES = _modules()


def _is_package(name: str) -> bool:
    return MODULES.get(name, Path()).name == "__init__.py"


def _own_package(module: str) -> str:
    """The package a module belongs to: itself for a package's ``__init__``, else its parent."""
    return module if _is_package(module) else module.rpartition(".")[0]


def _resolve(module: str, node: ast.ImportFrom) -> str:
    base = module if _is_package(module) else module.rpartition(".")[0]
    for _ in range(node.level - 1):
        base = base.rpartition(".")[0]
    if node.level == 0:
        return node.module or ""
    return f"{base}.{node.module}" if node.module else base


def _imports(module: str) -> list[tuple[str, int]]:
    """Every gymtrack dotted path ``module`` imports (a module, or ``module.name`` for a name), with its line."""
    tree = ast.parse(MODULES[module].read_text(), filename=str(MODULES[module]))
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out += [(a.name, node.lineno) for a in node.names if a.name.split(".")[0] == "gymtrack"]
        elif isinstance(node, ast.ImportFrom):
            src = _resolve(module, node)
            if src.split(".")[0] == "gymtrack":
                out += [(f"{src}.{a.name}", node.lineno) for a in node.names if a.name != "*"]
    return out


def _target_module(path: str) -> str:
    """The module a dotted import path lands in: the path itself when it is a module, else its
    longest prefix that is one (``gymtrack.eval.report.fmt`` -> ``gymtrack.eval.report``)."""
    while path and path not in MODULES:
        path = path.rpartition(".")[0]
    return path


def _package(module: str) -> str:
    """The layer package of a module: ``core`` for gymtrack/*.py, else its first sub-package."""
    if module == FACADE:
        return FACADE
    parts = module.split(".")
    return parts[1] if _is_package(".".join(parts[:2])) else "core"


EDGES: list[tuple[str, str, str, int]] = []  # (importer, imported path, imported module, line)
for _m in MODULES:
    for _path, _line in _imports(_m):
        EDGES.append((_m, _path, _target_module(_path), _line))


def _where(importer: str, line: int) -> str:
    return f"{MODULES[importer].relative_to(ROOT.parent)}:{line}"


def _find_cycle(graph: dict[str, set[str]]) -> list[str] | None:
    """One cycle of ``graph`` (as a list of nodes, first repeated last), or None."""
    state: dict[str, int] = {}
    stack: list[str] = []

    def visit(n: str) -> list[str] | None:
        state[n] = 1
        stack.append(n)
        for m in sorted(graph.get(n, ())):
            if state.get(m) == 1:
                return stack[stack.index(m):] + [m]
            if m not in state:
                found = visit(m)
                if found:
                    return found
        stack.pop()
        state[n] = 2
        return None

    for n in sorted(graph):
        if n not in state:
            found = visit(n)
            if found:
                return found
    return None


def _check(kind: str, offences: dict[str, str]) -> None:
    """Fail on offences outside ``ALLOWED[kind]`` and on allow-list entries that are no longer offences."""
    new = {k: v for k, v in offences.items() if k not in ALLOWED[kind]}
    stale = ALLOWED[kind] - set(offences)
    assert not new, f"{kind} offences:\n" + "\n".join(f"  {k}: {v}" for k, v in sorted(new.items()))
    assert not stale, f"ALLOWED[{kind!r}] lists what is no longer an offence (remove it): {sorted(stale)}"


# ----------------------------------------------------------------------------- the checks
def test_the_graph_is_read():
    """The parser sees the modules and the imports it is meant to check (a broken walk would pass everything)."""
    assert {"gymtrack.scene", "gymtrack.tracking.tracker", "gymtrack.formats.calibration"} <= set(MODULES)
    assert _is_package("gymtrack.formats.calibration") and not _is_package("gymtrack.scene")
    assert _package("gymtrack.scene") == "core" and _package("gymtrack.formats.calibration.native") == "formats"
    got = {(i, t) for i, _, t, _ in EDGES}
    assert ("gymtrack.tracking.tracker", "gymtrack.scene") in got  # from ..scene import Scene
    assert ("gymtrack.formats.calibration.native", "gymtrack.formats.calibration.checks") in got
    assert _target_module("gymtrack.eval.render.fmt") == "gymtrack.eval.render"


def test_every_package_has_a_layer():
    unknown = {_package(m) for m in MODULES} - set(LAYERS) - {FACADE}
    assert not unknown, f"packages without a layer (add them to LAYERS): {sorted(unknown)}"


def test_no_import_from_a_higher_layer():
    offences = {}
    for importer, path, target, line in EDGES:
        a, b = _package(importer), _package(target)
        if a == b or a == FACADE:
            continue
        if b == FACADE:
            offences[f"{importer} -> {path}"] = f"{_where(importer, line)} imports the facade gymtrack/__init__.py"
        elif LAYERS[b] >= LAYERS[a]:
            offences[f"{importer} -> {target}"] = f"{_where(importer, line)}: {a} (layer {LAYERS[a]}) imports {b} (layer {LAYERS[b]})"
    _check("layer", offences)


def test_no_import_cycles():
    packages: dict[str, set[str]] = defaultdict(set)
    modules: dict[str, set[str]] = defaultdict(set)
    for importer, _, target, _ in EDGES:
        if _package(importer) != _package(target):
            packages[_package(importer)].add(_package(target))
        if target != importer and not _is_package(importer) and not _is_package(target):
            modules[importer].add(target)
    offences = {}
    for kind, graph in (("packages", packages), ("modules", modules)):
        cycle = _find_cycle(graph)
        if cycle:
            offences[" -> ".join(cycle)] = f"import cycle between {kind}"
    _check("cycle", offences)


def test_no_module_over_the_size_limit():
    offences = {}
    for m, path in MODULES.items():
        n = len(path.read_text().splitlines())
        if n > MAX_LINES:
            offences[m] = f"{path.relative_to(ROOT.parent)} has {n} lines (limit {MAX_LINES})"
    _check("size", offences)


def _private_owner(path: str) -> str | None:
    """The package owning the first private component of a dotted path, or None if all are public."""
    parts = path.split(".")
    for i, p in enumerate(parts):
        if p.startswith("_") and not (p.startswith("__") and p.endswith("__")):
            prefix = ".".join(parts[:i])
            if ".".join(parts[: i + 1]) in MODULES:  # a private module or sub-package
                return prefix
            return _own_package(prefix)  # a private name inside the module ``prefix``
    return None


def test_no_private_name_imported_from_another_package():
    offences = {}
    for importer, path, target, line in EDGES:
        owner = _private_owner(path)
        mine = _own_package(importer)
        if owner is not None and mine != owner and not mine.startswith(owner + "."):
            offences[f"{importer} -> {path}"] = f"{_where(importer, line)} imports a private name of {owner}"
    _check("private", offences)


@pytest.mark.parametrize("path, owner", [
    ("gymtrack.eval.report._fmt", "gymtrack.eval"),
    ("gymtrack.tracking._compiled", "gymtrack.tracking"),
    ("gymtrack.tracking._compiled.plane_kernel", "gymtrack.tracking"),
    ("gymtrack.formats.calibration.checks.as_array", None),
    ("gymtrack.__version__", None),
])
def test_private_owner(path, owner):
    """A private function belongs to its module's package; a private module to the package holding it."""
    assert _private_owner(path) == owner


def test_every_module_has_a_docstring():
    missing = [str(p.relative_to(ROOT.parent)) for p in MODULES.values() if not ast.get_docstring(ast.parse(p.read_text()))]
    assert not missing, f"modules without a docstring: {missing}"
