"""Count how src/ is built: import cycles, arrows up the layers, long files, function-level and private imports.

The figures of the "Done when" of issue 27, counted from the imports of src/e2esim with ``ast``, module-level and
function-level imports alike:

* **import cycles**: strongly connected components of more than one module in the graph of runtime imports
  (an import under ``if TYPE_CHECKING:`` never runs and is left out; so is a function-level import whose line
  carries the marker ``# lazy: start-up time``, kept out of the module level only so that a command starts fast);
* **up-arrows**: imports (distinct importer and imported module) from a lower layer of ``LAYERS`` to a higher
  one, every import counted, lazy and type-only ones too (docs/architecture.md, "Layers", is this table);
* **files over 400 lines**;
* **function-level imports**: import statements inside a function (the lazy ones among them said apart);
* **private names across modules**: ``from e2esim.x import _name`` (dunder names excepted), each importer and
  name once;
* **duplicated blocks**: the pairs of places sharing 6 or more lines, as the ``duplicates`` command on this
  machine counts them (``duplicates --repo src --most 200``); "unavailable" where there is no such command;
* **memo dicts**: a field or attribute named ``_memo`` or ``_<something>_memo`` (a class field, ``self._memo = ...``
  or ``__dict__.setdefault("_memo", ...)``): what a ``functools.cached_property`` or the kernel memo does
  (docs/architecture.md, "Caching");
* **module caches not listed**: a module-level function under ``functools.lru_cache`` or ``functools.cache`` that
  ``CONSTANT_CACHES`` does not name: a module-level cache is allowed for a constant computed late only;
* **module-level dicts**: a module-level ``_NAME = {}`` or ``_NAME: dict = {}`` that a function of the module
  writes into (``_NAME[k] = v``, ``del _NAME[k]``, ``_NAME.update/setdefault/pop/popitem/clear(...)``): a cache kept
  outside the services' memo, or a process's state;
* **``__dict__`` writes** and **direct ``process_memo()`` calls** (docs/architecture.md, "Caching"): a value
  written into an object's ``__dict__`` (``x.__dict__[k] = v``, ``x.__dict__.setdefault/update(...)``), and a call
  of ``process_memo()`` outside ``e2esim.case`` and the runner's service set-up (``MEMO_OWNERS``): what is kept
  goes through a ``cached_property``, a field or the services' memo.

Run ``python tools/architecture_check.py`` (``--list`` names every offender; ``--json`` prints the figures);
tests/test_architecture.py holds the figures to the ratchet in tools/architecture_ratchet.json.
"""

from __future__ import annotations

import argparse
import ast
import fnmatch
import json
import re
import shutil
import subprocess
import sys
from collections import deque
from dataclasses import dataclass, field
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = "e2esim"
MAX_LINES = 400
LAZY_MARKER = "# lazy: start-up time"

# The layers, lowest first. A module imports from its own layer and the layers below it. A pattern is a dotted
# name (the module, or a package and every module in it) or a glob with "*". A module is placed by the most
# specific pattern that matches it: its own name, then a glob, then the longest package name.
# docs/architecture.md ("Layers") shows this table.
LAYERS: tuple[tuple[str, tuple[str, ...]], ...] = (
    (
        "frame",
        (
            "e2esim",
            "e2esim.errors",
            "e2esim.limits",
            "e2esim.distinct",
            "e2esim.atomic",
            "e2esim.blas_threads",
            "e2esim.allocator",
            "e2esim.input_files",
            "e2esim.io.safe_h5",  # checked reading of a user's HDF5 file: physics readers (NISAR orbits) use it too
            "e2esim.key_paths",
            "e2esim.units",
            "e2esim.case_values",
            "e2esim.settings",
            "e2esim.value_text",
            "e2esim.params",
            "e2esim.param_constraints",
            "e2esim.param_components",
            "e2esim.plugin_import",
            "e2esim.registry",
            "e2esim.module",
            "e2esim.case",
            "e2esim.block",
            "e2esim.error_model",
            "e2esim.derived",
            "e2esim.extras",
            "e2esim.kinds",
            "e2esim.memo_keys",
        ),
    ),
    (
        "physics",
        (
            "e2esim.geomag",
            "e2esim.orbit",
            "e2esim.ionosphere",
            "e2esim.polarimetry",
            "e2esim.scene",
            "e2esim.instrument",
            "e2esim.faraday",
            "e2esim.distortion",
            "e2esim.stack",
            "e2esim.budget",
            "e2esim.calibration",
            "e2esim.retrieval",
            "e2esim.requirements",
            "e2esim.error_terms",
            "e2esim.scintillation",
            "e2esim.campaign",
            "e2esim.product_inputs",  # a product's values at a pixel, read for the product-driven modules
            "e2esim.products_io.biomass_layout",  # the BIOMASS L1 names: the product-driven modules read them too
            "e2esim.products_io.biomass_annotation",
            "e2esim.products_io.pixels",  # ProductFileError and the units check the product readers share
            "e2esim.products_io.nisar_*",  # the NISAR readers: the NISAR product-driven modules read a pixel with them
            "e2esim.products_io.lut_grid",  # the bilinear interpolation the NISAR readers use
        ),
    ),
    (
        "stages",
        (
            "e2esim.products",
            "e2esim.*.modules",
            "e2esim.*.*_modules",
            "e2esim.*.stage",
            "e2esim.faraday.global_lookup",
            "e2esim.stack.retrieval",
            "e2esim.stack.multichannel_retrieval",
        ),
    ),
    ("runner", ("e2esim.runner", "e2esim.maps", "e2esim.maps.grid")),
    ("io", ("e2esim.io", "e2esim.maps.netcdf", "e2esim.products_io")),
    ("report", ("e2esim.report", "e2esim.verification", "e2esim.maps.plots")),
    (
        "front",
        (
            "e2esim.runner.outputs",
            "e2esim.runner.folder_run",
            "e2esim.results",
            "e2esim.compare",
            "e2esim.testing",
            "e2esim.docs_reference",
            "e2esim.api",
            "e2esim.flowdown",
            "e2esim.cli",
            "e2esim.__main__",
        ),
    ),
)


def _specificity(pattern: str, module: str) -> tuple[int, int]:
    kind = 2 if pattern == module else 1 if "*" in pattern else 0
    return kind, len(pattern.replace("*", ""))


def _matches(pattern: str, module: str) -> bool:
    if "*" in pattern:
        return fnmatch.fnmatchcase(module, pattern)
    return module == pattern or (pattern != PACKAGE and module.startswith(pattern + "."))


def layer_of(module: str, layers=LAYERS) -> int | None:
    """Index in ``layers`` of the layer of ``module`` (None: unplaced); two equally specific matches are an error."""
    best: list[tuple[tuple[int, int], int, str]] = []
    for index, (_, patterns) in enumerate(layers):
        best += [(_specificity(p, module), index, p) for p in patterns if _matches(p, module)]
    if not best:
        return None
    best.sort(reverse=True)
    if len(best) > 1 and best[0][0] == best[1][0] and best[0][1] != best[1][1]:
        raise ValueError(f"{module} is placed twice, by {best[0][2]!r} and {best[1][2]!r}")
    return best[0][1]


@dataclass(frozen=True)
class Import:
    importer: str
    imported: str
    name: str  # the imported name ("" for `import x`)
    line: int
    in_function: bool
    type_only: bool
    lazy: bool


@dataclass
class Figures:
    cycles: list[list[str]] = field(default_factory=list)
    up_arrows: list[Import] = field(default_factory=list)
    long_files: dict[str, int] = field(default_factory=dict)
    function_imports: list[Import] = field(default_factory=list)
    private_imports: list[Import] = field(default_factory=list)
    unplaced: list[str] = field(default_factory=list)
    duplicates: int | None = None
    dict_writes: list[str] = field(default_factory=list)  # "module:line" of each __dict__ write
    memo_calls: list[str] = field(default_factory=list)  # "module:line" of each direct process_memo() call
    memo_dicts: list[str] = field(default_factory=list)
    module_dicts: list[str] = field(default_factory=list)  # "module:line name" of each module-level dict written
    module_caches: list[str] = field(default_factory=list)
    modules: int = 0
    lines: int = 0

    def counts(self) -> dict[str, int | None]:
        return {
            "import_cycles": len(self.cycles),
            "up_arrows": len(self.up_arrows),
            "files_over_400_lines": len(self.long_files),
            "function_level_imports": len({(i.importer, i.line) for i in self.function_imports}),
            "lazy_imports": len({(i.importer, i.line) for i in self.function_imports if i.lazy}),
            "private_imports": len({(i.importer, i.name) for i in self.private_imports}),
            "unplaced_modules": len(self.unplaced),
            "duplicated_blocks": self.duplicates,
            "dict_writes": len(self.dict_writes),
            "process_memo_calls": len(self.memo_calls),
            "memo_dicts": len(self.memo_dicts),
            "module_dicts": len(self.module_dicts),
            "unlisted_module_caches": len(self.module_caches),
        }


def module_files(src: Path, package: str = PACKAGE) -> dict[str, Path]:
    """Every module of ``package`` under ``src``, by dotted name (a package by the name of its __init__)."""
    files = {}
    for path in sorted((src / package).rglob("*.py")):
        parts = list(path.relative_to(src).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        files[".".join(parts)] = path
    return files


def _parsed(path: Path) -> tuple[str, ast.Module]:
    """(text, syntax tree) of one file: ``measure`` reads and parses each file once and hands both to the counts."""
    text = path.read_text(encoding="utf-8")
    return text, ast.parse(text, filename=str(path))


def _imports_in_context(tree: ast.AST) -> list[tuple[ast.AST, bool, bool]]:
    """(node, in a function, under ``if TYPE_CHECKING:``) of each import statement of ``tree``, in ``ast.walk``'s
    order, in one pass: in a function is below a ``def`` (a ``lambda`` holds no statement); under ``TYPE_CHECKING`` is
    in the body (not the ``else``) of an ``if`` whose test names it."""
    found = []
    todo = deque([(tree, False, False)])  # breadth first, as ast.walk
    while todo:
        node, in_function, type_only = todo.popleft()
        if isinstance(node, (ast.Import, ast.ImportFrom)):
            found.append((node, in_function, type_only))
        below_function = in_function or isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda))
        guarded = ()
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            guarded = {id(statement) for statement in node.body}
        todo.extend((child, below_function, type_only or id(child) in guarded) for child in ast.iter_child_nodes(node)
                    if not isinstance(child, ast.expr))  # an expression holds no statement, so no import
    return found


def imports_of(module: str, path: Path, modules: dict[str, Path], package: str = PACKAGE,
               source: tuple | None = None) -> list[Import]:
    """The imports of one module of ``package``, each resolved to the module it loads (a submodule where the
    imported name is one, else the module or package named). source: the file's (text, tree), or None: read."""
    text, tree = source or _parsed(path)
    lines = text.splitlines()
    is_package = path.name == "__init__.py"
    found = []
    for node, in_function, type_only in _imports_in_context(tree):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = module.split(".") if is_package else module.split(".")[:-1]
                base = base[: len(base) - (node.level - 1)]
                source = ".".join(base + ([node.module] if node.module else []))
            else:
                source = node.module or ""
            targets = [
                (f"{source}.{a.name}" if f"{source}.{a.name}" in modules else source, a.name) for a in node.names
            ]
        else:
            targets = [(a.name, "") for a in node.names]
        statement = "\n".join(lines[node.lineno - 1 : (node.end_lineno or node.lineno)])
        for target, name in targets:
            if target == package or target.startswith(package + "."):
                found.append(
                    Import(
                        module,
                        target,
                        name,
                        node.lineno,
                        in_function,
                        type_only,
                        LAZY_MARKER in statement,
                    )
                )
    return found


# The module-level caches allowed: constants computed late ("module:function", docs/architecture.md, "Caching").
CONSTANT_CACHES = frozenset({
    "e2esim.cli:build_parser",  # the command-line parser
    "e2esim.products:_resolve",  # a product class by its dotted name
    "e2esim.blas_threads:_library_setters", "e2esim.blas_threads:_threads_at_first_use",  # the BLAS libraries loaded
    "e2esim.runner.provenance:_versions", "e2esim.runner.provenance:source_commit",  # the installed versions
    "e2esim.runner.journal_check:_hints",  # the type hints of a result class
    "e2esim.scene.forest_cover:land_cover_grid", "e2esim.scene.land_mask:_mask",  # shipped grids
    "e2esim.ionosphere.iri:_coefficients", "e2esim.ionosphere.iri:_expansion_orders",  # the IRI coefficients
    "e2esim.geomag.igrf:_coefficient_table", "e2esim.ionosphere.iri_inclination:_igrf_coefficient_slots",  # IGRF
    "e2esim.scintillation.defocus:width_table", "e2esim.scintillation.faraday_window:_nodes",
    "e2esim.error_terms.notch:_full_band",  # the unnotched band
    "e2esim.distortion.analytic:_trig_at_even_nodes", "e2esim.distortion.higher_order:pairing_terms",
    "e2esim.stack.residual_fourier:frequencies",  # the residual polynomials' frequencies of (passes, degree)
    "e2esim.stack.residual_fourier:_code_digest",  # the source of the modules that compute the kept coefficients
    "e2esim.runner.plaindata:_plain_dtype",  # the stored form of a numpy dtype
    "e2esim.error_terms.effect_stack:_shared_fields",  # the fields an effect class's stacked effects share
    "e2esim.verification.men2021:table2_case",  # the published tables' cases
    "e2esim.verification.quegan2018:_zone", "e2esim.verification.quegan2018:_alternative_zones",
    "e2esim.verification.quegan2018:_grid_zones",
})
_MEMO_NAME = re.compile(r"^_(\w+_)?memo$")
_CACHES = ("lru_cache", "cache")


def _targets(node) -> list:
    return node.targets if isinstance(node, ast.Assign) else [node.target]


def caching_of(module: str, path: Path, source: tuple | None = None) -> tuple[list[str], list[str]]:
    """(memo dicts: fields or attributes named ``_memo``/``_..._memo`` and class fields named ``_shared``; module-level
    caches not in ``CONSTANT_CACHES``) of one module, as "module:line name". source: (text, tree), or None: read."""
    text, tree = source or _parsed(path)
    memos, caches = [], []
    # a memo's name holds "memo" and a shared field is "_shared": most modules hold neither, nothing to walk
    for node in ast.walk(tree) if "memo" in text or "_shared" in text else ():
        names = []
        if isinstance(node, ast.ClassDef):  # a class field (a ``_shared`` dict field too: a memo handed to others)
            names = [t.id for s in node.body if isinstance(s, (ast.Assign, ast.AnnAssign)) for t in _targets(s)
                     if isinstance(t, ast.Name)]
            memos += [f"{module}:{node.lineno} {n}" for n in names if n == "_shared"]
        elif isinstance(node, (ast.Assign, ast.AnnAssign)):  # an attribute set
            names = [t.attr for t in _targets(node) if isinstance(t, ast.Attribute)]
        elif isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) and node.args:
            if node.func.attr == "setdefault" and "__dict__" in ast.unparse(node.func.value):
                names = [node.args[0].value] if isinstance(node.args[0], ast.Constant) else []
        memos += [f"{module}:{node.lineno} {n}" for n in names if isinstance(n, str) and _MEMO_NAME.match(n)]
    for node in tree.body:
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)) and f"{module}:{node.name}" not in CONSTANT_CACHES:
            for d in node.decorator_list:
                d = d.func if isinstance(d, ast.Call) else d
                if (d.attr if isinstance(d, ast.Attribute) else getattr(d, "id", "")) in _CACHES:
                    caches.append(f"{module}:{node.lineno} {node.name}")
    return memos, caches


_DICT_WRITES = ("update", "setdefault", "pop", "popitem", "clear", "__setitem__")


def module_dicts(module: str, path: Path, source: tuple | None = None) -> list[str]:
    """"module:line name" of each module-level empty dict (``_NAME = {}``, ``_NAME: dict = {}``) that a function of
    the module writes into (an item set or deleted, ``update``, ``setdefault``, ``pop``, ``popitem``, ``clear``).
    source: (text, tree), or None: read."""
    text = source[0] if source else path.read_text(encoding="utf-8")
    if "= {}" not in text:  # most modules: nothing to look for
        return []
    tree = source[1] if source else ast.parse(text, filename=str(path))
    empty = {t.id: node.lineno for node in tree.body if isinstance(node, (ast.Assign, ast.AnnAssign))
             and isinstance(node.value, ast.Dict) and not node.value.keys
             for t in _targets(node) if isinstance(t, ast.Name)}
    written = set()
    for function in ast.walk(tree):
        if not isinstance(function, (ast.FunctionDef, ast.AsyncFunctionDef)):
            continue
        for node in ast.walk(function):
            if isinstance(node, ast.Subscript) and isinstance(node.ctx, (ast.Store, ast.Del)):
                target = node.value
            elif isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) and node.func.attr in _DICT_WRITES:
                target = node.func.value
            else:
                continue
            if isinstance(target, ast.Name) and target.id in empty:
                written.add(target.id)
    return [f"{module}:{empty[name]} {name}" for name in sorted(written, key=empty.get)]


def strongly_connected(graph: dict[str, set[str]]) -> list[list[str]]:
    """Tarjan's strongly connected components of more than one node (iterative), each sorted."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    on_stack: set[str] = set()
    stack: list[str] = []
    components = []
    counter = 0
    for root in sorted(graph):
        if root in index:
            continue
        work = [(root, iter(sorted(graph.get(root, ()))))]
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
                    work.append((child, iter(sorted(graph.get(child, ())))))
                    break
                if child in on_stack:
                    low[node] = min(low[node], index[child])
            else:
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
                        components.append(sorted(component))
    return sorted(components)


MEMO_OWNERS = ("e2esim.case", "e2esim.runner.cases")
"""The modules that may call ``process_memo()``: its own, and the runner's service set-up (``default_services``)."""


def caching_offences(module: str, path: Path, source: tuple | None = None) -> tuple[list[str], list[str]]:
    """("module:line" of each ``__dict__`` write, of each direct ``process_memo()`` call) in one module. source:
    (text, tree), or None: read."""
    text = source[0] if source else path.read_text(encoding="utf-8")
    writes, calls = [], []
    if "__dict__" not in text and "process_memo" not in text:  # most modules: nothing to look for
        return writes, calls
    tree = source[1] if source else ast.parse(text, filename=str(path))

    def is_dict(node) -> bool:
        return isinstance(node, ast.Attribute) and node.attr == "__dict__"

    for node in ast.walk(tree):
        targets = node.targets if isinstance(node, ast.Assign) else \
            [node.target] if isinstance(node, (ast.AugAssign, ast.AnnAssign)) else []
        if any(isinstance(t, ast.Subscript) and is_dict(t.value) for t in targets):
            writes.append(f"{module}:{node.lineno}")
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute):
            if node.func.attr in ("setdefault", "update", "__setitem__") and is_dict(node.func.value):
                writes.append(f"{module}:{node.lineno}")
        if isinstance(node, ast.Call) and module not in MEMO_OWNERS:
            name = node.func.attr if isinstance(node.func, ast.Attribute) else getattr(node.func, "id", "")
            if name == "process_memo":
                calls.append(f"{module}:{node.lineno}")
    return writes, calls


def count_duplicates(src: Path) -> int | None:
    """Pairs of places sharing 6+ lines, by the machine's ``duplicates`` command; None where it is absent."""
    command = shutil.which("duplicates")
    if command is None:
        return None
    out = subprocess.run(
        [command, "--repo", str(src), "--most", "200", "--seconds", "120"],
        capture_output=True,
        text=True,
        check=False,
        timeout=300,
    ).stdout
    first = out.splitlines()[0] if out.strip() else ""
    if first.startswith("no duplicates"):
        return 0
    match = re.match(r"(\d+) pairs? of places", first)
    if match is None or "incomplete:" in out:
        return None
    return int(match.group(1))


def measure(src: Path = ROOT / "src", package: str = PACKAGE, layers=LAYERS, duplicates: bool = True,
            sources: dict | None = None) -> Figures:
    """The figures of ``package`` under ``src``. sources: {module: (text, tree)} of its files already read (a caller
    that reads them too), or None: each file is read and parsed here."""
    modules = module_files(src, package)
    figures = Figures(modules=len(modules))
    graph: dict[str, set[str]] = {m: set() for m in modules}
    up: dict[tuple[str, str], Import] = {}
    for module, path in modules.items():
        source = sources[module] if sources else _parsed(path)  # read and parsed once for every count
        n_lines = len(source[0].splitlines())
        figures.lines += n_lines
        if n_lines > MAX_LINES:
            figures.long_files[str(path.relative_to(src))] = n_lines
        writes, calls = caching_offences(module, path, source)
        figures.dict_writes += writes
        figures.memo_calls += calls
        memos, caches = caching_of(module, path, source)
        figures.memo_dicts += memos
        figures.module_caches += caches
        figures.module_dicts += module_dicts(module, path, source)
        own_layer = layer_of(module, layers)
        if own_layer is None:
            figures.unplaced.append(module)
        for imp in imports_of(module, path, modules, package, source):
            if imp.in_function:
                figures.function_imports.append(imp)
            if imp.name.startswith("_") and not imp.name.startswith("__") and imp.imported != module:
                figures.private_imports.append(imp)
            if imp.imported == module or imp.imported not in modules:
                continue
            if not imp.type_only and not imp.lazy:
                graph[module].add(imp.imported)
            target_layer = layer_of(imp.imported, layers)
            if own_layer is not None and target_layer is not None and target_layer > own_layer:
                up.setdefault((module, imp.imported), imp)
    figures.cycles = strongly_connected(graph)
    figures.up_arrows = sorted(up.values(), key=lambda i: (i.importer, i.imported))
    if duplicates:
        figures.duplicates = count_duplicates(src)
    return figures


# The targets of issue 27 ("Done when"); None: no target, the figure is reported.
TARGETS = {
    "import_cycles": 0,
    "up_arrows": 3,
    "files_over_400_lines": 0,
    "function_level_imports": None,
    "lazy_imports": None,
    "private_imports": 0,
    "unplaced_modules": 0,
    "duplicated_blocks": 15,
    "dict_writes": None,
    "process_memo_calls": 0,
    "memo_dicts": 0,
    "module_dicts": None,
    "unlisted_module_caches": 0,
}


RATCHET = ROOT / "tools" / "architecture_ratchet.json"


def worse_than(counts: dict[str, int | None], ratchet: dict[str, int]) -> dict[str, tuple[int, int]]:
    """The figures above their ratchet, {name: (figure, ratchet)}; a figure not counted (None) is not judged."""
    return {
        name: (counts[name], limit)
        for name, limit in ratchet.items()
        if counts.get(name) is not None and counts[name] > limit
    }


def report(figures: Figures, listing: bool = False) -> str:
    rows = [f"{figures.modules} modules, {figures.lines} lines"]
    for name, value in figures.counts().items():
        target = TARGETS.get(name)
        shown = "unavailable" if value is None else str(value)
        verdict = "" if target is None or value is None else ("  ok" if value <= target else "  over")
        rows.append(f"{name:24s} {shown:>11s}   target {'-' if target is None else '<= ' + str(target)}{verdict}")
    if listing:
        rows += ["", "cycles:"] + ["  " + " ".join(c) for c in figures.cycles]
        rows += ["up-arrows:"] + [
            f"  {i.importer}:{i.line} ({LAYERS[layer_of(i.importer)][0]}) -> {i.imported} "
            f"({LAYERS[layer_of(i.imported)][0]})"
            for i in figures.up_arrows
        ]
        rows += ["files over 400 lines:"] + [f"  {p}: {n}" for p, n in figures.long_files.items()]
        rows += ["function-level imports:"] + [
            f"  {i.importer}:{i.line} -> {i.imported} {i.name}{'  (lazy)' if i.lazy else ''}"
            for i in figures.function_imports
        ]
        rows += ["private names:"] + [
            f"  {i.importer}:{i.line} -> {i.imported} {i.name}" for i in figures.private_imports
        ]
        rows += ["unplaced modules:"] + [f"  {m}" for m in figures.unplaced]
        rows += ["__dict__ writes:"] + [f"  {w}" for w in figures.dict_writes]
        rows += ["direct process_memo() calls:"] + [f"  {c}" for c in figures.memo_calls]
        rows += ["memo dicts:"] + [f"  {m}" for m in figures.memo_dicts]
        rows += ["module-level dicts written:"] + [f"  {m}" for m in figures.module_dicts]
        rows += ["module caches not listed:"] + [f"  {m}" for m in figures.module_caches]
    return "\n".join(rows)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--src", type=Path, default=ROOT / "src", help="the folder holding the package")
    parser.add_argument("--list", action="store_true", help="name every cycle, up-arrow and offending import")
    parser.add_argument("--json", action="store_true", help="print the figures as JSON")
    parser.add_argument("--no-duplicates", action="store_true", help="skip the duplicates count")
    parser.add_argument("--ratchet", action="store_true", help=f"exit 1 where a figure is worse than {RATCHET.name}")
    args = parser.parse_args(argv)
    figures = measure(args.src, duplicates=not args.no_duplicates)
    print(json.dumps(figures.counts(), indent=1) if args.json else report(figures, args.list))
    if args.ratchet:
        worse = worse_than(figures.counts(), json.loads(RATCHET.read_text()))
        for name, (value, limit) in worse.items():
            print(f"worse than the ratchet: {name} {value} > {limit}", file=sys.stderr)
        return 1 if worse else 0
    return 0


if __name__ == "__main__":
    sys.exit(main())
