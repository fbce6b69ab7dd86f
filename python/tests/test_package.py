# SPDX-License-Identifier: MIT
"""The installed package: its version, its type stubs against the extension, docstrings, and the
command-line tool installed beside it."""

import ast
import importlib.metadata
import inspect
import pathlib
import re

import pytest

import spacebvh
from spacebvh import _core

PACKAGE = pathlib.Path(spacebvh.__file__).parent
REPOSITORY = pathlib.Path(__file__).resolve().parents[2]


def test_version_is_the_cmake_project_version():
    cmake = (REPOSITORY / "CMakeLists.txt").read_text()
    version = re.search(r"project\(spacebvh\s+VERSION\s+([0-9.]+)", cmake).group(1)
    assert spacebvh.__version__ == version
    assert importlib.metadata.version("spacebvh") == version


def test_package_is_typed():
    assert (PACKAGE / "py.typed").is_file()
    assert (PACKAGE / "_core.pyi").is_file()


def public_names(obj):
    return {name for name in dir(obj) if not name.startswith("_")}


def stub_definitions():
    """Names the stub declares at module level, and per class."""
    tree = ast.parse((PACKAGE / "_core.pyi").read_text())
    functions, classes = set(), {}
    for node in tree.body:
        if isinstance(node, ast.FunctionDef):
            functions.add(node.name)
        elif isinstance(node, ast.ClassDef):
            # Methods and properties, and annotated attributes (an enum's values).
            classes[node.name] = {n.name for n in node.body if isinstance(n, ast.FunctionDef)} | {
                n.target.id for n in node.body if isinstance(n, ast.AnnAssign) and isinstance(n.target, ast.Name)
            }
    return functions, classes


def test_stub_declares_exactly_the_extension():
    functions, classes = stub_definitions()
    extension_classes = {name for name in public_names(_core) if inspect.isclass(getattr(_core, name))}
    extension_functions = public_names(_core) - extension_classes
    assert functions == extension_functions
    assert set(classes) == extension_classes
    for name, members in classes.items():
        if name == "Error":
            continue
        declared = {m for m in members if not m.startswith("_")}
        assert declared == public_names(getattr(_core, name)), name


def docstring_of(obj):
    """The documentation text, without the signature line pybind11 puts first."""
    doc = inspect.getdoc(obj) or ""
    lines = doc.splitlines()
    if lines and re.match(r"^\w+\(.*\)( -> .*)?$", lines[0]):
        lines = lines[1:]
    return "\n".join(lines).strip()


def test_every_function_class_and_member_has_a_docstring():
    missing = []
    for name in public_names(_core):
        obj = getattr(_core, name)
        if not docstring_of(obj):
            missing.append(name)
        if inspect.isclass(obj) and obj is not _core.Error:
            for member in public_names(obj):
                if not docstring_of(getattr(obj, member)):
                    missing.append(f"{name}.{member}")
    for name in spacebvh.cli.__all__:
        if not docstring_of(getattr(spacebvh.cli, name)):
            missing.append(f"cli.{name}")
    assert not missing


def test_package_reexports_the_extension():
    for name in public_names(_core):
        assert getattr(spacebvh, name) is getattr(_core, name)
    assert set(spacebvh.__all__) >= public_names(_core)


def test_command_line_tool_is_installed():
    try:
        path = spacebvh.cli_executable()
    except FileNotFoundError:
        pytest.skip("the spacebvh command is not installed beside the package (a build-tree layout)")
    result = spacebvh.cli.run(["--help"])
    assert "spacebvh" in result.stdout
    assert pathlib.Path(path).name.startswith("spacebvh")
