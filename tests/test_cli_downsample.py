"""pcl-rg downsample's voxel attributes beyond LAS's standard ones (test_cli_commands.py
has the LAS scene): PCL's packed colours, codes stored as floats, LAS extra bytes
with a "no data" value, and LAS's waveform descriptors."""

from __future__ import annotations

import laspy
import numpy as np
from cli_helpers import run_json
from las_helpers import random_las

import pcl_rg
from pcl_rg._classification import (
    WAVEFORM_ATTRIBUTES,
    no_data_values,
    usable_points,
    voxel_attributes,
)
from pcl_rg.io import read_points, write_pcd


def test_downsample_averages_packed_colours_channel_by_channel(capsys, tmp_path):
    # Pure red and pure blue in one voxel: PCL packs 0x00RRGGBB into a float32 (rgb) or
    # a uint32 (rgba). As one number their mean has green in it; by channel it is purple.
    packed = np.array([0xFF0000, 0x0000FF, 0x00FF00], np.uint32)
    points = np.array([[0.0, 0.0, 0.0], [0.001, 0.0, 0.0], [5.0, 5.0, 5.0]])
    fields = {"rgb": packed.view(np.float32), "rgba": packed | np.uint32(0xFF000000)}
    write_pcd(tmp_path / "two.pcd", points, fields)
    run_json(capsys, "downsample", tmp_path / "two.pcd", tmp_path / "one.pcd", "--leaf-size", "1")
    out = read_points(tmp_path / "one.pcd")
    order = np.argsort(out.points[:, 0])
    assert [f"{v:08x}" for v in out.fields["rgb"].view(np.uint32)[order]] == [
        "00800080",  # 255 / 2 rounds to 128 in red and in blue
        "0000ff00",
    ]
    assert [f"{v:08x}" for v in out.fields["rgba"][order]] == ["ff800080", "ff00ff00"]


def test_downsample_takes_float_codes_from_the_first_point(capsys, tmp_path):
    # CloudCompare writes classes as floats; mOSD its labels. Averaged, a voxel of
    # ground (2) and building (6) points would get class 4.0 and could not be written
    # to LAS. Codes and ids are the first point's; other floats are averaged.
    points = np.array([[0.1, 0.0, 0.0], [0.2, 0.0, 0.0], [0.3, 0.0, 0.0], [5.0, 5.0, 5.0]])
    fields = {
        "classification": np.array([2, 6, 6, 5], np.float32),
        "label": np.array([3.0, 8.0, 8.0, 1.0]),
        "Object_ID": np.array([10.0, 11.0, 12.0, 13.0]),
        "intensity": np.array([1.0, 2.0, 6.0, 4.0], np.float32),
    }
    write_pcd(tmp_path / "floats.pcd", points, fields)
    run_json(capsys, "downsample", tmp_path / "floats.pcd", tmp_path / "v.pcd", "--leaf-size", "1")
    out = read_points(tmp_path / "v.pcd")
    order = np.argsort(out.points[:, 0])
    assert out.fields["classification"][order].tolist() == [2.0, 5.0]
    assert out.fields["label"][order].tolist() == [3.0, 1.0]
    assert out.fields["Object_ID"][order].tolist() == [10.0, 13.0]
    assert out.fields["intensity"][order].tolist() == [3.0, 4.0]
    run_json(capsys, "downsample", tmp_path / "floats.pcd", tmp_path / "v.las", "--leaf-size", "1")
    assert sorted(read_points(tmp_path / "v.las").classification.tolist()) == [2, 5]


def no_data_las(path, points: np.ndarray, height: np.ndarray, amp: np.ndarray) -> None:
    """LAS 1.4 with two extra-bytes fields that declare "no data": a scaled int16
    (-9999 stored, -99.99 read) and three float32 values (-1 each)."""
    header = laspy.LasHeader(version="1.4", point_format=6)
    header.scales, header.offsets = [0.001] * 3, [0.0] * 3
    header.add_extra_dims(
        [
            laspy.ExtraBytesParams(
                "height", "int16", scales=np.array([0.01]), offsets=np.array([0.0]), no_data=[-9999]
            ),
            laspy.ExtraBytesParams("amp", "3f4", no_data=[-1.0, -1.0, -1.0]),
        ]
    )
    las = laspy.LasData(header)
    las.x, las.y, las.z = points.T
    las.height, las.amp = height, amp.astype(np.float32)
    las.write(path)


def test_downsample_leaves_no_data_out_of_the_means(capsys, tmp_path):
    # A LAS extra-bytes field may declare a "no data" value. Averaged with the real
    # values of a voxel, it gave a number that means nothing: (1 - 99.99 + 3) / 3.
    points = np.array([[0.1, 0, 0], [0.2, 0, 0], [0.3, 0, 0], [5.1, 5, 5], [5.2, 5, 5]])
    height = np.array([1.0, -99.99, 3.0, -99.99, -99.99])
    amp = np.array([[1, 2, 3], [-1, 5, -1], [3, 4, 5], [-1, -1, -1], [-1, -1, -1]])
    no_data_las(tmp_path / "in.las", points, height, amp)
    cloud = read_points(tmp_path / "in.las")
    missing = no_data_values(cloud)
    assert missing.keys() == {"height", "amp"}
    # Exactly the values read where the file stores "no data" (-9999 x 0.01 in float64).
    assert missing["height"].tolist() == [cloud.fields["height"][1]]
    assert missing["amp"].tolist() == [-1.0, -1.0, -1.0]
    run_json(capsys, "downsample", tmp_path / "in.las", tmp_path / "out.las", "--leaf-size", "1")
    out = read_points(tmp_path / "out.las")
    order = np.argsort(out.points[:, 0])
    np.testing.assert_allclose(out.fields["height"][order], [2.0, -99.99])
    np.testing.assert_allclose(out.fields["amp"][order], [[2, 11 / 3, 4], [-1, -1, -1]], rtol=1e-6)
    assert no_data_values(out).keys() == {"height", "amp"}  # the declarations are kept


def test_a_nan_no_data_is_left_out_of_the_means():
    # NaN equals nothing, so it is found as NaN: else it was averaged into every voxel.
    fields = {"f": np.array([1.0, np.nan, 3.0, np.nan])}
    out = voxel_attributes(
        fields,
        np.arange(4),
        np.array([0, 0, 0, 1]),
        np.array([3, 1]),
        no_data={"f": np.array([np.nan])},
    )
    np.testing.assert_array_equal(out["f"], [2.0, np.nan])


def test_a_code_with_no_data_comes_from_the_first_point_that_has_one(capsys, tmp_path):
    # Codes are the first point's. Where a field declares "no data" and the first point
    # holds it, the voxel took "no data" although its other points had a code.
    header = laspy.LasHeader(version="1.4", point_format=6)
    header.scales, header.offsets = [0.001] * 3, [0.0] * 3
    header.add_extra_dims(
        [
            laspy.ExtraBytesParams("tree_id", "uint16", no_data=[0]),
            laspy.ExtraBytesParams("codes", "2u1", no_data=[255, 255]),
            # In float64 the no data 2^64 - 1 also matched 2^64 - 2, a code like any other.
            laspy.ExtraBytesParams("serial", "u8", no_data=[2**64 - 1]),
        ]
    )
    las = laspy.LasData(header)
    points = np.array([[0.1, 0, 0], [0.2, 0, 0], [0.3, 0, 0], [5.1, 5, 5], [5.2, 5, 5]])
    las.x, las.y, las.z = points.T
    las.tree_id = np.array([0, 7, 9, 0, 0], np.uint16)
    las.codes = np.array([[255, 4], [3, 255], [5, 6], [255, 255], [255, 1]], np.uint8)
    las.serial = np.array([2**64 - 1, 2**64 - 2, 9, 2**64 - 1, 2**64 - 1], np.uint64)
    las.write(tmp_path / "in.las")
    run_json(capsys, "downsample", tmp_path / "in.las", tmp_path / "out.las", "--leaf-size", "1")
    out = read_points(tmp_path / "out.las")
    order = np.argsort(out.points[:, 0])
    assert out.fields["tree_id"][order].tolist() == [7, 0]  # none in the second voxel
    assert out.fields["codes"][order].tolist() == [[3, 4], [255, 1]]  # column by column
    assert out.fields["serial"][order].tolist() == [2**64 - 2, 2**64 - 1]


def test_downsample_keeps_each_waveform_descriptor_whole(capsys, tmp_path):
    # The seven waveform fields describe one pulse together. x_t, y_t, z_t and the
    # return's location on the packet are floats: they were averaged, beside the first
    # point's packet index and offset, so the descriptor written matched no pulse.
    las = random_las("1.4", 9, 400, seed=5, extra=False)
    las.write(tmp_path / "in.las")
    cloud = read_points(tmp_path / "in.las")
    run_json(capsys, "downsample", tmp_path / "in.las", tmp_path / "out.las", "--leaf-size", "20")
    out = read_points(tmp_path / "out.las")
    assert len(out.points) < len(cloud.points) / 2  # voxels of several points
    names = list(WAVEFORM_ATTRIBUTES)
    assert set(names) <= set(out.fields)
    descriptors = {tuple(row) for row in zip(*(cloud.fields[k].tolist() for k in names))}
    written = list(zip(*(out.fields[k].tolist() for k in names)))
    assert all(row in descriptors for row in written)
    # The first point's in file order: of the points the command keeps, the least index.
    rows = np.flatnonzero(usable_points(cloud))
    voxel = pcl_rg.voxel_grid(cloud.points[rows], leaf_size=20.0).voxel_of_point
    _, first = np.unique(voxel, return_index=True)
    assert sorted(written) == sorted(
        tuple(cloud.fields[k][rows[i]].item() for k in names) for i in first if voxel[i] >= 0
    )
