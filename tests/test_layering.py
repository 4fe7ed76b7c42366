"""Dependencies point one way (docs/design.md, "Layers"): read from the sources with ``ast``, so
an import inside a function counts too, and one behind TYPE_CHECKING too unless a test says
otherwise."""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
# folder -> the import names it must never import (prefixes): the packages' order, and the
# controllers' distance from any env (docs/design.md); the order inside each package is
# test_imports_follow_the_layers_of_design_md's
FORBIDDEN = {
    "quad_dob_env": ("quad_dob_baselines", "quad_dob_composition", "quad_dob_training"),
    "baselines": ("quad_dob_env.envs", "quad_dob_env.wrappers", "quad_dob_composition",
                  "quad_dob_training"),
    "composition": ("quad_dob_training",),
}
# the public API of named tuples, whose names start with an underscore by design
NAMEDTUPLE_API = {"_replace", "_asdict", "_fields", "_make", "_field_defaults"}


def _modules(folder: str) -> list[Path]:
    return sorted((ROOT / folder).rglob("*.py"))


def _imported(tree: ast.AST) -> list[str]:
    names = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names += [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names += [node.module] + [f"{node.module}.{alias.name}" for alias in node.names]
    return names


@pytest.mark.parametrize("folder", list(FORBIDDEN))
def test_no_module_imports_a_layer_above_it(folder):
    offences = []
    for path in _modules(folder):
        for name in _imported(ast.parse(path.read_text())):
            if any(name == bad or name.startswith(bad + ".") for bad in FORBIDDEN[folder]):
                offences.append(f"{path.relative_to(ROOT)} imports {name}")
            if folder == "baselines" and "residual" in name:
                offences.append(f"{path.relative_to(ROOT)} imports {name} (the residual)")
    assert not offences, "\n".join(offences)


def _private_reads(tree: ast.AST) -> list[ast.Attribute]:
    """``x._name`` for any ``x`` but ``self`` and ``cls`` (dunders and the named-tuple API
    aside)."""
    return [node for node in ast.walk(tree)
            if isinstance(node, ast.Attribute) and node.attr.startswith("_")
            and not node.attr.startswith("__") and node.attr not in NAMEDTUPLE_API
            and not (isinstance(node.value, ast.Name) and node.value.id in ("self", "cls"))]


@pytest.mark.parametrize("folder", ["quad_dob_env", "baselines", "composition", "training"])
def test_no_module_reads_another_objects_private_attributes(folder):
    offences = [f"{path.relative_to(ROOT)}:{node.lineno} {ast.unparse(node)}"
                for path in _modules(folder)
                for node in _private_reads(ast.parse(path.read_text()))]
    assert not offences, "\n".join(offences)


def test_the_scans_catch_what_they_look_for():
    # the same scans on sources that break each rule
    bad_import = ast.parse("def f():\n    from quad_dob_baselines import make_controller\n")
    assert "quad_dob_baselines" in _imported(bad_import)
    private = ast.parse("x = observer._ks\ny = self._ks\nz = t._replace(a=1)\n")
    assert [ast.unparse(node) for node in _private_reads(private)] == ["observer._ks"]


def test_no_module_leans_on_compiler_internals():
    # multi-core stepping through public APIs only: no llvmlite symbol binding, no numba.core
    offences = [f"{path.relative_to(ROOT)} imports {name}"
                for folder in ("quad_dob_env", "baselines", "composition", "training")
                for path in _modules(folder)
                for name in _imported(ast.parse(path.read_text()))
                if name.split(".")[0] == "llvmlite" or name.startswith("numba.core")]
    assert not offences, offences


# Brax's one state record, in spirit: a compiled function takes records read by field name
# (named tuples), not long positional lists (issue 52)
MAX_KERNEL_PARAMETERS = 20
KERNEL_FOLDERS = ("quad_dob_env", "baselines", "composition")


def _compiled_functions(tree: ast.AST) -> list[ast.FunctionDef]:
    """The functions decorated ``@njit`` (bare, called, or as ``numba.njit``)."""
    def is_njit(decorator: ast.expr) -> bool:
        target = decorator.func if isinstance(decorator, ast.Call) else decorator
        return ast.unparse(target).split(".")[-1] == "njit"

    return [node for node in ast.walk(tree) if isinstance(node, ast.FunctionDef)
            and any(is_njit(decorator) for decorator in node.decorator_list)]


def _parameter_count(function: ast.FunctionDef) -> int:
    """Its parameters, a ``*rest`` counting one."""
    arguments = function.args
    return (len(arguments.posonlyargs) + len(arguments.args) + len(arguments.kwonlyargs)
            + (arguments.vararg is not None) + (arguments.kwarg is not None))


def _long_kernels(paths: list[Path]) -> list[str]:
    return [f"{path.relative_to(ROOT)}:{function.lineno} {function.name} "
            f"({_parameter_count(function)} parameters)"
            for path in paths for function in _compiled_functions(ast.parse(path.read_text()))
            if _parameter_count(function) > MAX_KERNEL_PARAMETERS]


def test_no_compiled_function_takes_more_than_20_parameters():
    offences = _long_kernels([path for folder in KERNEL_FOLDERS for path in _modules(folder)])
    assert not offences, "\n".join(offences)


def test_the_parameter_scan_counts_what_numba_compiles():
    names = ", ".join(f"a{k}" for k in range(20))
    tree = ast.parse(f"@njit(cache=True)\ndef wide({names}, extra): pass\n"
                     f"@numba.njit\ndef wider({names}, *rest): pass\n"
                     f"@njit\ndef fits({names}): pass\n"
                     f"def plain({names}, extra): pass\n")
    assert {function.name: _parameter_count(function)
            for function in _compiled_functions(tree)} == {"wide": 21, "wider": 21, "fits": 20}


PACKAGE_FOLDERS = ("quad_dob_env", "baselines", "composition", "training")


def _packages() -> list[Path]:
    return sorted(init.parent for folder in PACKAGE_FOLDERS
                  for init in (ROOT / folder).rglob("__init__.py"))


@pytest.mark.parametrize("package", _packages(), ids=lambda p: str(p.relative_to(ROOT)))
def test_each_package_docstring_lists_its_modules(package):
    # docs/design.md's map stops at the packages; each package's docstring names what lives
    # in it, so a module added without a line there fails here
    docstring = ast.get_docstring(ast.parse((package / "__init__.py").read_text())) or ""
    members = [path.stem for path in package.glob("*.py") if not path.stem.startswith("__")]
    members += [path.name for path in package.iterdir() if (path / "__init__.py").exists()]
    missing = [name for name in sorted(members)
               if not re.search(rf"(?<![\w.]){re.escape(name)}(?!\w)", docstring)]
    assert not missing, f"{package.relative_to(ROOT)}'s docstring does not name {missing}"


def test_no_import_circle_among_the_packages_modules():
    # a circle makes a module's meaning depend on which end was imported first; imports
    # inside functions count, those under TYPE_CHECKING do not
    graph = _import_graph()
    assert not _circles(graph), _circles(graph)


def test_the_circle_scan_finds_a_circle():
    assert _circles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]


INSTALLED_NAMES = {"quad_dob_env": "quad_dob_env", "baselines": "quad_dob_baselines",
                   "composition": "quad_dob_composition", "training": "quad_dob_training"}


def _module_names(packages: dict[Path, str] | None = None) -> dict[str, Path]:
    """Every module by its import name, of ``packages`` (folder -> installed name; the four
    by default)."""
    if packages is None:
        packages = {ROOT / folder: name for folder, name in INSTALLED_NAMES.items()}
    modules = {}
    for folder, name in packages.items():
        for path in folder.rglob("*.py"):
            parts = [name, *path.relative_to(folder).with_suffix("").parts]
            modules[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = path
    return modules


def _import_graph(modules: dict[str, Path] | None = None,
                  type_checking: bool = False) -> dict[str, set[str]]:
    """Module -> the modules it imports, anywhere in it; those under TYPE_CHECKING only with
    ``type_checking``."""
    modules = _module_names() if modules is None else modules

    def resolve(name: str) -> str | None:
        while name and name not in modules:
            name = name.rpartition(".")[0]
        return name or None

    graph = {}
    for module, path in modules.items():
        tree = ast.parse(path.read_text())
        skipped = set() if type_checking else {
            id(node) for block in ast.walk(tree) if isinstance(block, ast.If)
            and "TYPE_CHECKING" in ast.unparse(block.test)
            for statement in block.body for node in ast.walk(statement)}
        found = set()
        for node in ast.walk(tree):
            if id(node) in skipped:
                continue
            if isinstance(node, ast.Import):
                found.update(resolve(alias.name) for alias in node.names)
            elif isinstance(node, ast.ImportFrom):
                base = node.module
                if node.level:  # relative: from the module's package up
                    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
                    for _ in range(node.level - 1):
                        package = package.rpartition(".")[0]
                    base = f"{package}.{node.module}" if node.module else package
                found.update(resolve(f"{base}.{alias.name}") for alias in node.names)
        graph[module] = found - {None, module}
    return graph


def _circles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan's algorithm)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    circles = []

    def visit(node: str) -> None:
        index[node] = low[node] = len(index)
        stack.append(node)
        for other in sorted(graph.get(node, ())):
            if other not in index:
                visit(other)
                low[node] = min(low[node], low[other])
            elif other in stack:
                low[node] = min(low[node], index[other])
        if low[node] == index[node]:
            component = []
            while True:
                other = stack.pop()
                component.append(other)
                if other == node:
                    break
            if len(component) > 1:
                circles.append(sorted(component))

    for node in sorted(graph):
        if node not in index:
            visit(node)
    return circles


# --- the layers: each package's folders and top modules --------------------------------------

def _layer(module: str) -> str:
    """The layer a module lives in: its package's subpackage folder or top module
    (``quad_dob_env.envs`` for ``quad_dob_env.envs.core``), or the package itself for its
    ``__init__``."""
    return ".".join(module.split(".")[:2])


def _layer_edges(modules: dict[str, Path] | None = None) -> dict[str, dict[str, list[str]]]:
    """Layer -> the layers it imports, each with the module imports that make the edge. An
    import inside a function counts, and one under TYPE_CHECKING too: a type that needs a
    layer above is code in the wrong layer, and none is needed across the grain today."""
    edges: dict[str, dict[str, list[str]]] = {}
    for module, imported in _import_graph(modules, type_checking=True).items():
        targets = edges.setdefault(_layer(module), {})
        for other in sorted(imported):
            if _layer(other) != _layer(module):
                targets.setdefault(_layer(other), []).append(f"{module} -> {other}")
    return edges


def _circles_explained(edges: dict[str, dict[str, list[str]]]) -> list[str]:
    """Each circle of layers, with the module imports that close it."""
    circles = _circles({layer: set(targets) for layer, targets in edges.items()})
    return [f"{' <-> '.join(circle)}: " + "; ".join(via for layer in circle
                                                    for other, imports in edges[layer].items()
                                                    if other in circle for via in imports)
            for circle in circles]


@pytest.mark.parametrize("scope", [*INSTALLED_NAMES.values(), "across the four"])
def test_no_two_folders_or_top_modules_import_each_other(scope):
    # within each package, then across all four: no layer imports another that imports it
    # back, directly or through a chain (no exceptions)
    edges = {layer: {other: via for other, via in targets.items()
                     if scope not in INSTALLED_NAMES.values() or other.split(".")[0] == scope}
             for layer, targets in _layer_edges().items()
             if scope not in INSTALLED_NAMES.values() or layer.split(".")[0] == scope}
    circles = _circles_explained(edges)
    assert not circles, "\n".join(circles)


def test_the_layer_scan_finds_a_planted_circle(tmp_path):
    # a made-up package whose folders import each other back inside a function (a, b) and
    # under TYPE_CHECKING (c, d), beside a top module that only imports down
    sources = {
        "__init__.py": "", "top.py": "from .a import low\n",
        "a/__init__.py": "", "a/low.py": "from pkg.b.high import lift\n",
        "b/__init__.py": "", "b/high.py": "def lift():\n    from .. import a\n",
        "c/__init__.py": "", "c/x.py": "from typing import TYPE_CHECKING\n"
                                       "if TYPE_CHECKING:\n    from pkg.d import y\n",
        "d/__init__.py": "", "d/y.py": "import pkg.c.x\n",
    }
    for name, text in sources.items():
        (tmp_path / "pkg" / name).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / "pkg" / name).write_text(text)
    edges = _layer_edges(_module_names({tmp_path / "pkg": "pkg"}))
    assert _circles_explained(edges) == [
        "pkg.a <-> pkg.b: pkg.a.low -> pkg.b.high; pkg.b.high -> pkg.a",
        "pkg.c <-> pkg.d: pkg.c.x -> pkg.d.y; pkg.d.y -> pkg.c.x"]
    assert set(edges["pkg.top"]) == {"pkg.a"}


def _design_layers() -> dict[str, list[list[str]]]:
    """docs/design.md's "Layers" block: each package's lines of folders and top modules,
    bottom first, by installed name. A package's line starts at the margin with its folder;
    a layer's line two spaces in, its names joined by commas, then its description."""
    block = (ROOT / "docs" / "design.md").read_text().split("## Layers", 1)[1]
    block = block.split("```", 2)[1]
    layers: dict[str, list[list[str]]] = {}
    package = None
    for line in block.splitlines():
        if folder := re.match(r"(\w+)/\s", line):
            package = INSTALLED_NAMES.get(folder.group(1))
            if package is not None:
                layers[package] = []
        elif package is not None and (names := re.match(r"  (\w[\w/, ]*?)(?:\s{2,}|$)", line)):
            layers[package].append([f"{package}.{name.strip().rstrip('/')}"
                                    for name in names.group(1).split(",")])
    return layers


def test_imports_follow_the_layers_of_design_md():
    # the order is stated once, in docs/design.md; every import points down it: to an
    # earlier line of its package or to an earlier package (a package's __init__ sits on
    # top of its own lines), never along a line
    layers = _design_layers()
    assert list(layers) == list(INSTALLED_NAMES.values())
    rank = {}
    for package_place, (package, lines) in enumerate(layers.items()):
        rank[package] = (package_place, len(lines))
        for line_place, line in enumerate(lines):
            rank.update({layer: (package_place, line_place) for layer in line})
    edges = _layer_edges()
    unlisted, unknown = sorted(set(edges) - set(rank)), sorted(set(rank) - set(edges))
    assert not unlisted and not unknown, (f"docs/design.md's layers leave out {unlisted} and "
                                          f"name {unknown}, which the code does not have")
    against = [f"{layer} imports {other}: {'; '.join(via)}"
               for layer, targets in edges.items() for other, via in targets.items()
               if rank[other] >= rank[layer]]
    assert not against, "\n".join(against)


def _private_imports(tree: ast.AST) -> list[str]:
    """``from m import _name``: a module reading another module's private name (dunders
    such as ``__version__`` aside)."""
    return [f"{'.' * node.level}{node.module or ''} import {alias.name}"
            for node in ast.walk(tree) if isinstance(node, ast.ImportFrom)
            for alias in node.names
            if alias.name.startswith("_") and not alias.name.startswith("__")]


@pytest.mark.parametrize("folder", PACKAGE_FOLDERS)
def test_no_module_imports_another_modules_private_names(folder):
    # what two modules share is public in the one that defines it
    offences = [f"{path.relative_to(ROOT)}: from {found}"
                for path in _modules(folder)
                for found in _private_imports(ast.parse(path.read_text()))]
    assert not offences, "\n".join(offences)


def test_the_private_import_scan_finds_one():
    tree = ast.parse("from __future__ import annotations\nfrom a.b import _c, d\n"
                     "def f():\n    from .e import _g as h\n")
    assert _private_imports(tree) == ["a.b import _c", ".e import _g"]
