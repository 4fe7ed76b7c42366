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


def _parameters(kernel) -> list[str]:
    import inspect

    return [name for name, parameter in inspect.signature(kernel.py_func).parameters.items()
            if parameter.kind is not parameter.VAR_POSITIONAL]


def test_kernels_take_their_records_fields_in_order():
    # the records are built by keyword and spread into the kernels: a kernel whose
    # parameters drifted from its record's fields would take one array for another
    from quad_dob_composition.fused import (
        PlanArguments,
        UpdateArguments,
        plan_kernel,
        remember_state,
        reward_and_observer_update,
    )
    from quad_dob_env.envs.step_kernels import (
        StartArguments,
        StepArguments,
        start_kernel,
        step_kernel,
    )

    assert _parameters(step_kernel) == ["start", "stop", "actions", *StepArguments._fields]
    assert _parameters(start_kernel) == ["indices", "offsets", "rotations", "scales",
                                         *StartArguments._fields]
    assert _parameters(plan_kernel) == ["indices", *PlanArguments._fields]
    both = [*UpdateArguments._fields, *PlanArguments._fields]
    for kernel in (remember_state, reward_and_observer_update):
        names = _parameters(kernel)[2:]
        assert names == both[:len(names)], kernel.__name__


PACKAGE_FOLDERS = ("quad_dob_env", "baselines", "composition", "training")


def _packages() -> list[Path]:
    return sorted(init.parent for folder in PACKAGE_FOLDERS
                  for init in (ROOT / folder).rglob("__init__.py"))


@pytest.mark.parametrize("package", _packages(), ids=lambda p: str(p.relative_to(ROOT)))
def test_each_package_docstring_lists_its_modules(package):
    # docs/design.md's map stops at the packages; each package's docstring names what lives
    # in it, so a module added without a line there fails here
    docstring = ast.get_docstring(ast.parse((package / "__init__.py").read_text())) or ""
    members = [path.stem for path in package.glob("*.py") if path.stem != "__init__"]
    members += [path.name for path in package.iterdir() if (path / "__init__.py").exists()]
    missing = [name for name in sorted(members)
               if not re.search(rf"(?<![\w.]){re.escape(name)}(?!\w)", docstring)]
    assert not missing, f"{package.relative_to(ROOT)}'s docstring does not name {missing}"
