"""Batch runs on a survey where one tile holds a stray point far away (a bad GPS fix).

The stray point stretches its tile's header box over hundreds of km. It must not set
the survey's spacing (and so every tile's lengths), nor make its tile's buffer the
whole survey: the tile's buffer surrounds its points (batch._plan.footprint).
"""

from __future__ import annotations

import math
import os
import re
import warnings

import numpy as np
import pytest

import pcl_rg
from pcl_rg import batch
from pcl_rg.batch._plan import FOOTPRINT_GAP, Box, footprint, survey_spacing
from pcl_rg.datasets import synthetic_survey
from pcl_rg.io import Extent, read_points, write_points


def add_stray_point(path, classification: int) -> None:
    """Append one point 500 km west and 500 km south of the tile's corner."""
    import laspy

    las = laspy.read(path)
    n = len(las.points)
    points = laspy.ScaleAwarePointRecord.zeros(n + 1, header=las.header)
    points.array[:n] = las.points.array
    points.x[n] = float(np.min(np.asarray(las.x))) - 5e5
    points.y[n] = float(np.min(np.asarray(las.y))) - 5e5
    points.z[n] = float(np.mean(np.asarray(las.z)))
    points.classification[n] = classification
    las.points = points
    las.update_header()
    las.write(path)


def append_records(path, records: int) -> None:
    """Appends `records` records at (0, 0, 0), with zero fields, to the tile at `path`."""
    tile = read_points(path)
    fields = {k: np.concatenate([v, np.zeros_like(v[:records])]) for k, v in tile.fields.items()}
    write_points(path, np.r_[tile.points, np.zeros((records, 3))], fields)


def assert_denoise_is_the_merged_run(paths, report, params) -> np.ndarray:
    """Batch denoise's class-7 points equal one run's outliers over the merged tiles, and
    its tiles' far-point warnings count the merged run's far points."""
    merged = np.concatenate([read_points(p).points for p in paths])
    with pcl_rg.collect_diagnostics() as diagnostics, warnings.catch_warnings():
        warnings.simplefilter("ignore", pcl_rg.FarPointsWarning)  # counted below
        expected = ~pcl_rg.statistical_outlier_removal(merged, params=params)
    got = np.concatenate([read_points(t.output).classification for t in report.tiles]) == 7
    np.testing.assert_array_equal(got, expected)
    warned = [
        int(found.group(1).replace(",", ""))
        for tile in report.tiles
        for line in tile.warnings
        if (found := re.search(r"denoise: ([\d,]+) of [\d,]+ points lie more than", line))
    ]
    far = diagnostics["statistical_outlier_removal"]["far_points"]
    assert sum(warned) == sum(t.details["far_points"] for t in report.tiles) == far
    return expected


def extent(xmin: float, ymin: float, xmax: float, ymax: float, points: int) -> Extent:
    return Extent(xmin, ymin, 0.0, xmax, ymax, 1.0, points, True)


def test_a_tile_with_a_mostly_empty_box_does_not_set_the_survey_spacing() -> None:
    tiles = [extent(100.0 * i, 0.0, 100.0 * i + 100.0, 100.0, 40_000) for i in range(3)]
    regular = survey_spacing(tiles)
    assert regular == 0.5
    stray = extent(-5e5, -5e5, 300.0, 100.0, 40_001)  # 40,000 points and one far away
    assert survey_spacing([*tiles, stray]) == regular
    # Up to twice the median tile's spacing (4 x its area per point) a tile counts;
    # points on a line (no area) count as before.
    sparse = extent(300.0, 0.0, 400.0, 100.0, 10_000)
    line = extent(400.0, 0.0, 400.0, 100.0, 500)
    assert survey_spacing([*tiles, sparse, line]) == math.sqrt(40_000 / 130_500)
    assert survey_spacing([*tiles, extent(300.0, 0.0, 400.0, 100.0, 9_999)]) == regular


def test_denser_tiles_and_slivers_push_no_tile_out() -> None:
    # Only tiles above the median are left out: a sliver of 200 points 2 cm wide, or a
    # tile 20 times as dense, counts as it did, and the others still count.
    tiles = [extent(100.0 * i, 0.0, 100.0 * i + 100.0, 100.0, 40_000) for i in range(8)]
    sliver = extent(800.0, 0.0, 800.02, 100.0, 200)
    dense = extent(900.0, 0.0, 1000.0, 100.0, 800_000)
    for extra in (sliver, dense):
        area = 80_000.0 + (extra.xmax - extra.xmin) * 100.0
        assert survey_spacing([*tiles, extra]) == pytest.approx(
            math.sqrt(area / (320_000 + extra.points)), rel=1e-12
        )


def test_the_footprint_splits_only_at_wide_gaps() -> None:
    rng = np.random.default_rng(0)
    xy = rng.uniform(0.0, 900.0, (5000, 2)) + [500_000.0, 5_000_000.0]
    assert footprint(xy) == [Box(*xy.min(axis=0), *xy.max(axis=0))]
    assert footprint(np.empty((0, 2))) == []
    far = np.r_[xy, [[0.0, 0.0], [xy[0, 0], 0.0]]]  # two strays, one under the tile in x
    boxes = footprint(far)
    assert len(boxes) == 3 and Box(0.0, 0.0, 0.0, 0.0) in boxes
    assert Box(*xy.min(axis=0), *xy.max(axis=0)) in boxes
    # Every point lies in a box; the boxes are more than the gap apart on some axis.
    for point in far:
        assert any(b.xmin <= point[0] <= b.xmax and b.ymin <= point[1] <= b.ymax for b in boxes)
    for a in boxes:
        for b in boxes:
            if a != b:
                assert max(b.xmin - a.xmax, a.xmin - b.xmax, b.ymin - a.ymax, a.ymin - b.ymax) > (
                    FOOTPRINT_GAP
                )


@pytest.mark.parametrize("classification", [1, 7], ids=["unclassified", "noise"])
def test_a_stray_point_changes_no_other_label_nor_the_tiles_buffer(
    classification, tmp_path, scheduler
) -> None:
    source = synthetic_survey(tmp_path / "in", tiles=(3, 3), tile_size=40.0, seed=5)
    params = pcl_rg.GridGroundParams().at_spacing(batch.survey_spacing(source.paths))
    run = {"params": params, "buffer": 5.0, "scheduler": scheduler}  # a buffer within the tiles
    clean = batch.ground(source.paths, tmp_path / "clean", **run)
    add_stray_point(source.paths[4], classification)  # the middle tile
    assert batch.survey_spacing(source.paths) == pytest.approx(
        pcl_rg.point_spacing(np.concatenate([read_points(p).points[:-1] for p in source.paths])),
        rel=0.1,
    )
    report = batch.ground(source.paths, tmp_path / "stray", **run)
    assert [t.status for t in report.tiles] == ["done"] * 9
    for before, after in zip(clean.tiles, report.tiles, strict=True):
        labels = read_points(after.output).classification
        np.testing.assert_array_equal(
            labels[: before.points], read_points(before.output).classification
        )
    # The middle tile's buffer is that of its points, not of its 700 km box (which
    # would take every point of the 8 tiles around it).
    buffer = clean.tiles[4].details["buffer_points"]
    assert 0 < buffer < sum(t.points for t in clean.tiles) / 4
    assert report.tiles[4].details["buffer_points"] == buffer


def test_a_stray_point_leaves_the_survey_lengths_alone(tmp_path, scheduler) -> None:
    # The engine's own spacing (default params, lengths unset): as on the clean survey.
    source = synthetic_survey(tmp_path / "in", tiles=(3, 3), tile_size=40.0, seed=6)
    clean = batch.ground(source.paths, tmp_path / "clean", buffer=5.0, scheduler=scheduler)
    add_stray_point(source.paths[2], 1)
    report = batch.ground(source.paths, tmp_path / "stray", buffer=5.0, scheduler=scheduler)
    assert report.parameters == clean.parameters
    changed = []
    for before, after in zip(clean.tiles, report.tiles, strict=True):
        labels = read_points(after.output).classification[: before.points]
        changed.append(int((labels != read_points(before.output).classification).sum()))
    # The corner tile holding the stray point: its final pass's TIN joins the point to
    # the survey's border there (3 of its 6,980 points change, as on one file).
    assert changed[2] < 0.002 * clean.tiles[2].points
    assert changed[:2] + changed[3:] == [0] * 8


@pytest.mark.parametrize("records", [1, 400])
def test_denoise_flags_records_at_the_origin_with_the_ordinary_noise(records, tmp_path, scheduler):
    # (0, 0, 0) in a UTM survey lies beyond float32's reach of its local origin: the
    # merged run leaves it out of its deviation and flags it; the tiles agree. 400 such
    # records are 0.65 % of the survey, which the merged run leaves out, but 1.2 % of the
    # middle tile's cloud with its buffer, which the core alone refused: a tile failed.
    source = synthetic_survey(tmp_path / "in", tiles=(3, 3), tile_size=40.0, seed=5)
    append_records(source.paths[4], records)
    params = pcl_rg.StatisticalOutlierRemovalParams(mean_k=12, std_mul=1.0)
    with pytest.warns(pcl_rg.FarPointsWarning, match=f"denoise: {records:,} of "):
        report = batch.denoise(source.paths, tmp_path / "out", params=params, scheduler=scheduler)
    assert [t.status for t in report.tiles] == ["done"] * 9
    expected = assert_denoise_is_the_merged_run(source.paths, report, params)
    assert expected.sum() > records
    assert (read_points(report.tiles[4].output).classification[-records:] == 7).all()


def test_denoise_refuses_more_far_records_than_the_merged_run_takes(tmp_path, scheduler):
    # Over 1 % of the survey's points far away: the merged run refuses the cloud; the
    # batch fails the tile that holds them, with the count over the survey, and writes
    # the others (with the threshold of their own points, as when any tile fails).
    source = synthetic_survey(tmp_path / "in", tiles=(3, 3), tile_size=40.0, seed=5)
    survey_points = sum(len(read_points(p)) for p in source.paths)
    records = survey_points // 99 + 1  # just over 1 % of the survey with them
    append_records(source.paths[4], records)
    merged = np.concatenate([read_points(p).points for p in source.paths])
    params = pcl_rg.StatisticalOutlierRemovalParams(mean_k=12, std_mul=1.0)
    with pytest.raises(ValueError, match=f"{records} of {len(merged)} points lie more than"):
        pcl_rg.statistical_outlier_removal(merged, params=params)
    report = batch.denoise(source.paths, tmp_path / "out", params=params, scheduler=scheduler)
    assert [t.status for t in report.tiles] == ["done"] * 4 + ["failed"] + ["done"] * 4
    message = f"{records} of the survey's {len(merged)} points lie more than 2^24 x 0.1"
    assert message in report.tiles[4].error
    assert not (tmp_path / "out" / os.path.basename(report.tiles[4].output)).exists()
    others = [t for t in report.tiles if t.status == "done"]
    assert all(math.isfinite(t.details["threshold"]) for t in others)


def test_denoise_keeps_a_tile_whose_own_cloud_is_mostly_bad_records(tmp_path, scheduler):
    # A corner tile of 150 points and 400 records at (0, 0, 0): 0.74 % of the survey,
    # which the merged run takes for the far points, but 73 % of the tile's own cloud,
    # whose own origin lies among them. Far points are decided from the survey's origin,
    # so the batch flags the records and judges the 150 points as the merged run does.
    source = synthetic_survey(tmp_path / "in", tiles=(3, 3), tile_size=40.0, seed=5)
    clouds = [read_points(p) for p in source.paths]
    corner = int(np.argmin([c.points[:, :2].min(axis=0).sum() for c in clouds]))
    tile = clouds[corner]
    rows = np.argsort(tile.points[:, :2].sum(axis=1), kind="stable")[:150]  # a dense patch
    fields = {k: np.concatenate([v[rows], np.zeros_like(v[:400])]) for k, v in tile.fields.items()}
    write_points(source.paths[corner], np.r_[tile.points[rows], np.zeros((400, 3))], fields)
    params = pcl_rg.StatisticalOutlierRemovalParams(mean_k=12, std_mul=1.0)
    with pytest.warns(pcl_rg.FarPointsWarning, match="denoise: 400 of 550 points"):
        report = batch.denoise(
            source.paths, tmp_path / "out", params=params, buffer=1.0, scheduler=scheduler
        )
    assert [t.status for t in report.tiles] == ["done"] * 9
    assert_denoise_is_the_merged_run(source.paths, report, params)
    flagged = read_points(report.tiles[corner].output).classification == 7
    assert flagged[150:].all() and not flagged[:150].all()  # the records, not the patch


def test_the_survey_origin_is_the_merged_runs_found_from_the_tiles(tmp_path):
    # Batch denoise decides far points from the origin of one run over the merged
    # survey, found from each tile's sorted coordinates: it must be the core's, exactly.
    from pcl_rg import _core
    from pcl_rg.batch._origin import merged_float32_origin, save_sorted_axes

    rng = np.random.default_rng(7)
    utm = rng.random((3000, 3)) * [120.0, 120.0, 30.0] + [5e5, 5.4e6, -5.0]
    clouds = {
        "plain": utm,
        "records at 0": np.r_[utm, np.zeros((40, 3))],
        "mostly records": np.r_[utm[:500], np.zeros((2500, 3))],
        "a stray above": np.r_[utm, [[5e5, 9e9, 1.0]]],
        "ties": np.round(utm / 10.0) * 10.0,
        "signs": rng.normal(size=(999, 3)),
        "one point": utm[:1],
    }
    for name, cloud in clouds.items():
        parts = np.array_split(cloud[rng.permutation(len(cloud))], 5)
        folders = []
        for k, part in enumerate(parts + [cloud[:0]]):  # and an empty tile
            folders.append(str(tmp_path / f"{name}{k}"))
            os.mkdir(folders[-1])
            save_sorted_axes(folders[-1], part)
        expected = tuple(_core.float32_origin(np.ascontiguousarray(cloud)))
        assert merged_float32_origin(folders) == expected, name
    assert merged_float32_origin(folders[-1:]) == (0.0, 0.0, 0.0)


def test_denoise_far_points_are_the_merged_runs_at_the_reach_edge(tmp_path, scheduler):
    # A survey whose northing straddles 2^24 x 0.1 = 1677721.6 m, with records at
    # (0, 0, 0): whether they are far depends on the origin to the metre. The median of
    # the tiles' own origins (the survey's middle) took them for far points while the
    # merged run's origin (its southern edge) did not: 462 points differed.
    source = synthetic_survey(
        tmp_path / "in", tiles=(3, 3), tile_size=40.0, seed=5, origin=(5e5, 1677701.6, 100.0)
    )
    append_records(source.paths[0], 3)
    params = pcl_rg.StatisticalOutlierRemovalParams(mean_k=12, std_mul=1.0)
    report = batch.denoise(source.paths, tmp_path / "out", params=params, scheduler=scheduler)
    assert [t.status for t in report.tiles] == ["done"] * 9
    assert_denoise_is_the_merged_run(source.paths, report, params)


def test_a_tile_of_bad_records_alone_reads_no_buffer(tmp_path, scheduler):
    # Every point of it far: its distances are known (infinite) without neighbours.
    # It widened its buffer until it took in the whole survey, 5,400 km away.
    source = synthetic_survey(tmp_path / "in", tiles=(2, 2), tile_size=40.0, seed=5)
    tile = read_points(source.paths[0])
    fields = {k: np.zeros_like(v[:30]) for k, v in tile.fields.items()}
    records = str(tmp_path / "in" / "records.las")
    write_points(records, np.zeros((30, 3)), fields)
    params = pcl_rg.StatisticalOutlierRemovalParams(mean_k=12, std_mul=1.0)
    paths = [*source.paths, records]
    with pytest.warns(pcl_rg.FarPointsWarning, match="records.las: denoise: 30 of 30 points"):
        report = batch.denoise(paths, tmp_path / "out", params=params, scheduler=scheduler)
    assert [t.status for t in report.tiles] == ["done"] * 5
    assert report.tiles[4].details["buffer_used"] <= report.tiles[0].details["buffer_used"]
    assert (read_points(report.tiles[4].output).classification == 7).all()
    assert_denoise_is_the_merged_run(paths, report, params)


def test_neighbours_are_the_tiles_whose_boxes_meet_the_grown_box():
    from pcl_rg.batch._plan import grow, meets, neighbours

    rng = np.random.default_rng(5)
    corners = rng.integers(0, 40, size=(300, 2)).astype(float)  # touching edges are common
    sizes = rng.choice([1.0, 5.0, 10.0, 200.0], size=(300, 2))
    boxes = [Box(x, y, x + w, y + h) for (x, y), (w, h) in zip(corners, sizes, strict=True)]
    boxes[7] = boxes[50] = None
    for margin in (0.0, 2.5, 15.0):
        expected = [
            []
            if box is None
            else [j for j, b in enumerate(boxes) if j != i and b and meets(grow(box, margin), b)]
            for i, box in enumerate(boxes)
        ]
        assert neighbours(boxes, margin) == expected
        assert any(expected) and not all(expected)


def test_denoise_names_the_far_points_when_the_survey_is_too_small_for_mean_k(tmp_path):
    # The merged run's message counts the points within float32's reach and the far ones
    # left out; the batch, which reaches the whole survey, says the same.
    source = synthetic_survey(tmp_path / "in", tiles=(1, 2), tile_size=40.0, seed=5)
    for path in source.paths:
        tile = read_points(path)
        write_points(path, tile.points[:10], {k: v[:10] for k, v in tile.fields.items()})
    append_records(source.paths[1], 1)
    merged = np.concatenate([read_points(p).points for p in source.paths])
    params = pcl_rg.StatisticalOutlierRemovalParams(mean_k=20)
    with pytest.raises(ValueError) as error:
        pcl_rg.statistical_outlier_removal(merged, params=params)
    assert "(20 within float32's reach, of 21: 1 far, left out), got 20" in str(error.value)
    report = batch.denoise(source.paths, tmp_path / "out", params=params, workers=1)
    assert [t.status for t in report.tiles] == ["failed", "failed"]
    assert {t.error for t in report.tiles} == {f"ValueError: {error.value}"}
    # Two records are more far points than 22 points may hold: that comes first, as in
    # the merged run, not the count of mean_k.
    append_records(source.paths[1], 1)
    merged = np.concatenate([read_points(p).points for p in source.paths])
    with pytest.raises(ValueError, match="^points: 2 of 22 points lie more than 2"):
        pcl_rg.statistical_outlier_removal(merged, params=params)
    report = batch.denoise(source.paths, tmp_path / "again", params=params, workers=1)
    assert [t.status for t in report.tiles] == ["failed", "failed"]
    message = "ValueError: points: 2 of the survey's 22 points lie more than 2^24 x 0.1"
    assert all(t.error.startswith(message) for t in report.tiles)
