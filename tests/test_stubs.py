"""The typed stubs of the compiled modules match the built modules (a stubtest).

Checked both ways: every public name of the module is in its .pyi and every name
in the .pyi exists; each function's parameter names and order equal those of the
signature pybind11 records; each class has the stub's attributes and methods, and
the stub lists every attribute of the class.
"""

from __future__ import annotations

import ast
import importlib
import re
from pathlib import Path

import pytest

import pcl_rg

PACKAGE = Path(pcl_rg.__file__).parent
MODULES = sorted(p.stem for p in PACKAGE.glob("_*.pyi"))


def stub_tree(name: str) -> ast.Module:
    return ast.parse((PACKAGE / f"{name}.pyi").read_text())


def pybind_parameters(function) -> list[list[str]]:
    """Parameter names of each overload, from pybind11's docstring signatures."""
    overloads = []
    for line in (function.__doc__ or "").splitlines():
        match = re.match(rf"^(?:\d+\. )?{function.__name__}\((.*)\) ->", line.strip())
        if match:
            names = re.findall(r"(?:^|, )\*?(\w+):", match.group(1))
            overloads.append([n for n in names if n not in ("self",)])
    return overloads


def stub_parameters(node: ast.FunctionDef) -> list[str]:
    args = node.args
    return [a.arg for a in [*args.posonlyargs, *args.args, *args.kwonlyargs] if a.arg != "self"]


@pytest.mark.parametrize("name", MODULES)
def test_stub_names_match_the_module(name: str) -> None:
    module = importlib.import_module(f"pcl_rg.{name}")
    tree = stub_tree(name)
    stubbed = {
        node.name for node in tree.body if isinstance(node, (ast.FunctionDef, ast.ClassDef))
    } | {
        node.target.id
        for node in tree.body
        if isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name)
    }
    public = {n for n in dir(module) if not n.startswith("_")}
    assert stubbed == public, (sorted(public - stubbed), sorted(stubbed - public))


@pytest.mark.parametrize("name", MODULES)
def test_stub_functions_have_the_built_parameters(name: str) -> None:
    module = importlib.import_module(f"pcl_rg.{name}")
    for node in stub_tree(name).body:
        if isinstance(node, ast.FunctionDef):
            built = pybind_parameters(getattr(module, node.name))
            assert stub_parameters(node) in built, (node.name, built)


@pytest.mark.parametrize("name", MODULES)
def test_stub_classes_have_the_built_members(name: str) -> None:
    module = importlib.import_module(f"pcl_rg.{name}")
    for node in stub_tree(name).body:
        if not isinstance(node, ast.ClassDef):
            continue
        cls = getattr(module, node.name)
        members = {
            item.target.id
            for item in node.body
            if isinstance(item, ast.AnnAssign) and isinstance(item.target, ast.Name)
        } | {item.name for item in node.body if isinstance(item, ast.FunctionDef)}
        built = {n for n in dir(cls) if not n.startswith("_")} | (
            {"__init__"} if "__init__" in members else set()
        )
        assert members == built, (node.name, sorted(built - members), sorted(members - built))
        for item in node.body:
            if isinstance(item, ast.FunctionDef) and item.name != "__init__":
                built_parameters = pybind_parameters(getattr(cls, item.name))
                assert stub_parameters(item) in built_parameters, (node.name, item.name)
