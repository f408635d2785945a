"""The core's k-nearest lists on clouds of copies and equal distances.

The core walks nanoflann's k-d tree with one cut of its own (cpp/src/knn.cpp): once a
list is full, a branch whose box lies no nearer than the list's worst distance is
skipped. These clouds put many points at exactly that distance, where a wrong cut
would drop a nearer point and show as a different distance in a list.
"""

from __future__ import annotations

import numpy as np
from conftest import examples
from hypothesis import given, settings
from hypothesis import strategies as st

from pcl_rg import _core
from pcl_rg._normals import NormalsParams
from pcl_rg.reference.normals import neighbour_lists


def float32_squared_distances(points: np.ndarray, lists: np.ndarray) -> np.ndarray:
    """Squared distances as the core forms them: float32 coordinates relative to the
    minimum corner, x + y + z summed in that order."""
    local = (points - points.min(axis=0)).astype(np.float32)
    d = local[lists] - local[:, None, :]
    return (d[..., 0] * d[..., 0] + d[..., 1] * d[..., 1]) + d[..., 2] * d[..., 2]


def assert_lists_match_reference(points: np.ndarray, k: int) -> None:
    """Equal to the reference but where the k-th distance is shared; there, the same
    distances, and the same points nearer than the k-th, in the same order."""
    core = _core.neighbour_lists(points, NormalsParams(k=k).to_core()).astype(np.intp)
    ref, ties = neighbour_lists(points, k, return_boundary_ties=True)
    np.testing.assert_array_equal(core[~ties], ref[~ties])
    core_d = float32_squared_distances(points, core)
    ref_d = float32_squared_distances(points, ref)
    np.testing.assert_array_equal(core_d, ref_d)
    nearer = ref_d < ref_d[:, -1:]
    np.testing.assert_array_equal(core[nearer], ref[nearer])
    assert all(len(set(row)) == k for row in core.tolist())  # no point twice


@st.composite
def clouds_of_copies(draw: st.DrawFn) -> tuple[np.ndarray, int]:
    """Up to 400 points on a few positions of a 1 cm lattice (many copies, many equal
    distances), sometimes with one point far off; k from 3 to 40."""
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    side = draw(st.integers(1, 4))
    lattice = draw(st.integers(2, 12))  # distinct positions
    n = draw(st.integers(lattice + 2, 400))
    positions = rng.integers(0, side + 1, (lattice, 3)) * 0.01
    points = positions[rng.integers(0, lattice, n)]
    if draw(st.booleans()):
        points[-1] = [0.0, draw(st.sampled_from([0.05, 1.0, 1e3])), 0.0]
    k = draw(st.integers(3, min(40, n - 1)))
    return points + [4.5e5, 5.4e6, 120.0], k


@settings(max_examples=examples(150), deadline=None)
@given(case=clouds_of_copies())
def test_hypothesis_copies_match_reference(case: tuple[np.ndarray, int]) -> None:
    points, k = case
    assert_lists_match_reference(points, k)


def test_two_stacks_beside_a_point() -> None:
    # benchmarks/speed/copies.py's "two stacks": half the points at one position, half
    # 1 cm away, one 1 m off. Every list ends at a distance that thousands share.
    points = np.zeros((3001, 3))
    points[1500:, 0] = 0.01
    points[-1] = [0.0, 1.0, 0.0]
    for k in (3, 15, 50):
        assert_lists_match_reference(points, k)
