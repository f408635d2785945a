"""Seeded synthetic airborne-LiDAR scenes with ground truth.

The scenes are built from a known terrain surface, so tests and benchmarks of
the ground filters and segmenters can score against the truth: every point
carries its ASPRS class code, the terrain is available as a function
(:func:`terrain_height`) and the building footprints and tree crowns are
returned with the points. Everything is pure NumPy and reproducible from the
seed alone.

:func:`synthetic_survey` writes such a scene, as large as wanted, as a grid of
LAS/LAZ (or PLY, PCD) tiles with the class in each file, its buildings and
trees straddling the tile borders: test data for processing a survey tile by
tile, one tile in memory at a time.

:func:`isprs_like_scene` is a harder scene for the ground filters, with the class
ratios of the ISPRS filter-test samples (30-60 % object points), steep terrain
with break lines, a bridge, dense low vegetation and buildings up to 100 m long,
at any point density.

The real benchmark data sets load from here too: :func:`load_isprs` (an ISPRS
filter-test sample and its ground truth) and :func:`load_mosd` (an mOSD scene
with its segment labels and pixel indices).

:func:`building_ids` gives the truth instance (building) of every building point of
both synthetic scenes, for scoring segmentations.
"""

from ._instances import building_ids
from ._isprs import IsprsSample, load_isprs
from ._isprs_like import BRIDGE_DECK, LOW_VEGETATION, IsprsLikeScene, isprs_like_scene
from ._mosd import MosdScene, load_mosd
from ._objects import BUILDING, GROUND, NOISE, VEGETATION, PlacementError
from ._steep_terrain import isprs_like_terrain
from ._survey import SyntheticSurvey, synthetic_survey
from ._synthetic import SyntheticScene, synthetic_scene
from ._terrain import terrain_height

__all__ = [
    "BRIDGE_DECK",
    "BUILDING",
    "GROUND",
    "LOW_VEGETATION",
    "NOISE",
    "VEGETATION",
    "IsprsLikeScene",
    "IsprsSample",
    "MosdScene",
    "PlacementError",
    "SyntheticScene",
    "SyntheticSurvey",
    "building_ids",
    "isprs_like_scene",
    "isprs_like_terrain",
    "load_isprs",
    "load_mosd",
    "synthetic_scene",
    "synthetic_survey",
    "terrain_height",
]
