"""Run every docstring example of the installed package."""

from __future__ import annotations

import doctest
import importlib
import pkgutil

import pytest

import pcl_rg

MODULES = sorted(
    name
    for _, name, _ in pkgutil.walk_packages(pcl_rg.__path__, prefix="pcl_rg.")
    if not name.endswith("__main__")
)


@pytest.mark.parametrize("name", MODULES)
def test_docstring_examples(name):
    module = importlib.import_module(name)
    result = doctest.testmod(module, optionflags=doctest.NORMALIZE_WHITESPACE)
    assert result.failed == 0


def test_every_public_function_has_an_example():
    missing = [
        name
        for name in pcl_rg.__all__
        if callable(getattr(pcl_rg, name))
        and not isinstance(getattr(pcl_rg, name), type)
        and ">>>" not in (getattr(pcl_rg, name).__doc__ or "")
    ]
    assert not missing


def _public_functions():
    for module in (pcl_rg, pcl_rg.pcl, pcl_rg.pipeline):
        for name in module.__all__:
            value = getattr(module, name)
            if callable(value) and not isinstance(value, type):
                yield f"{module.__name__}.{name}", value


def test_shared_docstring_entries_are_filled():
    # pcl_rg._docstrings.fill_docstring replaces each "%(points)s" line; one left over
    # means a function lacks the decorator or names an entry that does not exist.
    unfilled = [name for name, function in _public_functions() if "%(" in function.__doc__]
    assert not unfilled
    filled = [
        name for name, function in _public_functions() if "points : array_like" in function.__doc__
    ]
    assert "pcl_rg.pcl.voxel_grid" in filled and "pcl_rg.tin_ground" in filled
