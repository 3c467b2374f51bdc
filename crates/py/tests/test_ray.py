"""Distributed bakes on a local Ray cluster (2 worker processes): equal to the local bake, and
still equal when a worker dies mid-bake."""

import json
import os
import subprocess
from pathlib import Path

import pytest

import sightline as sl

if os.environ.get("SIGHTLINE_REQUIRE_RAY"):
    import ray  # scripts/test-python installs Ray: a broken install must fail, not skip
else:
    ray = pytest.importorskip("ray")
import sightline.ray as slray  # noqa: E402

METHOD = sl.Method("gvs++", n_rand=5_000)


def process_alive(pid):
    """True while `pid` runs (a zombie waiting to be reaped counts as dead)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False


@pytest.fixture(scope="module")
def cluster():
    os.environ.setdefault("RAY_USAGE_STATS_ENABLED", "0")
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    yield
    ray.shutdown()


@pytest.fixture(scope="module")
def local(city, city_cells):
    return sl.bake(city, city_cells, METHOD, rays=30_000, seed=4)


def test_ray_bake_equals_local_bake(cluster, tmp_path, city, city_cells, local):
    out = tmp_path / "ray.pvs"
    pvs = slray.bake(city, city_cells, METHOD, rays=30_000, seed=4, output=out, batch_size=2)
    assert pvs == local
    assert sl.Pvs.load(str(out)) == local
    batches = pvs.metadata["distributed"]["batches"]
    assert len(batches) == 3 and sum(b["cells"] for b in batches) == len(city_cells)


def test_ray_bake_equals_cli_bake(cluster, tmp_path, cli, city, city_cells):
    out = tmp_path / "cli.pvs"
    cmd = [cli, "pvs", "bake", city.source, "--grid", "3,2,1", "--method", "gvs++"]
    cmd += ["--n-rand", "5000", "--rays", "30000", "--seed", "4", "-o", str(out)]
    subprocess.run(cmd, check=True, capture_output=True)
    pvs = slray.bake(city, city_cells, METHOD, rays=30_000, seed=4, batch_size=4)
    assert pvs == sl.Pvs.load(str(out))


def test_ray_bake_survives_a_worker_that_dies(cluster, tmp_path, city, city_cells, local):
    marker = tmp_path / "crashed"
    pvs = slray.bake(
        city,
        city_cells,
        METHOD,
        rays=30_000,
        seed=4,
        batch_size=3,
        max_retries=2,
        _crash_once_marker=str(marker),
    )
    # A worker process really exited (it wrote its pid into the marker, then died) ...
    pid = int(marker.read_text())
    assert not process_alive(pid)
    # ... and the retried batch gave the same sets.
    assert pid not in [b["pid"] for b in pvs.metadata["distributed"]["batches"]]
    assert pvs == local


def test_ray_bake_without_retries_fails_when_a_worker_dies(cluster, tmp_path, city, city_cells):
    marker = tmp_path / "crashed"
    with pytest.raises(ray.exceptions.RayError):
        slray.bake(city, city_cells[:2], "rand", rays=1_000, max_retries=0,
                   _crash_once_marker=str(marker))
    assert marker.exists()


def test_ray_bake_rejects_bad_arguments_before_submitting(cluster, city, city_cells):
    with pytest.raises(ValueError, match="batch_size"):
        slray.bake(city, city_cells, "rand", rays=10, batch_size=0)
    with pytest.raises(ValueError, match="unknown method"):
        slray.bake(city, city_cells, "magic", rays=10)


def test_ray_bake_keeps_per_cell_statistics(cluster, tmp_path, city, city_cells, local):
    out = tmp_path / "ray.pvs"
    slray.bake(city, city_cells, METHOD, rays=30_000, seed=4, output=out, batch_size=4,
               progress=False)
    metadata = sl.Pvs.load(out).metadata
    cells = metadata["cells"]
    assert len(cells) == len(city_cells)
    for got, want in zip(cells, local.metadata["cells"]):
        # Rays and PVS size are deterministic for a ray budget; seconds are not.
        assert got["rays"] == want["rays"] > 0
        assert got["pvs_size"] == want["pvs_size"]
        assert got["seconds"] > 0 and got["convergence"][-1] == want["convergence"][-1]
    assert metadata["total_rays"] == local.metadata["total_rays"]
    assert metadata["fingerprint"]["cell_count"] == len(city_cells)


def test_ray_bake_reports_progress(cluster, city, city_cells, local):
    calls = []
    slray.bake(city, city_cells, METHOD, rays=30_000, seed=4, batch_size=2,
               progress=lambda *a: calls.append(a))
    n = len(city_cells)
    # Once at the start, then once per batch of 2 cells.
    assert [c[0] for c in calls] == [0, 2, 4, 6] and all(c[1] == n for c in calls)
    assert calls[-1][2] == local.metadata["total_rays"]


def interrupted_bake(tmp_path, city, city_cells):
    """A Ray bake whose driver fails after 2 of 6 cells: the output and its checkpoint."""
    out = tmp_path / "resumed.pvs"
    with pytest.raises(slray._InjectedFailure):
        slray.bake(city, city_cells, METHOD, rays=30_000, seed=4, output=out, batch_size=1,
                   checkpoint_every=0, progress=False, _fail_after_cells=2)
    checkpoint = Path(slray.checkpoint_path(out))
    assert not out.exists() and checkpoint.exists()
    saved = sl.Pvs.load(checkpoint)
    assert 2 <= len(saved) < len(city_cells)
    return out, checkpoint, saved.metadata["cell_indices"]


def test_ray_bake_resumes_from_its_checkpoint(cluster, tmp_path, city, city_cells, local):
    out, checkpoint, finished = interrupted_bake(tmp_path, city, city_cells)
    calls = []
    pvs = slray.bake(city, city_cells, METHOD, rays=30_000, seed=4, output=out, batch_size=1,
                     progress=lambda *a: calls.append(a))
    distributed = pvs.metadata["distributed"]
    # The finished cells were not baked again ...
    assert distributed["resumed_cells"] == len(finished)
    assert distributed["baked_cells"] == len(city_cells) - len(finished)
    assert not {b["first_cell"] for b in distributed["batches"]} & set(finished)
    assert calls[0][0] == len(finished)
    # ... and the result is the uninterrupted bake's, statistics included.
    assert pvs == local and sl.Pvs.load(out) == local
    assert [c["rays"] for c in sl.Pvs.load(out).metadata["cells"]] == [
        c["rays"] for c in local.metadata["cells"]
    ]
    assert not checkpoint.exists()


def test_ray_checkpoint_is_the_cli_checkpoint(cluster, tmp_path, cli, city, city_cells, local):
    out, checkpoint, finished = interrupted_bake(tmp_path, city, city_cells)
    cmd = [cli, "pvs", "bake", city.source, "--grid", "3,2,1", "--method", "gvs++", "--json"]
    cmd += ["--n-rand", "5000", "--rays", "30000", "--seed", "4", "-o", str(out)]
    summary = json.loads(subprocess.run(cmd, check=True, capture_output=True).stdout)
    assert summary["resumed_cells"] == len(finished)
    assert sl.Pvs.load(out) == local and not checkpoint.exists()


def test_ray_bake_refuses_the_checkpoint_of_another_bake(cluster, tmp_path, city, city_cells):
    out, checkpoint, _ = interrupted_bake(tmp_path, city, city_cells)
    with pytest.raises(ValueError, match="different bake.*seed.*restart=True"):
        slray.bake(city, city_cells, METHOD, rays=30_000, seed=5, output=out, progress=False)
    assert checkpoint.exists()
    pvs = slray.bake(city, city_cells, METHOD, rays=30_000, seed=5, output=out, restart=True,
                     progress=False)
    assert pvs.metadata["distributed"]["resumed_cells"] == 0


def test_ray_bake_takes_path_like_scenes_and_outputs(cluster, tmp_path):
    teapot = Path(__file__).resolve().parents[3] / "scenes" / "teapot.obj"
    scene = sl.load(teapot)
    lo, hi = scene.bounds
    cells = sl.grid(lo, hi, (2, 1, 1))
    out = tmp_path / "teapot.pvs"
    pvs = slray.bake(teapot, cells, "rand", rays=2_000, output=out, progress=False)
    assert sl.Pvs.load(out) == pvs == sl.bake(scene, cells, "rand", rays=2_000)


def test_ray_threads_above_every_node_are_capped_with_a_warning(cluster, city, city_cells, local):
    # The cluster's one node has 2 CPUs: a task asking for 3 could never be scheduled.
    with pytest.warns(RuntimeWarning, match="3 threads per task requested, using 2"):
        pvs = slray.bake(city, city_cells, METHOD, rays=30_000, seed=4, threads=3,
                         progress=False)
    assert pvs == local and pvs.metadata["distributed"]["threads_per_task"] == 2
