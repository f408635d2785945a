"""Pure NumPy/SciPy reference implementations, one per C++ algorithm.

Slow but short and readable: each follows the definition in the project's
algorithms document line by line, and the tests hold the C++ core to it.
They need SciPy, the ``reference`` extra: ``pip install 'pcl_rg[reference]'``.
"""

try:
    import scipy  # noqa: F401  (checked here, used by the modules below)
except ImportError as error:  # pragma: no cover - depends on the environment
    raise ImportError("pcl_rg.reference needs SciPy: pip install 'pcl_rg[reference]'") from error

from ._lattice import lattice_floor
from .convex_segmentation import convex_segmentation
from .grid_ground import grid_ground
from .normals import normals
from .point_scale import point_scale
from .point_spacing import box_spacing, point_spacing
from .region_growing import region_growing
from .statistical_outlier_removal import statistical_outlier_removal
from .tin_ground import tin_ground
from .voxel_grid import voxel_grid

__all__ = [
    "box_spacing",
    "convex_segmentation",
    "grid_ground",
    "lattice_floor",
    "normals",
    "point_scale",
    "point_spacing",
    "region_growing",
    "statistical_outlier_removal",
    "tin_ground",
    "voxel_grid",
]
