"""What pcl-rg writes, and where: a figure that names OUTPUT, an OUTPUT that is a FIFO,
voxel centroids of an organized PCD cloud, and the segment ids that info counts."""

from __future__ import annotations

import os

import numpy as np
import pytest
from cli_helpers import assert_one_error_line, run, run_json

from pcl_rg.io import read_points, write_pcd, write_points


@pytest.mark.parametrize("how", ["link to OUTPUT", "hard link of OUTPUT"])
def test_a_figure_that_is_output_is_refused_before_the_work(capsys, tmp_path, scene_las, how):
    # The figure was written last, through the link over the point file: OUTPUT began
    # with PNG's signature and the run exited 0.
    output, plot = tmp_path / "out.las", tmp_path / "figure.png"
    if how == "link to OUTPUT":
        plot.symlink_to(output)
    else:
        output.write_bytes(b"an earlier result")
        os.link(output, plot)
    code, _, err = run(capsys, "ground", scene_las, output, "--plot", plot)
    assert code == 2
    assert_one_error_line(err, "is the OUTPUT file")
    assert not output.exists() or output.read_bytes() == b"an earlier result"


@pytest.mark.parametrize("which", ["OUTPUT", "--plot"])
def test_a_fifo_is_not_replaced_by_an_output(capsys, tmp_path, scene_las, which):
    # The atomic rename replaced a FIFO (or, for root, a link to /dev/null's device)
    # by a regular file.
    fifo = tmp_path / ("pipe.las" if which == "OUTPUT" else "pipe.png")
    os.mkfifo(fifo)
    output = fifo if which == "OUTPUT" else tmp_path / "out.las"
    extra = ["--plot", fifo] if which == "--plot" else []
    code, _, err = run(capsys, "ground", scene_las, output, *extra)
    assert code == 2
    assert_one_error_line(err, "is not a regular file")
    assert fifo.exists() and not fifo.is_file()
    assert sorted(os.listdir(tmp_path)) == [fifo.name]


def test_downsample_of_an_organized_cloud_writes_one_row(capsys, tmp_path):
    # Every point in a voxel of its own: as many centroids as pixels, in voxel order.
    # The output kept WIDTH 4 HEIGHT 3, so the image's rows were scrambled.
    width, height = 4, 3
    pixels = np.array([[c, height - r, 0.25 * c] for r in range(height) for c in range(width)])
    write_pcd(tmp_path / "image.pcd", pixels, width=width, height=height)
    run_json(capsys, "downsample", tmp_path / "image.pcd", tmp_path / "v.pcd", "--leaf-size", "0.5")
    out = read_points(tmp_path / "v.pcd")
    assert (out.header.width, out.header.height) == (12, 1)
    assert sorted(map(tuple, out.points)) == sorted(map(tuple, pixels))


def test_info_counts_segment_ids_of_any_size(capsys, tmp_path):
    # np.bincount sized its counters by the largest id: 2**32 - 1, a common "no
    # segment" mark, asked for 32 GiB, and 1e15 raised MemoryError.
    text = "# x y z segment_id\n1 2 3 0\n4 5 6 4294967295\n7 8 9 1000000000000000\n2 2 2 0\n"
    (tmp_path / "ids.xyz").write_text(text)
    info = run_json(capsys, "info", tmp_path / "ids.xyz")
    assert info["segmentation"] == {
        "segments": 3,
        "assigned": 4,
        "unassigned": 0,
        "largest_segment": 2,
    }


def test_info_describes_segment_ids_that_are_not_whole_numbers(capsys, tmp_path):
    (tmp_path / "ids.xyz").write_text("# x y z segment_id\n1 2 3 0.5\n4 5 6 nan\n")
    info = run_json(capsys, "info", tmp_path / "ids.xyz")
    assert "segmentation" not in info
    assert info["segmentation_problem"] == "segment_id is not one whole number per point"


@pytest.mark.parametrize("command", [["ground"], ["denoise"], ["segment"]])
def test_a_field_las_would_take_for_a_coordinate_is_refused_before_the_work(
    capsys, tmp_path, command
):
    # A PLY with property X beside x: the LAS write failed after the work (exit 1).
    rng = np.random.default_rng(0)
    points = np.c_[rng.uniform(0.0, 40.0, (3000, 2)), rng.normal(0.0, 0.05, 3000)]
    write_points(tmp_path / "in.ply", points, {"X": points[:, 0]})
    code, _, err = run(capsys, *command, tmp_path / "in.ply", tmp_path / "out.las")
    assert code == 2
    assert_one_error_line(err, "field 'X' would be taken for a coordinate")
    assert not (tmp_path / "out.las").exists()
    report = run_json(capsys, *command, tmp_path / "in.ply", tmp_path / "out.ply")
    assert list(read_points(tmp_path / "out.ply").fields)[0] == "X"
    assert report["points_in"] == 3000
