"""pcl_rg.datasets.load_isprs: the two PCD files of a sample matched as multisets."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import ISPRS_SAMPLES, shared_data

from pcl_rg.datasets import IsprsSample, load_isprs
from pcl_rg.io import read_pcd, write_pcd


def sorted_rows(points: np.ndarray) -> np.ndarray:
    return points[np.lexsort(points.T[::-1])]


@pytest.mark.parametrize("sample", ISPRS_SAMPLES)
def test_real_samples(sample):
    full = shared_data("isprs", f"{sample}-utm.pcd")
    ground_file = shared_data("isprs", f"{sample}-utm-ground.pcd")
    result = load_isprs(full, ground_file)
    assert isinstance(result, IsprsSample)
    points, ground = result
    assert points.dtype == np.float64 and points.shape[1] == 3
    assert ground.dtype == np.bool_ and ground.shape == (len(points),)
    # Points in file order, untouched; the ground ones are exactly the ground file's
    # multiset of coordinates.
    np.testing.assert_array_equal(points, read_pcd(full).points)
    expected = read_pcd(ground_file).points
    np.testing.assert_array_equal(sorted_rows(points[ground]), sorted_rows(expected))
    # Both classes occur in every sample, in UTM zone 32 coordinates.
    assert 0 < ground.sum() < len(points)
    assert (points[:, 0] > 1e5).all() and (points[:, 1] > 5e6).all()


def test_samp11_duplicates_follow_the_multiset_rule():
    """The data README: samp11 holds 213 exact duplicates, some with both labels."""
    points, ground = load_isprs(
        shared_data("isprs", "samp11-utm.pcd"), shared_data("isprs", "samp11-utm-ground.pcd")
    )
    _, key, count = np.unique(points, axis=0, return_inverse=True, return_counts=True)
    key = key.ravel()
    assert len(points) - len(count) == 213
    mixed = [k for k in np.flatnonzero(count > 1) if 0 < ground[key == k].sum() < count[k]]
    assert mixed, "expected duplicate keys carrying both labels"
    for k in mixed:  # ground goes to the first copies in file order
        labels = ground[key == k]
        assert not np.any(~labels[:-1] & labels[1:])


def write(path, rows) -> str:
    write_pcd(path, np.asarray(rows, dtype=float).reshape(-1, 3))
    return str(path)


def test_multiset_matching(tmp_path):
    full = write(
        tmp_path / "all.pcd",
        [[0, 0, 0], [1, 0, 0], [0, 0, 0], [2, 0, 5], [0, 0, 0], [1, 0, 0.5]],
    )
    ground = write(tmp_path / "ground.pcd", [[0, 0, 0], [1, 0, 0.5], [0, 0, 0], [1, 0, 0]])
    points, labels = load_isprs(full, ground)
    assert labels.tolist() == [True, True, True, False, False, True]
    assert points.tolist()[3] == [2.0, 0.0, 5.0]


def test_identical_and_empty_ground_files(tmp_path):
    rows = [[0, 0, 0], [1, 2, 3], [1, 2, 3]]
    full = write(tmp_path / "all.pcd", rows)
    assert load_isprs(full, full).ground.all()
    empty = write(tmp_path / "none.pcd", np.empty((0, 3)))
    assert not load_isprs(full, empty).ground.any()
    nothing = load_isprs(empty, empty)
    assert nothing.points.shape == (0, 3) and nothing.ground.shape == (0,)


def test_ground_point_missing_from_the_full_file(tmp_path):
    full = write(tmp_path / "all.pcd", [[0, 0, 0], [1, 0, 0]])
    stray = write(tmp_path / "stray.pcd", [[0, 0, 0], [0, 0, 1]])
    with pytest.raises(ValueError, match=r"ground_pcd .*stray.pcd\) holds 1 point"):
        load_isprs(full, stray)
    too_many = write(tmp_path / "twice.pcd", [[1, 0, 0], [1, 0, 0]])
    with pytest.raises(ValueError, match="holds 1 point"):
        load_isprs(full, too_many)


def test_non_finite_points_are_refused(tmp_path):
    full = write(tmp_path / "all.pcd", [[0, 0, 0], [np.nan, 0, 0]])
    ground = write(tmp_path / "ground.pcd", [[0, 0, 0]])
    with pytest.raises(ValueError, match=r"all_pcd .* 1 point\(s\) with NaN"):
        load_isprs(full, ground)


def test_missing_file(tmp_path):
    full = write(tmp_path / "all.pcd", [[0, 0, 0]])
    with pytest.raises(FileNotFoundError):
        load_isprs(full, tmp_path / "absent.pcd")
