"""Points far from the rest: a stray return, a bad GPS fix, a point at (0, 0, 0).

A few such points make the bounding box huge and mostly empty. The measured spacing
then follows the occupied cells, not the box (pcl_rg.point_spacing), so the lengths
that follow it stay those of the data; and tin_ground's seed raster leaves out the long
empty runs of cells between the points, whose seeds are those of the full raster, so it
no longer refuses such a cloud. Core against reference, exactly, and against the same
cloud without the stray points.
"""

from __future__ import annotations

import contextlib
import math
import subprocess
import sys

import numpy as np
import pytest
from conftest import shared_data
from hypothesis import given, settings
from hypothesis import strategies as st

import pcl_rg
from pcl_rg import reference
from pcl_rg.datasets import load_isprs
from pcl_rg.evaluation import ground_errors
from pcl_rg.reference.tin_ground import seeds


def terrain(n: int, side: float, seed: int = 0) -> np.ndarray:
    """A gently rolling surface of n random points on a side x side square."""
    rng = np.random.default_rng(seed)
    xy = rng.uniform(0.0, side, (n, 2))
    z = 2.0 * np.sin(xy[:, 0] / 17.0) + np.cos(xy[:, 1] / 23.0) + rng.normal(0.0, 0.05, n)
    return np.c_[xy, z] + [500_000.0, 5_400_000.0, 300.0]


STRAYS = {
    "10 km east": [[510_000.0, 5_400_050.0, 300.0]],
    "100 km north-east": [[600_000.0, 5_500_000.0, 310.0]],
    "700 km diagonal": [[0.0, 4_700_000.0, 300.0]],
    "at the origin": [[0.0, 0.0, 0.0]],
    "three, far apart": [[0.0, 0.0, 0.0], [2e6, 9e6, 900.0], [500_050.0, 5e6, 280.0]],
}


# ------------------------------------------------------------------ the spacing


@pytest.mark.parametrize("strays", STRAYS.values(), ids=STRAYS.keys())
def test_stray_points_barely_move_the_spacing(strays: list) -> None:
    points = terrain(40_000, 200.0)
    alone = pcl_rg.point_spacing(points)
    assert alone == reference.box_spacing(points)  # a covered box: the box sets the cells
    with_strays = pcl_rg.point_spacing(np.r_[points, strays])
    assert with_strays == reference.point_spacing(np.r_[points, strays])
    # The box is at least 50 times wider: measured on the box, the spacing would be
    # more than 10 times too large. On the occupied cells it moves by a few per cent.
    assert with_strays == pytest.approx(alone, rel=0.1)


def test_the_box_measure_is_the_spacing_of_a_covered_box() -> None:
    # reference.box_spacing rounds as point_spacing does (a review found one unit in
    # the last place apart on 14 % of such clouds when it squared the cell first).
    for seed in range(50):
        points = np.random.default_rng(seed).uniform(0.0, 100.0, (500, 3))
        assert reference.box_spacing(points) == pcl_rg.point_spacing(points)


@pytest.mark.parametrize("far", [1e160, 1e200, 1e300])
def test_a_point_so_far_that_the_cell_squared_overflows_gives_a_finite_spacing(
    far: float,
) -> None:
    # The box's area is finite (its height is small), the cell side c is not far below
    # the width, and c**2 overflows float64: the spacing was inf.
    points = np.r_[np.random.default_rng(0).uniform(0.0, 1.0, (200, 3)), [[far, 0.5, 0.0]]]
    spacing = pcl_rg.point_spacing(points)
    assert math.isfinite(spacing) and spacing > 0.0
    assert spacing == reference.point_spacing(points)
    assert math.isfinite(reference.box_spacing(points))


@settings(max_examples=40, deadline=None)
@given(
    n=st.integers(50, 3000),
    far=st.floats(1e3, 1e8),
    angle=st.floats(0.0, 2.0 * math.pi),
    strays=st.integers(1, 5),
    copies=st.integers(1, 60),
)
def test_core_equals_reference_with_stray_points_and_copies(
    n: int, far: float, angle: float, strays: int, copies: int
) -> None:
    # Both branches of the bulk rule: boxes nearly empty, and copies whose 1st-99th
    # percentile box has no area (up to 5 strays: more than 1 % of the smallest clouds).
    points = np.repeat(terrain(n, 100.0), copies, axis=0)
    offsets = far * np.c_[np.cos(angle + np.arange(strays)), np.sin(angle + np.arange(strays))]
    cloud = np.r_[points, np.c_[points[0, :2] + offsets, np.full(strays, 300.0)]]
    assert pcl_rg.point_spacing(cloud) == reference.point_spacing(cloud)


def clusters(rng: np.random.Generator) -> np.ndarray:
    """1,000 clusters of 40 points within 1 cm, over 200 m."""
    centres = np.repeat(rng.uniform(0.0, 200.0, (1000, 3)), 40, axis=0)
    return centres + rng.uniform(0.0, 0.01, centres.shape)


def corridor(rng: np.random.Generator) -> np.ndarray:
    """A 2 km corridor 40 m wide along the diagonal of its box: 2 % of it."""
    along, across = rng.uniform(0.0, 2000.0, 320_000), rng.uniform(-20.0, 20.0, 320_000)
    return np.c_[(along - across) * math.sqrt(0.5), (along + across) * math.sqrt(0.5), along * 0]


def copies(rng: np.random.Generator) -> np.ndarray:
    """60,000 copies of one point and 10 others."""
    points = np.zeros((60_000, 3))
    points[-10:] = rng.uniform(0.0, 10.0, (10, 3))
    return points


@pytest.mark.parametrize("cloud", [clusters, corridor, copies])
def test_clouds_whose_bulk_fills_their_box_keep_the_measure_on_the_box(cloud) -> None:
    # They fill less than a quarter of their box too, but not because of a few far
    # points: their 1st-99th percentile box is the box (or, for copies, has no area).
    points = cloud(np.random.default_rng(1))
    spacing = pcl_rg.point_spacing(points)
    assert spacing == reference.point_spacing(points)
    assert spacing == reference.box_spacing(points)


# ------------------------------------------------------------------ tin_ground


@pytest.mark.parametrize("strays", STRAYS.values(), ids=STRAYS.keys())
def test_tin_ground_takes_stray_points_with_the_reference_seeds(strays: list) -> None:
    # The full seed raster would have 10^8 cells and more: the core closes its empty
    # runs, the reference always does; the seeds are the same.
    points = np.r_[terrain(3000, 120.0), strays]
    params = pcl_rg.TinGroundParams().at_spacing(pcl_rg.point_spacing(points))
    with pcl_rg.collect_diagnostics() as diagnostics:
        ground = pcl_rg.tin_ground(points, params=params)
    assert diagnostics["tin_ground"]["seeds"] == len(seeds(points, params))
    assert ground[:3000].mean() > 0.95  # the terrain is ground


@pytest.mark.parametrize("strays", ["10 km east", "100 km north-east", "700 km diagonal"])
def test_tin_ground_with_stray_points_equals_the_reference(strays: str) -> None:
    # Whole classes, where qhull (the reference's TIN) resolves the grid of the extent:
    # not for extents of thousands of km, whose grid step it cannot separate.
    points = np.r_[terrain(3000, 120.0), STRAYS[strays]]
    params = pcl_rg.TinGroundParams().at_spacing(pcl_rg.point_spacing(points))
    np.testing.assert_array_equal(
        pcl_rg.tin_ground(points, params=params), reference.tin_ground(points, params=params)
    )


def patches(rng: np.random.Generator) -> np.ndarray:
    """2 to 4 square patches of random size, place and level (0, 6 or 12 m) in 50 m."""
    parts = []
    for _ in range(rng.integers(2, 5)):
        side, x, y = rng.uniform(1.0, 10.0), rng.uniform(0.0, 40.0), rng.uniform(0.0, 40.0)
        m = int(2 * side * side) + 1
        parts.append(
            np.c_[
                rng.uniform(x, x + side, m),
                rng.uniform(y, y + side, m),
                rng.choice([0.0, 6.0, 12.0]) + rng.normal(0.0, 0.05, m),
            ]
        )
    return np.concatenate(parts)


@pytest.mark.parametrize("stray", [False, True], ids=["full raster", "closed raster"])
def test_closing_the_gaps_of_the_seed_raster_keeps_the_seeds(stray: bool) -> None:
    # The reference always closes the raster's empty runs longer than the windows'
    # reach (2r for the opening, 2 for the outlier test). On these small clouds the core
    # builds the full raster; with a point 100 km away it closes the gaps too. The seeds
    # and classes must be equal either way. Checked to fail with a reach one cell short
    # (4 of these 80 clouds differ) or half as long (5), in the reference, and with
    # the runs cut one cell shorter in the core.
    rng = np.random.default_rng(0)
    differ = []
    for k in range(80):
        points = patches(rng)
        if stray:
            points = np.r_[points, [[1e5, 7e4, 3.0]]]
        params = pcl_rg.TinGroundParams(
            max_building_size=float(rng.choice([1.0, 3.0, 12.0])),
            seed_cell=1.0,
            outlier_depth=float(rng.choice([0.0, 3.0])),
        )
        with pcl_rg.collect_diagnostics() as diagnostics:
            ground = pcl_rg.tin_ground(points, params=params)
        if diagnostics["tin_ground"]["seeds"] != len(seeds(points, params)) or not np.array_equal(
            ground, reference.tin_ground(points, params=params)
        ):
            differ.append(k)
    assert differ == []


def full_raster_seeds(
    points: np.ndarray, params: pcl_rg.TinGroundParams, monkeypatch: pytest.MonkeyPatch
) -> np.ndarray:
    """The reference's seeds with no empty run cut and no size limit: the oracle."""
    module = sys.modules["pcl_rg.reference._tin_seeds"]
    closing = module._close_gaps
    with monkeypatch.context() as patch:
        patch.setattr(module, "_close_gaps", lambda index, reach: closing(index, 2**62))
        patch.setattr(module, "_raster_limit", lambda points: math.inf)
        return seeds(points, params)


def test_the_closed_raster_gives_the_full_rasters_seeds(monkeypatch: pytest.MonkeyPatch) -> None:
    # A point 2.2 km away: the full raster (4.8 million cells of 1 m) is just over the
    # core's limit, so the core closes it, and small enough for the oracle.
    rng = np.random.default_rng(1)
    for k in range(4):
        points = np.r_[patches(rng), [[2200.0, 2200.0, 3.0]]]
        params = pcl_rg.TinGroundParams(
            max_building_size=[1.0, 3.0, 12.0, 12.0][k], seed_cell=1.0, outlier_depth=[0, 3][k % 2]
        )
        with pcl_rg.collect_diagnostics() as diagnostics:
            pcl_rg.tin_ground(points, params=params)
        oracle = full_raster_seeds(points, params, monkeypatch)
        np.testing.assert_array_equal(seeds(points, params), oracle)
        assert diagnostics["tin_ground"]["seeds"] == len(oracle)


def test_the_raster_border_counts_as_empty_cells(monkeypatch: pytest.MonkeyPatch) -> None:
    # The seed cells start at a multiple of seed_cell at or below the minimum x; here
    # rounding leaves the first column empty. The full raster keeps that column, whose
    # eroded value the opening reads: the closed raster must keep it too (a review
    # found 56 seeds in the core against 48 in the reference).
    cell, xmin = 0.41116543133067146, 78747.22573931285
    corner = reference.lattice_floor(xmin, cell)
    assert math.floor((xmin - corner) / cell) == 1
    columns = [xmin] + [corner + (c + 0.5) * cell for c in range(2, 8)]
    points = np.array(
        [
            [x, (row + 0.5) * cell, 5.0 if c == 0 else 0.0]
            for c, x in enumerate(columns)
            for row in range(8)
        ]
    )
    params = pcl_rg.TinGroundParams(max_building_size=3 * cell, seed_cell=cell, outlier_depth=0.0)
    for cloud in (points, np.r_[points, [[xmin + 1e5, 7e4, 0.0]]]):  # full, then closed
        with pcl_rg.collect_diagnostics() as diagnostics:
            ground = pcl_rg.tin_ground(cloud, params=params)
        assert diagnostics["tin_ground"]["seeds"] == len(seeds(cloud, params))
        np.testing.assert_array_equal(ground, reference.tin_ground(cloud, params=params))
    np.testing.assert_array_equal(
        seeds(points, params), full_raster_seeds(points, params, monkeypatch)
    )


def test_points_scattered_far_apart_are_still_refused() -> None:
    # 600 points 1 km apart along the diagonal: even with every empty run cut short,
    # the raster would hold 10^9 cells.
    k = np.arange(600.0)
    points = np.c_[k * 1000.0, k * 1000.0 + (k % 3), np.zeros(600)]
    for function in (pcl_rg.tin_ground, reference.tin_ground):
        with pytest.raises(ValueError, match=r"seed_cell is too small .* cut short"):
            function(points, seed_cell=1.0)


def test_extreme_extents_are_still_refused() -> None:
    points = np.random.default_rng(0).random((500, 3)) * [50.0, 50.0, 5.0]
    for function in (pcl_rg.tin_ground, reference.tin_ground):
        with pytest.raises(ValueError, match=r"collinear .* far from the rest coarsen it"):
            function(np.r_[points, [[1e15, 1e15, 0.0]]])


def test_sor_flags_only_a_far_point_and_a_second_run_the_ordinary_noise() -> None:
    # As the docstring and README say: the far point raises the deviation of all mean
    # distances until it alone is an outlier (PCL's definition, to the bit).
    points = terrain(20_000, 100.0)
    points[::500, 2] += 3.0  # 40 points well above the surface
    clean = pcl_rg.statistical_outlier_removal(points)
    stray = np.r_[points, [points.mean(axis=0) - [5e5, 5e5, 0.0]]]
    first = pcl_rg.statistical_outlier_removal(stray)
    assert (~clean).sum() >= 40 and np.flatnonzero(~first).tolist() == [len(points)]
    np.testing.assert_array_equal(pcl_rg.statistical_outlier_removal(stray[first]), clean)


def test_sor_leaves_a_point_beyond_float32s_reach_out_of_its_deviation() -> None:
    # A record at (0, 0, 0) in a UTM tile lies 5,400 km from it, beyond float32's reach
    # of the tile's local origin: it was refused. Now it is an outlier by rule and stays
    # out of mu and sigma, so one run also flags the ordinary noise, as without it.
    points = terrain(20_000, 100.0) + [5e5, 5.4e6, 100.0]
    points[::500, 2] += 3.0
    stray = np.r_[points, [[0.0, 0.0, 0.0]]]
    says_so = pytest.warns(pcl_rg.FarPointsWarning, match="1 of 20,001 points lie more than")
    for sor, warns in (
        (pcl_rg.statistical_outlier_removal, says_so),
        (reference.statistical_outlier_removal, contextlib.nullcontext()),
    ):
        clean = sor(points)
        with warns:
            inlier = sor(stray)
        assert (~clean).sum() >= 40 and not inlier[-1]
        np.testing.assert_array_equal(inlier[:-1], clean)


# ------------------------------------------------------------------ on ISPRS


def test_a_stray_point_barely_changes_the_ground_filters_on_isprs() -> None:
    # One point 700 km away (a bad GPS fix) in each of the seven samples. Measured on
    # its box, the spacing was 56-190 m, and grid_ground's mean total error went from
    # 4.4 to 10.9 %; tin_ground refused the cloud. Now grid_ground's lengths stay those
    # of the data; tin_ground's TIN reaches the stray point along the samples' borders.
    # The final pass's side vertices (final_pass_border.hpp) mend the data's border only
    # where it is the box's: the stray point moves the box away, so grid_ground keeps
    # 4.16 % with it against 4.04 % without (both were 4.4 % before the side vertices).
    data = shared_data("isprs")
    totals: dict[str, list[float]] = {"grid": [], "grid stray": [], "tin": [], "tin stray": []}
    for name in ("samp11", "samp21", "samp31", "samp41", "samp51", "samp52", "samp61"):
        sample = load_isprs(data / f"{name}-utm.pcd", data / f"{name}-utm-ground.pcd")
        points, n = sample.points, len(sample.points)
        stray = np.r_[points, [points.mean(axis=0) - [5e5, 5e5, 0.0]]]
        assert pcl_rg.point_spacing(stray) == pytest.approx(pcl_rg.point_spacing(points), rel=0.02)
        for method, function in (("grid", pcl_rg.grid_ground), ("tin", pcl_rg.tin_ground)):
            totals[method].append(ground_errors(sample.ground, function(points)).total)
            totals[f"{method} stray"].append(
                ground_errors(sample.ground, function(stray)[:n]).total
            )
    mean = {key: 100 * float(np.mean(values)) for key, values in totals.items()}  # %
    assert mean["grid stray"] == pytest.approx(mean["grid"], abs=0.2)  # 4.16, 4.04
    assert mean["tin stray"] < mean["tin"] + 0.5  # 3.63, 3.23


@pytest.mark.parametrize("rows", [[0], [0, 1, 150], [299, 300, 301], [5, 301]])
def test_far_points_anywhere_leave_the_others_results_in_their_own_rows(rows: list) -> None:
    # The kept points' results are made in the first rows of the full-size arrays and
    # moved to their own rows in place: far points first, in a run, and last.
    from pcl_rg import _core
    from pcl_rg._normals import NormalsParams

    kept = np.random.default_rng(5).random((302 - len(rows), 3)) * [50.0, 50.0, 5.0]
    kept += [5e5, 5.4e6, 0.0]
    points = np.zeros((302, 3))  # the far points at (0, 0, 0)
    near = np.setdiff1d(np.arange(302), rows)
    points[near] = kept
    with pytest.warns(pcl_rg.FarPointsWarning, match=f"normals: {len(rows)} of 302 points"):
        beside = pcl_rg.normals(points)
    alone = pcl_rg.normals(kept)
    for got, want in zip(beside, alone, strict=True):
        np.testing.assert_array_equal(got[near], want)
        assert np.isnan(got[rows]).all()
    params = NormalsParams(k=6).to_core()
    lists = np.asarray(_core.neighbour_lists(points, params))
    np.testing.assert_array_equal(
        lists[near], near[np.asarray(_core.neighbour_lists(kept, params))]
    )
    np.testing.assert_array_equal(lists[rows], np.repeat(np.c_[rows], 6, axis=1))


def test_a_far_point_costs_no_second_neighbour_table() -> None:
    # The kept points' neighbour lists were made in a table of their own, then copied
    # into a second one for the whole cloud: one stray point nearly doubled region
    # growing's peak memory (1M points, k = 30: +365 MB against +184 MB without it;
    # benchmarks/RESULTS.md, "Far points"), beyond the table's bound.
    script = (
        "import resource, sys, numpy as np, pcl_rg\n"
        "points = np.random.default_rng(0).random((200_000, 3)) * [300.0, 300.0, 5.0]\n"
        "if sys.argv[1] == 'far':\n"
        "    points[7] = [0.0, 0.0, 5e6]\n"
        "before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss\n"
        "pcl_rg.region_growing(points, k=30)\n"
        "print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before)\n"
    )
    # Both at once: each measures its own peak.
    runs = {
        case: subprocess.Popen(
            [sys.executable, "-c", script, case],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        for case in ("clean", "far")
    }
    peak_kib = {}
    try:
        for case, run in runs.items():
            # A bound against a hang, not a speed: 400,000 points under AddressSanitizer
            # beside another job took over 120 s once (200,000 now).
            out, err = run.communicate(timeout=600)
            assert run.returncode == 0, err
            peak_kib[case] = int(out)
    finally:  # neither outlives a failure of the other
        for run in runs.values():
            if run.poll() is None:
                run.kill()
                run.communicate()
    table_kib = 200_000 * 30 * 4 / 1024
    # Left: a float64 copy of the kept points and their row numbers, 32 bytes a point.
    assert peak_kib["far"] - peak_kib["clean"] < 0.5 * table_kib, peak_kib


def test_convex_segmentation_counts_the_points_of_far_centroids() -> None:
    # No point is far in the points' own frame, but the voxel grid's centroids have a
    # frame of their own: one sparse point a voxel near x = +reach outnumbers the dense
    # sites, so the centroids' origin moves there and the dense site near x = -reach is
    # far. Its 800 points were left out (-1) with a count of 0 and no warning.
    reach = 2**24 * 0.1
    rng = np.random.default_rng(0)

    def plane(n: int, size: float, at: tuple[float, float, float]) -> np.ndarray:
        xy = rng.uniform(0.0, size, (n, 2))
        return np.column_stack([xy, rng.normal(0.0, 0.0007, n)]) + at

    grid = np.arange(0.0, 700.0, 10.0)
    sparse = np.array([(reach - 701.0 + x, y, 0.0) for x in grid for y in grid])
    second_site = plane(800, 0.2, (-reach + 10.0, 0.0, 0.0))
    points = np.vstack([plane(20_000, 1.0, (0.0, 0.0, 0.0)), second_site, sparse])
    with (
        pytest.warns(pcl_rg.FarPointsWarning, match="^convex_segmentation: 800 of 25,700"),
        pcl_rg.collect_diagnostics() as diagnostics,
    ):
        labels = pcl_rg.convex_segmentation(points, noise_leaves=120.0)
    assert diagnostics["convex_segmentation"]["leaf"] > 0  # the grid was used
    assert diagnostics["convex_segmentation"]["far_points"] == 800
    assert (labels[20_000:20_800] == -1).all()
    assert (pcl_rg.convex_segmentation(second_site, noise_leaves=0.0) >= 0).all()  # a surface
