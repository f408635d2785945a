"""Helpers of the grid_ground tests (test_grid_ground*.py)."""

from __future__ import annotations

import functools

import numpy as np

import pcl_rg
from pcl_rg import GridGroundParams, reference
from pcl_rg.datasets import SyntheticScene, synthetic_scene

DEFINITION = GridGroundParams.definition()
"""The seed's plain rule (the definition of docs/algorithms.md, no improvement on)."""


def assert_core_equals_reference(points, params):
    """The core's mask, after checking it equals the reference's point for point."""
    core = pcl_rg.grid_ground(points, params=params)
    expected = reference.grid_ground(points, params=params)
    assert core.dtype == np.bool_ and core.shape == (len(points),)
    np.testing.assert_array_equal(core, expected)
    return core


@functools.cache
def small_scene() -> SyntheticScene:
    """A small synthetic scene (70 m square, about 12k points) with its labels."""
    return synthetic_scene(seed=3, size=70.0, density=2.5, n_buildings=2, n_trees=6)
