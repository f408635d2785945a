"""LAS points whose withheld flag is set are "not to be included in processing" (LAS
1.4): every command and batch operation leaves them out and keeps their class."""

from __future__ import annotations

import json
import os

import laspy
import numpy as np
import pytest
from conftest import run_pcl_rg
from test_batch import agreement, merged
from units_files import write_las

import pcl_rg
from pcl_rg import batch
from pcl_rg.datasets import synthetic_scene, synthetic_survey
from pcl_rg.io import read_points


def withhold(path, target, rows):
    """A copy of the LAS/LAZ `path` with the withheld flag set on `rows`, which are
    lowered 1.5 m (withheld low points that would spoil the work if used)."""
    las = laspy.read(path)
    las.withheld = np.isin(np.arange(len(las.points)), rows)
    las.z = np.asarray(las.z) - np.where(las.withheld, 1.5, 0.0)
    las.classification = np.full(len(las.points), 5, np.uint8)
    las.write(target)


@pytest.fixture(scope="module")
def scene_file(tmp_path_factory):
    folder = tmp_path_factory.mktemp("withheld")
    points = synthetic_scene(seed=3, size=120.0, density=4).points
    write_las(folder / "scene.las", points)
    rows = np.random.default_rng(0).choice(len(points), 300, replace=False)
    withhold(folder / "scene.las", folder / "withheld.las", rows)
    return folder / "withheld.las"


@pytest.mark.parametrize("command", ["ground", "denoise", "segment"])
def test_commands_leave_withheld_points_out(command, scene_file, tmp_path):
    cloud = read_points(scene_file)
    withheld = cloud.fields["withheld"].astype(bool)
    out = tmp_path / "out.las"
    result = run_pcl_rg(command, scene_file, out, "--json")
    assert result.returncode == 0, result.stderr
    assert json.loads(result.stdout)["skipped_withheld"] == 300
    written = read_points(out)
    kept = cloud.points[~withheld]
    if command == "ground":
        expected = np.where(pcl_rg.grid_ground(kept), 2, 1)
        spoiled = np.where(pcl_rg.grid_ground(cloud.points), 2, 1)[~withheld]
        assert (expected != spoiled).sum() > 100  # the low points would change it
        np.testing.assert_array_equal(written.classification[~withheld], expected)
    elif command == "denoise":
        expected = np.where(pcl_rg.statistical_outlier_removal(kept), 5, 7)
        np.testing.assert_array_equal(written.classification[~withheld], expected)
    else:
        assert (written.fields["segment_id"][withheld] == -1).all()
    assert (written.classification[withheld] == 5).all()  # their class kept


def test_batch_ground_leaves_withheld_points_out(tmp_path, scheduler):
    source = synthetic_survey(tmp_path / "in", tiles=(1, 2), tile_size=60.0, seed=6)
    os.makedirs(tmp_path / "flagged")
    paths = []
    for k, path in enumerate(source.paths):
        target = tmp_path / "flagged" / os.path.basename(path)
        withhold(path, target, np.arange(k, 5000, 50))
        paths.append(str(target))
    report = batch.ground(paths, tmp_path / "out", scheduler=scheduler)
    clouds = merged(paths)
    points = np.concatenate([c.points for c in clouds])
    withheld = np.concatenate([c.fields["withheld"] for c in clouds]).astype(bool)
    params = pcl_rg.GridGroundParams().at_spacing(batch.survey_spacing(paths))
    expected = np.full(len(points), 5)
    expected[~withheld] = np.where(pcl_rg.grid_ground(points[~withheld], params=params), 2, 1)
    assert agreement(report, expected) >= 0.999


def test_a_field_named_withheld_in_another_format_is_data(tmp_path):
    # Only LAS defines the flag; a PLY property of that name is the user's.
    points = synthetic_scene(seed=3, size=120.0, density=1).points
    flag = np.ones(len(points), np.float32)
    pcl_rg.io.write_points(tmp_path / "a.ply", points, {"withheld": flag})
    result = run_pcl_rg("ground", tmp_path / "a.ply", tmp_path / "b.ply", "--json")
    assert result.returncode == 0, result.stderr
    report = json.loads(result.stdout)
    assert report["filtered"] == len(points) and "skipped_withheld" not in report
