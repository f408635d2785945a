"""Pure NumPy/SciPy reference implementations, one per C++ algorithm.

Slow but short and readable: each follows the definition in the project's
algorithms document line by line, and the tests hold the C++ core to it.
"""

from .statistical_outlier_removal import statistical_outlier_removal
from .voxel_grid import voxel_grid

__all__ = ["statistical_outlier_removal", "voxel_grid"]
