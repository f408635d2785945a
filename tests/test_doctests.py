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
