"""Inputs beyond the core's index types are refused up front, naming the limit.

A zero-stride view of billions of rows costs no memory, so the refusal is tested
for real: it must come before any copy or conversion of the input. Coordinates
that the float32 local frame cannot hold are left out as stray points (up to 1 %)
or refused, instead of becoming inf, and so are masked arrays, whose masks
np.asarray would drop.
"""

from __future__ import annotations

import contextlib
import warnings

import numpy as np
import pytest

import pcl_rg
from pcl_rg import pipeline, reference

UINT32 = 2**32 - 1
INT32 = 2**31 - 1


def rows(n: int) -> np.ndarray:
    return np.broadcast_to(np.zeros(3), (n, 3))  # n rows, 24 bytes of memory


CASES = [
    ("voxel_grid", lambda p: pcl_rg.voxel_grid(p, leaf_size=1.0), UINT32),
    ("statistical_outlier_removal", pcl_rg.statistical_outlier_removal, UINT32),
    ("normals", pcl_rg.normals, UINT32),
    ("grid_ground", pcl_rg.grid_ground, INT32),
    ("tin_ground", pcl_rg.tin_ground, INT32 - 8),
    ("region_growing", pcl_rg.region_growing, INT32),
    ("pcl.region_growing", pcl_rg.pcl.region_growing, INT32),
    ("pcl.normals", pcl_rg.pcl.normals, INT32),
    ("pcl.voxel_grid", lambda p: pcl_rg.pcl.voxel_grid(p, leaf_size=1.0), UINT32),
    ("pipeline.seed004", pipeline.seed004, UINT32),
]


@pytest.mark.parametrize(("name", "call", "limit"), CASES, ids=[c[0] for c in CASES])
def test_one_point_over_the_limit_is_refused_without_allocating(name, call, limit) -> None:
    with pytest.raises(ValueError, match=f"at most {limit:,} points are supported"):
        call(rows(limit + 1))


@pytest.mark.parametrize("limit", [INT32 - 8, INT32, UINT32])
def test_the_message_names_the_index_type_and_the_count(limit) -> None:
    from pcl_rg._validation import as_points

    with pytest.raises(ValueError, match=r"uint32|int32") as error:
        as_points(rows(limit + 1), max_points=limit)
    assert f"got {limit + 1:,}" in str(error.value)
    # At the limit itself the gate lets a (small) cloud through unchanged.
    assert as_points(np.ones((4, 3)), max_points=limit).shape == (4, 3)


def _per_point(result) -> np.ndarray:
    """A step's result as one row per point (normals: every field side by side)."""
    if isinstance(result, pcl_rg.NormalsResult):
        return np.column_stack(list(result))
    return np.asarray(result)


# Ours and the references: a far point is left out (reference._local.near_rows).
LEAVING_OUT_STEPS = [
    ("statistical_outlier_removal", pcl_rg.statistical_outlier_removal),
    ("normals", pcl_rg.normals),
    ("region_growing", pcl_rg.region_growing),
    ("convex_segmentation", pcl_rg.convex_segmentation),
    ("point_scale", pcl_rg.point_scale),
    ("reference.statistical_outlier_removal", reference.statistical_outlier_removal),
    ("reference.normals", reference.normals),
    ("reference.region_growing", reference.region_growing),
    ("reference.convex_segmentation", reference.convex_segmentation),
    ("reference.point_scale", reference.point_scale),
]
# PCL's classes work on one float32 cloud, which cannot hold the far point with the rest.
REFUSING_STEPS = [
    ("pcl.voxel_grid", lambda p: pcl_rg.pcl.voxel_grid(p, leaf_size=1.0)),
    ("pcl.statistical_outlier_removal", pcl_rg.pcl.statistical_outlier_removal),
    ("pcl.normals", pcl_rg.pcl.normals),
    ("pcl.region_growing", pcl_rg.pcl.region_growing),
    ("pcl.progressive_morphological_filter", pcl_rg.pcl.progressive_morphological_filter),
]
FLOAT32_STEPS = LEAVING_OUT_STEPS + REFUSING_STEPS
# Nothing at all for a point without neighbours: an outlier, NaN geometry, no segment.
NO_NEIGHBOURS = {"statistical_outlier_removal": False, "region_growing": -1}
NO_NEIGHBOURS["convex_segmentation"] = -1


@pytest.mark.parametrize("far", [-1e39, 1e39, -1e300, -1e9, 2e6])
@pytest.mark.parametrize(("name", "call"), LEAVING_OUT_STEPS, ids=[c[0] for c in LEAVING_OUT_STEPS])
def test_a_point_beyond_float32s_reach_is_left_out(name, call, far) -> None:
    # One far point below the rest made the minimum corner far, and every other point
    # minus it lost its precision in float32 (all inf beyond 3.4e38; at 1e9, steps of
    # 64 m): silently wrong, then refused. Such a stray point (a record at (0, 0, 0) in
    # a UTM tile) is now left out: the others get the run without it, and it gets the
    # result of a point without neighbours.
    points = np.random.default_rng(0).random((300, 3)) * [50.0, 50.0, 5.0]
    # Ours say so (a real second site far away is left out too); the references do not.
    ours = not name.startswith("reference.")
    with (
        (
            pytest.warns(pcl_rg.FarPointsWarning, match=f"^{name}: 1 of 301 points lie more than")
            if ours
            else contextlib.nullcontext()
        ),
        pcl_rg.collect_diagnostics() as diagnostics,
    ):
        beside = _per_point(call(np.r_[points, [[0.0, far, 0.0]]]))
    if ours:
        assert diagnostics[name]["far_points"] == 1
    with pcl_rg.collect_diagnostics() as diagnostics:
        alone = _per_point(call(points))
    if ours:
        assert diagnostics[name]["far_points"] == 0
    if name.endswith("point_scale"):  # measured on the others
        np.testing.assert_array_equal(beside, alone)
        return
    np.testing.assert_array_equal(beside[:-1], alone)
    expected = NO_NEIGHBOURS.get(name.removeprefix("reference."))
    if expected is None:  # normals: every field NaN
        assert np.isnan(beside[-1]).all()
    else:
        assert beside[-1] == expected


def test_the_core_neighbour_lists_leave_far_points_out_as_the_reference_does() -> None:
    from pcl_rg import _core
    from pcl_rg._normals import NormalsParams
    from pcl_rg.reference.normals import neighbour_lists

    utm = np.random.default_rng(2).random((400, 3)) * [50.0, 50.0, 5.0] + [5e5, 5.4e6, 0.0]
    points = np.r_[utm[:200], [[0.0, 0.0, 0.0]], utm[200:], [[5e5, 1e7, 0.0]]]
    core = np.asarray(_core.neighbour_lists(points, NormalsParams(k=8).to_core()))
    np.testing.assert_array_equal(core, neighbour_lists(points, 8))
    assert (core[200] == 200).all() and (core[401] == 401).all()  # themselves alone
    # The others: their lists without the far points, numbered in the whole cloud.
    alone = np.asarray(_core.neighbour_lists(utm, NormalsParams(k=8).to_core()))
    np.testing.assert_array_equal(np.delete(core, [200, 401], axis=0), alone + (alone >= 200))


def test_the_cores_far_rows_and_limit_are_the_references() -> None:
    # pcl_rg.batch's denoise finds a tile's far points with the core, from an origin of
    # its own choosing, and holds their count over the survey to max_far_points: the
    # rule of near_rows, without its limit.
    from pcl_rg import _core
    from pcl_rg.reference._local import float32_origin, max_far_points, near_rows

    utm = np.random.default_rng(4).random((300, 3)) * [50.0, 50.0, 5.0] + [5e5, 5.4e6, 0.0]
    for far_rows in ([], [0], [17, 298, 299]):
        points = utm.copy()
        points[far_rows] = [0.0, 0.0, 0.0]
        expected = near_rows(points)
        origin = _core.float32_origin(points)
        np.testing.assert_array_equal(origin, float32_origin(points))
        kept = _core.rows_within_float32_reach(points, origin)
        np.testing.assert_array_equal(kept, np.arange(300) if expected is None else expected)
    points = utm.copy()
    points[:5] = [0.0, 0.0, 0.0]  # more than near_rows leaves out: it refuses
    with pytest.raises(ValueError, match="lie more than"):
        near_rows(points)
    origin = _core.float32_origin(points)
    kept = _core.rows_within_float32_reach(points, origin)
    np.testing.assert_array_equal(kept, np.arange(5, 300))
    # From the origin of the bad records instead, the others are the far ones.
    kept = _core.rows_within_float32_reach(points, np.zeros(3))
    np.testing.assert_array_equal(kept, np.arange(5))
    assert len(_core.rows_within_float32_reach(np.empty((0, 3)), origin)) == 0
    np.testing.assert_array_equal(_core.float32_origin(np.empty((0, 3))), np.zeros(3))
    with pytest.raises(ValueError, match=r"origin must have shape \(3,\)"):
        _core.rows_within_float32_reach(points, np.zeros(2))
    for n in (0, 1, 99, 100, 199, 200, 250, 10**9):
        assert _core.max_far_points(n) == max_far_points(n)


def test_the_far_point_count_is_what_the_core_left_out_in_every_frame() -> None:
    # Once the far points are out, the kept points get a frame of their own, whose origin
    # may lie far below the first one, so that a point that was near is far in turn:
    # here 1 point at x = 5e6, then 1 at 1.9e6 (25 at 0, 74 at 1e6). The warning and
    # the diagnostics give the core's count over both frames (2), which a count of the
    # first frame alone missed (1).
    rng = np.random.default_rng(6)
    x = np.r_[np.zeros(25), np.full(74, 1e6), [1.9e6, 5e6]] + rng.random(101)
    points = np.c_[x, rng.random((101, 2)) * [50.0, 5.0]]
    calls = {
        "normals": lambda p: np.isnan(pcl_rg.normals(p, k=8).normals).all(axis=1),
        "region_growing": lambda p: pcl_rg.region_growing(p, k=8, min_cluster_size=2) < 0,
        "convex_segmentation": lambda p: pcl_rg.convex_segmentation(p, k=8) < 0,
        "statistical_outlier_removal": lambda p: ~pcl_rg.statistical_outlier_removal(p, mean_k=8),
        "point_scale": lambda p: pcl_rg.point_scale(p) and None,
    }
    for name, call in calls.items():
        with (
            pytest.warns(pcl_rg.FarPointsWarning, match=f"^{name}: 2 of 101 points") as caught,
            pcl_rg.collect_diagnostics() as diagnostics,
        ):
            left_out = call(points)
        assert len(caught) == 1 and caught[0].filename == __file__, name
        assert diagnostics[name]["far_points"] == 2, name
        if left_out is not None:
            assert left_out[-2:].all(), name
    # The reference leaves out the same two.
    assert np.isnan(reference.normals(points, k=8).normals[-2:]).all()
    assert not np.isnan(reference.normals(points, k=8).normals[:-2]).any()


@pytest.mark.parametrize(("name", "call"), FLOAT32_STEPS, ids=[c[0] for c in FLOAT32_STEPS])
def test_more_far_points_than_one_percent_are_refused(name, call) -> None:
    # 1 % of the points may be strays; more mean a cloud wider than one float32 frame
    # (two surveys 2,000 km apart), whose far part would all come out as outliers.
    points = np.random.default_rng(0).random((300, 3)) * [50.0, 50.0, 5.0]
    far = np.zeros((4, 3)) + [0.0, 2e6, 0.0]
    if (name, call) in LEAVING_OUT_STEPS:
        with warnings.catch_warnings():  # counted in the test above
            warnings.simplefilter("ignore", pcl_rg.FarPointsWarning)
            call(np.r_[points, far[:3]])  # 3 of 303 are left out
    with pytest.raises(ValueError, match=r"more than 2\^24 x 0.1"):
        call(np.r_[points, far])


@pytest.mark.parametrize("far", [-1e39, 1e39, -1e300, -1e9, 2e6])
@pytest.mark.parametrize(("name", "call"), REFUSING_STEPS, ids=[c[0] for c in REFUSING_STEPS])
def test_pcl_refuses_a_point_beyond_float32s_reach(name, call, far) -> None:
    points = np.random.default_rng(0).random((300, 3)) * [50.0, 50.0, 5.0]
    with pytest.raises(ValueError, match=r"more than 2\^24 x 0.1"):
        call(np.r_[points, [[0.0, far, 0.0]]])
    call(points)  # the same cloud without it runs


@pytest.mark.parametrize(("name", "call"), FLOAT32_STEPS, ids=[c[0] for c in FLOAT32_STEPS])
def test_a_survey_within_float32s_reach_runs(name, call) -> None:
    # 1,600 km apart, at UTM-sized coordinates: within reach (2^24 x 0.1 = 1,677.7 km).
    points = np.random.default_rng(1).random((300, 3)) * [50.0, 50.0, 5.0] + [5e5, 5.4e6, 0]
    call(np.r_[points, points[:1] + [0.0, 1.6e6, 0.0]])


@pytest.mark.parametrize(("name", "call", "limit"), CASES, ids=[c[0] for c in CASES])
def test_masked_points_are_refused_not_unmasked(name, call, limit) -> None:
    # np.asarray drops a mask: the masked rows (here far away) would be used silently.
    points = np.ma.masked_array(np.random.default_rng(0).uniform(0.0, 10.0, (60, 3)))
    points[:5] = 1e3
    points[:5] = np.ma.masked
    with pytest.raises(ValueError, match="masked arrays are not accepted"):
        call(points)


def test_voxel_indices_beyond_2_62_are_refused_by_both_layers() -> None:
    # int64 would wrap them: three points 1e19 apart fell into one voxel.
    points = np.array([[1e19, 0, 0], [2e19, 0, 0], [3e19, 0, 0.0]])
    for voxel_grid in (pcl_rg.voxel_grid, reference.voxel_grid):
        with pytest.raises(ValueError, match=r"voxel indices exceed 2\^62 on axis 0"):
            voxel_grid(points, 1.0)
        with pytest.raises(ValueError, match=r"voxel indices exceed 2\^62 on axis 0"):
            voxel_grid(np.random.default_rng(0).random((50, 3)) + [0, 0, 1.0], 1e-300)


@pytest.mark.parametrize("far", [1e308, 1e200])
def test_an_extent_whose_area_is_not_finite_is_refused(far) -> None:
    # An inf extent made the cell NaN (and its cast undefined); 1e200 on both axes gave
    # an area of inf, a spacing of inf, and cells blamed on cell_size.
    points = np.array([[far, far, 0.0], [-far, -far, 0.0], [0.0, 1.0, 0.0]])
    for call in (pcl_rg.point_spacing, reference.point_spacing, pcl_rg.grid_ground):
        with pytest.raises(ValueError, match="XY extent is too large to measure the point spacing"):
            call(points)


def test_a_far_point_is_blamed_when_the_cell_size_was_unset() -> None:
    points = np.vstack([np.random.default_rng(0).uniform(0, 10, (50, 3)), [[1e15, 0, 0]]])
    messages = set()
    for grid_ground in (pcl_rg.grid_ground, reference.grid_ground):
        with pytest.raises(ValueError, match="cell_size unset: from the point spacing") as error:
            grid_ground(points)
        messages.add(str(error.value).split(" m from the block corner")[1])
        with pytest.raises(ValueError, match=r"cell_size is too small .* 2\^40 cells on x"):
            grid_ground(points, cell_size=1e-4)
    assert len(messages) == 1  # the same words after the extent


def test_reference_seed_windows_wider_than_the_raster() -> None:
    # Clipped to the raster (2n - 1 cells): a max_building_size of 2^31 m took 8 GB.
    rng = np.random.default_rng(0)
    terrain = np.c_[rng.uniform(0, 50, (2000, 2)), rng.uniform(0, 0.2, 2000)]
    for size in (40.0, 1e8, 2.0**31):
        np.testing.assert_array_equal(
            reference.tin_ground(terrain, max_building_size=size),
            pcl_rg.tin_ground(terrain, max_building_size=size),
        )


TABLE_CASES = [
    ("region_growing", pcl_rg.region_growing),
    ("convex_segmentation", pcl_rg.convex_segmentation),
]


@pytest.mark.parametrize(("name", "call"), TABLE_CASES, ids=[c[0] for c in TABLE_CASES])
def test_a_neighbour_table_over_8_gib_is_refused_before_it_is_made(name, call) -> None:
    # k = N - 1 on 100k points asked for a 40 GB table of neighbour indices and failed
    # with a bare MemoryError (std::bad_alloc); now k is refused, naming its largest.
    points = np.random.default_rng(0).uniform(0.0, 10.0, (100_000, 3))
    largest = 2**33 // (4 * len(points))
    with pytest.raises(ValueError, match=rf"k must be at most {largest} for 100000 points"):
        call(points, k=len(points) - 1)
    with pytest.raises(ValueError, match=rf"k must be at most {largest} .*, got {largest + 1}$"):
        call(points, k=largest + 1)


PCL_SEARCH_CASES = [
    ("pcl.statistical_outlier_removal", pcl_rg.pcl.statistical_outlier_removal, "mean_k"),
    ("pcl.normals", pcl_rg.pcl.normals, "k"),
    ("pcl.region_growing", pcl_rg.pcl.region_growing, "k"),
]


@pytest.mark.parametrize(
    ("name", "call", "k"), PCL_SEARCH_CASES, ids=[c[0] for c in PCL_SEARCH_CASES]
)
def test_pcl_searches_over_two_minutes_are_refused(name, call, k) -> None:
    # PCL's k-nearest searches cost about 1.1e-7 s per N x k at large k, and cannot be
    # interrupted: mean_k = N - 1 on 100k points would run for about 18 minutes.
    points = np.random.default_rng(1).uniform(0.0, 10.0, (100_000, 3))
    largest = int(1.2e9 // len(points))
    message = rf"^{k} must be at most {largest} for 100000 points \(PCL's k-nearest searches"
    with pytest.raises(ValueError, match=rf"{message}.*, got 99999$"):
        call(points, **{k: len(points) - 1})
    with pytest.raises(ValueError, match=rf"{message}.*, got {largest + 1}$"):
        call(points, **{k: largest + 1})


NEIGHBOUR_COUNTS = [
    ("statistical_outlier_removal", "mean_k", reference.statistical_outlier_removal),
    ("normals", "k", reference.normals),
    ("region_growing", "k", reference.region_growing),
    ("convex_segmentation", "k", reference.convex_segmentation),
]


@pytest.mark.parametrize(
    ("name", "key", "twin"), NEIGHBOUR_COUNTS, ids=[c[0] for c in NEIGHBOUR_COUNTS]
)
def test_a_neighbour_count_that_only_the_far_points_make_too_large_says_so(name, key, twin):
    # 30 points and a record at (0, 0, 0): k = 30 is below the 31 points passed, but the
    # far one is left out. The message counted the 30 alone, unlike the caller's array.
    points = np.random.default_rng(3).random((30, 3)) * [50.0, 50.0, 5.0] + [5e5, 5.4e6, 0.0]
    points = np.r_[points, np.zeros((1, 3))]
    for call in (getattr(pcl_rg, name), twin):
        with pytest.raises(ValueError) as error:
            call(points, **{key: 30})
        assert str(error.value) == (
            f"{key} must be < the number of points (30 within float32's reach, of 31: 1 far, "
            "left out), got 30"
        )
        with pytest.raises(ValueError, match=rf"^{key} must be < the number of points \(31\)"):
            call(points, **{key: 31})
