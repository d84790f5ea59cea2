"""The maps wing (issue 27, Build 5): map sweeps, their results.nc and their plots live in ``e2esim.maps``, sit in
no import cycle (function-level imports counted) and import no private name of another module."""

import ast
import functools
from pathlib import Path

SRC = Path(__file__).resolve().parents[1] / "src"


def _module(path: Path) -> str:
    parts = path.relative_to(SRC).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


@functools.cache  # parsed once for the module's tests (neither changes what it returns)
def _imports() -> dict:
    """{module: {(imported module, name or None)}} of every import in src/e2esim, at any level of the file."""
    modules = {_module(p): p for p in SRC.rglob("*.py")}
    out = {}
    for name, path in modules.items():
        found = set()
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Import):
                found |= {(a.name, None) for a in node.names if a.name in modules}
            elif isinstance(node, ast.ImportFrom) and node.module and not node.level:
                for alias in node.names:
                    target = f"{node.module}.{alias.name}"
                    found.add((target, None) if target in modules else (node.module, alias.name))
        out[name] = {(m, n) for m, n in found if m in modules and m != name}
    return out


def _reaches(graph: dict, start: str) -> set:
    seen, todo = set(), [start]
    while todo:
        for nxt in graph[todo.pop()]:
            if nxt not in seen:
                seen.add(nxt)
                todo.append(nxt)
    return seen


def test_the_maps_wing_and_the_outputs_sit_in_no_import_cycle():
    imports = _imports()
    graph = {m: {target for target, _ in found} for m, found in imports.items()}
    wing = {m for m in graph if m.startswith("e2esim.maps")}
    assert {"e2esim.maps.grid", "e2esim.maps.netcdf", "e2esim.maps.plots"} <= wing
    for module in sorted(wing | {"e2esim.results", "e2esim.runner.outputs", "e2esim.runner.sweep",
                                 "e2esim.report.plots", "e2esim.runner.folder_run"}):
        assert module not in _reaches(graph, module), f"{module} imports itself through others"


def test_the_maps_wing_imports_no_private_name_and_is_imported_by_none():
    imports = _imports()
    for module, found in imports.items():
        for target, name in found:
            if module.startswith("e2esim.maps") or target.startswith("e2esim.maps"):
                assert name is None or not name.startswith("_"), f"{module} imports {target}.{name}"
