"""Helpers of the tin_ground tests (test_tin_ground*.py): presets, scenes, the core's
statistics and the ISPRS samples."""

from __future__ import annotations

import dataclasses

import numpy as np
from conftest import shared_data

import pcl_rg
from pcl_rg import _core
from pcl_rg.datasets import load_isprs, synthetic_scene

LIDAR360 = pcl_rg.TinGroundParams.lidar360()
ISPRS = pcl_rg.TinGroundParams.isprs()
# The preset with the lengths fixed (those it had before they followed the spacing), for
# the tests of the world lattice: a subset or a moved cloud keeps them.
ISPRS_FIXED = dataclasses.replace(
    ISPRS, stop_edge=2.0, near_vertex_distance=1.0, seed_cell=2.0, final_cell=3.0
)

# Parameter sets on which the core must equal the reference (test_tin_ground*.py).
GRID = [
    LIDAR360,
    ISPRS,
    pcl_rg.TinGroundParams.lidar360(iteration_angle=25.0, reduce_angle_edge=3.0, stop_edge=1.0),
    pcl_rg.TinGroundParams.lidar360(
        max_building_size=15.0, iteration_distance=0.5, iteration_angle=45.0, max_terrain_angle=60.0
    ),
    pcl_rg.TinGroundParams.lidar360(seed_cell=3.0, seed_tolerance=0.3, near_vertex_distance=0.5),
    pcl_rg.TinGroundParams.lidar360(
        max_building_size=12.0, seed_cell=2.0, outlier_depth=0.5, opening_rank=3
    ),
]


def scene(seed: int, size: float = 70.0, density: float = 1.0):
    return synthetic_scene(seed=seed, size=size, density=density, n_buildings=1, n_trees=6)


def run_core(points: np.ndarray, params: pcl_rg.TinGroundParams) -> tuple[np.ndarray, dict]:
    """The mask and the run statistics of the C++ core."""
    return _core.tin_ground(np.ascontiguousarray(points, dtype=np.float64), params.to_core())


def isprs(sample: str) -> tuple[np.ndarray, np.ndarray]:
    return load_isprs(
        shared_data("isprs", f"{sample}-utm.pcd"), shared_data("isprs", f"{sample}-utm-ground.pcd")
    )
