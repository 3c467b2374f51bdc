"""Long local bakes from Python: Ctrl-C, progress reports, thread caps, path-like arguments."""

import os
import pty
import signal
import subprocess
import sys
import time
import warnings
from pathlib import Path

import pytest

import sightline as sl

from conftest import CITY, REPO

# A bake that takes many seconds (thousands of cells), for interrupting it.
# The child restores Python's own Ctrl-C handler: started from a background job (a CI
# runner's `cmd &`), it would inherit an ignored SIGINT, which a user's interpreter does not have.
LONG_BAKE = f"""
import signal, sys, sightline as sl
signal.signal(signal.SIGINT, signal.default_int_handler)
scene = sl.load({CITY!r})
lo, hi = scene.bounds
cells = sl.grid(lo, hi, (40, 40, 2))
print("baking", flush=True)
sl.{{call}}(scene, cells, "rand", rays=200_000, threads=1, progress=False)
print("finished", flush=True)
"""


@pytest.mark.parametrize("call", ["bake", "bake_cells"])
def test_ctrl_c_stops_a_long_bake_with_keyboard_interrupt(call):
    child = subprocess.Popen(
        [sys.executable, "-c", LONG_BAKE.format(call=call)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        assert child.stdout.readline().strip() == "baking"
        time.sleep(0.5)  # well into the bake (3200 cells of 200k rays: tens of seconds)
        sent = time.monotonic()
        child.send_signal(signal.SIGINT)
        out, err = child.communicate(timeout=10)
        waited = time.monotonic() - sent
    finally:
        child.kill()
    assert "KeyboardInterrupt" in err, err
    assert child.returncode != 0 and "finished" not in out
    assert waited < 2.0, f"the bake took {waited:.1f} s to stop"


def test_progress_callback_sees_every_cell_and_the_rays(city, city_cells):
    calls = []
    pvs = sl.bake(city, city_cells, "rand", rays=20_000, progress=lambda *a: calls.append(a))
    assert calls, "no progress reported"
    assert calls[-1] == (len(city_cells), len(city_cells), pvs.metadata["total_rays"])
    assert all(total == len(city_cells) for _, total, _ in calls)
    assert [c[0] for c in calls] == sorted(c[0] for c in calls)
    assert [c[2] for c in calls] == sorted(c[2] for c in calls)

    calls.clear()
    sets = sl.bake_cells(city, city_cells[:2], "rand", rays=5_000, progress=lambda *a: calls.append(a))
    assert len(sets) == 2 and calls[-1] == (2, 2, 10_000)


def test_an_exception_from_the_progress_callback_stops_the_bake(city, city_cells):
    def fail(done, total, rays):
        raise RuntimeError("stop here")

    with pytest.raises(RuntimeError, match="stop here"):
        sl.bake(city, city_cells, "rand", rays=1_000, progress=fail)
    with pytest.raises(TypeError, match="progress must be"):
        sl.bake(city, city_cells, "rand", rays=1_000, progress=3)


SHORT_BAKE = f"""
import sightline as sl
scene = sl.load({CITY!r})
lo, hi = scene.bounds
sl.bake(scene, sl.grid(lo, hi, (3, 2, 1)), "rand", rays=20_000{{extra}})
"""


def run_with_stderr_on_a_terminal(code):
    """Runs `code` with stderr on a pseudo-terminal; what it wrote there."""
    leader, follower = pty.openpty()
    try:
        subprocess.run([sys.executable, "-c", code], stderr=follower, check=True, timeout=60)
    finally:
        os.close(follower)
    chunks = []
    try:
        while True:
            chunk = os.read(leader, 4096)
            if not chunk:
                break
            chunks.append(chunk)
    except OSError:  # EIO: the terminal's other side is closed and everything was read
        pass
    os.close(leader)
    return b"".join(chunks).decode()


def test_default_progress_is_shown_on_a_terminal_only():
    shown = run_with_stderr_on_a_terminal(SHORT_BAKE.format(extra=""))
    assert "sightline: cells 6/6" in shown, repr(shown)
    assert run_with_stderr_on_a_terminal(SHORT_BAKE.format(extra=", progress=False")) == ""
    piped = subprocess.run(
        [sys.executable, "-c", SHORT_BAKE.format(extra="")],
        capture_output=True,
        text=True,
        check=True,
        timeout=60,
    )
    assert piped.stderr == ""


def test_huge_thread_counts_are_capped_with_a_warning(city, city_cells):
    cells = city_cells[:2]
    expected = sl.bake(city, cells, "rand", rays=5_000, threads=1)
    with pytest.warns(RuntimeWarning, match="1000 threads requested, using"):
        assert sl.bake(city, cells, "rand", rays=5_000, threads=1000) == expected
    with pytest.warns(RuntimeWarning, match="1000 threads requested"):
        sets = sl.bake_cells(city, cells, "rand", rays=5_000, threads=1000)
    assert [list(s) for s in sets] == [list(s) for s in expected.sets()]
    with pytest.warns(RuntimeWarning, match="1000 threads requested"):
        ids = sl.bake_cell(city, cells[0], "rand", rays=5_000, threads=1000)
    assert list(ids) == list(expected.visible(0))
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a sane count warns about nothing
        sl.bake(city, cells, "rand", rays=5_000, threads=2)
    with pytest.raises(ValueError, match="threads must be >= 1"):
        sl.bake(city, cells, "rand", rays=5_000, threads=0)


def test_paths_may_be_str_or_path_like(tmp_path, city, city_cells):
    teapot = REPO / "scenes" / "teapot.obj"
    by_str = sl.load(str(teapot))
    for scene in (sl.load(teapot), sl.Scene.load(teapot)):
        assert scene.geometry_hash == by_str.geometry_hash
    # A path-like is always a file, never a procedural spec.
    with pytest.raises(OSError, match="procedural:city.obj"):
        sl.load(Path("procedural:city.obj"))
    with pytest.raises(ValueError):
        sl.load("procedural:city.obj")
    pvs = sl.bake(city, city_cells[:2], "rand", rays=1_000)
    out = tmp_path / "a.pvs"
    pvs.save(out)
    assert sl.Pvs.load(out) == pvs
