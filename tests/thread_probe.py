"""Run every algorithm once on fixed clouds and print a digest of each result as JSON.

tests/test_thread_independence.py starts this script in subprocesses under different
OpenMP settings and compares the digests with the plain run's. Modes:

- ``plain``: each algorithm called once from the main thread;
- ``parallel-region``: each call made from inside an OpenMP parallel region of two
  threads (libgomp's ``GOMP_parallel`` through ctypes), where nested regions get one
  thread although ``omp_get_max_threads()`` still says more;
- ``python-threads``: 3 Python threads (more than the cores CI has) call every
  algorithm at once; every thread's digest must agree, or the digest printed is
  ``"threads disagree"``.

The clouds are sized to reach every parallel path: more than 64 Ki points for the
radix sort's chunks, and more than 500 000 for grid_ground's parallel loops.
"""

from __future__ import annotations

import ctypes
import hashlib
import json
import sys
from collections.abc import Callable

import numpy as np
from conftest import run_in_threads  # this script runs from tests/

import pcl_rg
from pcl_rg import _core, datasets


def _digest(*arrays: np.ndarray) -> str:
    h = hashlib.sha256()
    for a in arrays:
        a = np.ascontiguousarray(a)
        h.update(str((a.dtype.str, a.shape)).encode())
        h.update(a.tobytes())
    return h.hexdigest()[:16]


def _clouds() -> dict[str, np.ndarray]:
    airborne = datasets.synthetic_scene(seed=3, size=360.0, density=4.0).points  # ~520 k
    uniform = np.random.default_rng(11).uniform(0.0, 100.0, (300_000, 3))
    surfaces = pcl_rg.voxel_grid(airborne[:150_000], leaf_size=0.6).centroids
    # Stacks of 50 copies of every 1000th point: the copy shortcuts of the ground filters
    # (CellGrid::copy_of_previous, skip_idle_iterations) run in their parallel passes.
    stacked = np.vstack([airborne, np.repeat(airborne[::1000], 50, axis=0)])
    return {"airborne": airborne, "uniform": uniform, "surfaces": surfaces, "stacked": stacked}


def _jobs(c: dict[str, np.ndarray]) -> dict[str, Callable[[], str]]:
    air, uni, surf = c["airborne"], c["uniform"], c["surfaces"]

    def voxel() -> str:
        g = pcl_rg.voxel_grid(uni, leaf_size=1.0)
        return _digest(g.centroids, g.counts, g.voxel_of_point)

    def normals() -> str:
        r = pcl_rg.normals(surf, k=12)
        return _digest(*r)

    def pcl_voxel() -> str:
        return _digest(*pcl_rg.pcl.voxel_grid(uni, leaf_size=1.0))

    def delaunay_batch() -> str:
        # Gridded XY: co-circular vertices everywhere, and repeated points; the batch's
        # vertex ids and triangle slots, not only its triangles, must not change.
        xy = np.ascontiguousarray(np.round(uni[:, :2] * 4.0) / 4.0)
        tin = _core.DelaunayTin(0.0, 0.0, 100.0, 100.0)
        ids = tin.insert(xy, batch=True)
        return _digest(ids, tin.triangles, tin.neighbors, tin.live)

    def pcl_sor() -> str:
        return _digest(pcl_rg.pcl.statistical_outlier_removal(uni[:100_000], mean_k=8, std_mul=1.0))

    return {
        "voxel_grid": voxel,
        "statistical_outlier_removal": lambda: _digest(
            pcl_rg.statistical_outlier_removal(uni[:200_000], mean_k=8, std_mul=1.0)
        ),
        # Lists long enough for the k-NN heap (knn.cpp, from k = 96).
        "statistical_outlier_removal_long_lists": lambda: _digest(
            pcl_rg.statistical_outlier_removal(uni[:30_000], mean_k=150, std_mul=1.0)
        ),
        "delaunay_insert_batch": delaunay_batch,
        "grid_ground": lambda: _digest(pcl_rg.grid_ground(air)),
        "grid_ground_copies": lambda: _digest(pcl_rg.grid_ground(c["stacked"])),
        "tin_ground_copies": lambda: _digest(pcl_rg.tin_ground(c["stacked"])),
        "point_spacing": lambda: _digest(np.array([pcl_rg.point_spacing(air)])),
        "tin_ground": lambda: _digest(pcl_rg.tin_ground(air)),
        # The window medians of final_pass_low.cpp, in parallel beyond 65536 cells of
        # the raster: 1 m final cells over the 360 m scene.
        "grid_ground_low_depth": lambda: _digest(
            pcl_rg.grid_ground(air, final_cell=1.0, final_low_depth=0.5)
        ),
        "tin_ground_low_depth": lambda: _digest(
            pcl_rg.tin_ground(air, final_cell=1.0, final_low_depth=0.5)
        ),
        "tin_ground_densify_off": lambda: _digest(pcl_rg.tin_ground(air, densify_cell=0.0)),
        "tin_ground_lidar360": lambda: _digest(
            pcl_rg.tin_ground(air, params=pcl_rg.TinGroundParams.lidar360())
        ),
        "normals": normals,
        "region_growing": lambda: _digest(pcl_rg.region_growing(surf)),
        "convex_segmentation": lambda: _digest(pcl_rg.convex_segmentation(surf)),
        "point_scale": lambda: _digest(np.asarray(pcl_rg.point_scale(surf))),
        "pcl.region_growing": lambda: _digest(pcl_rg.pcl.region_growing(surf)),
        "pcl.normals": lambda: _digest(*pcl_rg.pcl.normals(surf, k=12)),
        "pcl.voxel_grid": pcl_voxel,
        "pcl.statistical_outlier_removal": pcl_sor,
        "pcl.lccp": lambda: _digest(
            pcl_rg.pcl.lccp(surf, voxel_resolution=0.6, seed_resolution=2.4, viewpoint=surf.min(0))
        ),
        "pcl.progressive_morphological_filter": lambda: _digest(
            pcl_rg.pcl.progressive_morphological_filter(air[:10_000])
        ),
        "pcl.progressive_morphological_filter_approximate": lambda: _digest(
            pcl_rg.pcl.progressive_morphological_filter(air[:10_000], approximate=True)
        ),
    }


def _in_parallel_region(job: Callable[[], str]) -> str:
    """Call `job` on thread 0 of a two-thread OpenMP region; thread 1 only waits."""
    gomp = ctypes.CDLL("libgomp.so.1")
    gomp.omp_get_thread_num.restype = ctypes.c_int
    gomp.omp_get_level.restype = ctypes.c_int
    outcome: dict[str, object] = {}

    @ctypes.CFUNCTYPE(None, ctypes.c_void_p)
    def body(_data: int) -> None:  # ctypes takes the GIL for the callback
        if gomp.omp_get_thread_num() != 0:
            return
        outcome["level"] = gomp.omp_get_level()
        try:
            outcome["digest"] = job()
        except BaseException as error:  # an exception must not unwind through libgomp
            outcome["error"] = error

    gomp.GOMP_parallel(body, None, ctypes.c_uint(2), ctypes.c_uint(0))
    if "error" in outcome:
        raise outcome["error"]  # type: ignore[misc]
    if outcome.get("level") != 1:
        raise RuntimeError(f"the call ran at OpenMP level {outcome.get('level')}, not 1")
    return str(outcome["digest"])


def _from_python_threads(job: Callable[[], str], count: int = 3) -> str:
    results = run_in_threads(job, count)
    return results[0] if len(set(results)) == 1 and results[0] else "threads disagree"


def main(mode: str) -> None:
    if mode == "no-kept-blocks":
        pcl_rg.set_memory_cache_limit(0)
    jobs = _jobs(_clouds())
    call = {
        "plain": lambda job: job(),
        "no-kept-blocks": lambda job: job(),
        "parallel-region": _in_parallel_region,
        "python-threads": _from_python_threads,
    }[mode]
    print(json.dumps({name: call(job) for name, job in jobs.items()}))


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "plain")
