"""Pure NumPy/SciPy reference implementations, one per C++ algorithm.

Slow but short and readable: each follows the definition in the project's
algorithms document line by line, and the tests hold the C++ core to it.
"""

from .grid_ground import grid_ground
from .normals import normals
from .region_growing import region_growing
from .statistical_outlier_removal import statistical_outlier_removal
from .tin_ground import tin_ground
from .voxel_grid import voxel_grid

__all__ = [
    "grid_ground",
    "normals",
    "region_growing",
    "statistical_outlier_removal",
    "tin_ground",
    "voxel_grid",
]
