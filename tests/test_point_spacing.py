"""The measured point spacing and the density-aware defaults of the ground filters.

pcl_rg.point_spacing (C++) against pcl_rg.reference.point_spacing (the same float64
operations: equal, not close), its meaning on clouds of known spacing, and the lengths
of TinGroundParams / GridGroundParams that are unset by default: each call takes them
from the spacing of its points, reports them, and gives what the same call with those
lengths given explicitly gives.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from conftest import examples, shared_data
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

import pcl_rg
from pcl_rg import GridGroundParams, TinGroundParams, reference
from pcl_rg.datasets import load_isprs, synthetic_scene


def grid(step: float, nx: int, ny: int) -> np.ndarray:
    x, y = np.meshgrid(np.arange(nx) * step, np.arange(ny) * step)
    return np.c_[x.ravel(), y.ravel(), np.zeros(x.size)]


# ------------------------------------------------------------------ the spacing


@pytest.mark.parametrize("seed", range(4))
def test_core_equals_reference_on_random_clouds(seed: int) -> None:
    rng = np.random.default_rng(seed)
    n = int(rng.integers(2, 20_000))
    points = rng.uniform(-1.0, 1.0, (n, 3)) * rng.uniform(0.01, 1000.0, 3)
    points += rng.uniform(-1e6, 1e6, 3)
    assert pcl_rg.point_spacing(points) == reference.point_spacing(points)


def test_core_equals_reference_on_isprs_and_a_slim_cloud() -> None:
    points, _ = load_isprs(
        shared_data("isprs", "samp11-utm.pcd"), shared_data("isprs", "samp11-utm-ground.pcd")
    )
    assert pcl_rg.point_spacing(points) == reference.point_spacing(points)
    # 1 km long, 1 micrometre wide, 500 points: the cells are max(w, h) / 65536, more
    # than 64 per point, so the core sorts the keys instead of flagging cells.
    rng = np.random.default_rng(7)
    slim = np.c_[rng.uniform(0, 1000.0, 500), rng.uniform(0, 1e-6, 500), np.zeros(500)]
    assert 3.0 * math.sqrt(1000.0 * 1e-6 / 500) < 1000.0 / 65536
    assert pcl_rg.point_spacing(slim) == reference.point_spacing(slim)
    assert 0.0 < pcl_rg.point_spacing(slim) <= 1000.0 / 65536


@settings(max_examples=examples(60), deadline=None)
@given(
    hnp.arrays(
        np.float64,
        st.tuples(st.integers(0, 60), st.just(3)),
        elements=st.floats(-1e3, 1e3, allow_nan=False).map(lambda v: round(v, 1)),
    )
)
def test_core_equals_reference_on_odd_clouds(points: np.ndarray) -> None:
    # Rounded coordinates give duplicates, collinear and tiny clouds.
    core, ref = pcl_rg.point_spacing(points), reference.point_spacing(points)
    assert (math.isnan(core) and math.isnan(ref)) or core == ref


def test_a_regular_grid_has_its_step_as_spacing() -> None:
    # Cells straddle the last row and column: within 2 % for a 200 x 200 grid.
    for step in (0.2, 1.0, 2.5):
        assert pcl_rg.point_spacing(grid(step, 200, 200)) == pytest.approx(step, rel=0.02)


def test_empty_parts_of_the_box_do_not_count() -> None:
    full = grid(1.0, 200, 200)
    # An L-shaped outline: three quarters of the box hold points.
    corner = full[~((full[:, 0] >= 100) & (full[:, 1] >= 100))]
    assert pcl_rg.point_spacing(corner) == pytest.approx(pcl_rg.point_spacing(full), rel=0.02)


def test_more_points_per_area_give_a_smaller_spacing() -> None:
    rng = np.random.default_rng(1)
    for density in (0.25, 4.0, 25.0):
        n = int(density * 100 * 100)
        points = np.c_[rng.uniform(0, 100, (n, 2)), np.zeros(n)]
        # Uniform random points: sqrt(1 / density), less the few empty cells at 9 per cell.
        expected = 1.0 / math.sqrt(density)
        assert pcl_rg.point_spacing(points) == pytest.approx(expected, rel=0.03)


def test_translation_by_an_exact_offset_keeps_the_spacing() -> None:
    points = np.round(np.random.default_rng(2).uniform(0, 50, (3000, 3)) * 1024) / 1024
    moved = points + [500_000.0, 5_000_000.0, 100.0]
    assert pcl_rg.point_spacing(moved) == pcl_rg.point_spacing(points)


def test_undefined_spacing_is_nan() -> None:
    assert math.isnan(pcl_rg.point_spacing(np.zeros((0, 3))))
    assert math.isnan(pcl_rg.point_spacing([[1.0, 2.0, 3.0]]))
    assert math.isnan(pcl_rg.point_spacing([[1.0, 2.0, 3.0], [1.0, 2.0, 5.0]]))
    wall = np.c_[np.zeros(50), np.arange(50.0), np.arange(50.0)]  # no XY area
    assert math.isnan(pcl_rg.point_spacing(wall))
    assert math.isnan(reference.point_spacing(wall))


def test_bad_points_are_refused() -> None:
    with pytest.raises(ValueError, match="NaN or Inf"):
        pcl_rg.point_spacing([[0.0, 0.0, np.nan], [1.0, 1.0, 1.0]])
    with pytest.raises(ValueError, match="shape"):
        pcl_rg.point_spacing(np.zeros((4, 2)))
    with pytest.raises(TypeError):
        pcl_rg.point_spacing(np.zeros((4, 3), dtype=complex))


# ------------------------------------------------------------------ unset lengths

TIN_LENGTHS = ("stop_edge", "near_vertex_distance", "seed_cell", "final_cell", "densify_cell")
# The ISPRS preset's lengths, which an unset length never exceeds (the caps).
ISPRS_LENGTHS = {
    "stop_edge": 2.0,
    "near_vertex_distance": 1.0,
    "seed_cell": 2.0,
    "final_cell": 3.0,
    "densify_cell": 1.5,
}


def test_the_defaults_leave_the_spacing_lengths_unset() -> None:
    tin, grid_params = TinGroundParams(), GridGroundParams()
    assert all(getattr(tin, name) is None for name in TIN_LENGTHS)
    assert set(tin.SPACING_MULTIPLES) == set(tin.SPACING_CAPS) == set(TIN_LENGTHS)
    assert grid_params.cell_size is None and set(grid_params.SPACING_MULTIPLES) == {"cell_size"}
    # So do the presets that are the defaults; LiDAR360's set is fixed lengths.
    assert TinGroundParams.isprs() == tin and GridGroundParams.isprs() == grid_params
    assert all(getattr(TinGroundParams.lidar360(), n) is not None for n in TIN_LENGTHS)


def test_unset_and_given_values_are_checked() -> None:
    assert TinGroundParams(stop_edge=None).stop_edge is None
    with pytest.raises(ValueError, match="stop_edge must be > 0, got 0"):
        TinGroundParams(stop_edge=0.0)
    with pytest.raises(ValueError, match="cell_size must be <= block_size"):
        GridGroundParams(cell_size=40.0)
    for params in (TinGroundParams(), GridGroundParams()):
        with pytest.raises(ValueError, match="spacing must be > 0, got 0"):
            params.at_spacing(0.0)
        with pytest.raises(ValueError, match="spacing must be finite"):
            params.at_spacing(math.nan)


def assert_rung(length: float, name: str, spacing: float) -> None:
    """`length` is the largest cap x 2^(-j/8), j >= 0 whole, at most multiple x spacing."""
    cap, most = (
        TinGroundParams.SPACING_CAPS[name],
        TinGroundParams.SPACING_MULTIPLES[name] * spacing,
    )
    j = round(-8 * math.log2(length / cap))
    assert j >= 0 and length == pytest.approx(cap * 2 ** (-j / 8), rel=1e-12)
    assert length <= most and (j == 0 or cap * 2 ** (-(j - 1) / 8) > most)


def test_at_spacing_uses_the_multiples_and_keeps_given_lengths() -> None:
    spacing = 0.37
    fixed = TinGroundParams(near_vertex_distance=0.0).at_spacing(spacing)
    assert fixed.stop_edge == TinGroundParams.SPACING_MULTIPLES["stop_edge"] * spacing
    for name in ("seed_cell", "final_cell"):  # on a world lattice: a rung below the cap
        assert_rung(getattr(fixed, name), name, spacing)
    assert fixed.near_vertex_distance == 0.0  # given: kept (0 is "off")
    assert fixed.at_spacing(5.0) == fixed  # nothing left unset
    cells = GridGroundParams(block_size=(30.0, 20.0)).at_spacing(spacing).cell_size
    largest = GridGroundParams.SPACING_MULTIPLES["cell_size"] * spacing
    for block, cell in zip((30.0, 20.0), cells):
        # The largest cell of at most `largest` that divides the block a whole number of times.
        k = round(block / cell)
        assert math.isclose(block / k, cell) and cell <= largest < block / (k - 1)


@pytest.mark.parametrize("spacing", [0.96, 0.99, 1.06, 2.41, 50.0])
def test_at_isprs_spacing_and_sparser_the_unset_lengths_are_the_isprs_ones(
    spacing: float,
) -> None:
    # The ISPRS samples have 0.99-2.41 m: the caps bind, so the defaults are the fixed
    # lengths chosen and cross-validated there; below 0.95 m they shrink with the spacing,
    # the stop edge (multiple of a 4 m edge) only below 0.475 m.
    assert TinGroundParams().at_spacing(spacing) == TinGroundParams(**ISPRS_LENGTHS)
    denser = TinGroundParams().at_spacing(0.9 * 0.95)
    assert denser.stop_edge == 2.0 and denser.near_vertex_distance == pytest.approx(0.9)
    for name in ("seed_cell", "final_cell", "densify_cell"):  # 0.9 x cap: cap x 2^(-2/8)
        assert_rung(getattr(denser, name), name, 0.9 * 0.95)
        assert getattr(denser, name) == pytest.approx(ISPRS_LENGTHS[name] * 2**-0.25)
    for factor, stop_edge in ((1.01, 2.0), (0.9, 0.9 * 2.0)):
        assert TinGroundParams().at_spacing(factor * 0.475).stop_edge == pytest.approx(stop_edge)


def test_the_defaults_give_the_fixed_length_preset_on_isprs() -> None:
    # samp41, the smallest urban sample (1.06 m spacing), and samp31, the densest (0.99 m).
    for sample in ("samp41", "samp31"):
        points, _ = load_isprs(
            shared_data("isprs", f"{sample}-utm.pcd"),
            shared_data("isprs", f"{sample}-utm-ground.pcd"),
        )
        assert 0.95 <= pcl_rg.point_spacing(points) < 1.1
        np.testing.assert_array_equal(
            pcl_rg.tin_ground(points), pcl_rg.tin_ground(points, **ISPRS_LENGTHS)
        )


def scenes() -> list[np.ndarray]:
    sparse = synthetic_scene(seed=8, size=80.0, density=0.8, n_buildings=2, n_trees=5).points
    dense = synthetic_scene(seed=9, size=60.0, density=12.0, n_buildings=1, n_trees=5).points
    return [sparse + [500_000.0, 5_000_000.0, 0.0], dense]


def run_with_the_lengths_of_the_spacing(
    name: str, params_type: type, points: np.ndarray
) -> tuple[dict, object, np.ndarray]:
    """Ground filter `name` with its default parameters: it reports the measured spacing
    and gives what `params_type().at_spacing(spacing)` given explicitly gives. Returns
    what it reports, those explicit parameters and the labels."""
    ground_filter = getattr(pcl_rg, name)
    spacing = pcl_rg.point_spacing(points)
    with pcl_rg.collect_diagnostics() as diagnostics:
        ground = ground_filter(points)
    used = diagnostics[name]
    assert used["point_spacing"] == spacing
    explicit = params_type().at_spacing(spacing)
    np.testing.assert_array_equal(ground_filter(points, params=explicit), ground)
    return used, explicit, ground


@pytest.mark.parametrize("index", [0, 1], ids=["0.8 pts/m2", "12 pts/m2"])
def test_tin_ground_takes_and_reports_the_lengths_of_the_spacing(index: int) -> None:
    points = scenes()[index]
    used, explicit, _ = run_with_the_lengths_of_the_spacing("tin_ground", TinGroundParams, points)
    for name in TIN_LENGTHS:
        assert used[name] == getattr(explicit, name)
    # Given lengths: no spacing is measured, and the given ones are used.
    with pcl_rg.collect_diagnostics() as diagnostics:
        pcl_rg.tin_ground(points, params=TinGroundParams.lidar360())
    assert math.isnan(diagnostics["tin_ground"]["point_spacing"])
    assert diagnostics["tin_ground"]["stop_edge"] == 2.0


@pytest.mark.parametrize("index", [0, 1], ids=["0.8 pts/m2", "12 pts/m2"])
def test_grid_ground_takes_and_reports_the_cell_of_the_spacing(index: int) -> None:
    points = scenes()[index]
    used, explicit, ground = run_with_the_lengths_of_the_spacing(
        "grid_ground", GridGroundParams, points
    )
    assert used["cell_size"] == explicit.cell_size
    np.testing.assert_array_equal(reference.grid_ground(points), ground)
    with pcl_rg.collect_diagnostics() as diagnostics:
        pcl_rg.grid_ground(points, cell_size=2.0)
    assert math.isnan(diagnostics["grid_ground"]["point_spacing"])
    assert diagnostics["grid_ground"]["cell_size"] == (2.0, 2.0)


def test_without_an_xy_area_the_lengths_take_one_metre() -> None:
    wall = np.c_[np.zeros(200), np.repeat(np.arange(20.0), 10), np.tile(np.arange(10.0), 20)]
    with pcl_rg.collect_diagnostics() as diagnostics:
        pcl_rg.grid_ground(wall)
    assert diagnostics["grid_ground"]["point_spacing"] == 1.0
    expected = GridGroundParams().at_spacing(1.0).cell_size
    assert diagnostics["grid_ground"]["cell_size"] == expected


def test_the_lengths_scale_with_the_density() -> None:
    # The same objects at 8 and 32 pts/m^2: half the spacing, half the lengths (up to the
    # Poisson counts), where fixed lengths would stay. (At 2 pts/m^2 the stop edge would
    # still be at its cap.)
    used = []
    for density in (8.0, 32.0):
        points = synthetic_scene(seed=4, size=60.0, density=density, n_buildings=1).points
        with pcl_rg.collect_diagnostics() as diagnostics:
            pcl_rg.tin_ground(points)
        used.append(diagnostics["tin_ground"])
    ratio = used[1]["point_spacing"] / used[0]["point_spacing"]
    assert ratio == pytest.approx(0.5, rel=0.05)
    for name in TIN_LENGTHS:
        # The cells are rungs 2^(1/8) apart: in proportion up to that step.
        step = 0.1 if name.endswith("_cell") else 1e-9
        assert used[1][name] / used[0][name] == pytest.approx(ratio, rel=step)


def test_extreme_spacings_give_the_caps_or_the_proportional_cells() -> None:
    # 1e308 overflowed the product to inf and log2(0) raised "math domain error"; the
    # core gives the caps there. Below cap / DBL_MAX the rungs cannot be counted: as
    # min(cap, multiple x spacing), as before.
    assert TinGroundParams().at_spacing(1e308) == TinGroundParams(**ISPRS_LENGTHS)
    tiny = TinGroundParams().at_spacing(1e-310)
    assert tiny.seed_cell == TinGroundParams.SPACING_MULTIPLES["seed_cell"] * 1e-310


def test_a_stray_point_moves_no_cell_of_tin_grounds_lattices_in_utm() -> None:
    # One point 1 km above the tile nudges the spacing by 1.6e-5 (0.819847 -> 0.819834
    # m). Cells in proportion to it sat on the world lattice of a length 1.6e-5 shorter,
    # which at x = 500 km is 8 m of shift: 508 of 60,000 labels changed. The rungs of a
    # ladder below the caps do not move with such a nudge.
    points = synthetic_scene(seed=0, offset=(5e5, 5.4e6, 0.0)).points[:60_000]
    stray = np.r_[points, [[500_100.0, 5_400_100.0, 1000.0]]]
    np.testing.assert_array_equal(pcl_rg.tin_ground(stray)[:-1], pcl_rg.tin_ground(points))

    # The rule before, cells of min(cap, multiple x spacing), on the same two spacings
    # (densify_cell off, as it was then: the moved seed and final cells alone change
    # 508 labels; with it on, 28).
    def proportional(cloud: np.ndarray) -> np.ndarray:
        spacing = pcl_rg.point_spacing(cloud)
        cells = {
            name: min(TinGroundParams.SPACING_CAPS[name], multiple * spacing)
            for name, multiple in TinGroundParams.SPACING_MULTIPLES.items()
            if name in ("seed_cell", "final_cell")
        }
        params = TinGroundParams(**cells, densify_cell=0.0).at_spacing(spacing)
        return pcl_rg.tin_ground(cloud, params=params)

    assert (proportional(stray)[:-1] != proportional(points)).sum() > 100


def test_the_c_structs_leave_the_lengths_unset_too() -> None:
    core = TinGroundParams().to_core()
    assert core.stop_edge is None and core.seed_cell is None
    core.stop_edge = 1.5
    assert core.stop_edge == 1.5
    assert dataclasses.replace(GridGroundParams(), cell_size=2.0).to_core().cell_size == (2.0, 2.0)


def test_spacing_scale_and_normals_report_what_they_measured() -> None:
    points = scenes()[1]
    with pcl_rg.collect_diagnostics() as diagnostics:
        spacing = pcl_rg.point_spacing(points)
        scale = pcl_rg.point_scale(points)
        pcl_rg.normals(points[:2000], k=12)
    assert diagnostics["point_spacing"] == {"points": len(points), "point_spacing": spacing}
    assert diagnostics["point_scale"]["noise"] == scale.noise
    assert diagnostics["point_scale"]["point_spacing"] == scale.spacing
    assert diagnostics["normals"] == {"points": 2000, "k": 12, "far_points": 0}


def test_diagnostics_iterate_over_the_functions_recorded() -> None:
    points = scenes()[1]
    with pcl_rg.collect_diagnostics() as diagnostics:
        assert not diagnostics and len(diagnostics) == 0
        pcl_rg.point_spacing(points)
        pcl_rg.grid_ground(points[:5000])
        pcl_rg.point_spacing(points[:100])
    assert list(diagnostics) == ["point_spacing", "grid_ground"] and len(diagnostics) == 2
    assert diagnostics["point_spacing"]["points"] == 100  # the latest call
