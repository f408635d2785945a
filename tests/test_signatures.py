"""Every layer names exactly the parameters its dataclass declares (the one source).

For each algorithm: the public function's keywords, the reference's keywords, the
docstring's Parameters list (with the defaults it states) and the command line's
flags all equal the dataclass fields; tests/test_params.py does the same for the
C++ structs and their checks.
"""

from __future__ import annotations

import dataclasses
import inspect
import re

import pytest

import pcl_rg
from pcl_rg import reference
from pcl_rg._params import presets

ALGORITHMS = [
    ("voxel_grid", pcl_rg.VoxelGridParams, "downsample"),
    ("statistical_outlier_removal", pcl_rg.StatisticalOutlierRemovalParams, "denoise"),
    ("normals", pcl_rg.NormalsParams, None),
    ("region_growing", pcl_rg.RegionGrowingParams, "segment"),
    ("convex_segmentation", pcl_rg.ConvexSegmentationParams, "segment"),
    ("grid_ground", pcl_rg.GridGroundParams, "ground"),
    ("tin_ground", pcl_rg.TinGroundParams, "ground"),
]
IDS = [name for name, _, _ in ALGORITHMS]


def field_names(cls: type) -> list[str]:
    return [f.name for f in dataclasses.fields(cls)]


def keywords(function) -> list[str]:
    skip = {"points", "params"}
    return [n for n in inspect.signature(function).parameters if n not in skip]


@pytest.mark.parametrize(("name", "cls", "command"), ALGORITHMS, ids=IDS)
def test_public_function_takes_every_field_as_a_keyword(name, cls, command) -> None:
    function = getattr(pcl_rg, name)
    assert keywords(function) == field_names(cls)
    signature = inspect.signature(function)
    for field in field_names(cls):
        assert signature.parameters[field].default is None, field  # None: from params
    assert signature.parameters["params"].default is None


@pytest.mark.parametrize(("name", "cls", "command"), ALGORITHMS, ids=IDS)
def test_reference_has_the_same_signature(name, cls, command) -> None:
    ours = inspect.signature(getattr(pcl_rg, name))
    theirs = inspect.signature(getattr(reference, name))
    assert list(theirs.parameters) == list(ours.parameters)
    for key, parameter in ours.parameters.items():
        assert theirs.parameters[key].kind == parameter.kind, key
        assert theirs.parameters[key].default == parameter.default, key


def documented_parameters(function) -> dict[str, str]:
    """name -> description of each entry of the numpydoc Parameters section."""
    doc = inspect.getdoc(function) or ""
    section = doc.split("Parameters\n----------\n", 1)[1].split("\n\n", 1)[0]
    entries: dict[str, str] = {}
    current = None
    for line in section.splitlines():
        match = re.match(r"^(\w+(?:, \w+)*) : ", line)
        if match:  # numpydoc allows "a, b : type" for parameters described together
            names = match.group(1).split(", ")
            current = names[0] if len(names) == 1 else None
            entries.update({n: "" for n in names})
        elif current:
            entries[current] += " " + line.strip()
    return entries


@pytest.mark.parametrize(("name", "cls", "command"), ALGORITHMS, ids=IDS)
def test_docstring_lists_every_field_with_its_default(name, cls, command) -> None:
    documented = documented_parameters(getattr(pcl_rg, name))
    assert [n for n in documented if n not in ("points", "params")] == field_names(cls)
    for field in dataclasses.fields(cls):
        stated = re.search(
            r"\b[Dd]efault:? (-?\d+(?:\.\d+)?(?:e[+-]?\d+)?|True|False)",
            documented[field.name],
        )
        if stated is None or field.default is dataclasses.MISSING:
            continue
        text = stated.group(1)
        said = {"True": True, "False": False}[text] if text in ("True", "False") else float(text)
        value = field.default
        if isinstance(value, tuple):
            assert len(set(value)) == 1, field.name  # a docstring states one per-axis value
            value = value[0]
        assert said == value, (field.name, text, value)


def cli_flags(command: str) -> set[str]:
    from pcl_rg.cli import build_parser

    parser = build_parser()
    sub = next(
        a for a in parser._actions if isinstance(a, type(parser._subparsers._group_actions[0]))
    )
    return {
        option
        for action in sub.choices[command]._actions
        for option in action.option_strings
        if option.startswith("--")
    }


@pytest.mark.parametrize(
    ("name", "cls", "command"),
    [a for a in ALGORITHMS if a[2]],
    ids=[a[0] for a in ALGORITHMS if a[2]],
)
def test_command_line_has_a_flag_per_field(name, cls, command) -> None:
    flags = cli_flags(command)
    for field in field_names(cls):
        assert f"--{field.replace('_', '-')}" in flags, (command, field)


@pytest.mark.parametrize(
    ("cls", "names"),
    [
        (pcl_rg.TinGroundParams, ["isprs", "lidar360"]),
        (pcl_rg.GridGroundParams, ["isprs", "definition"]),
    ],
)
def test_presets_are_named_classmethods_and_the_defaults_are_one_of_them(cls, names) -> None:
    found = presets(cls)
    assert list(found) == names
    assert found["isprs"]() == cls()
    for make in found.values():
        assert isinstance(make(), cls)


def test_old_preset_name_warns() -> None:
    with pytest.warns(DeprecationWarning, match="use TinGroundParams.isprs"):
        params = pcl_rg.TinGroundParams.tuned_isprs()
    assert params == pcl_rg.TinGroundParams.isprs()


def test_old_preset_name_takes_the_same_overrides() -> None:
    with pytest.warns(DeprecationWarning, match="use TinGroundParams.isprs"):
        params = pcl_rg.TinGroundParams.tuned_isprs(stop_edge=1.0)
    assert params == pcl_rg.TinGroundParams.isprs(stop_edge=1.0)
