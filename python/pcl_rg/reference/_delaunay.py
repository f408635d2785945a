"""The one Delaunay triangulation the core builds where it is not unique.

Where four or more vertices lie on one circle, any triangulation of them is Delaunay,
and qhull picks one of its own. The core breaks those ties by a symbolic perturbation
(``incircle_perturbed`` in ``delaunay.hpp``: each vertex's lifted height x^2 + y^2
raised by eps^r, r its rank in (x, y) order), which makes the triangulation unique.
:func:`follow_perturbation` flips qhull's diagonals until every edge passes that test,
so the reference's TIN is the core's everywhere.
"""

from __future__ import annotations

import numpy as np

__all__ = ["follow_perturbation", "triangle_neighbours"]


def _orient(a: tuple[int, int], b: tuple[int, int], c: tuple[int, int]) -> int:
    return (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])


def _incircle(a, b, c, d) -> int:  # type: ignore[no-untyped-def]
    """Sign of d inside (> 0) the circle of counter-clockwise (a, b, c); exact (ints)."""
    adx, ady, bdx, bdy = a[0] - d[0], a[1] - d[1], b[0] - d[0], b[1] - d[1]
    cdx, cdy = c[0] - d[0], c[1] - d[1]
    det = (
        (adx * adx + ady * ady) * (bdx * cdy - bdy * cdx)
        + (bdx * bdx + bdy * bdy) * (cdx * ady - cdy * adx)
        + (cdx * cdx + cdy * cdy) * (adx * bdy - ady * bdx)
    )
    return (det > 0) - (det < 0)


def _incircle_perturbed(a, b, c, d) -> int:  # type: ignore[no-untyped-def]
    """incircle with the core's tie rule: the lowest-ranked point of the four whose
    coefficient is not zero decides (a, b, c: the orientation of the other three in
    the cyclic order; d: -orient(a, b, c))."""
    exact = _incircle(a, b, c, d)
    if exact:
        return exact
    terms = [(a, _orient(b, c, d)), (b, _orient(c, a, d)), (c, _orient(a, b, d))]
    decider = (d, -_orient(a, b, c))
    for point, coefficient in terms:
        if coefficient != 0 and point < decider[0]:
            decider = (point, coefficient)
    return 1 if decider[1] > 0 else -1


def triangle_neighbours(tri: np.ndarray) -> np.ndarray:
    """The triangle across the edge opposite each vertex of each row, -1 on the hull."""
    t = np.repeat(np.arange(len(tri)), 3)
    k = np.tile(np.arange(3), len(tri))
    u, v = tri[t, (k + 1) % 3], tri[t, (k + 2) % 3]
    key = np.minimum(u, v) * (int(tri.max()) + 1) + np.maximum(u, v)
    order = np.argsort(key, kind="stable")
    pair = np.flatnonzero(key[order][1:] == key[order][:-1])
    result = np.full((len(tri), 3), -1, dtype=np.int64)
    first, second = order[pair], order[pair + 1]
    result[t[first], k[first]] = t[second]
    result[t[second], k[second]] = t[first]
    return result


def follow_perturbation(tri: np.ndarray, vx: np.ndarray, vy: np.ndarray) -> np.ndarray:
    """The triangles (counter-clockwise rows) after flipping every edge that fails the
    perturbed in-circle test, round after round, each triangle in one flip a round.

    An edge's float64 in-circle determinant decides where it is far from zero (a
    relative bound of 1e-12 of its magnitude, far above the rounding of integers below
    2^31); the others are decided exactly on Python integers, ties by the perturbation.
    Lawson's flips end at the Delaunay triangulation of the perturbed points.
    """
    tri = tri.copy()
    x, y = vx.astype(np.float64), vy.astype(np.float64)
    # Each round flips at least one edge, and Lawson's flips never undo one another (the
    # lifted surface only goes down): at most one flip per pair of vertices in all.
    for _ in range(len(vx) * len(vx) + 1):
        nb = triangle_neighbours(tri)
        t, k = np.nonzero(nb >= 0)
        u = nb[t, k]
        c, a, b = tri[t, k], tri[t, (k + 1) % 3], tri[t, (k + 2) % 3]
        d = np.take_along_axis(tri[u], np.argmax(nb[u] == t[:, None], axis=1)[:, None], 1)[:, 0]
        adx, ady, bdx, bdy = x[c] - x[d], y[c] - y[d], x[a] - x[d], y[a] - y[d]
        cdx, cdy = x[b] - x[d], y[b] - y[d]
        lifts = (adx * adx + ady * ady, bdx * bdx + bdy * bdy, cdx * cdx + cdy * cdy)
        minors = (bdx * cdy - bdy * cdx, cdx * ady - cdy * adx, adx * bdy - ady * bdx)
        det = sum(lift * minor for lift, minor in zip(lifts, minors, strict=True))
        size = sum(
            lift * (abs(p * q) + abs(r * s))
            for lift, (p, q, r, s) in zip(
                lifts,
                ((bdx, cdy, bdy, cdx), (cdx, ady, cdy, adx), (adx, bdy, ady, bdx)),
                strict=True,
            )
        )
        failing = det > 1e-12 * size
        for e in np.flatnonzero(np.abs(det) <= 1e-12 * size):
            points = [(int(vx[v]), int(vy[v])) for v in (c[e], a[e], b[e], d[e])]
            failing[e] = _incircle_perturbed(*points) > 0
        flipped = np.zeros(len(tri), bool)
        done = True
        for e in np.flatnonzero(failing):
            if flipped[t[e]] or flipped[u[e]]:
                continue
            flipped[t[e]] = flipped[u[e]] = True
            tri[t[e]] = (c[e], a[e], d[e])
            tri[u[e]] = (c[e], d[e], b[e])
            done = False
        if done:
            return tri
    raise RuntimeError("the flips did not end")  # pragma: no cover
