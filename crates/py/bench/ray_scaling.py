"""Scaling of a Ray bake from 1 to 2 worker processes on this machine, beside the same bake
in-process (single-threaded and with all cores), all with one scene, cells, method and seed.

    python crates/py/bench/ray_scaling.py [--scene SPEC] [--grid NX,NY] [--rays N] [--repeat K]

Each Ray run starts a fresh local cluster with `num_cpus` = the worker count and bakes with one
thread per task, so the worker count is the parallelism. Every run's PVS is checked equal to
the in-process bake. Prints a Markdown table (times are the median of --repeat runs, each
configuration run in turn so that load changes hit all of them alike).
"""

import argparse
import os
import statistics
import time

import ray

import sightline as sl
import sightline.ray as slray


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--scene", default="procedural:city?size=20000")
    ap.add_argument("--grid", default="4,4")
    ap.add_argument("--bounds", default="-400,-400,1,400,400,3")
    ap.add_argument("--rays", type=int, default=200_000)
    ap.add_argument("--n-rand", type=int, default=50_000)
    ap.add_argument("--batch-size", type=int, default=2)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()

    load_before = os.getloadavg()[0]
    scene = sl.load(args.scene)
    b = [float(x) for x in args.bounds.split(",")]
    nx, ny = (int(x) for x in args.grid.split(","))
    cells = sl.grid(b[:3], b[3:], (nx, ny, 1))
    method = sl.Method("gvs++", n_rand=args.n_rand)
    bake_args = dict(rays=args.rays, seed=1)

    reference = sl.bake(scene, cells, method, threads=1, **bake_args)
    times = {k: [] for k in ("local, 1 thread", "local, 2 threads", "ray, 1 worker", "ray, 2 workers")}
    busy = {k: [] for k in times}
    for _ in range(args.repeat):
        for threads in (1, 2):
            t = time.perf_counter()
            pvs = sl.bake(scene, cells, method, threads=threads, **bake_args)
            times[f"local, {threads} thread{'s' if threads > 1 else ''}"].append(time.perf_counter() - t)
            assert pvs == reference
        for workers in (1, 2):
            ray.init(num_cpus=workers, include_dashboard=False, log_to_driver=False)
            # Warm the workers up (process start, import) outside the timing.
            ray.get([ray.remote(lambda: os.getpid()).remote() for _ in range(workers)])
            t = time.perf_counter()
            pvs = slray.bake(scene, cells, method, batch_size=args.batch_size, threads=1, **bake_args)
            wall = time.perf_counter() - t
            name = f"ray, {workers} worker{'s' if workers > 1 else ''}"
            times[name].append(wall)
            task_seconds = sum(b["seconds"] for b in pvs.metadata["distributed"]["batches"])
            busy[name].append(task_seconds / wall)
            ray.shutdown()
            assert pvs == reference, "distributed bake differs from the local bake"

    base = statistics.median(times["local, 1 thread"])
    print(f"{scene.source}: {scene.triangle_count} triangles, {len(cells)} cells, gvs++ "
          f"n_rand={args.n_rand}, {args.rays} rays per cell, batch size {args.batch_size}; "
          f"load average before: {load_before:.2f}, after: {os.getloadavg()[0]:.2f}")
    print()
    print("| run | seconds (median) | cells per minute | speed-up over local, 1 thread "
          "| tasks running at once (task seconds / wall) |")
    print("|---|---|---|---|---|")
    for name, ts in times.items():
        m = statistics.median(ts)
        b = f"{statistics.median(busy[name]):.2f}" if busy[name] else "-"
        print(f"| {name} | {m:.2f} | {60 * len(cells) / m:.0f} | {base / m:.2f}x | {b} |")
    print()
    print("every run's PVS equal to the in-process single-thread bake: yes")


if __name__ == "__main__":
    main()
