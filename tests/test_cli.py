"""The pcl-rg command line's surface (commands, flags from the dataclasses, lazy imports)
and real subprocesses (python -m pcl_rg and the pcl-rg console script)."""

from __future__ import annotations

import dataclasses
import inspect
import json
import sys
import typing
from pathlib import Path

import pytest
from cli_helpers import assert_one_error_line, run, run_json
from conftest import run_command, run_pcl_rg

import pcl_rg
import pcl_rg._grid_ground
from pcl_rg.io import read_points

COMMANDS = ("ground", "denoise", "downsample", "segment", "pipeline", "evaluate", "info", "demo")


# ---------------------------------------------------------------- the surface


def test_help_lists_every_command(capsys):
    code, out, _ = run(capsys, "--help")
    assert code == 0
    for command in COMMANDS:
        assert f"\n    {command}" in out, command
    code, out, _ = run(capsys, "--version")
    assert code == 0 and pcl_rg.__version__ in out


def params_classes(command: str) -> list[type]:
    if command == "pipeline":
        return [pipeline_options()]
    return {
        "ground": [pcl_rg.GridGroundParams, pcl_rg.TinGroundParams],
        "denoise": [pcl_rg.StatisticalOutlierRemovalParams],
        "downsample": [pcl_rg.VoxelGridParams],
        "segment": [
            pcl_rg.RegionGrowingParams,
            pcl_rg.ConvexSegmentationParams,
            pcl_rg.pcl.RegionGrowingPclParams,
        ],
    }[command]


def pipeline_options() -> type:
    """seed004's keyword parameter objects (sor, voxel, region) as one dataclass."""
    from pcl_rg.pipeline import seed004

    hints = typing.get_type_hints(seed004)
    fields = []
    for name in inspect.signature(seed004).parameters:
        kinds = [t for t in typing.get_args(hints[name]) or (hints[name],) if t is not type(None)]
        if len(kinds) == 1 and dataclasses.is_dataclass(kinds[0]):
            fields.append((name, kinds[0]))
    assert [name for name, _ in fields] == ["sor", "voxel", "region"]
    return dataclasses.make_dataclass("Options", fields)


def leaves(cls: type, prefix: tuple[str, ...] = ()):
    """(path, field) of every field, the fields of nested parameter dataclasses flattened."""
    hints = typing.get_type_hints(cls)
    for f in dataclasses.fields(cls):
        if dataclasses.is_dataclass(hints[f.name]):
            yield from leaves(hints[f.name], prefix + (f.name,))
        else:
            yield prefix + (f.name,), f


@pytest.mark.parametrize("command", ["ground", "denoise", "downsample", "segment", "pipeline"])
def test_flags_come_from_the_dataclasses(capsys, command):
    code, out, _ = run(capsys, command, "--help")
    assert code == 0
    squeezed = "".join(out.split())
    expected = set()
    for cls in params_classes(command):
        for path, f in leaves(cls):
            flag = "--" + "-".join(path).replace("_", "-")
            expected.add(flag)
            assert f"{flag} " in out or f"{flag}\n" in out or f"{flag}," in out, flag
            assert "".join(f.metadata["help"].split()) in squeezed, f.name
    if command == "pipeline":
        expected.add("--no-sor")  # SOR runs by default; the switch turns it off
    # No flag without a field behind it.
    group = out.split("parameters:", 1)[1].split("\n\n", 1)[0]
    flags = {
        line.split()[0].rstrip(",") for line in group.splitlines() if line.strip().startswith("--")
    }
    assert flags == expected


def test_defaults_are_the_dataclass_defaults(capsys, tmp_path, scene_las):
    result = run_json(capsys, "denoise", scene_las, tmp_path / "d.las")
    assert result["parameters"] == dataclasses.asdict(pcl_rg.StatisticalOutlierRemovalParams())
    result = run_json(capsys, "ground", scene_las, tmp_path / "g.las", "--method", "tin")
    assert result["parameters"] == dataclasses.asdict(pcl_rg.TinGroundParams())
    result = run_json(capsys, "ground", scene_las, tmp_path / "g.las", "--block-size", "30,50")
    expected = dataclasses.asdict(pcl_rg.GridGroundParams(block_size=(30.0, 50.0)))
    assert result["parameters"] == {
        k: list(v) if isinstance(v, tuple) else v for k, v in expected.items()
    }


# ----------------------------------------------------------- real processes


def test_python_dash_m(tmp_path, scene_las):
    done = run_pcl_rg("info", scene_las, "--json")
    assert done.returncode == 0, done.stderr
    assert json.loads(done.stdout)["points"] == len(read_points(scene_las))
    done = run_pcl_rg("info", tmp_path / "none.las")
    assert done.returncode == 2
    assert_one_error_line(done.stderr, "does not exist")


def test_console_script(tmp_path, scene_las):
    script = Path(sys.executable).parent / "pcl-rg"
    assert script.exists(), f"the console script is not installed next to {sys.executable}"
    done = run_command(script, "ground", scene_las, tmp_path / "g.laz", "--drop")
    assert done.returncode == 0, done.stderr
    assert "ground" in done.stdout and "wrote" in done.stdout
    assert (read_points(tmp_path / "g.laz").classification == 2).all()
    (tmp_path / "bad.ply").write_bytes(b"ply\nformat ascii 1.0\n")
    done = run_command(script, "denoise", tmp_path / "bad.ply", tmp_path / "x.ply")
    assert done.returncode == 2
    assert_one_error_line(done.stderr, "invalid PLY file")
