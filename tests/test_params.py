"""Every Python parameter dataclass mirrors its C++ struct: same fields, same defaults,
and the same values rejected with the same message."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import pcl_rg
import pcl_rg.pcl
from pcl_rg import _core, _pcl
from pcl_rg._params import Spec, spec_of, to_core

# Each extension module with the public module holding its dataclasses: _core's
# structs pair with pcl_rg's, _pcl's (PCL's classes) with pcl_rg.pcl's. _pcl's
# filters take _core's VoxelGridParams and StatisticalOutlierRemovalParams.
MODULES = [(_core, pcl_rg), (_pcl, pcl_rg.pcl)]
PAIRS = [
    (cls, getattr(module, name))
    for module, public in MODULES
    for name in dir(module)
    if name.endswith("Params")
    for cls in [getattr(public, name, None)]
    if cls is not None
]


def _id(value: object) -> str:
    module = getattr(value, "__module__", "")
    name = getattr(value, "__name__", str(value))
    return f"_pcl.{name}" if module == "pcl_rg._pcl" else name


@pytest.mark.parametrize(("module", "public"), MODULES, ids=["_core", "_pcl"])
def test_every_core_struct_has_a_dataclass(module, public):
    core_names = {name for name in dir(module) if name.endswith("Params")}
    assert core_names, "the extension exposes no parameter structs"
    assert core_names == {cls.__name__ for cls, core in PAIRS if core.__module__ == module.__name__}


def test_pcl_filters_take_the_core_structs() -> None:
    # One C++ type, registered once: _pcl must not declare a second Python class for it.
    assert not hasattr(_pcl, "VoxelGridParams")
    assert not hasattr(_pcl, "StatisticalOutlierRemovalParams")
    inlier = _pcl.statistical_outlier_removal(
        CLOUD, pcl_rg.StatisticalOutlierRemovalParams().to_core()
    )
    assert inlier.shape == (len(CLOUD),)


@pytest.mark.parametrize(("python_cls", "core_cls"), PAIRS, ids=_id)
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


# --- Python and C++ reject the same values with the same words ------------------------

CLOUD = np.random.default_rng(3).uniform(0.0, 10.0, (200, 3))
# Every compiled function that takes a struct; each struct is checked by all of them.
CORE_CALLS = {
    _core.VoxelGridParams: [_core.voxel_grid, _pcl.voxel_grid],
    _core.StatisticalOutlierRemovalParams: [
        _core.statistical_outlier_removal,
        _pcl.statistical_outlier_removal,
    ],
    _core.NormalsParams: [_core.normals],
    _core.RegionGrowingParams: [_core.region_growing],
    _core.ConvexSegmentationParams: [_core.convex_segmentation],
    _core.GridGroundParams: [_core.grid_ground],
    _core.TinGroundParams: [_core.tin_ground],
    _pcl.NormalEstimationParams: [_pcl.normal_estimation],
    _pcl.RegionGrowingPclParams: [_pcl.region_growing],
    _pcl.ProgressiveMorphologicalFilterParams: [_pcl.progressive_morphological_filter],
    _pcl.LccpParams: [_pcl.lccp],
}
REQUIRED = {"VoxelGridParams": {"leaf_size": 1.0}}


def _invalid_values(spec: Spec) -> list[float]:
    """Values just outside each bound, and the non-finite ones for reals."""
    step = 1 if spec.kind is int else 0.5
    values = []
    if spec.minimum is not None:
        values.append(spec.minimum - step)
    if spec.above is not None:
        values.append(spec.above)
    if spec.maximum is not None:
        values.append(spec.maximum + step)
    if spec.below is not None:
        values.append(spec.below)
    if spec.kind is float:
        values += [float("nan"), float("inf"), -float("inf")]
    return [int(v) if spec.kind is int else v for v in values]


def test_every_struct_has_a_call() -> None:
    assert {core_cls for _, core_cls in PAIRS} == set(CORE_CALLS)


def _cases() -> list[tuple[type, type, str, object]]:
    cases = []
    for cls, core_cls in PAIRS:
        for field in dataclasses.fields(cls):
            spec = spec_of(field)
            if spec.kind in (int, float):
                cases += [(cls, core_cls, field.name, value) for value in _invalid_values(spec)]
    return cases


def _core_messages(cls: type, core_cls: type, name: str, value: object) -> list[str]:
    """What each compiled function taking the struct says of the value."""
    core = to_core(cls(**REQUIRED.get(cls.__name__, {})), core_cls())
    spec = spec_of(next(f for f in dataclasses.fields(cls) if f.name == name))
    setattr(core, name, [value] * spec.axes if spec.axes else value)
    messages = []
    for call in CORE_CALLS[core_cls]:
        with pytest.raises(ValueError) as error:
            call(CLOUD, core)
        messages.append(str(error.value))
    return messages


@pytest.mark.parametrize(("cls", "core_cls", "name", "value"), _cases(), ids=_id)
def test_python_and_cpp_reject_the_same_value_with_the_same_message(
    cls, core_cls, name, value
) -> None:
    with pytest.raises(ValueError) as error:
        cls(**{**REQUIRED.get(cls.__name__, {}), name: value})
    python_message = str(error.value)
    assert python_message.startswith(f"{name} must be "), python_message
    for core_message in _core_messages(cls, core_cls, name, value):
        assert python_message == core_message


def test_every_bounded_parameter_is_covered() -> None:
    covered = {(cls.__name__, name) for cls, _, name, _ in _cases()}
    for cls, _ in PAIRS:
        for field in dataclasses.fields(cls):
            spec = spec_of(field)
            bounded = any(
                b is not None for b in (spec.minimum, spec.above, spec.maximum, spec.below)
            )
            if bounded:
                assert (cls.__name__, field.name) in covered


@pytest.mark.parametrize(
    ("cls", "first", "second", "values"),
    [
        (pcl_rg.GridGroundParams, "block_size", "cell_size", (4.0, 5.0)),
        (pcl_rg.RegionGrowingParams, "min_cluster_size", "max_cluster_size", (50, 10)),
        (pcl_rg.pcl.RegionGrowingPclParams, "min_cluster_size", "max_cluster_size", (50, 10)),
        (pcl_rg.pcl.LccpParams, "voxel_resolution", "seed_resolution", (0.05, 0.01)),
    ],
)
def test_relations_between_parameters_are_worded_alike(cls, first, second, values) -> None:
    with pytest.raises(ValueError) as error:
        cls(**{first: values[0], second: values[1]})
    core = cls().to_core()
    fields = {f.name: spec_of(f) for f in dataclasses.fields(cls)}
    for name, value in zip((first, second), values):
        setattr(core, name, [value] * fields[name].axes if fields[name].axes else value)
    for call in CORE_CALLS[type(core)]:
        with pytest.raises(ValueError) as core_error:
            call(CLOUD, core)
        assert str(error.value) == str(core_error.value)
    assert str(error.value).startswith(f"{second} must be ")


@pytest.mark.parametrize(
    "value",
    [-1e-5, -1.5e-4, -1e-4, -0.1, -2.5, -100000.0, -123456.789, -1e15, -1.5e15, -9.999e15]
    + [-1e16, -1.25e16, -1e300, -5e-324, -3.0e-10, -(2.0**53), -0.30000000000000004],
    ids=repr,
)
def test_numbers_are_written_alike_in_both_layers(value) -> None:
    """C++'s shortest form is Python's repr() layout: positional from 1e-4 to below 1e16
    (to_chars alone writes 100000 as "1e+05"), scientific outside."""
    with pytest.raises(ValueError) as error:
        pcl_rg.GridGroundParams(slope=value)
    python_message = str(error.value)
    text = repr(value)
    assert python_message == f"slope must be >= 0, got {text.removesuffix('.0')}"
    core = pcl_rg.GridGroundParams().to_core()
    core.slope = value
    with pytest.raises(ValueError) as error:
        _core.grid_ground(CLOUD, core)
    assert str(error.value) == python_message


@pytest.mark.parametrize(
    "call",
    [
        lambda p: pcl_rg.grid_ground(p, slope=10**400),
        lambda p: pcl_rg.tin_ground(p, iteration_distance=10**309),
        lambda p: pcl_rg.voxel_grid(p, 10**400),
        lambda p: pcl_rg.VoxelGridParams(leaf_size=[0.5, 0.5, 10**400]),
    ],
)
def test_an_integer_beyond_float64_is_refused_like_inf(call):
    # float(10**400) raises OverflowError, which named no parameter.
    points = np.random.default_rng(0).uniform(0, 10, (100, 3))
    with pytest.raises(ValueError, match="must be finite"):
        call(points)
