"""Batch runs on tiles in US survey feet: the work in metres, as on the merged cloud;
tiles in degrees or in two units refused before any work."""

from __future__ import annotations

import json
import os

import numpy as np
import pytest
from conftest import run_pcl_rg
from test_batch import agreement, merged, outputs_of
from units_files import ESRI_FEET_METRES, NEW_YORK_FTUS_WKT1, US_FOOT, WGS84_DEGREES, in_feet

import pcl_rg
from pcl_rg import batch
from pcl_rg.datasets import synthetic_survey


def feet_survey(folder, wkt, z_in_feet=True):
    """A 2 x 2 synthetic survey written again in feet, stating `wkt`."""
    source = synthetic_survey(folder / "metres", tiles=(2, 2), tile_size=60.0, seed=5)
    os.makedirs(folder / "feet")
    paths = []
    for path in source.paths:
        target = folder / "feet" / (os.path.splitext(os.path.basename(path))[0] + ".las")
        in_feet(path, target, wkt, z_in_feet)
        paths.append(str(target))
    return paths


def metres_of(paths):
    """The merged cloud of `paths` in metres, and its metres per unit."""
    clouds = merged(paths)
    factors = np.array([clouds[0].units.xy, clouds[0].units.xy, clouds[0].units.z])
    return np.concatenate([c.points for c in clouds]) * factors, factors


def test_ground_on_feet_tiles_matches_the_merged_run_in_metres(tmp_path, scheduler):
    paths = feet_survey(tmp_path, NEW_YORK_FTUS_WKT1)
    report = batch.ground(paths, tmp_path / "out", scheduler=scheduler)
    points, factors = metres_of(paths)
    assert report.units["metres_per_unit"] == list(factors)
    assert "US survey foot" in report.units["source"]
    spacing = batch.survey_spacing(paths) * factors[0]  # the headers' spacing is in feet
    params = pcl_rg.GridGroundParams().at_spacing(spacing)
    assert report.parameters["cell_size"] == list(params.cell_size)
    classes = np.concatenate([c.classification for c in merged(paths)])
    work = ~np.isin(classes, (7, 18))  # noise is left as it was, as pcl-rg ground does
    expected, unscaled = classes.copy(), classes.copy()
    expected[work] = np.where(pcl_rg.grid_ground(points[work], params=params), 2, 1)
    unscaled[work] = np.where(pcl_rg.grid_ground(points[work] / factors), 2, 1)
    assert agreement(report, expected) >= 0.999
    # What the run gave before: the survey is 99 % ground, so only ~0.1 % differ.
    assert (expected != unscaled).sum() > 50
    assert agreement(report, unscaled) < agreement(report, expected)


def test_denoise_on_feet_and_metres_tiles_is_the_merged_run_in_metres(tmp_path, scheduler):
    # x, y in feet, z in metres: distances change shape, not only scale.
    paths = feet_survey(tmp_path, ESRI_FEET_METRES, z_in_feet=False)
    params = pcl_rg.StatisticalOutlierRemovalParams(mean_k=8, std_mul=1.0)
    report = batch.denoise(paths, tmp_path / "out", params=params, scheduler=scheduler)
    points, factors = metres_of(paths)
    assert factors[0] != factors[2]
    expected = ~pcl_rg.statistical_outlier_removal(points, params=params)
    unscaled = ~pcl_rg.statistical_outlier_removal(points / factors, params=params)
    got = np.concatenate([c.classification for c in outputs_of(report)]) == 7
    assert np.array_equal(got, expected) and not np.array_equal(got, unscaled)


def test_downsample_on_feet_tiles_writes_feet(tmp_path, scheduler):
    paths = feet_survey(tmp_path, NEW_YORK_FTUS_WKT1)
    params = pcl_rg.VoxelGridParams(leaf_size=2.0)
    report = batch.downsample(paths, tmp_path / "out", params=params, scheduler=scheduler)
    points, factors = metres_of(paths)
    grid = pcl_rg.voxel_grid(points, params=params)
    got = np.concatenate([c.points for c in outputs_of(report)])
    assert len(got) == len(grid.centroids)
    # Each centroid back in feet (within LAS's 0.01 ft) and inside its voxel's feet.
    assert np.abs(got * factors).max() < np.abs(grid.centroids).max() + 1.0
    assert abs(got.mean(axis=0) - (grid.centroids / factors).mean(axis=0)).max() < 0.01


def test_degrees_or_two_units_are_refused_before_any_work(tmp_path, scheduler):
    paths = feet_survey(tmp_path, NEW_YORK_FTUS_WKT1)
    in_feet(paths[1], tmp_path / "degrees.las", WGS84_DEGREES, True)
    with pytest.raises(ValueError, match="longitude and latitude"):
        batch.ground([tmp_path / "degrees.las"], tmp_path / "a", scheduler=scheduler)
    in_feet(paths[1], tmp_path / "mixed.las", ESRI_FEET_METRES, True)
    with pytest.raises(ValueError, match="not in one unit"):
        batch.ground([paths[0], tmp_path / "mixed.las"], tmp_path / "b", scheduler=scheduler)
    for folder in ("a", "b"):
        assert not os.path.exists(tmp_path / folder)  # not even the folder the run made
    with pytest.raises(ValueError, match="units must be one of"):
        batch.ground(paths, tmp_path / "c", units="yard")


def test_the_command_says_the_tiles_units(tmp_path, scheduler):
    paths = feet_survey(tmp_path, NEW_YORK_FTUS_WKT1)
    shown = run_pcl_rg(
        "batch", "ground", *paths, "--out", tmp_path / "out2", "--scheduler", scheduler
    )
    assert shown.returncode == 0, shown.stderr
    assert "coordinates in US survey foot" in shown.stdout + shown.stderr
    result = run_pcl_rg(
        "batch", "ground", *paths, "--out", tmp_path / "o3", "--scheduler", scheduler, "--json"
    )
    assert json.loads(result.stdout)["units"]["metres_per_unit"][0] == pytest.approx(US_FOOT)
