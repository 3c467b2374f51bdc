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

With ``output``, finished cells are checkpointed in ``OUTPUT.checkpoint``, the checkpoint file
of ``sightline pvs bake -o OUTPUT`` (same format and key: a ``.pvs`` of the finished cells with
``metadata = {"checkpoint": 1, "key": .., "cell_indices": [..], "cells": [stats..]}``, the key
fingerprinting scene, cells, method, parameters, budget and seed). A driver that crashes or is
interrupted resumes from it when run again with the same arguments; the checkpoint is
removed once the output is written. Like the CLI's, the output holds every cell's statistics
(``metadata["cells"]``: rays, seconds, PVS size, convergence), which ``sightline report`` shows.

See docs/distributed.md for running on a real cluster.
"""

from __future__ import annotations

import json
import os
import time
import warnings
from typing import Dict, List, Optional, Sequence, Tuple, Union

import ray

from . import _progress
from . import _sightline as _native

__all__ = ["bake", "checkpoint_path"]


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
    # No progress display in workers: their stderr is a log, and the driver reports cells.
    sets, stats = _native.bake_cells(
        scene,
        list(cells),
        method,
        rays=rays,
        seed=seed,
        indices=list(indices),
        threads=threads,
        progress=False,
        stats=True,
    )
    return {
        "indices": list(indices),
        "sets": sets,
        "stats": stats,
        "seconds": time.perf_counter() - start,
        "pid": os.getpid(),
        "node": ray.get_runtime_context().get_node_id(),
    }


_bake_batch_remote = ray.remote(_bake_batch)


class _InjectedFailure(RuntimeError):
    """Raised by the driver after ``_fail_after_cells`` cells (tests of resuming)."""


def checkpoint_path(output: Union[str, os.PathLike]) -> str:
    """The checkpoint file of ``output``: ``OUTPUT.checkpoint`` (as ``sightline pvs bake``)."""
    return os.fspath(output) + ".checkpoint"


def _load_checkpoint(
    path: str, scene: _native.Scene, cells: List[_native.ViewCell], key
) -> Dict[int, Tuple[object, dict]]:
    """The finished cells in the checkpoint at ``path`` (none when it does not exist), by index,
    with their sets and statistics. Refuses a checkpoint of another bake, as the CLI does."""
    if not os.path.exists(path):
        return {}
    hint = "pass restart=True to discard it, or choose another output"
    try:
        pvs = _native.Pvs.load(path)
    except (OSError, ValueError) as e:
        raise ValueError(f"the checkpoint {path} cannot be read ({e}); {hint}") from e
    metadata = pvs.metadata if isinstance(pvs.metadata, dict) else {}
    if metadata.get("checkpoint") != 1:
        raise ValueError(f"{path} is not a bake checkpoint (no checkpoint marker); {hint}")
    if metadata.get("key") != key:
        theirs = (metadata.get("key") or {}).get("fingerprint") or {}
        ours = key["fingerprint"]
        differ = sorted(k for k in set(theirs) | set(ours) if theirs.get(k) != ours.get(k))
        raise ValueError(
            f"{path} is the checkpoint of a different bake (it differs in: "
            f"{', '.join(differ) or 'the cells this run bakes'}); {hint}"
        )
    indices = metadata.get("cell_indices")
    stats = metadata.get("cells")
    if not isinstance(indices, list) or not isinstance(stats, list):
        raise ValueError(f"{path} is not a bake checkpoint (no cell_indices or cells); {hint}")
    if len(indices) != len(pvs) or len(stats) != len(pvs):
        raise ValueError(f"{path}: cell_indices or cells do not match its cells; {hint}")
    pvs.check_scene(scene)
    done = {}
    for k, (i, cell) in enumerate(zip(indices, pvs.cells)):
        if not (isinstance(i, int) and 0 <= i < len(cells) and cells[i] == cell):
            raise ValueError(f"{path}: a cell index does not name its cell; {hint}")
        done[i] = (pvs.visible(k), stats[k])
    return done


def _save_checkpoint(path: str, scene, cells, key, done) -> None:
    """Writes the finished cells to the checkpoint (atomically, like every ``Pvs.save``)."""
    order = sorted(done)
    metadata = {
        "checkpoint": 1,
        "key": key,
        "cell_indices": order,
        "cells": [done[i][1] for i in order],
    }
    _native.Pvs(scene, [cells[i] for i in order], [done[i][0] for i in order], metadata).save(path)


def _largest_node_cpus() -> Optional[int]:
    """CPUs of the largest live node of the cluster (``None`` when Ray does not say)."""
    try:
        cpus = [n.get("Resources", {}).get("CPU", 0) for n in ray.nodes() if n.get("Alive")]
    except Exception:  # an older or remote Ray without node listing: no cap
        return None
    return int(max(cpus)) if cpus and max(cpus) >= 1 else None


def bake(
    scene: Union[_native.Scene, str, os.PathLike],
    cells: Sequence[_native.ViewCell],
    method: Union[str, _native.Method] = "gvs++",
    rays: Optional[int] = None,
    seed: int = 1,
    output: Optional[Union[str, os.PathLike]] = None,
    batch_size: int = 16,
    threads: Optional[int] = 1,
    max_retries: int = 3,
    progress: _progress.ProgressArg = None,
    restart: bool = False,
    checkpoint_every: float = 2.0,
    _crash_once_marker: Optional[str] = None,
    _fail_after_cells: Optional[int] = None,
) -> _native.Pvs:
    """Bakes the PVS of ``cells`` as Ray tasks and merges them into one ``Pvs``.

    scene: a ``Scene``, or a spec or path for ``Scene.load`` (loaded here, on the driver).
    cells: the view cells, in the order of the result.
    method, rays, seed: as ``sightline.bake``; ``rays=None`` lets GVS++/GVS stop by their own
        rule (time budgets are not offered: they would make the result depend on the machine).
    output: when given, the ``.pvs`` is also written there (atomically), and finished cells are
        checkpointed in ``OUTPUT.checkpoint`` meanwhile: a rerun with the same arguments
        resumes from it (see the module's docs). A checkpoint of a different bake is refused
        with ``ValueError``.
    batch_size: cells per task; a task pays for one BVH build, so batches should be large
        enough for the bake to dominate.
    threads: threads each task bakes with (and the CPUs it asks Ray for); ``None``: all cores
        of the worker's machine (and 1 CPU asked). A count above the CPUs of the cluster's
        largest node, which Ray could never schedule, is capped to them with a
        ``RuntimeWarning``.
    max_retries: how often Ray reruns a task whose worker died.
    progress: as for ``sightline.bake``: ``progress(cells_done, cells_total, rays)`` after
        each finished batch (cells resumed from the checkpoint count as done); by default a
        line on stderr when it is a terminal, ``False`` for none.
    restart: discard an existing checkpoint of ``output`` instead of resuming from it.
    checkpoint_every: least seconds between checkpoint writes (the first finished batch is
        always written; an interrupted or failing driver writes what it has before raising).
    _crash_once_marker: for tests only: a file path; the first task to find it absent creates
        it and kills its own worker process (the retry then bakes the batch).
    _fail_after_cells: for tests only: the driver raises after this many cells were baked (as
        a crashed driver would stop), leaving them in the checkpoint.

    Connects to Ray with ``ray.init()`` when it is not connected yet (set ``RAY_ADDRESS`` or
    call ``ray.init(address=...)`` first to use a cluster). Ctrl-C in the driver cancels the
    pending tasks, keeps the finished cells in the checkpoint and raises ``KeyboardInterrupt``.
    """
    if isinstance(scene, (str, os.PathLike)):
        scene = _native.Scene.load(scene)
    cells = list(cells)
    if batch_size < 1:
        raise ValueError(f"batch_size must be >= 1, got {batch_size}")
    if rays is not None and rays < 1:
        raise ValueError(f"rays must be positive, got {rays}")
    if threads is not None and threads < 1:
        raise ValueError(f"threads must be >= 1 or None, got {threads}")
    if not checkpoint_every >= 0:
        raise ValueError(f"checkpoint_every must be >= 0 seconds, got {checkpoint_every}")
    if isinstance(method, str):
        method = _native.Method(method)  # fails here, not in a worker, for an unknown name
    report = _progress.resolve(progress)
    keys = json.loads(_native._bake_fingerprint(scene, cells, method, rays, seed))
    checkpoint = checkpoint_path(output) if output is not None else None
    done: Dict[int, Tuple[object, dict]] = {}
    if checkpoint is not None and not restart:
        done = _load_checkpoint(checkpoint, scene, cells, keys["checkpoint_key"])
    resumed = len(done)
    if not ray.is_initialized():
        ray.init()
    if threads is not None:
        largest = _largest_node_cpus()
        if largest is not None and threads > largest:
            warnings.warn(
                f"threads: {threads} threads per task requested, using {largest}: no node of "
                f"the cluster has more CPUs, so Ray could never schedule such a task",
                RuntimeWarning,
                stacklevel=2,
            )
            threads = largest

    start = time.perf_counter()
    todo = [i for i in range(len(cells)) if i not in done]
    vertices_ref = ray.put(scene.vertices)
    triangles_ref = ray.put(scene.triangles)
    task = _bake_batch_remote.options(max_retries=max_retries, num_cpus=threads or 1)
    pending = []
    for first in range(0, len(todo), batch_size):
        indices = todo[first : first + batch_size]
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
    batches = []
    baked = 0
    unsaved = False
    last_write: Optional[float] = None
    rays_so_far = sum(s.get("rays", 0) for _, s in done.values())
    try:
        if report is not None:
            report(len(done), len(cells), rays_so_far)
        # Batches are taken as they finish (not in submission order), so that each one is
        # reported and checkpointed at once.
        while pending:
            ready, pending = ray.wait(pending, num_returns=1)
            result = ray.get(ready[0])
            for i, ids, stats in zip(result["indices"], result["sets"], result["stats"]):
                done[i] = (ids, stats)
                rays_so_far += stats.get("rays", 0)
            baked += len(result["indices"])
            unsaved = True
            batches.append(
                {
                    "cells": len(result["indices"]),
                    "first_cell": result["indices"][0],
                    "seconds": result["seconds"],
                    "pid": result["pid"],
                    "node": result["node"],
                }
            )
            if report is not None:
                report(len(done), len(cells), rays_so_far)
            now = time.monotonic()
            if checkpoint is not None and pending and (
                last_write is None or now - last_write >= checkpoint_every
            ):
                _save_checkpoint(checkpoint, scene, cells, keys["checkpoint_key"], done)
                last_write, unsaved = now, False
            if _fail_after_cells is not None and baked >= _fail_after_cells and pending:
                raise _InjectedFailure(f"driver stopped after {baked} cells (test hook)")
    except BaseException:
        # Ctrl-C, a failed task or a test hook: keep what is finished for the next run, and do
        # not leave the cluster busy with tasks nobody will collect.
        for ref in pending:
            ray.cancel(ref)
        if checkpoint is not None and unsaved:
            _save_checkpoint(checkpoint, scene, cells, keys["checkpoint_key"], done)
        raise
    stats = [done[i][1] for i in range(len(cells))]
    metadata = {
        "tool": f"sightline {_native.__version__} (python, ray)",
        "scene": scene.source,
        "method": method.name,
        "seed": seed,
        "budget": {"max_rays": rays, "max_time": None},
        "total_rays": sum(s.get("rays", 0) for s in stats),
        "seconds": time.perf_counter() - start,
        "cells": stats,
        "parameters": keys["parameters"],
        "fingerprint": keys["fingerprint"],
        "total_cells": len(cells),
        "cell_seconds": sum(s.get("seconds", 0.0) for s in stats),
        "distributed": {
            "engine": "ray",
            "ray_version": ray.__version__,
            "batch_size": batch_size,
            "threads_per_task": threads,
            "resumed_cells": resumed,
            "baked_cells": baked,
            "batches": batches,
        },
    }
    pvs = _native.Pvs(scene, cells, [done[i][0] for i in range(len(cells))], metadata)
    if output is not None:
        pvs.save(output)
        if os.path.exists(checkpoint):
            # The output is complete; a leftover checkpoint would only be resumed into the
            # same result, so failing to delete it is not an error.
            try:
                os.remove(checkpoint)
            except OSError:
                pass
    return pvs
