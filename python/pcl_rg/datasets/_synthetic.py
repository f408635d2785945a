"""Seeded synthetic airborne-LiDAR scenes with ground truth (see pcl_rg.datasets)."""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from .._params import check_number
from . import _objects as objects
from ._terrain import fill_dataset_docstring, make_terrain

__all__ = ["SyntheticScene", "synthetic_scene"]


class SyntheticScene(NamedTuple):
    """A synthetic labelled point cloud returned by :func:`synthetic_scene`.

    Attributes
    ----------
    points : ndarray of float64, shape (N, 3)
        x, y, z in metres, with ``origin`` added; in random order.
    labels : ndarray of uint8, shape (N,)
        ASPRS class of each point: :data:`GROUND`, :data:`BUILDING`,
        :data:`VEGETATION` or :data:`NOISE`.
    origin : ndarray of float64, shape (3,)
        The offset added to every point (zeros when none was given).
    buildings : ndarray of float64, shape (B, 5)
        One row per building: ``[xmin, ymin, xmax, ymax, height]``, the
        footprint in the coordinates of ``points`` (``origin`` included) and
        the roof height in metres above the highest terrain under the footprint.
    trees : ndarray of float64, shape (T, 4)
        One row per tree: ``[x, y, crown_radius, height]``, the trunk position
        in the coordinates of ``points``, the crown radius and the tree-top
        height above the terrain at the trunk, in metres.
    """

    points: NDArray[np.float64]
    labels: NDArray[np.uint8]
    origin: NDArray[np.float64]
    buildings: NDArray[np.float64]
    trees: NDArray[np.float64]


# --------------------------------------------------------------------------
# argument checks


# --------------------------------------------------------------------------
# objects


@fill_dataset_docstring
def synthetic_scene(
    *,
    seed: int = 0,
    size: float = 200.0,
    density: float = 4.0,
    n_buildings: int = 6,
    n_trees: int = 40,
    noise_fraction: float = 0.002,
    offset: tuple[float, float, float] | None = None,
) -> SyntheticScene:
    """Generate a labelled airborne-LiDAR-like point cloud with known ground truth.

    Parameters
    ----------
    %(scene_seed)s
    size : float, default 200.0
        Side of the square area in metres, at most 100 km; the scene covers
        ``[0, size] x [0, size]`` before ``offset``.
    density : float, default 4.0
        Points per m^2 on the open ground, the roofs and the tree crowns.
        The total is about ``density * size**2`` (160 000 with the defaults).
    n_buildings : int, default 6
        Number of axis-aligned box buildings. The first has sides of 20-30 m
        (one side at least 25 m); the others 8-18 m. Heights 4-15 m.
    n_trees : int, default 40
        Number of trees: crown radius 2-5 m, tree top 5-20 m above the terrain.
    noise_fraction : float, default 0.002
        Fraction of the returned points that are outliers, in [0, 0.5): half
        1-20 m below the terrain (multipath), half 20-100 m above it (birds).
    %(scene_offset)s

    Returns
    -------
    SyntheticScene
        ``points`` float64 (N, 3) in random order, ``labels`` uint8 (N,) with
        the ASPRS codes GROUND (2), VEGETATION (5), BUILDING (6) and NOISE (7),
        ``origin`` float64 (3,) (the offset, or zeros), ``buildings`` float64
        (B, 5) ``[xmin, ymin, xmax, ymax, height]`` and ``trees`` float64
        (T, 4) ``[x, y, crown_radius, height]``, both in the coordinates of
        ``points``.

    Raises
    ------
    ValueError
        If ``size`` or ``density`` is not finite and > 0, ``size`` exceeds
        100 km, ``seed``, ``n_buildings`` or ``n_trees`` is negative,
        ``n_buildings`` exceeds 100,000, ``noise_fraction`` is not in
        [0, 0.5), ``offset`` is not 3 finite numbers or farther than 1e11 m
        from 0 (where float64 cannot resolve 0.1 mm), the buildings or trees
        do not fit in the area (:class:`PlacementError`, a ValueError), or
        the scene would need more memory than the machine has.
    TypeError
        If a count or the seed is not an integer, or ``size``, ``density`` or
        ``noise_fraction`` is not a real number.

    See Also
    --------
    terrain_height : the true terrain surface of the same scene.
    synthetic_survey : such a scene at survey scale, written as a grid of tiles.

    Notes
    -----
    The scene, in local coordinates ``[0, size]^2``:

    * Terrain (:func:`terrain_height`): rolling sinusoids of a few metres plus
      a terrace band, 15-25 degrees steep, whose edges are slope breaks.
      Ground returns are uniform at ``density`` per m^2 with 3 cm Gaussian
      roughness, none under a building footprint (occluded) and only half
      under a tree crown (partial penetration).
    * Buildings: placed by a seeded rejection loop, inside the area (2 m
      margin), at least 4 m apart and clear of the sloped band. Flat roofs
      (2 cm roughness) at ``density``, above the highest terrain under the
      footprint; walls on the footprint edges at 0.15 x ``density`` per m^2
      of wall, from the terrain up to the roof.
    * Trees: upper half-ellipsoid crowns sampled at ``density`` over the
      crown disc, returns penetrating a little into the crown, plus 10 % as
      many returns on the trunk and understory (0.2-2 m above the terrain).
      Crowns stay 1 m clear of footprints.
    * Noise: ``noise_fraction`` of the total, uniform in x and y.

    With buildings the square must hold the large one beside the sloped band:
    ``size`` of about 80 m or more (60 m works for some seeds); smaller
    scenes need ``n_buildings=0``.

    Counts are Poisson draws, so N varies slightly with the seed. Peak memory is
    about 60 bytes per point (10 million points: about 5 s and 0.6 GB).

    References
    ----------
    .. [1] ASPRS, "LAS Specification 1.4 - R15", 2019, Table 17 (ASPRS
       standard point classes).

    Examples
    --------
    >>> import numpy as np
    >>> from pcl_rg.datasets import GROUND, NOISE, synthetic_scene
    >>> scene = synthetic_scene(seed=1, size=100.0, n_buildings=2, n_trees=5)
    >>> scene.points.dtype, scene.points.shape[1], scene.labels.dtype
    (dtype('float64'), 3, dtype('uint8'))
    >>> bool(np.mean(scene.labels == GROUND) > 0.5)
    True
    >>> scene.buildings.shape, scene.trees.shape
    ((2, 5), (5, 4))
    """
    seed = check_number("seed", seed, int, minimum=0)
    size = check_number("size", size, float, above=0.0, maximum=objects.MAX_SIZE)
    density = check_number("density", density, float, above=0.0)
    n_buildings = check_number("n_buildings", n_buildings, int, minimum=0)
    n_trees = check_number("n_trees", n_trees, int, minimum=0)
    noise_fraction = objects.check_noise_fraction(noise_fraction)
    origin = objects.check_offset(offset)
    if n_buildings > objects.MAX_BUILDINGS:
        raise ValueError(
            f"n_buildings must be <= {objects.MAX_BUILDINGS:,} (each is placed clear of every "
            f"other), got {n_buildings:,}"
        )
    # Each building with its gap takes at least this much of the square: refuse at once
    # what cannot fit, rather than after every attempt to place it.
    usable = (size - 2.0 * objects.BUILDING_MARGIN + objects.BUILDING_GAP) ** 2
    smallest = (objects.SMALL_SIDE[0] + objects.BUILDING_GAP) ** 2
    if n_buildings and (n_buildings - 1) * smallest > usable:
        raise objects.PlacementError(
            f"n_buildings={n_buildings:,} buildings of at least {objects.SMALL_SIDE[0]:g} m "
            f"a side do not fit in a {size:g} m square; use a larger size or fewer n_buildings"
        )
    crown = math.pi * objects.CROWN_RADIUS[1] ** 2
    objects.check_scene_budget(
        density * (size * size + n_trees * crown) * (1.0 + noise_fraction) * 1.2,
        n_trees + n_buildings,
        f"size={size:g}, density={density:g}, n_trees={n_trees:,}",
    )

    terrain = make_terrain(seed, size)
    # Everything else comes from the scene stream (spawn key 1), drawn in a
    # fixed order; the offset is only added at the end.
    rng = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(1,)))
    buildings = objects.place_buildings(rng, n_buildings, (size, size), terrain)
    if len(buildings) < n_buildings:
        raise objects.PlacementError(
            f"n_buildings={n_buildings} non-overlapping buildings (the first "
            f"{objects.LARGE_SIDES[0][0]:g}-{objects.LARGE_SIDES[0][1]:g} m long) do not fit "
            f"in a {size:g} m square beside its sloped band; use a larger size or fewer n_buildings"
        )
    trees = objects.place_trees(rng, n_trees, (size, size), buildings)
    if len(trees) < n_trees:
        raise objects.PlacementError(
            f"could not place n_trees={n_trees} trees clear of the buildings in a {size:g} m "
            "square; use a larger size or fewer n_buildings/n_trees"
        )

    blocks = [objects.ground_points(rng, terrain, density, (0.0, 0.0), size, buildings, trees)]
    blocks += objects.building_points(rng, terrain, buildings, buildings[:, :4], density)
    if n_trees:
        semi_z = objects.crown_semi_axes(rng, trees)
        blocks += objects.tree_points(rng, terrain, trees, semi_z, density)
    n_signal = sum(blk[0].size for blk in blocks)
    blocks += objects.noise_points(rng, terrain, n_signal, noise_fraction, (0.0, 0.0), size)
    n_total = sum(blk[0].size for blk in blocks)
    points, labels = objects.assemble(blocks, rng.permutation(n_total))
    del blocks

    if offset is not None:
        points += origin
    footprints, tree_rows = objects.object_rows(buildings, trees, origin)
    return SyntheticScene(points, labels, origin, footprints, tree_rows)
