"""Tests of the demo (pcl_rg.demo.run_demo and `pcl-rg demo`): every algorithm runs,
the table agrees with the files written, the figures exist."""

from __future__ import annotations

import json

import numpy as np
import pytest

import pcl_rg.cli as cli
import pcl_rg.datasets
from pcl_rg.demo import run_demo
from pcl_rg.evaluation import ground_errors
from pcl_rg.io import read_points

STAGES = [
    "denoise: SOR",
    "downsample: voxel grid",
    "ground: grid",
    "ground: tin",
    "segment: convex (voxels)",
    "segment: curvature (voxels)",
    "segment: pcl (voxels)",
    "pipeline: seed 004",
    "batch: ground, 4 tiles",
]


@pytest.fixture(scope="module")
def demo(tmp_path_factory):
    folder = tmp_path_factory.mktemp("demo")
    return folder, run_demo(folder, seed=1, size=100.0, plots=True)


def test_every_algorithm_runs(demo):
    _, report = demo
    assert [row["stage"] for row in report.rows] == STAGES
    for row in report.rows:
        assert row["seconds"] >= 0 and row["points_out"] <= row["points_in"], row["stage"]


def test_table_matches_the_files(demo):
    folder, report = demo
    truth = read_points(folder / "scene_truth.laz")
    rows = {row["stage"]: row for row in report.rows}
    for method in ("grid", "tin"):
        written = read_points(folder / f"ground_{method}.laz")
        np.testing.assert_allclose(written.points, truth.points)
        errors = ground_errors(truth.classification == 2, written.classification == 2)
        row = rows[f"ground: {method}"]
        for key in ("type_i", "type_ii", "total", "kappa"):
            assert row[key] == pytest.approx(getattr(errors, key)), (method, key)
        # SOR outliers are class 7 in both ground files, and only they are.
        denoise = rows["denoise: SOR"]
        assert (written.classification == 7).sum() == denoise["points_in"] - denoise["points_out"]
    # The grid filter with the demo's stated parameters separates this scene well.
    assert rows["ground: grid"]["kappa"] > 0.9
    # The survey step: its tiles as the merged run, to the batch target.
    survey = rows["batch: ground, 4 tiles"]
    assert float(survey["result"].split(" %")[0]) >= 99.9
    assert len(list((folder / "survey_ground").glob("*.laz"))) == 4
    for name in ("segments_convex", "segments_curvature", "segments_pcl", "pipeline"):
        segments = read_points(folder / f"{name}.laz").fields["segment_id"]
        assert segments.dtype == np.int32 and len(segments) == len(truth)
        assert (segments >= 0).any()
    table = report.table()
    assert table.count("\n" + "-" * 20) == 1
    for stage in STAGES:
        assert sum(line.startswith(stage) for line in table.splitlines()) == 1, stage


def test_figures(demo):
    folder, report = demo
    pngs = [p for p in report.files if p.suffix == ".png"]
    names = {p.name for p in pngs}
    assert {
        "truth_classes.png",
        "truth_profile.png",
        "ground_grid.png",
        "ground_tin.png",
        "ground_grid_profile.png",
        "segments_curvature.png",
        "segments_convex.png",
    } <= names
    for path in report.files:
        assert path.parent == folder and path.stat().st_size > 0
    for path in pngs:
        assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_demo_command(capsys, tmp_path):
    code = cli.main(
        ["demo", "--output", str(tmp_path / "out"), "--size", "90", "--no-plots", "--json", "-q"]
    )
    captured = capsys.readouterr()
    assert code == 0, captured.err
    result = json.loads(captured.out)
    assert [row["stage"] for row in result["rows"]] == STAGES
    assert all((tmp_path / "out").joinpath(p).exists() for p in result["files"])
    assert not any(p.endswith(".png") for p in result["files"])
    code = cli.main(
        ["demo", "--output", str(tmp_path / "out"), "--size", "90", "--no-plots", "--seed", "2"]
    )
    captured = capsys.readouterr()
    assert code == 0
    assert captured.out.splitlines()[0].startswith("stage")
    assert f"output folder: {tmp_path / 'out'}" in captured.out
    (tmp_path / "file").write_text("x")
    code = cli.main(["demo", "--output", str(tmp_path / "file"), "-q"])
    assert code == 2
    assert "exists and is not a folder" in capsys.readouterr().err
    for size in ("50", "1e9"):  # refused before any work, leaving no folder behind
        code = cli.main(["demo", "--output", str(tmp_path / "none"), "--size", size, "-q"])
        assert code == 2
        assert "size must be in [80, 5000] m" in capsys.readouterr().err
        assert not (tmp_path / "none").exists()


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"size": "100"}, TypeError, "size must be a real number"),
        ({"seed": -1}, ValueError, "seed must be >= 0"),  # was refused after the mkdir
        ({"plots": "no"}, TypeError, "plots must be"),
        ({"survey": 1}, TypeError, "survey must be"),
        ({"stage": 5}, TypeError, "stage must be callable"),
    ],
)
def test_run_demo_checks_its_arguments_before_making_the_folder(
    tmp_path, kwargs: dict, error: type, match: str
) -> None:
    with pytest.raises(error, match=match):
        run_demo(tmp_path / "out", **{"size": 100.0, **kwargs})
    assert not (tmp_path / "out").exists()


def test_the_smallest_scene_runs_for_a_seed_that_cannot_hold_six_buildings(tmp_path):
    # Seed 14 at 80 m places five buildings apart: the demo failed with advice about
    # n_buildings, an option it does not have, and left its folder behind empty.
    with pytest.raises(ValueError, match="n_buildings=6"):
        pcl_rg.datasets.synthetic_scene(seed=14, size=80.0)
    report = run_demo(tmp_path / "out", seed=14, size=80.0, plots=False, survey=False)
    assert report.rows and (tmp_path / "out").is_dir()
