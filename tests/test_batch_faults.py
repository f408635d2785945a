"""Batch runs against damaged or misleading tiles and a damaged output folder: header
boxes unlike their points, tiles in two coordinate systems, failed reruns, the record
of finished tiles; and the parameters a run reports."""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import pytest
from conftest import run_pcl_rg
from test_batch import corrupt_points

import pcl_rg
from pcl_rg import batch
from pcl_rg.batch._manifest import MANIFEST
from pcl_rg.datasets import synthetic_survey


def shift_header_min_xy(path, by):
    """Move a LAS/LAZ header's min x and min y by `by` metres, leaving the points alone
    (the header is stored uncompressed in LAZ too: doubles at bytes 187 and 203)."""
    data = bytearray(Path(path).read_bytes())
    for offset in (187, 203):
        value = np.frombuffer(bytes(data[offset : offset + 8]), "<f8")[0] + by
        data[offset : offset + 8] = np.float64(value).tobytes()
    Path(path).write_bytes(bytes(data))


@pytest.mark.parametrize("by", [-2000.0, 10.0, 0.02])  # far too wide, too small, a bit small
def test_a_header_box_unlike_its_points_fails_its_tile(by, tmp_path, scheduler):
    # The run's plan (neighbours, the survey's spacing) comes from the headers: a box
    # that lies must not pass silently.
    source = synthetic_survey(tmp_path / "in", tiles=(1, 2), tile_size=40.0, seed=4)
    bad = source.paths[0]
    batch.ground(source.paths, tmp_path / "out", scheduler=scheduler)  # an earlier output
    shift_header_min_xy(bad, by)
    report = batch.ground(source.paths, tmp_path / "out", scheduler=scheduler)
    assert [t.input for t in report.failed] == [bad]
    assert "header's bounding box" in report.failed[0].error
    assert [t.status for t in report.tiles] == ["failed", "done"]
    assert not os.path.exists(report.failed[0].output)  # that output is gone


def test_a_header_box_rounded_outwards_passes(tmp_path, scheduler):
    # Some writers round the bounds outwards: harmless to the plan, so not refused.
    source = synthetic_survey(tmp_path / "in", tiles=(1, 2), tile_size=40.0, seed=4)
    shift_header_min_xy(source.paths[0], -0.3)
    report = batch.ground(source.paths, tmp_path / "out", scheduler=scheduler)
    assert [t.status for t in report.tiles] == ["done", "done"]


def add_crs_record(path, wkt):
    import laspy

    las = laspy.read(path)  # in place of any record it has
    las.vlrs = [v for v in las.vlrs if v.user_id != "LASF_Projection"]
    las.vlrs.append(laspy.VLR("LASF_Projection", 2112, "wkt", wkt.encode() + b"\0"))
    las.write(path)


UTM_32N_WKT1 = (
    'PROJCS["WGS 84 / UTM zone 32N",GEOGCS["WGS 84",DATUM["WGS_1984",SPHEROID["WGS 84",'
    '6378137,298.257223563,AUTHORITY["EPSG","7030"]],AUTHORITY["EPSG","6326"]],'
    'AUTHORITY["EPSG","4326"]],PROJECTION["Transverse_Mercator"],UNIT["metre",1],'
    'AUTHORITY["EPSG","32632"]]'
)
UTM_32N_WKT2 = (
    'PROJCRS["WGS 84 / UTM zone 32N",BASEGEOGCRS["WGS 84",ID["EPSG",4326]],ID["EPSG",32632]]'
)


def test_tiles_in_two_coordinate_systems_are_refused(tmp_path, scheduler):
    source = synthetic_survey(tmp_path / "in", tiles=(1, 2), tile_size=40.0, seed=4)
    # One system written two ways (WKT 1, WKT 2) is one system.
    add_crs_record(source.paths[0], UTM_32N_WKT1)
    add_crs_record(source.paths[1], UTM_32N_WKT2)
    report = batch.ground(source.paths, tmp_path / "a", scheduler=scheduler)
    assert {t.status for t in report.tiles} == {"done"}
    add_crs_record(source.paths[1], UTM_32N_WKT2.replace("32632", "32633"))
    with pytest.raises(ValueError, match="EPSG:32632 and .* in EPSG:32633"):
        batch.ground(source.paths, tmp_path / "b", scheduler=scheduler)
    assert not [name for name in os.listdir(tmp_path / "b") if not name.startswith(".")]


@pytest.mark.parametrize("damage", ["header", "points"])  # found at stage 0, at stage 1
def test_a_failed_rerun_removes_the_tiles_earlier_output(damage, tmp_path, scheduler):
    source = synthetic_survey(tmp_path / "in", tiles=(1, 2), tile_size=40.0, seed=4)
    out = tmp_path / "out"
    first = batch.ground(source.paths, out, scheduler=scheduler)
    assert os.path.exists(first.tiles[0].output)
    if damage == "header":  # the input is damaged since
        Path(source.paths[0]).write_bytes(Path(source.paths[0]).read_bytes()[:3000])
    else:
        corrupt_points(source.paths[0])
    again = batch.ground(source.paths, out, scheduler=scheduler)
    assert [t.input for t in again.failed] == [source.paths[0]]
    assert "earlier output" in again.failed[0].error
    # No output left that does not come from its current input, nor a record of one.
    assert not os.path.exists(again.tiles[0].output)
    manifest = json.loads((out / MANIFEST).read_text())
    assert os.path.basename(source.paths[0]) not in manifest
    # Its neighbour ran without its buffer: done, and not recorded, so redone next time.
    assert again.tiles[1].status == "done" and again.tiles[1].no_buffer_from


def test_a_run_without_resuming_forgets_the_record_on_disk(tmp_path, scheduler):
    source = synthetic_survey(tmp_path / "in", tiles=(1, 2), tile_size=40.0, seed=4)
    out = tmp_path / "out"
    batch.ground(source.paths, out, scheduler=scheduler)
    corrupt_points(source.paths[0])
    batch.ground(source.paths, out, resume=False, scheduler=scheduler)
    assert os.path.basename(source.paths[0]) not in json.loads((out / MANIFEST).read_text())


def test_a_folder_in_place_of_the_manifest_is_refused(tmp_path, survey):
    (tmp_path / "out" / MANIFEST).mkdir(parents=True)
    with pytest.raises(ValueError, match="is not a file"):
        batch.ground(survey.paths[:2], tmp_path / "out")


def test_the_report_gives_the_parameters_the_tiles_ran_with(tmp_path, scheduler):
    source = synthetic_survey(tmp_path / "in", tiles=(1, 2), tile_size=40.0, seed=4)
    report = batch.ground(source.paths, tmp_path / "out", scheduler=scheduler)
    used = pcl_rg.GridGroundParams().at_spacing(batch.survey_spacing(source.paths))
    assert report.parameters["cell_size"] == list(used.cell_size)  # not None, as given
    options = ["--out", tmp_path / "c", "--scheduler", scheduler, "--json"]
    result = run_pcl_rg("batch", "ground", *source.paths, *options, timeout=300)
    assert json.loads(result.stdout)["parameters"]["cell_size"] == list(used.cell_size)
