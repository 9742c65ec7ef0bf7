"""The Python package planetwear_fmu reads as a pipeline: its modules form
layers and a module imports only modules of a lower layer, lazy imports
inside functions included, so no two modules import each other.

The checks read the sources with `ast` (nothing is imported): every Import
and ImportFrom node, at any depth, relative (`from . import x`,
`from .x import y`) or absolute (`import planetwear_fmu.x`,
`from planetwear_fmu.x import y`), and calls of `__import__` or
`importlib.import_module` with a constant name. A new module must be given
a layer in LAYERS; the layers are described in planetwear_fmu/__init__.py.
"""

from __future__ import annotations

import ast
import importlib
import tomllib
from pathlib import Path

PACKAGE = "planetwear_fmu"
PACKAGE_DIR = Path(__file__).resolve().parents[2] / "python" / PACKAGE

# Module → layer. A module may import only modules of a strictly lower layer.
LAYERS = {
    # Imports nothing of the package: importing any module runs it first.
    "__init__": 0,
    # write_atomic, sha256_file.
    "files": 0,
    # The optional extras and the check that one is installed.
    "extras": 0,
    # The campaign file and the worn-profile state's format.
    "campaign_file": 1,
    # The duty-cycle document the FMU gives (dutyCycle) and its file.
    "duty": 1,
    # FMU access and results: the FMU's verdict and the full check of a
    # campaign file (load_campaign), one task, the plots, the regression kit.
    "fmu_check": 2,
    "sweep": 2,
    "plots": 2,
    "regression": 2,
    # A campaign on Dask.
    "runner": 3,
    # Front ends.
    "loop": 4,
    # The drive cycle through the FMU in its steady fidelity, and its wear loop.
    "drive_cycle": 4,
    "bench": 4,
    "pytest_plugin": 4,
    # The command line (python -m planetwear_fmu.campaign, planetwear-campaign).
    "campaign": 5,
}


def package_modules():
    """{module name: source path} of the package (a flat package: a
    subpackage would need this test extended)."""
    subpackages = [p for p in PACKAGE_DIR.iterdir() if p.is_dir() and any(p.rglob("*.py"))]
    assert not subpackages, f"{PACKAGE} has subpackages {subpackages}: extend this test to name their modules"
    return {p.stem: p for p in sorted(PACKAGE_DIR.glob("*.py"))}


def _target(dotted, modules):
    """The package module that an absolute name imports, or None outside
    the package; `planetwear_fmu` alone is the package's __init__."""
    parts = dotted.split(".")
    if parts[0] != PACKAGE:
        return None
    if len(parts) == 1:
        return "__init__"
    return parts[1] if parts[1] in modules else f"{parts[1]} (no such module)"


def imports_of(source, filename, modules):
    """[(imported module, line, where)] of one module's source, `where`
    naming the function an import is made in ('module level' otherwise)."""
    found = []

    def add(target, node, scope):
        if target is not None:
            found.append((target, node.lineno, f"in {'.'.join(scope)}()" if scope else "at module level"))

    def visit(node, scope):
        if isinstance(node, ast.Import):
            for alias in node.names:
                add(_target(alias.name, modules), node, scope)
        elif isinstance(node, ast.ImportFrom):
            if node.level == 0:
                base = node.module or ""
            elif node.level == 1:
                # Every module is a top-level module of the package.
                base = PACKAGE + (f".{node.module}" if node.module else "")
            else:
                found.append((f"(a relative import of level {node.level}, outside {PACKAGE})", node.lineno,
                              "here"))
                return
            if base == PACKAGE:
                # `from planetwear_fmu import x`: the module x, or a name of __init__.
                for alias in node.names:
                    add(alias.name if alias.name in modules else "__init__", node, scope)
            else:
                add(_target(base, modules), node, scope)
        elif isinstance(node, ast.Call):
            f = node.func
            name = f.id if isinstance(f, ast.Name) else f.attr if isinstance(f, ast.Attribute) else None
            args = node.args
            if name in ("__import__", "import_module") and args and isinstance(args[0], ast.Constant) \
                    and isinstance(args[0].value, str):
                dotted = args[0].value
                if dotted.startswith(".") and len(args) > 1 and isinstance(args[1], ast.Constant):
                    dotted = f"{args[1].value}{dotted}"
                add(_target(dotted, modules), node, scope)
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            scope = scope + [node.name]
        for child in ast.iter_child_nodes(node):
            visit(child, scope)

    visit(ast.parse(source, filename=filename), [])
    return found


def import_graph(sources):
    """{module: [(imported module, line, where)]} of {module: (source, file name)}."""
    return {m: imports_of(src, fn, sources) for m, (src, fn) in sources.items()}


def layer_violations(graph, layers, filenames):
    """One message per import of a module not in a lower layer."""
    bad = []
    for m, edges in graph.items():
        for target, line, where in edges:
            if target not in layers:
                bad.append(f"{filenames[m]}:{line} ({where}) imports {target}, which is not a module with a layer "
                           f"in LAYERS")
            elif layers[target] >= layers[m]:
                bad.append(f"{filenames[m]}:{line} ({where}) imports {target} ({filenames.get(target, target)}, "
                           f"layer {layers[target]}), but {m} is in layer {layers[m]}: a module may import only "
                           "modules of a lower layer")
    return bad


def find_cycle(graph, filenames):
    """An import cycle as ['a.py:line imports b', …], or None."""
    state = {}  # module → "open" (on the path) or "done"
    path = []  # [(module, line of its import of the next module)]

    def dfs(m):
        state[m] = "open"
        for target, line, _ in graph.get(m, []):
            if target not in graph:
                continue
            path.append((m, line, target))
            if state.get(target) == "open":
                start = next(i for i, (a, _, _) in enumerate(path) if a == target)
                return [f"{filenames[a]}:{ln} imports {b}" for a, ln, b in path[start:]]
            if target not in state:
                cycle = dfs(target)
                if cycle:
                    return cycle
            path.pop()
        state[m] = "done"
        return None

    for m in sorted(graph):
        if m not in state:
            cycle = dfs(m)
            if cycle:
                return cycle
    return None


def _package():
    modules = package_modules()
    sources = {m: (p.read_text(encoding="utf-8"), str(p)) for m, p in modules.items()}
    filenames = {m: f"python/{PACKAGE}/{p.name}" for m, p in modules.items()}
    return import_graph(sources), filenames


def test_every_module_of_the_package_has_a_layer():
    modules = set(package_modules())
    missing = sorted(modules - set(LAYERS))
    stale = sorted(set(LAYERS) - modules)
    assert not missing, (f"modules of {PACKAGE} without a layer: {', '.join(missing)}; place each in LAYERS "
                         f"(tests/python/test_package_layers.py) and say in its docstring what it may import")
    assert not stale, f"LAYERS names modules {PACKAGE} does not have: {', '.join(stale)}"


def test_the_package_imports_follow_the_layers():
    graph, filenames = _package()
    bad = layer_violations(graph, LAYERS, filenames)
    assert not bad, "imports against the layer order:\n" + "\n".join(f"  - {b}" for b in bad)
    edges = sum(len(e) for e in graph.values())
    print(f"{len(graph)} modules, {edges} imports within {PACKAGE}, all to a lower layer")


def test_the_package_has_no_import_cycle():
    graph, filenames = _package()
    cycle = find_cycle(graph, filenames)
    assert cycle is None, "import cycle:\n" + "\n".join(f"  - {c}" for c in cycle)


def test_the_checks_catch_a_back_import_and_a_cycle():
    """The checks themselves: a lazy import from a lower module of a higher
    one is reported with file and line, and the circle it closes is found."""
    sources = {
        "__init__": ("", "__init__.py"),
        "low": ("import json\n\n\ndef f():\n    from .high import g\n    return g\n", "low.py"),
        "high": ("from . import low\nfrom planetwear_fmu.low import f\n", "high.py"),
        "other": ("import planetwear_fmu.low\n__import__('planetwear_fmu.high')\n", "other.py"),
    }
    filenames = {m: fn for m, (_, fn) in sources.items()}
    graph = import_graph(sources)
    assert sorted((t, ln) for t, ln, _ in graph["high"]) == [("low", 1), ("low", 2)]
    assert sorted((t, ln) for t, ln, _ in graph["other"]) == [("high", 2), ("low", 1)]
    bad = layer_violations(graph, {"__init__": 0, "low": 1, "high": 2, "other": 3}, filenames)
    assert len(bad) == 1 and bad[0].startswith("low.py:5 (in f()) imports high (high.py, layer 2)"), bad
    cycle = find_cycle(graph, filenames)
    assert cycle is not None and sorted(cycle) == ["high.py:1 imports low", "low.py:5 imports high"], cycle
    del sources["low"]
    graph = import_graph({**sources, "low": ("import json\n", "low.py")})
    assert find_cycle(graph, filenames) is None


def test_the_entry_points_of_the_pyproject_exist():
    """The console script and the pytest plugin that python/pyproject.toml
    names resolve to objects of the package."""
    project = tomllib.loads((PACKAGE_DIR.parent / "pyproject.toml").read_text())["project"]
    targets = list(project.get("scripts", {}).values())
    for group in project.get("entry-points", {}).values():
        targets += list(group.values())
    assert targets
    for target in targets:
        module, _, attr = target.partition(":")
        obj = importlib.import_module(module)
        for part in filter(None, attr.split(".")):
            obj = getattr(obj, part)
        assert obj is not None, target


# Top-level module → the distribution that provides it, for every
# third-party import of the package.
DISTRIBUTION_OF = {
    "fmpy": "fmpy",
    "pyarrow": "pyarrow",
    "distributed": "dask",
    "dask": "dask",
    "tqdm": "tqdm",
    "matplotlib": "matplotlib",
}
# Imported only where its own host loads it: the pytest plugin runs inside pytest.
PROVIDED_BY_HOST = {"pytest"}


def third_party_imports():
    """{top-level module: [file:line]} of every import outside the standard
    library and the package, lazy imports included."""
    import sys

    found = {}
    for name, path in package_modules().items():
        for node in ast.walk(ast.parse(path.read_text(), filename=path.name)):
            if isinstance(node, ast.Import):
                tops = [a.name.split(".")[0] for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                tops = [node.module.split(".")[0]]
            else:
                continue
            for top in tops:
                if top != PACKAGE and top not in sys.stdlib_module_names and top != "__future__":
                    found.setdefault(top, []).append(f"{path.name}:{node.lineno}")
    return found


def _requirement_name(req):
    """The distribution name of a requirement string ('dask[distributed]>=1' → 'dask')."""
    import re

    return re.split(r"[\[<>=!~; ]", req, maxsplit=1)[0].lower()


def test_every_third_party_import_is_declared_in_the_pyproject():
    """`pip install ./python` (with the extras the module's part needs)
    installs everything the package imports: each third-party import maps
    to a distribution named in `dependencies` or in an optional extra, and
    the `extras` module's table agrees with the pyproject's extras."""
    from planetwear_fmu import extras

    project = tomllib.loads((PACKAGE_DIR.parent / "pyproject.toml").read_text())["project"]
    base = {_requirement_name(r) for r in project["dependencies"]}
    optional = {k: {_requirement_name(r) for r in v} for k, v in project["optional-dependencies"].items()}
    declared = base.union(*optional.values())
    imports = third_party_imports()
    assert {"fmpy", "pyarrow", "distributed", "matplotlib"} <= set(imports), imports
    for top, where in imports.items():
        if top in PROVIDED_BY_HOST:
            continue
        assert top in DISTRIBUTION_OF, f"{top} (imported at {', '.join(where)}): name its distribution here"
        assert DISTRIBUTION_OF[top] in declared, (
            f"{top} (imported at {', '.join(where)}) comes from {DISTRIBUTION_OF[top]}, which "
            f"python/pyproject.toml declares neither in dependencies nor in an extra")
    for extra, modules in extras.EXTRAS.items():
        assert extra in optional, f"extras.EXTRAS names '{extra}', which the pyproject does not declare"
        for m in modules:
            assert DISTRIBUTION_OF[m] in optional[extra], f"module {m} of extra '{extra}' is not installed by it"


def test_a_missing_extra_is_named_with_its_install_command(monkeypatch):
    """A command that needs an extra which is not installed stops with the
    extra's name, the missing module and the pip command."""
    import importlib.util

    import pytest

    from planetwear_fmu import extras

    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec", lambda n, *a: None if n == "matplotlib" else real(n, *a))
    assert extras.missing("plot") == ["matplotlib"]
    with pytest.raises(extras.MissingExtra, match=r"the 'plot' extra .*missing: matplotlib.*pip install"):
        extras.require("plot", "the campaign's plots")
