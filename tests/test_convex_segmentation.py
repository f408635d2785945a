"""Tests of pcl_rg.convex_segmentation: core vs reference, the convexity rule, errors."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from conftest import MOSD_SCENES, run_in_threads, shared_data
from test_region_growing import assert_numbered_by_smallest_index, matched_agreement, partition

import pcl_rg
from pcl_rg import _core, reference
from pcl_rg._convex_segmentation import ConvexSegmentationParams
from pcl_rg._normals import NormalsParams
from pcl_rg.datasets import load_mosd
from pcl_rg.reference.convex_segmentation import (
    default_viewpoint,
    merge_convex,
    scaled_curvedness,
)
from pcl_rg.reference.normals import neighbour_lists
from pcl_rg.reference.region_growing import grow_regions

VIEW = (0.5, -1.5, 1.5)  # in front of and above the scenes below
UTM = np.array([500_000.0, 5_000_000.0, 300.0])  # where airborne tiles lie


def box(rng, centre, size, n):
    """The three faces of an axis-aligned box seen from VIEW: top, front (-y), side (+x)."""
    (cx, cy), (w, d, h) = centre, size
    u = rng.uniform(0, 1, (3, n, 2))
    top = np.column_stack([cx + (u[0, :, 0] - 0.5) * w, cy + (u[0, :, 1] - 0.5) * d, np.full(n, h)])
    front = np.column_stack([cx + (u[1, :, 0] - 0.5) * w, np.full(n, cy - d / 2), u[1, :, 1] * h])
    side = np.column_stack([np.full(n, cx + w / 2), cy + (u[2, :, 0] - 0.5) * d, u[2, :, 1] * h])
    return np.vstack([top, front, side])


def table_scene(seed: int, noise: float = 5e-4, scale: float = 1.0):
    """A table with two boxes standing apart on it; points and truth (0 table, 1, 2 boxes)."""
    rng = np.random.default_rng(seed)
    table = np.column_stack([rng.uniform(-0.6, 0.6, (6000, 2)), np.zeros(6000)])
    boxes = [((-0.25, 0.0), (0.2, 0.16, 0.22)), ((0.25, 0.05), (0.18, 0.22, 0.15))]
    for (cx, cy), (w, d, _) in boxes:
        inside = (np.abs(table[:, 0] - cx) < w / 2) & (np.abs(table[:, 1] - cy) < d / 2)
        table = table[~inside]
    parts = [table] + [box(rng, c, s, 700) for c, s in boxes]
    truth = np.concatenate([np.full(len(p), i) for i, p in enumerate(parts)])
    pts = np.vstack(parts)
    return (pts + rng.normal(0, noise, pts.shape)) * scale, truth


def test_boxes_are_objects_not_faces_and_stay_off_the_table() -> None:
    pts, truth = table_scene(seed=0)
    labels = pcl_rg.convex_segmentation(pts, viewpoint=VIEW)
    for part in range(3):
        ids, counts = np.unique(labels[truth == part], return_counts=True)
        assert counts.max() >= 0.95 * counts.sum(), (part, ids, counts)
    majority = [
        np.bincount(labels[truth == part][labels[truth == part] >= 0]).argmax() for part in range(3)
    ]
    assert len(set(majority)) == 3
    # Smoothness-constrained growth alone splits the box into its faces (top, front,
    # side: 700 points each): the merge does the work.
    faces = pcl_rg.region_growing(pts, k=15, smoothness_deg=12, min_cluster_size=1)[truth == 1]
    assert len({np.bincount(faces[i : i + 700]).argmax() for i in (0, 700, 1400)}) == 3


def test_same_segments_at_any_scale() -> None:
    # Scale-free: the same cloud in millimetres (x1000) gives the same partition.
    pts, _ = table_scene(seed=1)
    metres = pcl_rg.convex_segmentation(pts, viewpoint=VIEW)
    view_mm = tuple(1000.0 * v for v in VIEW)
    millimetres = pcl_rg.convex_segmentation(pts * 1000.0, viewpoint=view_mm)
    assert matched_agreement(metres, millimetres) >= 0.999


def test_a_box_seen_from_below_is_not_merged() -> None:
    # Turn the viewpoint under the table: the box's faces are now concave to it.
    pts, truth = table_scene(seed=2)
    labels = pcl_rg.convex_segmentation(pts, viewpoint=(0.5, -1.5, -1.5))
    assert len(np.unique(labels[truth == 1])) >= 2


@pytest.mark.parametrize("seed", range(3))
def test_core_equals_reference(seed: int) -> None:
    pts, _ = table_scene(seed=seed)
    k = 12
    nbr, ties = neighbour_lists(pts, k, return_boundary_ties=True)
    # Rows with a tie at the k-th place may keep either point (knn.hpp); all others agree.
    core_nbr = _core.neighbour_lists(pts, NormalsParams(k=k).to_core())
    np.testing.assert_array_equal(core_nbr[~ties], nbr[~ties])
    p = ConvexSegmentationParams(k=k, viewpoint=VIEW, min_cluster_size=15)
    core = pcl_rg.convex_segmentation(pts, params=p)
    ref = reference.convex_segmentation(pts, params=p)
    # Equal up to the growth's rounding and the k-th place ties (normals agree to
    # ~1e-12): the merge itself is order-free and is compared exactly below.
    assert matched_agreement(core, ref) >= 0.999
    assert_numbered_by_smallest_index(core)


@pytest.mark.parametrize("tolerance", [0.0, 5.0, 30.0])
def test_merge_equals_reference_on_identical_inputs(tolerance: float) -> None:
    pts, _ = table_scene(seed=4)
    k = 15
    geometry = pcl_rg.normals(pts, k=k)
    nbr = _core.neighbour_lists(pts, NormalsParams(k=k).to_core())
    measure = scaled_curvedness(
        pts, nbr.astype(np.intp), geometry.mean_curvature, geometry.gaussian_curvature
    )
    p = ConvexSegmentationParams(k=k, viewpoint=VIEW, concavity_tolerance_deg=tolerance)
    growth = pcl_rg.RegionGrowingParams(
        k=k,
        smoothness_deg=p.smoothness_deg,
        curvature_threshold=p.curvature_threshold,
        min_cluster_size=1,
    )
    patches = grow_regions(nbr, geometry.normals, np.ascontiguousarray(measure), growth)
    patches = np.ascontiguousarray(patches, dtype=np.int32)
    core = _core.merge_convex(pts, nbr, geometry.normals, patches, p.to_core())
    ref = merge_convex(pts, nbr, geometry.normals, patches, p)
    np.testing.assert_array_equal(core, ref)
    # The merge only joins patches: every patch lies within one segment.
    for patch in np.unique(patches):
        assert len(np.unique(core[patches == patch])) == 1
    # And the whole function is exactly these steps on the core's own growth.
    measure_core = np.ascontiguousarray(measure)
    grown = _core.grow_regions(nbr, geometry.normals, measure_core, growth.to_core())
    np.testing.assert_array_equal(grown, patches)
    np.testing.assert_array_equal(core, pcl_rg.convex_segmentation(pts, params=p))


def test_merge_is_independent_of_patch_numbering() -> None:
    pts, _ = table_scene(seed=5)
    k = 15
    geometry = pcl_rg.normals(pts, k=k)
    nbr = _core.neighbour_lists(pts, NormalsParams(k=k).to_core())
    patches = pcl_rg.region_growing(
        pts, k=k, smoothness_deg=12, curvature_threshold=1e-9, min_cluster_size=1
    )
    p = ConvexSegmentationParams(k=k, viewpoint=VIEW).to_core()
    base = _core.merge_convex(pts, nbr, geometry.normals, patches, p)
    shuffled = np.random.default_rng(0).permutation(patches.max() + 1).astype(np.int32)[patches]
    other = _core.merge_convex(pts, nbr, geometry.normals, np.ascontiguousarray(shuffled), p)
    assert partition(base) == partition(other)


def test_tolerance_is_monotone() -> None:
    # A larger tolerance only adds convex pairs: segments can only grow.
    pts, _ = table_scene(seed=6)
    strict = pcl_rg.convex_segmentation(pts, viewpoint=VIEW, concavity_tolerance_deg=1.0)
    loose = pcl_rg.convex_segmentation(pts, viewpoint=VIEW, concavity_tolerance_deg=60.0)
    assert len(np.unique(loose)) <= len(np.unique(strict))
    for segment in np.unique(strict[strict >= 0]):
        assert len(np.unique(loose[strict == segment])) == 1


def test_deterministic_and_threads_give_the_serial_result() -> None:
    pts, _ = table_scene(seed=7)
    serial = pcl_rg.convex_segmentation(pts, viewpoint=VIEW)
    for result in run_in_threads(lambda: pcl_rg.convex_segmentation(pts, viewpoint=VIEW)):
        np.testing.assert_array_equal(result, serial)


def test_params_defaults_match_core() -> None:
    core = _core.ConvexSegmentationParams()
    for field in dataclasses.fields(ConvexSegmentationParams):
        value = getattr(core, field.name)
        assert (tuple(value) if isinstance(value, list) else value) == field.default


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"k": 5}, "k must be >= 6"),
        ({"smoothness_deg": 0.0}, "smoothness_deg"),
        ({"curvature_threshold": -1.0}, "curvature_threshold"),
        ({"concavity_tolerance_deg": 90.0}, "concavity_tolerance_deg"),
        ({"min_cluster_size": 0}, "min_cluster_size"),
        ({"k": 50}, "k must be < the number of points"),
    ],
)
def test_bad_parameters(kwargs: dict, match: str) -> None:
    pts = np.random.default_rng(0).uniform(0, 1, (40, 3))
    with pytest.raises(ValueError, match=match):
        pcl_rg.convex_segmentation(pts, **kwargs)


def test_bad_inputs_of_the_merge_and_empty_input() -> None:
    pts = np.random.default_rng(0).uniform(0, 1, (20, 3))
    nbr = _core.neighbour_lists(pts, NormalsParams(k=6).to_core())
    normals = pcl_rg.normals(pts, k=6).normals
    p = ConvexSegmentationParams(k=6).to_core()
    with pytest.raises(ValueError, match="patches: id 20 out of range"):
        _core.merge_convex(pts, nbr, normals, np.full(20, 20, dtype=np.int32), p)
    with pytest.raises(ValueError, match="patches must have shape"):
        _core.merge_convex(pts, nbr, normals, np.zeros(3, dtype=np.int32), p)
    assert pcl_rg.convex_segmentation(np.empty((0, 3))).shape == (0,)
    assert reference.convex_segmentation(np.empty((0, 3))).shape == (0,)
    with pytest.raises(ValueError, match="NaN or Inf"):
        pcl_rg.convex_segmentation(np.full((10, 3), np.nan))


@pytest.mark.parametrize("scene", MOSD_SCENES[:2])
def test_mosd_scene_beats_region_growing(scene: str) -> None:
    # A real Kinect frame at 5 mm voxels: objects, not faces, and not the table.
    from pcl_rg.evaluation import segmentation_scores

    data = load_mosd(shared_data("mosd", f"{scene}.pcd"))
    grid = pcl_rg.voxel_grid(data.points, leaf_size=0.005)
    carried = grid.voxel_of_point
    ours = pcl_rg.convex_segmentation(grid.centroids)[carried]
    base = pcl_rg.region_growing(grid.centroids)[carried]
    mine, theirs = segmentation_scores(data.labels, ours), segmentation_scores(data.labels, base)
    assert mine.mean_iou >= theirs.mean_iou
    assert mine.over_segmented <= theirs.over_segmented


def gable_houses(seed: int):
    """Two gable-roofed houses, ground removed, as an airborne scan sees them: roofs at
    8 points per m^2, walls at 1; points (local, metres) and truth per house h: h and
    h + 2 its roof halves, h + 4 its walls."""
    rng = np.random.default_rng(seed)
    parts, truth = [], []
    for house, (cx, cy) in enumerate([(20.0, 20.0), (50.0, 25.0)]):
        for side in (-1.0, 1.0):  # the ridge runs along x at cy, 3 m above the 6 m eaves
            u = rng.uniform(0, 1, (int(8 * 12 * 4), 2))
            y = cy + side * 4.0 * u[:, 1]
            z = 9.0 - 3.0 * np.abs(y - cy) / 4.0
            parts.append(np.column_stack([cx - 6 + 12 * u[:, 0], y, z]))
            truth.append(np.full(len(u), house + (2 if side > 0 else 0)))
        for x0, y0, x1, y1 in [(-6, -4, 6, -4), (6, -4, 6, 4), (6, 4, -6, 4), (-6, 4, -6, -4)]:
            u = rng.uniform(0, 1, (int(1 * 12 * 6), 2))
            parts.append(
                np.column_stack(
                    [cx + x0 + (x1 - x0) * u[:, 0], cy + y0 + (y1 - y0) * u[:, 0], 6 * u[:, 1]]
                )
            )
            truth.append(np.full(len(u), house + 4))
    pts = np.vstack(parts)
    return pts + rng.normal(0, 0.02, pts.shape), np.concatenate(truth)


def test_default_viewpoint_rule_core_equals_reference() -> None:
    pts, _ = table_scene(seed=8)  # a sensor's own frame: the origin is next to the points
    far = pts + UTM  # the same points on a UTM tile
    for cloud in (pts, far, pts + [0.0, 0.0, 90.0], pts[:1], np.empty((0, 3))):
        assert tuple(_core.default_viewpoint(np.ascontiguousarray(cloud))) == (
            default_viewpoint(cloud)
        )
    assert default_viewpoint(pts) == (0.0, 0.0, 0.0)
    # 90 m from a 1.7 m scene is within 100 diagonals (a crop of a distant scan): origin.
    assert default_viewpoint(pts + [0.0, 0.0, 90.0]) == (0.0, 0.0, 0.0)
    low, high = far.min(axis=0), far.max(axis=0)
    above = default_viewpoint(far)
    np.testing.assert_allclose(above[:2], (low[:2] + high[:2]) / 2)
    assert above[2] == pytest.approx(high[2] + np.linalg.norm(high - low))


def test_airborne_tile_needs_no_viewpoint() -> None:
    # On a UTM tile the default looks down: each gable roof is convex seen from above and
    # its halves are one segment; seen from below its ridge is a concave crease. (Walls
    # that face away from the sensor, which a real airborne scan does not see, are turned
    # inwards and may stay apart: only the roofs are checked.)
    pts, truth = gable_houses(seed=0)
    tile = pts + UTM
    with pcl_rg.collect_diagnostics() as diagnostics:
        labels = pcl_rg.convex_segmentation(tile)
    used = diagnostics["convex_segmentation"]["viewpoint"]
    assert used == default_viewpoint(tile)
    np.testing.assert_array_equal(labels, pcl_rg.convex_segmentation(tile, viewpoint=used))
    roof_segments = []
    for h in (0, 1):
        roof = labels[(truth == h) | (truth == h + 2)]
        ids, counts = np.unique(roof, return_counts=True)
        assert counts.max() >= 0.95 * counts.sum(), (h, ids, counts)
        roof_segments.append(ids[counts.argmax()])
    assert roof_segments[0] != roof_segments[1]
    below = (*used[:2], UTM[2] - 1000.0)
    split = pcl_rg.convex_segmentation(tile, viewpoint=below)
    for h in (0, 1):
        halves = [
            np.bincount(split[truth == t][split[truth == t] >= 0]).argmax() for t in (h, h + 2)
        ]
        assert halves[0] != halves[1]
    # The origin as sensor (the former default) sees these roofs edge-on.
    assert matched_agreement(pcl_rg.convex_segmentation(tile, viewpoint=(0, 0, 0)), labels) < 0.95


def test_core_equals_reference_on_a_tile_with_the_default_viewpoint() -> None:
    pts, _ = gable_houses(seed=1)
    tile = pts + UTM
    core, ref = pcl_rg.convex_segmentation(tile), reference.convex_segmentation(tile)
    # As test_core_equals_reference: growth rounding and k-th place ties only.
    assert matched_agreement(core, ref) >= 0.999


def test_a_grid_that_leaves_too_few_centroids_is_not_used() -> None:
    # 36 points of noise 1 m on a 1 m lattice: the noise grid would leave 9 voxels, too
    # few for k = 15 (the caller's N = 36 is enough). So is a clump whose grid, anchored
    # at the world origin, happens to leave 12 after a shift.
    rng = np.random.default_rng(2)
    lattice = np.stack(np.meshgrid(np.arange(6.0), np.arange(6.0)), -1).reshape(-1, 2) - 3.0
    rng_clump = np.random.default_rng(1)
    clump = np.vstack([rng_clump.normal(0, 0.01, (20, 3)), rng_clump.uniform(-20, 20, (10, 3))])
    for points in (np.c_[lattice, rng.uniform(0, 1, 36)], clump + [1000.0, 1000.0, 0.0]):
        labels = pcl_rg.convex_segmentation(points)
        np.testing.assert_array_equal(labels, reference.convex_segmentation(points))
        np.testing.assert_array_equal(labels, pcl_rg.convex_segmentation(points, noise_leaves=0))


def test_a_record_at_the_origin_does_not_move_the_default_viewpoint():
    # A tile within float32's reach of (0, 0, 0) (RD, or a UTM northing below 1.68e6)
    # with one bad record there: the box held the origin, the origin became the
    # viewpoint, every normal lay sideways and two walls merged into the ground.
    rng = np.random.default_rng(0)
    g = rng.uniform(0.0, 60.0, (6000, 2))
    g = g[(np.abs(g - 30.0) > 8.0).any(axis=1)]
    ground = np.c_[g, rng.normal(0.0, 0.02, len(g))]
    r = rng.uniform(-8.0, 8.0, (1200, 2))
    roof = np.c_[r + 30.0, 11.0 - 0.4 * np.abs(r[:, 0]) + rng.normal(0.0, 0.02, 1200)]
    t, z = rng.uniform(-8.0, 8.0, (4, 150)), rng.uniform(0.0, 7.8, (4, 150))
    walls = [
        np.c_[t[0] + 30.0, np.full(150, 22.0), z[0]],
        np.c_[t[1] + 30.0, np.full(150, 38.0), z[1]],
        np.c_[np.full(150, 22.0), t[2] + 30.0, z[2]],
        np.c_[np.full(150, 38.0), t[3] + 30.0, z[3]],
    ]
    tile = np.vstack([ground, roof, *walls]) + (150_000.0, 450_000.0, 0.0)
    clean = pcl_rg.convex_segmentation(tile)
    assert clean.max() + 1 == 6  # ground, roof and four walls
    # The origin; a no-data height, away or in the tile; a bad fix 5 km up.
    for stray in ([0.0, 0.0, 0.0], [0.0, 0.0, -9999.0], [150_030.0, 450_030.0, -9999.0],
                  [150_030.0, 450_030.0, 5000.0]):  # fmt: skip
        bad = np.r_[tile, [stray]]
        for viewpoint in (_core.default_viewpoint, default_viewpoint):
            assert tuple(viewpoint(bad)) == tuple(viewpoint(tile))
            assert viewpoint(tile)[2] > 50.0  # above the tile, not the origin
        np.testing.assert_array_equal(pcl_rg.convex_segmentation(bad)[:-1], clean)
