"""Distributed bakes on a local Ray cluster (2 worker processes): equal to the local bake, and
still equal when a worker dies mid-bake."""

import os
import subprocess

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
