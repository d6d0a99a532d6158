"""The layout holds (issue 9): no import cycle between modules (a package's
__init__ counts as imported with any of its modules), no private name
imported across modules, only Optuna's public API, and lower layers never
import higher ones."""
from __future__ import annotations

import ast
import collections
import re
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1] / "modesel"

#: layer of each top-level part of the package; a module may import only its
#: own layer or lower ones (the README's Layout section)
LAYERS = {
    "errors": 0, "files": 0, "vocabulary": 0, "engine_cache": 0, "forwarding": 0, "modeset": 1, "candidates": 1, "multibody": 2,
    "turbine": 3, "aero": 3, "model": 4, "simulation": 5, "study": 6, "export": 6,
    "search": 7, "convergence": 7, "commands": 8, "cli": 9, "server": 10, "__main__": 10, "": 10,
}


def _modules() -> dict:
    out = {}
    for path in PACKAGE.rglob("*.py"):
        parts = ("modesel",) + path.relative_to(PACKAGE).with_suffix("").parts
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out[".".join(parts)] = path
    return out


MODULES = _modules()


def _resolve(name: str) -> str | None:
    parts = name.split(".")
    for k in range(len(parts), 0, -1):
        candidate = ".".join(parts[:k])
        if candidate in MODULES:
            return candidate
    return None


def _imports(name: str):
    """(target module, imported name or None, node) of every modesel import in module `name`."""
    tree = ast.parse(MODULES[name].read_text())
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("modesel"):
            for alias in node.names:
                yield _resolve(f"{node.module}.{alias.name}") or _resolve(node.module), alias.name, node
        elif isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name.startswith("modesel"):
                    yield _resolve(alias.name), None, node


def _graph() -> dict:
    edges = collections.defaultdict(set)
    for name in MODULES:
        for target, _, _ in _imports(name):
            if not target:
                continue
            if target != name:
                edges[name].add(target)
            parts = target.split(".")
            for k in range(2, len(parts)):           # the packages importing the target runs first
                pkg = ".".join(parts[:k])            # (a module's own packages are running already)
                if pkg in MODULES and pkg != name and not name.startswith(pkg + "."):
                    edges[name].add(pkg)
    return edges


def _cycles(edges) -> list:
    index, low, stack, on, found = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in edges[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for v in sorted(MODULES):
        if v not in index:
            visit(v)
    return found


def test_no_import_cycle():
    assert _cycles(_graph()) == []


def test_no_private_name_imported_across_modules():
    bad = [(name, target, imported) for name in MODULES for target, imported, _ in _imports(name)
           if imported and imported.startswith("_") and not imported.startswith("__") and target != name]
    assert bad == []


def test_only_public_optuna_api():
    pattern = re.compile(r"\._storage\b|\._trial_id\b|optuna\.\w+\._|from optuna[\w.]*\._|import _")
    bad = [(str(path.relative_to(PACKAGE)), line.strip()) for path in MODULES.values()
           for line in path.read_text().splitlines() if pattern.search(line)]
    assert bad == []


def _layer(name: str) -> int:
    part = name.split(".")[1] if "." in name else ""
    return LAYERS[part]


def test_lower_layers_never_import_higher_ones():
    bad = [(name, target) for name in MODULES for target, _, _ in _imports(name)
           if target and _layer(target) > _layer(name)]
    assert bad == []
