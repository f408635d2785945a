"""NumPy/SciPy reference for :func:`pcl_rg.normals` and its neighbour lists."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
from scipy.spatial import cKDTree

from .._far_points import check_fewer_than_kept
from .._normals import NormalsParams, NormalsResult
from .._params import check_number, resolve_arguments
from .._validation import as_points
from ._local import local_frame, near_rows

__all__ = ["neighbour_lists", "normals", "QUADRIC_CONDITION_LIMIT"]

#: Same rank tolerance as the core (``pcl_rg._core.QUADRIC_CONDITION_LIMIT``).
QUADRIC_CONDITION_LIMIT = 1e-10


def _float32_squared_distances(local: np.ndarray, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
    """Squared distances as the core's k-d tree forms them: float32, x + y + z in order."""
    d = local[cols] - local[rows][:, None, :]
    return (d[..., 0] * d[..., 0] + d[..., 1] * d[..., 1]) + d[..., 2] * d[..., 2]


def neighbour_lists(
    points: npt.ArrayLike, k: int, *, return_boundary_ties: bool = False
) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
    """The k nearest points of every point, itself included: intp (N, k).

    Same definition as the core: float32 coordinates relative to the float64
    origin ``_local.float32_origin`` (the minimum corner, stray points far
    below left out; far points, ``_local.near_rows``, have only themselves in
    their rows and are in no other row), float32 squared distances
    summed over x, y, z in that order, ascending, equal distances by lower
    index. cKDTree proposes candidates in float64; they are re-ranked in
    float32 and the query is widened wherever a non-candidate could still
    rank among the first k.

    With ``return_boundary_ties=True`` also returns a bool (N,) mask of the
    points whose k-th and (k+1)-th float32 distances are equal: there the
    core's k-d tree may keep either point (nanoflann only guarantees the
    index order among points it has already accepted), so neighbour lists,
    and everything downstream, may legitimately differ.
    """
    xyz = as_points(points)
    k = check_number("k", k, int, minimum=1)
    n = len(xyz)
    if n == 0:
        empty = np.empty((0, k), dtype=np.intp)
        return (empty, np.empty(0, dtype=bool)) if return_boundary_ties else empty
    if k >= n:
        raise ValueError(f"k must be < the number of points ({n}), got {k}")
    near = near_rows(xyz)
    if near is not None:  # far points: rows of themselves alone, no neighbours
        check_fewer_than_kept("k", k, len(near), n)
        out = np.repeat(np.arange(n)[:, None], k, axis=1)
        ties = np.zeros(n, dtype=bool)
        kept, kept_ties = neighbour_lists(xyz[near], k, return_boundary_ties=True)
        ties[near] = kept_ties
        out[near] = near[kept]
        return (out, ties) if return_boundary_ties else out
    local = local_frame(xyz).astype(np.float32)
    tree = cKDTree(local.astype(np.float64))
    out = np.empty((n, k), dtype=np.intp)
    ties = np.zeros(n, dtype=bool)
    todo = np.arange(n)
    extra = 8
    while todo.size:
        m = min(k + extra, n)
        dist64, cand = tree.query(local[todo].astype(np.float64), k=m)
        cand = cand.reshape(len(todo), m)
        d32 = _float32_squared_distances(local, todo, cand)
        order = np.lexsort((cand, d32), axis=-1)
        cand = np.take_along_axis(cand, order, axis=-1)
        d32 = np.take_along_axis(d32, order, axis=-1)
        # Any point not proposed is at float64 distance >= the last candidate's; keep
        # rows whose k-th float32 distance is clearly below that (float32 vs float64
        # squared distances differ by far less than 1e-5 relative).
        last = dist64.reshape(len(todo), m)[:, -1] ** 2
        safe = (m == n) | (d32[:, k - 1] < last * (1.0 - 1e-5))
        if m > k:
            ties[todo[safe]] = d32[safe, k - 1] == d32[safe, k]
        out[todo[safe]] = cand[safe, :k]
        todo = todo[~safe]
        extra *= 4
    return (out, ties) if return_boundary_ties else out


def _orient_up(normal: np.ndarray) -> np.ndarray:
    x, y, z = normal[:, 0], normal[:, 1], normal[:, 2]
    flip = (z < 0) | ((z == 0) & ((y < 0) | ((y == 0) & (x < 0))))
    return np.where(flip[:, None], -normal, normal)


def _distinct_positions(rel: np.ndarray) -> np.ndarray:
    """How many distinct positions each neighbourhood (n, k, 3) holds: the quadric's six
    unknowns need six, fewer make its design exactly rank deficient (the core's
    enough_distinct_positions)."""
    order = np.lexsort((rel[..., 2], rel[..., 1], rel[..., 0]), axis=-1)
    ordered = np.take_along_axis(rel, order[..., None], axis=1)
    return 1 + (ordered[:, 1:] != ordered[:, :-1]).any(axis=-1).sum(axis=1)


def _cholesky_pivots(matrix: np.ndarray) -> np.ndarray:
    """Diagonal of the Cholesky factor L of each matrix (NaN once a pivot is not > 0).

    The factor of a positive definite matrix is unique, so these are the pivots any
    correct Cholesky (Eigen's LLT in the core) produces, up to rounding.
    """
    size = matrix.shape[-1]
    factor = np.zeros_like(matrix)
    with np.errstate(invalid="ignore", divide="ignore"):
        for j in range(size):
            rest = matrix[:, j, j] - np.einsum("ij,ij->i", factor[:, j, :j], factor[:, j, :j])
            factor[:, j, j] = np.sqrt(np.where(rest > 0, rest, np.nan))
            for i in range(j + 1, size):
                dot = np.einsum("ij,ij->i", factor[:, i, :j], factor[:, j, :j])
                factor[:, i, j] = (matrix[:, i, j] - dot) / factor[:, j, j]
    return np.diagonal(factor, axis1=1, axis2=2)


def normals(
    points: npt.ArrayLike, *, k: int | None = None, params: NormalsParams | None = None
) -> NormalsResult:
    """Reference normals and curvatures: same signature and result as :func:`pcl_rg.normals`.

    Vectorised NumPy in float64 on the neighbour lists of :func:`neighbour_lists`;
    LAPACK's eigensolver instead of Eigen's, so values agree with the core to
    rounding (and normals up to sign where n_z is 0 within rounding).

    Examples
    --------
    >>> import numpy as np
    >>> from pcl_rg import reference
    >>> rng = np.random.default_rng(1)
    >>> plane = np.column_stack([rng.uniform(0, 1, (50, 2)), np.zeros(50)])
    >>> result = reference.normals(plane, k=10)
    >>> float(np.abs(result.normals[:, 2]).min()), float(np.abs(result.gaussian_curvature).max())
    (1.0, 0.0)
    """
    p = resolve_arguments(NormalsParams, locals())
    xyz = as_points(points)
    n, k = len(xyz), p.k
    nan = np.full(n, np.nan)
    if n == 0:
        return NormalsResult(np.empty((0, 3)), *(np.empty(0) for _ in range(5)))
    nbr = neighbour_lists(xyz, k)
    rel = xyz[nbr] - xyz[:, None, :]  # neighbours relative to the point, float64

    # Step 1: PCA normal and surface variation.
    centred = rel - rel.mean(axis=1, keepdims=True)
    covariance = np.einsum("nki,nkj->nij", centred, centred) / k
    trace = np.trace(covariance, axis1=1, axis2=2)
    defined = trace > 0
    eigenvalues, eigenvectors = np.linalg.eigh(covariance)
    normal = _orient_up(eigenvectors[:, :, 0])
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    normal[~defined] = np.nan
    with np.errstate(invalid="ignore", divide="ignore"):
        surface_variation = np.where(defined, np.maximum(eigenvalues[:, 0], 0.0) / trace, np.nan)

    gaussian, mean, k1, k2 = nan.copy(), nan.copy(), nan.copy(), nan.copy()
    if k < 6:
        return NormalsResult(normal, surface_variation, gaussian, mean, k1, k2)

    # Step 2: quadric in the frame (largest axis, n x it, n), centred at the point.
    x_axis = eigenvectors[:, :, 2]
    x_axis = x_axis / np.linalg.norm(x_axis, axis=1, keepdims=True)
    y_axis = np.cross(normal, x_axis)
    u = np.einsum("nki,ni->nk", rel, x_axis)
    v = np.einsum("nki,ni->nk", rel, y_axis)
    w = np.einsum("nki,ni->nk", rel, normal)
    s = np.sqrt(((u**2).sum(axis=1) + (v**2).sum(axis=1)) / k)
    ok = defined & (s > 0) & (_distinct_positions(rel) >= 6)
    with np.errstate(invalid="ignore", divide="ignore"):
        us, vs, ws = u / s[:, None], v / s[:, None], w / s[:, None]
        design = np.stack([us * us, us * vs, vs * vs, us, vs, np.ones_like(us)], axis=-1)
        matrix = np.einsum("nki,nkj->nij", design, design)
        rhs = np.einsum("nki,nk->ni", design, ws)
        pivots = _cholesky_pivots(np.where(ok[:, None, None], matrix / k, np.eye(6)))
    ok &= (pivots**2 > QUADRIC_CONDITION_LIMIT).all(axis=1)
    idx = np.flatnonzero(ok)
    if idx.size:
        q = np.linalg.solve(matrix[idx] / k, (rhs[idx] / k)[..., None])[..., 0]
        a, b, c = (q[:, j] / s[idx] for j in range(3))
        d, e = q[:, 3], q[:, 4]
        m = 1.0 + d * d + e * e
        gaussian[idx] = (4.0 * a * c - b * b) / (m * m)
        mean[idx] = ((1.0 + e * e) * a - d * e * b + (1.0 + d * d) * c) / (m * np.sqrt(m))
        root = np.sqrt(np.maximum(mean[idx] ** 2 - gaussian[idx], 0.0))
        k1[idx] = mean[idx] + root
        k2[idx] = mean[idx] - root
    return NormalsResult(normal, surface_variation, gaussian, mean, k1, k2)
