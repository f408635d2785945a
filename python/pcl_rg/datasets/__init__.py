"""Seeded synthetic airborne-LiDAR scenes with ground truth.

The scenes are built from a known terrain surface, so tests and benchmarks of
the ground filters and segmenters can score against the truth: every point
carries its ASPRS class code, the terrain is available as a function
(:func:`terrain_height`) and the building footprints and tree crowns are
returned with the points. Everything is pure NumPy and reproducible from the
seed alone.

The real benchmark data sets load from here too: :func:`load_isprs` (an ISPRS
filter-test sample and its ground truth) and :func:`load_mosd` (an mOSD scene
with its segment labels and pixel indices).
"""

from ._isprs import IsprsSample, load_isprs
from ._mosd import MosdScene, load_mosd
from ._synthetic import (
    BUILDING,
    GROUND,
    NOISE,
    VEGETATION,
    SyntheticScene,
    synthetic_scene,
)
from ._terrain import terrain_height

__all__ = [
    "BUILDING",
    "GROUND",
    "NOISE",
    "VEGETATION",
    "IsprsSample",
    "MosdScene",
    "SyntheticScene",
    "load_isprs",
    "load_mosd",
    "synthetic_scene",
    "terrain_height",
]
