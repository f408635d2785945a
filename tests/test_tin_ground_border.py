"""tin_ground's border vertices: virtual vertices along the long sides of the XY box.

Without them the TIN's only virtual vertices are the box's four corners, and along
a corridor its border triangles reach to corners kilometres away; where the seeds'
opening is clipped at the uphill side of a slope, that side's strip then stays
without ground (tin_ground.cpp, border_points in ground_tin.hpp).
"""

from __future__ import annotations

import dataclasses
import sys
from pathlib import Path

import numpy as np
import pytest
from tin_ground_helpers import ISPRS, LIDAR360

import pcl_rg
from pcl_rg import reference
from pcl_rg.reference.tin_ground import MAX_BORDER_PARTS, border_points

# The corridors of the study that reports the option's effect (benchmarks/RESULTS.md).
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks" / "studies"))
from tin_corridor import corridor  # noqa: E402


def test_a_corridor_keeps_the_ground_of_its_uphill_side() -> None:
    points, truth, across = corridor(2000.0, 30.0, 2.0, seed=1)
    uphill = across > 20.0
    lost = {
        border: ~pcl_rg.tin_ground(points, border_vertices=border)[truth & uphill]
        for border in (False, True)
    }
    assert lost[True].mean() < 0.03  # 1.2 % when written
    # Off, the four corners alone: the strip the clipped opening leaves without seeds
    # loses its ground (the reason for the option; 31 % of it when written).
    assert lost[False].mean() > 5 * lost[True].mean() + 0.1


@pytest.mark.parametrize(
    "params",
    [
        ISPRS,
        dataclasses.replace(LIDAR360, border_vertices=True),
        dataclasses.replace(ISPRS, max_building_size=7.0),  # every 10 m on the long sides
    ],
    ids=["isprs", "lidar360-with-border", "short-parts"],
)
def test_core_equals_reference_on_a_corridor(params) -> None:
    points, _, _ = corridor(500.0, 10.0, 1.0, seed=2)
    np.testing.assert_array_equal(
        pcl_rg.tin_ground(points, params=params), reference.tin_ground(points, params=params)
    )


def test_border_heights_do_not_depend_on_the_order_of_the_points() -> None:
    # Each border vertex takes its nearest seed's height, ties by the lower seed: a
    # permutation of the rows permutes the mask and changes nothing else.
    points, _, _ = corridor(800.0, 15.0, 1.0, seed=3, direction=90.0)  # the sides along y
    points[:, :2] = np.round(points[:, :2])  # whole metres: many equidistant seeds
    points = np.unique(points, axis=0)
    perm = np.random.default_rng(4).permutation(len(points))
    ground = pcl_rg.tin_ground(points)
    np.testing.assert_array_equal(pcl_rg.tin_ground(points[perm]), ground[perm])
    np.testing.assert_array_equal(reference.tin_ground(points), ground)


def test_border_points_cut_only_sides_at_least_twice_the_spacing() -> None:
    # A box about square gets none; a corridor's long sides are cut into equal parts
    # of at least the spacing and less than twice it; the count per side is capped.
    assert border_points(100, 100, 50.0, 50.0, 50.0)[0].size == 0
    assert border_points(100, 99, 50.0, 49.5, 49.5)[0].size == 0
    # 12 parts of each long side, the cuts of the two sides in turn (each insertion then
    # changes a few triangles next to the last one's: the order of the core's).
    cuts = [j * 1002 // 12 for j in range(1, 12)]
    x, y = border_points(1002, 42, 500.0, 20.0, 40.0)
    assert list(zip(x.tolist(), y.tolist())) == [(c, side) for c in cuts for side in (0, 42)]
    x, y = border_points(42, 1002, 20.0, 500.0, 40.0)  # the same along y
    assert list(zip(x.tolist(), y.tolist())) == [(side, c) for c in cuts for side in (0, 42)]
    x, _ = border_points(2**29, 4, 1e9, 1.0, 1.0)
    assert x.size == 2 * (MAX_BORDER_PARTS - 1)
