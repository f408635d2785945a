"""Tests of the mOSD reader (pcl_rg.datasets.load_mosd) on the real scenes and made-up files."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import MOSD_SCENES, shared_data

from pcl_rg.datasets import MosdScene, load_mosd
from pcl_rg.io import read_pcd, write_pcd


@pytest.mark.parametrize("name", MOSD_SCENES)
def test_real_scene(name: str) -> None:
    path = shared_data("mosd", f"{name}.pcd")
    scene = load_mosd(path)
    raw = read_pcd(path)
    assert isinstance(scene, MosdScene)
    assert (scene.width, scene.height) == (640, 480)
    n = len(scene.points)
    assert n + scene.n_invalid == 640 * 480
    # Every dropped pixel really is invalid, every kept one finite.
    invalid = ~np.isfinite(raw.points).all(axis=1)
    assert scene.n_invalid == int(invalid.sum()) > 0
    assert scene.points.dtype == np.float64 and scene.points.shape == (n, 3)
    assert np.isfinite(scene.points).all() and scene.points.flags.c_contiguous
    # The pixel index leads back to the organized cloud, row-major.
    assert scene.pixel.dtype == np.intp and (np.diff(scene.pixel) > 0).all()
    np.testing.assert_array_equal(scene.points, raw.points[scene.pixel])
    np.testing.assert_array_equal(scene.labels, raw.fields["label"][scene.pixel])
    row, col = np.divmod(scene.pixel, scene.width)
    assert row.max() < 480 and col.max() < 640
    # The database's label scheme: invalid points carry 0; valid ones the table (1-9)
    # or an object part (20 and up). Kinect depth: 0.4 to 2 m in front of the camera.
    assert (raw.fields["label"][invalid] == 0).all()
    assert scene.labels.dtype == np.int32
    assert ((scene.labels >= 1) & (scene.labels <= 9) | (scene.labels >= 20)).all()
    assert (scene.labels <= 9).sum() > n / 2  # the table dominates every scene
    assert 0.4 < scene.points[:, 2].min() and scene.points[:, 2].max() < 2.0


def test_made_up_file_with_nan_pixels(tmp_path) -> None:
    xyz = np.array(
        [
            [0.0, 0.0, 1.0],
            [np.nan, np.nan, np.nan],
            [0.1, 0.0, 1.0],
            [0.0, np.nan, 1.0],
            [0.2, 0.1, 1.1],
            [0.3, 0.1, 1.2],
        ]
    )
    label = np.array([1, 0, 1, 0, 20, 21], dtype=np.uint32)
    path = tmp_path / "scene.pcd"
    write_pcd(path, xyz, {"label": label, "rgba": np.zeros(6, np.uint32)}, width=3, height=2)
    scene = load_mosd(path)
    assert scene.n_invalid == 2  # a single NaN coordinate invalidates the point
    assert scene.pixel.tolist() == [0, 2, 4, 5]
    assert scene.labels.tolist() == [1, 1, 20, 21]
    np.testing.assert_array_equal(scene.points, xyz[[0, 2, 4, 5]].astype(np.float32))  # PCD float32
    assert (scene.width, scene.height) == (3, 2)


def test_refuses_files_that_are_not_mosd(tmp_path) -> None:
    unorganized = tmp_path / "flat.pcd"
    write_pcd(unorganized, np.zeros((4, 3)), {"label": np.ones(4, np.uint32)})
    with pytest.raises(ValueError, match="not an organized cloud"):
        load_mosd(unorganized)
    unlabeled = tmp_path / "nolabel.pcd"
    write_pcd(unlabeled, np.zeros((4, 3)), width=2, height=2)
    with pytest.raises(ValueError, match="no 'label' field"):
        load_mosd(unlabeled)
    with pytest.raises(OSError):
        load_mosd(tmp_path / "missing.pcd")


@pytest.mark.parametrize(
    "label",
    [
        np.array([1.5, 0.0, 2.0, 20.7]),  # fractional: was truncated to 1 and 20
        np.array([1.0, np.nan, 2.0, 20.0]),  # NaN: was -2^31 with a RuntimeWarning
        np.array([1, 2, 3, 2**32 - 1], dtype=np.uint32),  # was -1 after the int32 cast
        np.array([[1, 1], [2, 2], [3, 3], [20, 20]], dtype=np.uint32),  # was an IndexError
    ],
    ids=["fractional", "nan", "beyond-int32", "two-per-point"],
)
def test_refuses_a_damaged_label_field(tmp_path, label) -> None:
    path = tmp_path / "scene.pcd"
    write_pcd(path, np.zeros((4, 3)), {"label": label}, width=2, height=2)
    with pytest.raises(ValueError, match="'label' field"):
        load_mosd(path)
