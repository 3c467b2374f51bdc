"""Distributed PVS bakes on Ray.

``bake(scene, cells, ...)`` splits the cells into batches and runs one Ray task per batch. The
scene travels once: its vertex and triangle arrays are put into Ray's object store and every
task reads them from there (zero-copy on the same node), rebuilding the scene and its BVH once
per task. Each cell is baked with the seed ``cell_seed(seed, global_index)``, the rule of the
single-machine bake, so the merged ``.pvs`` has exactly the cells and sets of
``sightline.bake`` / ``sightline pvs bake`` with the same scene, cells, method, budget and seed,
however the cells are batched and wherever the batches run. A worker that dies mid-task (a
killed process, a lost node) is covered by Ray's task retries (``max_retries``): the batch runs
again from scratch and, being deterministic, gives the same sets.

See docs/distributed.md for running on a real cluster.
"""

from __future__ import annotations

import os
import time
from typing import Optional, Sequence, Union

import ray

from . import _sightline as _native

__all__ = ["bake"]


def _bake_batch(
    vertices,
    triangles,
    source: str,
    up: str,
    scene_hash: int,
    cells,
    indices,
    method,
    rays: Optional[int],
    seed: int,
    threads: Optional[int],
    crash_once_marker: Optional[str],
):
    """One Ray task: rebuild the scene from the shared arrays, bake a batch of cells."""
    if crash_once_marker is not None:
        # Fault injection for tests: the first task to find no marker creates it and kills its
        # own worker process, as a crash or an OOM kill would; Ray then retries the task.
        try:
            fd = os.open(crash_once_marker, os.O_CREAT | os.O_EXCL | os.O_WRONLY)
        except FileExistsError:
            pass
        else:
            os.write(fd, str(os.getpid()).encode())
            os.close(fd)
            os._exit(1)
    scene = _native.Scene.from_arrays(vertices, triangles, source, up)
    if scene.geometry_hash != scene_hash:
        raise ValueError(
            f"scene rebuilt on the worker has hash {scene.geometry_hash:016x}, "
            f"expected {scene_hash:016x}"
        )
    start = time.perf_counter()
    sets = _native.bake_cells(
        scene, list(cells), method, rays=rays, seed=seed, indices=list(indices), threads=threads
    )
    return {
        "indices": list(indices),
        "sets": sets,
        "seconds": time.perf_counter() - start,
        "pid": os.getpid(),
        "node": ray.get_runtime_context().get_node_id(),
    }


_bake_batch_remote = ray.remote(_bake_batch)


def bake(
    scene: Union[_native.Scene, str],
    cells: Sequence[_native.ViewCell],
    method: Union[str, _native.Method] = "gvs++",
    rays: Optional[int] = None,
    seed: int = 1,
    output: Optional[Union[str, os.PathLike]] = None,
    batch_size: int = 16,
    threads: Optional[int] = 1,
    max_retries: int = 3,
    _crash_once_marker: Optional[str] = None,
) -> _native.Pvs:
    """Bakes the PVS of ``cells`` as Ray tasks and merges them into one ``Pvs``.

    scene: a ``Scene`` or a spec for ``Scene.load`` (loaded here, on the driver).
    cells: the view cells, in the order of the result.
    method, rays, seed: as ``sightline.bake``; ``rays=None`` lets GVS++/GVS stop by their own
        rule (time budgets are not offered: they would make the result depend on the machine).
    output: when given, the ``.pvs`` is also written there (atomically).
    batch_size: cells per task; a task pays for one BVH build, so batches should be large
        enough for the bake to dominate.
    threads: threads each task bakes with (and the CPUs it asks Ray for); ``None``: all cores
        of the worker's machine (and 1 CPU asked).
    max_retries: how often Ray reruns a task whose worker died.
    _crash_once_marker: for tests only: a file path; the first task to find it absent creates
        it and kills its own worker process (the retry then bakes the batch).

    Connects to Ray with ``ray.init()`` when it is not connected yet (set ``RAY_ADDRESS`` or
    call ``ray.init(address=...)`` first to use a cluster).
    """
    if isinstance(scene, str):
        scene = _native.Scene.load(scene)
    cells = list(cells)
    if batch_size < 1:
        raise ValueError(f"batch_size must be >= 1, got {batch_size}")
    if rays is not None and rays < 1:
        raise ValueError(f"rays must be positive, got {rays}")
    if threads is not None and threads < 1:
        raise ValueError(f"threads must be >= 1 or None, got {threads}")
    if isinstance(method, str):
        method = _native.Method(method)  # fails here, not in a worker, for an unknown name
    if not ray.is_initialized():
        ray.init()

    start = time.perf_counter()
    vertices_ref = ray.put(scene.vertices)
    triangles_ref = ray.put(scene.triangles)
    task = _bake_batch_remote.options(max_retries=max_retries, num_cpus=threads or 1)
    pending = []
    for first in range(0, len(cells), batch_size):
        indices = list(range(first, min(first + batch_size, len(cells))))
        pending.append(
            task.remote(
                vertices_ref,
                triangles_ref,
                scene.source,
                scene.up,
                scene.geometry_hash,
                [cells[i] for i in indices],
                indices,
                method,
                rays,
                seed,
                threads,
                _crash_once_marker,
            )
        )
    sets = [None] * len(cells)
    batches = []
    for result in ray.get(pending):
        for i, ids in zip(result["indices"], result["sets"]):
            sets[i] = ids
        batches.append(
            {
                "cells": len(result["indices"]),
                "seconds": result["seconds"],
                "pid": result["pid"],
                "node": result["node"],
            }
        )
    metadata = {
        "tool": f"sightline {_native.__version__} (python, ray)",
        "scene": scene.source,
        "method": method.name,
        "seed": seed,
        "budget": {"max_rays": rays, "max_time": None},
        "seconds": time.perf_counter() - start,
        "distributed": {
            "engine": "ray",
            "ray_version": ray.__version__,
            "batch_size": batch_size,
            "threads_per_task": threads,
            "batches": batches,
        },
    }
    pvs = _native.Pvs(scene, cells, sets, metadata)
    if output is not None:
        pvs.save(os.fspath(output))
    return pvs
