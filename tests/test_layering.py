"""Dependencies point one way (docs/design.md): read from the sources with ``ast``, so an import
inside a function or behind TYPE_CHECKING counts too."""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
# folder -> the import names it must never import (prefixes)
FORBIDDEN = {
    "quad_dob_env": ("quad_dob_baselines", "quad_dob_composition", "quad_dob_training"),
    "baselines": ("quad_dob_env.envs", "quad_dob_env.wrappers", "quad_dob_composition",
                  "quad_dob_training"),
    "composition": ("quad_dob_training",),
    # training's subpackages (their docstrings): the command line on top, imported by none
    # but the wind-tunnel tool's own argument checks
    "training/evaluation": ("quad_dob_training.cli", "quad_dob_training.tuning",
                            "quad_dob_training.wind_tunnel", "quad_dob_training.rl.train",
                            "quad_dob_training.rl.sweep"),
    "training/rl": ("quad_dob_training.cli", "quad_dob_training.tuning",
                    "quad_dob_training.wind_tunnel"),
    "training/tuning": ("quad_dob_training.cli", "quad_dob_training.wind_tunnel",
                        "quad_dob_training.rl.train", "quad_dob_training.rl.sweep"),
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


def _module_names() -> dict[str, Path]:
    modules = {}
    for folder, name in INSTALLED_NAMES.items():
        for path in (ROOT / folder).rglob("*.py"):
            parts = [name, *path.relative_to(ROOT / folder).with_suffix("").parts]
            modules[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = path
    return modules


def _import_graph() -> dict[str, set[str]]:
    modules = _module_names()

    def resolve(name: str) -> str | None:
        while name and name not in modules:
            name = name.rpartition(".")[0]
        return name or None

    graph = {}
    for module, path in modules.items():
        tree = ast.parse(path.read_text())
        skipped = {id(node) for block in ast.walk(tree) if isinstance(block, ast.If)
                   and "TYPE_CHECKING" in ast.unparse(block.test)
                   for statement in block.body for node in ast.walk(statement)}
        found = set()
        for node in ast.walk(tree):
            if id(node) in skipped:
                continue
            if isinstance(node, ast.Import):
                found.update(resolve(alias.name) for alias in node.names)
            elif isinstance(node, ast.ImportFrom) and node.module:
                base = node.module
                if node.level:  # relative: from the module's package up
                    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
                    for _ in range(node.level - 1):
                        package = package.rpartition(".")[0]
                    base = f"{package}.{node.module}"
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
