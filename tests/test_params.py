"""Every Python parameter dataclass mirrors its C++ struct: same fields, same defaults."""

from __future__ import annotations

import dataclasses

import pytest

import pcl_rg
from pcl_rg import _core

PAIRS = [
    (cls, getattr(_core, name))
    for name in dir(_core)
    if name.endswith("Params")
    for cls in [getattr(pcl_rg, name, None)]
    if cls is not None
]


def test_every_core_struct_has_a_dataclass():
    core_names = {name for name in dir(_core) if name.endswith("Params")}
    assert core_names, "the extension exposes no parameter structs"
    assert core_names == {cls.__name__ for cls, _ in PAIRS}


@pytest.mark.parametrize(("python_cls", "core_cls"), PAIRS, ids=lambda c: c.__name__)
def test_fields_and_defaults_match(python_cls, core_cls):
    core = core_cls()
    core_fields = {f for f in dir(core) if not f.startswith("_")}
    python_fields = {f.name for f in dataclasses.fields(python_cls)}
    assert python_fields == core_fields
    for field in dataclasses.fields(python_cls):
        assert field.metadata.get("help"), f"{field.name} has no help text"
        if field.default is dataclasses.MISSING:
            continue  # a required parameter: the C++ default is an invalid placeholder
        value = getattr(core, field.name)
        if hasattr(value, "name") and isinstance(field.default, str):
            value = value.name  # a C++ enum mirrored by its name in Python
        if isinstance(value, list):
            value = tuple(value)  # std::array fields come back as lists
        assert value == field.default, (field.name, value, field.default)
