"""Batch downsample over tiles that do not hold the same attributes (another point
format, another file format): a voxel's attributes come from its points that have
them (test_batch.py has the surveys of one format)."""

from __future__ import annotations

import laspy
import numpy as np

import pcl_rg
from pcl_rg import batch
from pcl_rg.io import read_points


def las_tile(path, points: np.ndarray, point_format: int, **values) -> None:
    las = laspy.LasData(laspy.LasHeader(version="1.2", point_format=point_format))
    las.header.scales, las.header.offsets = [0.001] * 3, [0.0] * 3
    las.x, las.y, las.z = points.T
    for name, value in values.items():
        setattr(las, name, np.full(len(points), value))
    las.write(path)


def downsample_a_and_b(tmp_path, scheduler, leaf_size: float) -> None:
    """Batch downsample of in/a.las and in/b.las into out/, both tiles done."""
    report = batch.downsample(
        [tmp_path / "in" / "a.las", tmp_path / "in" / "b.las"],
        tmp_path / "out",
        params=pcl_rg.VoxelGridParams(leaf_size=leaf_size),
        scheduler=scheduler,
    )
    assert [t.status for t in report.tiles] == ["done", "done"]


def test_a_neighbour_without_colours_does_not_grey_a_tiles_voxels(tmp_path, scheduler):
    # Tile a (point format 3) is white; tile b (format 1) has no colours. b's points in
    # a's seam voxels were averaged in as zeros: red 32133 instead of 65535.
    rng = np.random.default_rng(3)
    (tmp_path / "in").mkdir()
    a = rng.uniform([0.0, 0.0, 0.0], [20.0, 20.0, 1.0], (4000, 3))
    b = rng.uniform([20.0, 0.0, 0.0], [40.0, 20.0, 1.0], (4000, 3))
    white = {"red": 65535, "green": 65535, "blue": 65535, "intensity": 100, "gps_time": 1e6}
    las_tile(tmp_path / "in" / "a.las", a, 3, **white)
    las_tile(tmp_path / "in" / "b.las", b, 1, intensity=300, gps_time=2e6)
    downsample_a_and_b(tmp_path, scheduler, leaf_size=3.0)  # voxels across x = 20 m, from both
    out = read_points(tmp_path / "out" / "a.las")
    assert set(out.fields["red"].tolist()) == {65535}
    assert set(out.fields["blue"].tolist()) == {65535}
    # What both tiles have is averaged over both: the seam voxels' intensity lies
    # between the tiles' own, which their first tile writes.
    seam = out.points[:, 0] > 18.0
    assert seam.any() and (out.fields["intensity"][seam] > 100).any()
    assert (out.fields["intensity"][~seam] == 100).all()


def test_no_data_stays_out_of_the_seam_voxels_means(tmp_path, scheduler):
    # Each tile's "no data" heights (LAS extra bytes, -9999 stored) are left out of the
    # means, across the seam too: a voxel's height is a real one or, where it has none
    # (4 m on each side of the seam), "no data".
    from test_cli_downsample import no_data_las

    rng = np.random.default_rng(5)
    (tmp_path / "in").mkdir()
    for name, x0 in (("a", 0.0), ("b", 20.0)):
        points = rng.uniform([x0, 0.0, 0.0], [x0 + 20.0, 20.0, 1.0], (3000, 3))
        missing = (rng.random(3000) < 0.3) | (np.abs(points[:, 0] - 20.0) < 4.0)
        height = np.where(missing, -99.99, rng.uniform(1.0, 2.0, 3000))
        no_data_las(tmp_path / "in" / f"{name}.las", points, height, np.zeros((3000, 3)))
    downsample_a_and_b(tmp_path, scheduler, leaf_size=3.0)
    for name in ("a", "b"):
        height = read_points(tmp_path / "out" / f"{name}.las").fields["height"]
        real = height > -99.0
        assert (height[~real] == height[~real].min()).all() and height.min() < -99.0
        assert (height[real] >= 1.0 - 1e-9).all() and (height[real] <= 2.0 + 1e-9).all()


def test_seam_voxels_keep_each_waveform_descriptor_whole(tmp_path, scheduler):
    # Tile a holds waveform descriptors (point format 9), tile b none (format 6). Every
    # voxel written, the seam's too, must carry one descriptor of a's points whole:
    # averaged, x_t, y_t, z_t and the return's location described no pulse.
    from las_helpers import random_las

    from pcl_rg._classification import WAVEFORM_ATTRIBUTES

    (tmp_path / "in").mkdir()
    a = random_las("1.4", 9, 3000, seed=11, extra=False)
    b = random_las("1.4", 6, 3000, seed=12, extra=False)
    b.x = b.x + 200.0  # beside a, sharing the seam at x = 512200
    a.write(tmp_path / "in" / "a.las")
    b.write(tmp_path / "in" / "b.las")
    downsample_a_and_b(tmp_path, scheduler, leaf_size=15.0)
    names = list(WAVEFORM_ATTRIBUTES)
    source = read_points(tmp_path / "in" / "a.las")
    descriptors = {tuple(row) for row in zip(*(source.fields[k].tolist() for k in names))}
    out = read_points(tmp_path / "out" / "a.las")
    assert len(out.points) < len(source.points) / 2  # voxels of several points
    seam = out.points[:, 0] > 512200.0 - 15.0
    assert seam.any()
    written = list(zip(*(out.fields[k].tolist() for k in names)))
    assert all(row in descriptors for row in written)
