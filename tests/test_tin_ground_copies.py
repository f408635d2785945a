"""tin_ground on clouds with copies of points: the core does the definition's idle
iterations (every choice already a vertex) at once (tin_idle_iterations.cpp); its mask
and iteration count must stay the reference's."""

from __future__ import annotations

import sys

import numpy as np
import pytest
from tin_ground_helpers import GRID, LIDAR360, scene

import pcl_rg
from pcl_rg import reference


def reference_iterations(monkeypatch) -> list[int]:
    """A counter of the reference's iterations (one TIN per iteration), reset per call."""
    module = sys.modules["pcl_rg.reference.tin_ground"]
    count = [0]
    real = module.triangulate

    def counting(*args, **kwargs):
        count[0] += 1
        return real(*args, **kwargs)

    monkeypatch.setattr(module, "triangulate", counting)
    return count


@pytest.mark.parametrize("params", GRID[:3], ids=[str(i) for i in range(3)])
def test_copies_of_points_give_the_references_mask_and_iterations(params, monkeypatch) -> None:
    # A copy of a vertex is accepted one per triangle per iteration and adds no vertex,
    # so the definition spends iterations that leave the TIN as it was; the core does
    # them at once (skip_idle_iterations) and must still count them and end with the
    # reference's mask. Copies of 40 points (2 to 39 each), and points stacked on 10
    # of them at other heights.
    rng = np.random.default_rng(3)
    points = scene(1).points
    picked = rng.choice(len(points), 40, replace=False)
    copies = np.repeat(points[picked], rng.integers(2, 40, 40), axis=0)
    stacked = np.repeat(points[picked[:10]], 5, axis=0)
    stacked[:, 2] += rng.uniform(-0.3, 0.3, len(stacked))
    cloud = np.r_[points, copies, stacked][rng.permutation(len(points) + len(copies) + 50)]
    count = reference_iterations(monkeypatch)
    with pcl_rg.collect_diagnostics() as diagnostics:
        core = pcl_rg.tin_ground(cloud, params=params)
    np.testing.assert_array_equal(core, reference.tin_ground(cloud, params=params))
    assert diagnostics["tin_ground"]["iterations"] == count[0]


def test_many_copies_of_one_point_are_not_tested_once_per_iteration(monkeypatch) -> None:
    # 600 copies of one point and 10 others: the definition takes about one iteration
    # per copy. Testing every waiting copy in each of them was quadratic (2e8 tests for
    # 20,000 copies); the core tests each point a few times. densify_cell off: with it
    # only the lowest copy is tested.
    points = np.zeros((610, 3))
    points[600:] = np.random.default_rng(0).uniform(0.0, 10.0, (10, 3))
    count = reference_iterations(monkeypatch)
    with pcl_rg.collect_diagnostics() as diagnostics:
        core = pcl_rg.tin_ground(points, densify_cell=0.0)
    np.testing.assert_array_equal(core, reference.tin_ground(points, densify_cell=0.0))
    assert diagnostics["tin_ground"]["iterations"] == count[0] > 590
    assert diagnostics["tin_ground"]["tests"] <= 2 * len(points)


@pytest.mark.parametrize("copies", [0, 5])
def test_iterations_end_when_every_point_is_ground(copies, monkeypatch) -> None:
    # The reference stops as soon as no point is left to test; so must the core's count.
    corners = [[0.0, 0.0, 0.0], [10.0, 0.0, 0.0], [0.0, 10.0, 0.0], [10.0, 10.0, 0.0]]
    points = np.array(corners + [[3.0, 3.0, 0.0]] * (1 + copies))
    count = reference_iterations(monkeypatch)
    with pcl_rg.collect_diagnostics() as diagnostics:
        core = pcl_rg.tin_ground(points, params=LIDAR360)
    np.testing.assert_array_equal(core, reference.tin_ground(points, params=LIDAR360))
    assert core.all()
    assert diagnostics["tin_ground"]["iterations"] == count[0]


def test_a_corridor_across_the_axes_is_not_refused() -> None:
    # A 7 km x 50 m strip at 45 degrees fills every row and column of its box: 6.2M seed
    # cells for 175,000 points, over the 4-per-point limit, so it was refused while the
    # same strip along an axis ran (ground hunt; roads and power lines run so). 1.4 % of
    # its cells hold a point; a cloud too sparse for its cells stays refused
    # (test_tin_ground.py's tests of the seed cell's advice).
    rng = np.random.default_rng(0)
    along, across = rng.uniform(0.0, 7000.0, 175_000), rng.uniform(0.0, 50.0, 175_000)
    c = np.sqrt(0.5)
    points = np.c_[c * (along - across), c * (along + across), rng.normal(0.0, 0.03, 175_000)]
    points += (500_000.0, 5_000_000.0, 100.0)
    ground = pcl_rg.tin_ground(points)
    assert ground.mean() > 0.99
    np.testing.assert_array_equal(reference.tin_ground(points), ground)
