"""The final pass's virtual vertices on the sides of its TIN's box (final_pass.cpp:
border_vertices). With the four corners alone, the strip between the outermost
vertices and a side took heights interpolated towards corners hundreds of metres
away, and on a slope the uphill strip lay above that surface. Core against reference
on such tiles; the rules themselves in the reference's doctest."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

import pcl_rg
from pcl_rg import GridGroundParams, reference

# The sloping tiles of the study that reports the border vertices of tin_ground.
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks" / "studies"))
from tin_corridor import corridor  # noqa: E402


@pytest.mark.parametrize("seed", [0, 1])
def test_a_sloping_tile_keeps_the_ground_of_its_uphill_side(seed: int) -> None:
    """A 500 m tile rising 0.25 m per m across y. The grid filter's growth alone
    (final_cell=0) keeps the uphill strip; with the corners alone the final pass lost
    11.5 % (seed 0) and 4.1 % (seed 1) of its ground, and 0.00 % with the border
    vertices when written."""
    points, truth, across = corridor(500.0, 500.0, 4.0, seed=seed)
    uphill = truth & (across > 490.0)
    grown = pcl_rg.grid_ground(points, final_cell=0.0)
    assert grown[uphill].mean() > 0.999  # the growth has it: the final pass must keep it
    for ground in (pcl_rg.grid_ground(points), pcl_rg.tin_ground(points)):
        assert ground[uphill].mean() > 0.99
        downhill = truth & (across < 10.0)
        assert ground[downhill].mean() > 0.99


def test_core_equals_reference_on_a_sloping_tile() -> None:
    """Every side holds border vertices, continued uphill, capped, or flat downhill."""
    points, _, _ = corridor(120.0, 80.0, 2.0, seed=3, direction=30.0)
    for final_passes in (1, 3):
        params = GridGroundParams(final_passes=final_passes)
        core = pcl_rg.grid_ground(points, params=params)
        np.testing.assert_array_equal(core, reference.grid_ground(points, params=params))
    core = pcl_rg.tin_ground(points)
    np.testing.assert_array_equal(core, reference.tin_ground(points))
