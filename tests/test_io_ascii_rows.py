"""Messages about a bad row of ascii point data name it counting from 1, in XYZ, PCD and
PLY alike (np.loadtxt counts an unreadable value's row from 0 and other rows from 1)."""

from __future__ import annotations

import pytest

from pcl_rg.io import read_points

PCD_HEADER = (
    "# .PCD v0.7\nVERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n"
    "WIDTH 3\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 3\nDATA ascii\n"
)
PLY_HEADER = (
    "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
    "property float z\nend_header\n"
)


@pytest.mark.parametrize(
    "name, content, fragment",
    [
        # XYZ names the line of the file: comments and blank lines count.
        ("bad.xyz", "1 2 3\n4 5 6\n7 x 9\n", "'x' cannot be read as float64 (line 3, value 2)"),
        (
            "bad.xyz",
            "# c\n1 2 3\n\n4 5 6\n7 x 9\n",
            "'x' cannot be read as float64 (line 5, value 2)",
        ),
        ("bad.xyz", "# c\n1 2 3\n4 5 6 7\n", "line 3 holds 4 values where the rows before"),
        ("bad.pcd", PCD_HEADER + "1 2 3\n4 5 6\n7 x 9\n", "(data row 3, value 2)"),
        ("bad.pcd", PCD_HEADER + "1 2 3\n4 5 6\n7 8\n", "data row 3 holds 2 values"),
        ("bad.ply", PLY_HEADER + "1 2 3\nx 5 6\n7 8 9\n", "(data row 2, value 1)"),
    ],
)
def test_a_bad_ascii_row_is_named_counting_from_1(tmp_path, name, content, fragment):
    (tmp_path / name).write_text(content)
    with pytest.raises(ValueError) as caught:
        read_points(tmp_path / name)
    assert fragment in str(caught.value)
    assert str(tmp_path / name) in str(caught.value)
