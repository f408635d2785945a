"""Arguments a caller should never pass, refused with a ValueError that names them:
ragged point lists, masked per-axis lengths, and spacings or cells so small that a
quotient overflows."""

from __future__ import annotations

import numpy as np
import pytest

import pcl_rg
import pcl_rg.io
from pcl_rg import reference


@pytest.mark.parametrize("call", [pcl_rg.grid_ground, pcl_rg.normals, reference.normals])
def test_a_ragged_point_list_names_points(call):
    # NumPy's "setting an array element with a sequence ... inhomogeneous shape".
    with pytest.raises(ValueError, match=r"points must have shape \(N, 3\): its rows differ"):
        call([[0.0, 0.0, 0.0], [1.0, 1.0]])


@pytest.mark.parametrize(
    "call",
    [
        lambda value: pcl_rg.voxel_grid(np.zeros((4, 3)), leaf_size=value),
        lambda value: pcl_rg.GridGroundParams(block_size=value),
        lambda value: pcl_rg.RegionGrowingParams(viewpoint=value),
    ],
)
def test_a_masked_per_axis_length_is_refused(call):
    # np.asarray dropped the mask: the hidden 2.0 was used as if it were given.
    with pytest.raises(ValueError, match="masked values are not accepted"):
        call(np.ma.array([1.0, 2.0, 3.0], mask=[0, 1, 0]))
    with pytest.raises(ValueError, match="masked values are not accepted"):
        call(np.ma.masked)


@pytest.mark.parametrize("spacing", [5e-324, 1e-300])
def test_a_subnormal_spacing_sets_no_cells(spacing):
    # block_size / (2 x spacing) was inf, and ceil(inf) an OverflowError.
    with pytest.raises(ValueError, match=r"spacing .* more than 2\^62 cells; set cell_size"):
        pcl_rg.GridGroundParams().at_spacing(spacing)
    with pytest.raises(ValueError, match=r"more than 2\^62 cells"):  # the product underflows
        pcl_rg.GridGroundParams().at_spacing(spacing, multiples={"cell_size": 1e-200})


@pytest.mark.parametrize("multiple", [0.0, -1.0, float("nan")])
def test_a_spacing_multiple_must_be_positive(multiple):
    # 0 divided by zero; -1 gave one cell per block without a word.
    with pytest.raises(ValueError, match=r"multiples\['cell_size'\] must be (> 0|finite)"):
        pcl_rg.GridGroundParams().at_spacing(1.0, multiples={"cell_size": multiple})
    with pytest.raises(ValueError, match="unknown names"):
        pcl_rg.GridGroundParams().at_spacing(1.0, multiples={"cell": 2.0})


def test_both_layers_refuse_absurdly_small_lengths_with_a_value_error():
    rng = np.random.default_rng(0)
    field = np.c_[rng.uniform(0.0, 30.0, (300, 2)), rng.normal(0.0, 0.1, 300)]
    for call in (pcl_rg.tin_ground, reference.tin_ground):  # the reference: OverflowError
        with pytest.raises(ValueError, match="seed_cell is too small"):
            call(field, seed_cell=1e-320)
    speck = np.c_[rng.uniform(0.0, 1e-10, (500, 2)), rng.normal(0.0, 1e-13, 500)]
    for call in (pcl_rg.grid_ground, reference.grid_ground):
        with pytest.raises(ValueError, match="2\\^40 cells|2\\^62 cells"):
            call(speck, block_size=1e300)


def test_write_points_refuses_a_ragged_list_and_masked_classes(tmp_path):
    # NumPy's "inhomogeneous shape" message; a masked class written as its hidden value.
    with pytest.raises(ValueError, match=r"points must have shape \(N, 3\): its rows differ"):
        pcl_rg.io.write_points(tmp_path / "a.xyz", [[0.0, 0.0, 0.0], [1.0, 1.0]])
    codes = np.ma.array([2, 7], mask=[0, 1])
    with pytest.raises(ValueError, match="classification: masked arrays are not written"):
        pcl_rg.io.write_points(tmp_path / "b.xyz", np.zeros((2, 3)), classification=codes)


@pytest.mark.parametrize("ext", ["las", "pcd", "ply", "xyz"])
def test_a_ragged_field_or_classification_names_its_column(tmp_path, ext):
    # NumPy's "inhomogeneous shape" message named no column.
    ragged = [[1], [2, 3], [4]]
    with pytest.raises(ValueError, match=r"fields\['intensity'\] must have shape .* differ"):
        pcl_rg.io.write_points(tmp_path / f"a.{ext}", np.zeros((3, 3)), {"intensity": ragged})
    with pytest.raises(ValueError, match=r"classification must have shape \(3,\): its rows"):
        pcl_rg.io.write_points(tmp_path / f"a.{ext}", np.zeros((3, 3)), classification=ragged)
    if ext == "pcd":
        with pytest.raises(ValueError, match=r"fields\['i'\] must have shape .* differ"):
            pcl_rg.io.write_pcd(tmp_path / "b.pcd", np.zeros((3, 3)), fields={"i": ragged})
