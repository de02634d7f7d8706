"""Stability atlases on Dask (issue 14): the sampled wall's boundary against its closed form,
identical stores whatever the number of workers, resuming an interrupted sweep, and bad
SPECs refused in one line."""

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import haptex as hx
from haptex.atlas import SweepSpec, sweep

from .conftest import GROOVES, needs_data

M, T = 0.1, 1e-4


def wall_spec(axes, duration="5 s", block=None):
    spec = {"duration": duration, "algorithm": {"letter": "W"},
            "device": {"preset": "point-mass", "mass": "0.1 kg", "damping": "0.5 N*s/m", "period": "100 us"},
            "operator": {"kind": "push", "force": "1 N"}, "axes": axes}
    if block is not None:
        spec["block"] = block
    return spec


def test_the_wall_atlas_finds_the_closed_form_boundary_within_one_grid_step():
    # W on a point mass pushed by 1 N: the loop is unstable above the stiffness that puts a
    # pole of the ZOH-discretised spring-mass-damper on the unit circle
    # (haptex.critical_stiffness, tested point-wise against simulation in test_simulate);
    # the atlas's boundary is where the motion first grows along the stiffness axis
    ds = sweep(wall_spec({"stiffness": "0.5-20 kN/m, 30 log steps", "damping": [f"{b} N*s/m" for b in (0.2, 0.5, 1.0)],
                          "delay": [0, 1]}), workers=1)  # (in this process: two processes cost 3 s
    # to start; test_one_or_two_workers_write_identical_stores... compares them, in the long set)
    assert list(ds.sizes) == ["stiffness", "damping", "delay"] and ds.stiffness.attrs["units"] == "N/m"
    _unstable_set_is_the_closed_form_one(ds)
    assert np.all(np.abs(ds.energy_balance_error.values) < 1e-9)  # the exact ZOH energy accounting
    # the limit `haptex atlas plot` draws is the same closed form, row by row
    from haptex.atlas import analytic_boundary

    for d in (0, 1):
        drawn = analytic_boundary(ds, "stiffness", "damping", {"delay": d})
        assert drawn == pytest.approx([hx.critical_stiffness(M, float(b), T, d) for b in ds.damping.values], rel=1e-12)


def _unstable_set_is_the_closed_form_one(ds):
    """On every column (device damping, delay) of a wall atlas, the runs whose regime is
    unstable (limit cycle, growing, diverged) are those above the critical stiffness (the
    closed-loop poles of the sampled wall, haptex.critical_stiffness), to one grid step: every
    run two steps or more below decays, every run two steps or more above does not."""
    k = ds.stiffness.values
    for b in ds.damping.values:
        for d in ds.delay.values:
            unstable = ds.unstable.sel(damping=b, delay=d).values
            kc = hx.critical_stiffness(M, float(b), T, int(d))
            expected = int(np.searchsorted(k, kc))  # the first grid stiffness above kappa_c
            assert not unstable[:max(expected - 1, 0)].any(), (b, d, kc)
            assert unstable[expected + 1:].all(), (b, d, kc, k[expected + 1:][~unstable[expected + 1:]])


def test_the_shipped_wall_atlas_finds_the_closed_form_boundary_on_every_column():
    """Issue 31: on the shipped wall atlas (examples/sweeps/wall.toml: 60 stiffnesses x 10
    dampings x delay 0, 1; W on a 0.1 kg point mass at 10 kHz), `growing` flipped with the last
    digits of a bounded cycle's decay ratio (delay 1, b = 1 N s/m: 12.1 kN/m growing, 12.9 not,
    13.7 growing, far above the limit of 6.7 kN/m) and missed the limit by more than a grid step
    on 4 of the 20 columns; the regime's unstable set matches it on all 20."""
    from haptex.atlas import SweepSpec

    ds = sweep(SweepSpec.from_file(Path(__file__).resolve().parents[1] / "examples" / "sweeps" / "wall.toml"),
               workers=1)
    _unstable_set_is_the_closed_form_one(ds)
    from haptex.simulate import REGIMES

    regimes = {REGIMES[i] for i in np.unique(ds.regime.values)}
    assert regimes == {"decaying", "limit cycle", "growing"}  # nothing diverges: the wall is one-sided


def test_small_blocks_are_gathered_into_tasks_and_give_the_same_atlas(tmp_path):
    # a Dask task costs ~1.7 ms here whatever it does (benchmarks/README.md): consecutive small
    # blocks share a task of about TASK_SAMPLES samples, keeping >= 4 tasks a worker thread
    from haptex.atlas import TASK_SAMPLES, _tasks

    todo = list(range(40))
    blocks = lambda tasks: [[i for i, _, _ in t] for t in tasks]  # noqa: E731
    assert blocks(_tasks(todo, 100_000, 1)) == [todo[i:i + 10] for i in range(0, 40, 10)]  # capped by 4 a thread
    assert blocks(_tasks(todo, 100_000, 2)) == [todo[i:i + 5] for i in range(0, 40, 5)]
    assert blocks(_tasks(list(range(400)), 100_000, 1))[0] == list(range(TASK_SAMPLES // 100_000))  # 20 a task
    assert _tasks(todo, TASK_SAMPLES, 1) == [[(i, 0, 1)] for i in todo]  # large blocks: one a task, whole
    # the same runs in blocks of 1 (24 blocks, gathered 6 to a task) and of 5: the same atlas
    axes = {"stiffness": "1-30 kN/m, 12 log steps", "delay": [0, 1]}
    fine = sweep(wall_spec(axes, duration="0.3 s", block=1), tmp_path / "fine.zarr", workers=1)
    coarse = sweep(wall_spec(axes, duration="0.3 s", block=5), tmp_path / "coarse.zarr", workers=1)
    assert fine.attrs["blocks_computed"] == 24 and bool(fine["done"].all())
    for name in coarse.data_vars:
        assert np.array_equal(fine[name].values, coarse[name].values, equal_nan=fine[name].dtype.kind == "f"), name


def test_fewer_blocks_than_workers_are_cut_into_parts_and_give_the_same_atlas(tmp_path, monkeypatch):
    """Issue 30: a sweep has enough tasks for its workers whatever the block size. The shipped
    wall atlas's 3 blocks (400 runs of 5 s each) give 64 workers 258 tasks (4 a worker), parts
    of at least PART_SAMPLES samples; and an atlas of one block computed in 8 parts equals the
    same atlas computed whole, bit for bit (each run's physics is its own)."""
    from haptex import atlas

    tasks = atlas._tasks([0, 1, 2], 400 * 50_000, 64, 400)
    assert len(tasks) == 258 and all(len(t) == 1 for t in tasks)
    assert sorted(i for t in tasks for i, _, _ in t) == [0] * 86 + [1] * 86 + [2] * 86
    assert atlas._tasks([0], 10 * 1000, 64, 10) == [[(0, 0, 1)]]  # 10^4 samples: no part below PART_SAMPLES
    spec = wall_spec({"stiffness": "1-30 kN/m, 12 log steps", "delay": [0, 1]}, duration="10 s", block=24)
    made = []
    real = atlas._tasks
    monkeypatch.setattr(atlas, "_tasks", lambda *a: made.append(real(*a)) or made[-1])
    cut = sweep(spec, tmp_path / "cut.zarr", workers=1)
    assert max(n for t in made[-1] for _, _, n in t) >= 4  # the one block was cut (4 tasks a worker thread)
    monkeypatch.setattr(atlas, "PART_SAMPLES", 10**12)  # parts of at least 10^12 samples: the block whole
    whole = sweep(spec, tmp_path / "whole.zarr", workers=1)
    assert made[-1] == [[(0, 0, 1)]]
    assert cut.attrs["blocks_computed"] == whole.attrs["blocks_computed"] == 1
    for name in whole.data_vars:
        assert np.array_equal(cut[name].values, whole[name].values, equal_nan=cut[name].dtype.kind == "f"), name


@pytest.mark.long  # Dask clusters started and killed: 6-14 s (issue 68)
def test_one_or_two_workers_write_identical_stores_and_a_resumed_sweep_completes(tmp_path):
    spec = wall_spec({"stiffness": "1-30 kN/m, 12 log steps", "delay": [0, 1]}, duration="0.3 s", block=5)
    one = sweep(spec, tmp_path / "one.zarr", workers=1)
    two = sweep(spec, tmp_path / "two.zarr", workers=2)
    assert one.attrs["blocks_computed"] == len(SweepSpec.from_mapping(spec).blocks()) == 6
    for name in one.data_vars:
        assert np.array_equal(one[name].values, two[name].values, equal_nan=one[name].dtype.kind == "f"), name

    class Interrupted(Exception):
        pass

    def stop_after_two(n):
        if n == 2:
            raise Interrupted  # the client dies after writing two blocks

    with pytest.raises(Interrupted):
        sweep(spec, tmp_path / "resumed.zarr", workers=2, on_block=stop_after_two)
    resumed = sweep(spec, tmp_path / "resumed.zarr", workers=2)
    assert resumed.attrs["blocks_skipped"] == 2 and resumed.attrs["blocks_computed"] == 4
    for name in one.data_vars:
        assert np.array_equal(one[name].values, resumed[name].values, equal_nan=one[name].dtype.kind == "f"), name
    # a store written by another SPEC is refused
    other = wall_spec({"stiffness": "1-30 kN/m, 13 log steps", "delay": [0, 1]}, duration="0.3 s", block=5)
    with pytest.raises(hx.ParameterError, match=r"one.zarr' is not allowed: it was written by another SPEC"):
        sweep(other, tmp_path / "one.zarr", workers=1)


@pytest.mark.parametrize("axes, pattern", [
    ({"stiffness": []}, r"^axes.stiffness = \[\] is not allowed: must be at least one value"),
    ({"stifness": "1-2 kN/m, 3 steps"}, r"^axes.stifness is not allowed: a swept parameter must be algorithm or one of"),
    ({"stiffness": "1-2 kg, 3 steps"}, r"^axes.stiffness = '1 kg' is not allowed"),
    ({"stiffness": "1-2, 3 steps"}, r"^axes.stiffness = '1-2, 3 steps' is not allowed: must be a range with its unit"),
    ({"stiffness": ["1 kN/m", 2000]}, r"^axes.stiffness = 2000 is not allowed: must be a quantity with its unit"),
    ({"delay": [0, 1.5]}, r"^axes.delay = 1.5 is not allowed"),
])
def test_bad_axes_are_refused_naming_them(axes, pattern):
    with pytest.raises(hx.ParameterError, match=pattern):
        SweepSpec.from_mapping(wall_spec(axes))


def test_a_spec_must_give_or_sweep_the_stiffness_and_its_start_must_fit_the_device():
    with pytest.raises(hx.ParameterError, match=r"^algorithm.stiffness is missing: give it \(e.g. '2 kN/m'\) or sweep"):
        SweepSpec.from_mapping(wall_spec({"delay": [0, 1]}))
    spec = wall_spec({"delay": [0, 1]})
    spec["algorithm"]["stiffness"] = "2 kN/m"
    spec["initial_position"] = ["0 mm", "0 mm", "1 mm"]  # three coordinates for a planar device
    with pytest.raises(hx.ParameterError, match=r"^initial_position = .* is not allowed: must be a list of 2 lengths"):
        SweepSpec.from_mapping(spec)


@pytest.mark.long  # (.ci/run's long set: waits out a real connection timeout in a new interpreter)
def test_the_cli_refuses_an_unreachable_scheduler_within_seconds(tmp_path):
    f = tmp_path / "s.toml"
    f.write_text('duration = "0.1 s"\n[algorithm]\nletter = "W"\n[device]\npreset = "point-mass"\n'
                 '[operator]\nkind = "push"\nforce = "1 N"\n[axes]\nstiffness = "1-2 kN/m, 2 steps"\n')
    r = subprocess.run([sys.executable, "-m", "haptex", "sweep", str(f), "--out", str(tmp_path / "a.zarr"),
                        "--scheduler", "tcp://127.0.0.1:9"], capture_output=True, text=True, timeout=60)
    assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1
    assert "no Dask scheduler answered there within" in r.stderr


@pytest.mark.long  # (.ci/run's long set: waits out a real scheduler's timeout)
def test_a_scheduler_that_accepts_and_never_answers_is_given_up_in_seconds(tmp_path, monkeypatch):
    """Issue 33: a peer that accepts the TCP connection and stays silent held Dask's client
    past 5 minutes (its connect timeout does not cover the handshake). The timeout is set to
    2 s here (10 s in haptex) so the test does not idle a worker for 10 s."""
    import socket
    import threading
    import time

    from haptex import atlas
    from haptex.atlas import _remote

    monkeypatch.setattr(atlas, "SCHEDULER_TIMEOUT", 2.0)
    SCHEDULER_TIMEOUT = atlas.SCHEDULER_TIMEOUT

    srv = socket.socket()
    srv.bind(("127.0.0.1", 0))
    srv.listen(8)
    held = []
    threading.Thread(target=lambda: [held.append(srv.accept()) for _ in range(8)], daemon=True).start()
    t = time.monotonic()
    with pytest.raises(hx.ParameterError, match=r"it accepted the connection but sent no handshake"):
        _remote(f"tcp://127.0.0.1:{srv.getsockname()[1]}")
    assert 0.9 * SCHEDULER_TIMEOUT <= time.monotonic() - t < SCHEDULER_TIMEOUT + 5
    srv.close()


@pytest.mark.parametrize("address", ["ucx://127.0.0.1:8786", "tls://127.0.0.1:8786", "inproc://x", "127.0.0.1:8786",
                                     "tcp://host:99999999", "tcp://a b:1"])
def test_scheduler_addresses_other_than_tcp_are_one_line(address):
    """Issue 33: ``ucx://`` and ``tls://`` ended in tracebacks (no UCX build, no certificates)."""
    from haptex.atlas import _remote

    with pytest.raises(hx.ParameterError, match=r"^scheduler = .* is not allowed: must be a Dask scheduler's address "
                                                r"tcp://HOST:PORT$"):
        _remote(address)


@pytest.mark.parametrize("axes, pattern", [
    # an axis of 10^12 steps allocated 7 TiB in np.geomspace before the run count was checked
    ({"stiffness": "1-2 kN/m, 1000000000000 log steps"}, r"^axes = '1000000000000' is not allowed: must be at most"),
    # exactly MAX_RUNS runs passed and exhausted memory: the atlas's size is counted first
    ({"stiffness": "1-2 kN/m, 100000 steps", "damping": "0.1-1 N*s/m, 10000 steps"},
     r"^axes = '100000 x 10000' is not allowed: the atlas's 1e\+09 runs .* over the memory budget"),
    ({"stiffness": "1-2 kN/m, 90000000 steps"}, r"^axes = '90000000' is not allowed: .* over the memory budget"),
])
def test_a_spec_is_sized_before_any_axis_is_expanded(axes, pattern):
    import tracemalloc

    tracemalloc.start()
    with pytest.raises(hx.ParameterError, match=pattern):
        SweepSpec.from_mapping(wall_spec(axes))
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert peak < 50e6  # nothing the size of an axis was allocated


def test_too_many_blocks_are_refused_naming_the_block():
    spec = wall_spec({"stiffness": "1-2 kN/m, 3000 steps", "damping": "0.1-1 N*s/m, 1000 steps"}, block=1)
    with pytest.raises(hx.ParameterError, match=r"^block = 1 is not allowed: must be a block size that cuts the 3e\+06 "
                                                r"runs into at most 1e\+06 blocks"):
        SweepSpec.from_mapping(spec)


@pytest.mark.parametrize("axes, pattern", [
    ({"stiffness": "-2-2 kN/m, 3 steps"}, r"^axes.stiffness = -2000 is not allowed: must be a finite number > 0"),
    ({"stiffness": ["1 kN/m"], "mass": ["0.1 kg", "0 kg"]}, r"^axes.mass = .* is not allowed: must be positive definite"),
    ({"stiffness": ["1 kN/m"], "damping": ["-1 N*s/m"]}, r"^axes.damping = .* is not allowed: must be positive semi-definite"),
])
def test_swept_values_are_range_checked_when_the_spec_is_read(axes, pattern):
    """Issue 33: such values were checked first inside a Dask task, after a worker's traceback."""
    with pytest.raises(hx.ParameterError, match=pattern):
        SweepSpec.from_mapping(wall_spec(axes))


def test_local_workers_are_capped_by_memory(monkeypatch):
    from haptex.atlas import WORKER_BYTES, _client

    monkeypatch.setenv("HAPTEX_MEMORY_BUDGET", str(4 * WORKER_BYTES))
    with pytest.raises(hx.ParameterError, match=r"^workers = 5 is not allowed: 5 local worker processes .* over the "
                                                r"memory budget"):
        _client(None, 5)


def test_one_writer_per_store_a_second_is_refused_in_one_line(tmp_path):
    """Issue 33: two sweeps of different SPECs into one new store, 0.2 s apart, both exited 0
    and left the store labelled with one SPEC and holding the other's data."""
    from haptex.atlas import _lock

    store = tmp_path / "a.zarr"
    held = _lock(store)
    try:
        spec = wall_spec({"stiffness": "1-2 kN/m, 2 steps"}, duration="0.05 s")
        with pytest.raises(hx.ParameterError, match=r"^out = .*a.zarr' is not allowed: another haptex sweep is writing it"):
            sweep(spec, store, workers=1)
        assert not store.exists()  # nothing was written under another writer's lock
    finally:
        held.release()
    ds = sweep(wall_spec({"stiffness": "1-2 kN/m, 2 steps"}, duration="0.05 s"), store, workers=1)
    assert bool(ds["done"].all())


@pytest.mark.long  # Dask clusters started and killed: 6-14 s (issue 68)
def test_two_concurrent_sweeps_of_different_specs_never_leave_a_mislabelled_store(tmp_path):
    """Two processes started together into one new store: exactly one writes it, the other
    exits 2 in one line; the store's label is the SPEC whose data it holds."""
    import json

    from haptex.atlas import open_atlas

    files = []
    for i, k in enumerate(("1-2 kN/m, 3 steps", "5-9 kN/m, 3 steps")):
        f = tmp_path / f"s{i}.toml"
        f.write_text('duration = "0.2 s"\n[algorithm]\nletter = "W"\n[device]\npreset = "point-mass"\n'
                     f'[operator]\nkind = "push"\nforce = "1 N"\n[axes]\nstiffness = "{k}"\n')
        files.append(f)
    store = tmp_path / "a.zarr"
    procs = [subprocess.Popen([sys.executable, "-m", "haptex", "sweep", str(f), "--out", str(store), "--workers", "1",
                               "--quiet"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True) for f in files]
    outs = [p.communicate(timeout=120) for p in procs]
    codes = sorted(p.returncode for p in procs)
    assert codes == [0, 2] or codes == [0, 0], (codes, [o[1][-300:] for o in outs])
    for p, (_, err) in zip(procs, outs):
        if p.returncode == 2:
            assert len(err.strip().splitlines()) == 1 and "another haptex sweep is writing it" in err
    ds = open_atlas(store)
    stored = json.loads(ds.attrs["haptex_spec"])
    k = dict(stored["axes"])["stiffness"]
    lo = 1000.0 if k.startswith("1-2") else 5000.0
    assert ds["stiffness"].values[0] == pytest.approx(lo) and bool(ds["done"].all())


@pytest.mark.parametrize("damage", ["label", "chunk"])
def test_a_corrupt_store_is_one_line(tmp_path, damage):
    from haptex.atlas import open_atlas

    store = tmp_path / "a.zarr"
    spec = wall_spec({"stiffness": "1-2 kN/m, 2 steps"}, duration="0.05 s")
    sweep(spec, store, workers=1)
    if damage == "label":
        import zarr

        g = zarr.open_group(str(store), mode="r+")
        g.attrs["haptex_spec"] = "{not json"
        pattern = r"not written by haptex sweep \(its 'haptex_spec' label is not a SPEC\)"
    else:
        chunks = [p for p in (store / "done").rglob("*") if p.is_file() and p.name != "zarr.json"]
        assert chunks
        for p in chunks:
            p.write_bytes(b"\x00garbage" * 3)
        pattern = r"(cannot be read|not a Zarr store)"
    with pytest.raises(hx.ParameterError, match=pattern):
        open_atlas(store)
    with pytest.raises(hx.ParameterError, match=pattern if damage == "chunk" else "written by another SPEC"):
        sweep(spec, store, workers=1)


@pytest.mark.long  # 7 s: two CLI runs in new interpreters (was -m slow, run by nothing)
def test_atlas_plot_at_the_command_line_needs_every_other_dimension_fixed(tmp_path):
    spec = wall_spec({"stiffness": "1-30 kN/m, 6 log steps", "damping": ["0.5 N*s/m", "1 N*s/m"], "delay": [0, 1]},
                     duration="0.2 s")
    sweep(spec, tmp_path / "a.zarr", workers=1)
    cmd = [sys.executable, "-m", "haptex", "atlas", "plot", str(tmp_path / "a.zarr"), "--x", "stiffness", "--y", "damping"]
    r = subprocess.run(cmd + ["--out", str(tmp_path / "a.png")], capture_output=True, text=True, timeout=120)
    assert r.returncode == 2 and "'delay' is left free: fix it with --select delay=VALUE (values: 0, 1)" in r.stderr
    r = subprocess.run(cmd + ["--select", "delay=1", "--out", str(tmp_path / "a.png")], capture_output=True, text=True,
                       timeout=120)
    assert r.returncode == 0, r.stderr
    from PIL import Image

    with Image.open(tmp_path / "a.png") as im:  # two panels side by side
        assert im.width > 2 * im.height


@pytest.mark.long  # Dask clusters started and killed: 6-14 s (issue 68)
def test_a_real_deployment_loses_nothing_when_a_worker_is_killed(tmp_path):
    # a `dask scheduler` and two `dask worker` processes on 127.0.0.1, as on a cluster; one
    # worker is killed (SIGKILL, no nanny to restart it) once the first block is written,
    # while the others are running or queued: Dask reruns its tasks on the survivor and the
    # store is bit for bit the single-process one (runs are deterministic)
    import json as _json
    import os
    import signal
    import time

    spec = wall_spec({"stiffness": "1-30 kN/m, 24 log steps", "delay": [0, 1]}, duration="20 s", block=4)
    reference = sweep(spec, tmp_path / "ref.zarr", workers=1)
    sched_file = tmp_path / "scheduler.json"
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    procs = [subprocess.Popen([sys.executable, "-m", "dask", "scheduler", "--scheduler-file", str(sched_file), "--host",
                               "127.0.0.1", "--port", "0", "--dashboard-address", "127.0.0.1:0"],
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env)]
    try:
        for _ in range(300):
            if sched_file.exists() and sched_file.stat().st_size:
                break
            time.sleep(0.1)
        address = _json.loads(sched_file.read_text())["address"]
        for _ in range(2):
            procs.append(subprocess.Popen([sys.executable, "-m", "dask", "worker", address, "--nthreads", "1",
                                           "--host", "127.0.0.1", "--no-nanny", "--no-dashboard"], stdout=subprocess.DEVNULL,
                                          stderr=subprocess.DEVNULL, env=env))
        from dask.distributed import Client

        with Client(address, timeout="30s") as c:
            c.wait_for_workers(2, timeout=60)
        killed, busy = [], []

        def kill_one(n):
            if n == 1:
                with Client(address, timeout="30s") as c:
                    addr = next(a for a, pid in c.run(os.getpid).items() if pid == procs[2].pid)
                    busy.append(len(c.processing()[addr]))  # its tasks running or queued at the kill
                procs[2].send_signal(signal.SIGKILL)
                killed.append(procs[2].wait(timeout=30))

        ds = sweep(spec, tmp_path / "cluster.zarr", scheduler=address, on_block=kill_one)
        assert killed == [-signal.SIGKILL] and busy[0] >= 1
        assert ds.attrs["blocks_computed"] == 12 and bool(ds["done"].all())
        for name in reference.data_vars:
            assert np.array_equal(reference[name].values, ds[name].values,
                                  equal_nan=reference[name].dtype.kind == "f"), name
    finally:
        for p in procs:
            if p.poll() is None:
                p.kill()
                p.wait(timeout=30)


def test_a_yaml_spec_is_the_same_spec_as_its_toml(tmp_path):
    # the example SPEC written in YAML: the same axes (values in SI) and the same identity,
    # so either file resumes the other's store (yaml is a dependency of SurfaceTopography and ours)
    from pathlib import Path

    toml = SweepSpec.from_file(Path(__file__).resolve().parents[1] / "examples" / "sweeps" / "wall.toml")
    import yaml

    f = tmp_path / "wall.yaml"
    f.write_text(yaml.safe_dump(toml.mapping, sort_keys=False))
    y = SweepSpec.from_file(f)
    assert y.canonical == toml.canonical and y.shape == (60, 10, 2)
    # the axes' order is the dimensions' order: the same axes in another order are another SPEC
    f.write_text(yaml.safe_dump(toml.mapping, sort_keys=True))
    assert SweepSpec.from_file(f).canonical != toml.canonical
    # 60 log steps from 0.5 to 20 kN/m: a ratio of 40^(1/59) between neighbours
    k = y.axes[0].values
    assert k[0] == pytest.approx(500.0) and k[-1] == pytest.approx(20_000.0)
    assert np.allclose(k[1:] / k[:-1], 40 ** (1 / 59), rtol=1e-12)


def test_a_3d_atlas_of_the_wall_is_the_planar_one():
    # an isotropic point mass pushed along the normal of W moves along z only: the 3-DOF
    # atlas (x, y, z) has the planar atlas's verdicts and energies, and no energy along x or y
    axes = {"stiffness": "1-30 kN/m, 10 log steps", "delay": [0, 1]}
    planar = sweep(wall_spec(axes, duration="1 s"), workers=1)
    spec = wall_spec(axes, duration="1 s")
    spec["device"] = dict(spec["device"], dimension=3)
    space = sweep(spec, workers=1)
    assert "energy_rate_y" in space and "energy_rate_y" not in planar
    assert np.array_equal(space.growing.values, planar.growing.values) and space.growing.values.any()
    np.testing.assert_allclose(space.energy_rate_z.values, planar.energy_rate_z.values, rtol=1e-12, atol=0)
    assert not space.energy_rate_x.values.any() and not space.energy_rate_y.values.any()


_SPEC_VALUES = st.recursive(
    st.one_of(st.none(), st.booleans(), st.integers(-10**20, 10**20), st.floats(allow_nan=True, allow_infinity=True),
              st.sampled_from(["1 kN/m", "0.1 kg", "100 us", "5 s", "push", "band", "hand", "W", "A", "D",
                               "sine:0.8mm,1mm", "egg-crate:0.1mm,2mm", "1-2 kN/m, 3 steps", "0.5-20 kN/m, 60 log steps",
                               "1e308 m", "-1 N", "9**9**9 N/m", "1-2 kN/m, 99999999999999 steps", "point-mass",
                               "pantograph", "", "nan", "1e-320 s"]),
              st.text(max_size=20)),
    lambda inner: st.one_of(st.lists(inner, max_size=4), st.dictionaries(st.text(max_size=8), inner, max_size=4)),
    max_leaves=12)


@st.composite
def _specs(draw):
    base = wall_spec({"stiffness": "1-2 kN/m, 2 steps"}, duration="0.1 s")
    for key in draw(st.lists(st.sampled_from(["duration", "block", "algorithm", "device", "operator", "axes",
                                              "initial_position", "extra"]), max_size=3, unique=True)):
        base[key] = draw(_SPEC_VALUES)
    if draw(st.booleans()):
        name = draw(st.sampled_from(["stiffness", "mass", "damping", "delay", "amplitude", "algorithm", "bogus"]))
        base["axes"] = {name: draw(_SPEC_VALUES)}
    return base


@settings(max_examples=60, deadline=None)
@given(_specs())
def test_any_spec_is_a_spec_or_one_parameter_error(spec):
    """Issue 33's SPEC fuzz: whatever a TOML or YAML file can hold, read as a SPEC, is a
    valid SweepSpec or a ParameterError (one line naming the key); never another exception,
    never an axis expanded past the run and memory checks."""
    try:
        parsed = SweepSpec.from_mapping(spec)
    except hx.ParameterError as exc:
        assert "\n" not in str(exc)
        return
    assert parsed.runs <= 10**9 and all(np.all(np.isfinite(a.values)) for a in parsed.axes if a.name != "algorithm")


def test_a_spec_can_name_a_product_preset_and_a_hand_model():
    # issue 31, the hand in the atlas: operator kind 'grip' names a hand of haptex.catalogue,
    # whose mass moves with the handle and whose spring and damper press it; the device table
    # names a product preset. A run of the sweep is the same run in Python.
    from haptex import catalogue

    spec = {"duration": "0.3 s", "algorithm": {"letter": "W"}, "device": {"preset": "falcon"},
            "operator": {"kind": "grip", "hand": "light-touch", "depth": "2 mm", "velocity": "0 m/s"},
            "axes": {"stiffness": ["1 kN/m", "3 kN/m", "6 kN/m"]}}
    parsed = SweepSpec.from_mapping(spec)
    alg, dev, op, _ = parsed.build()
    falcon = catalogue.preset("falcon").device()
    assert dev.mass[2, 2] == pytest.approx(falcon.mass[2, 2] + 0.03)
    ds = sweep(spec, workers=1)
    h = catalogue.hand("light-touch")
    for i, k in enumerate((1000.0, 3000.0, 6000.0)):
        r = hx.simulate(hx.algorithm("W", hx.Flat(dimension=2), k), h.attach(falcon), h.operator(depth=2e-3, dimension=3),
                        0.3)
        assert float(ds.deepest_penetration.values[i]) == pytest.approx(r.max_penetration, rel=1e-9)
        # (the atlas stores the energy the environment supplies per second, -E_z / duration)
        assert -float(ds.energy_rate_z.values[i]) * 0.3 == pytest.approx(r.totals["energy_z"], rel=1e-6, abs=1e-12)
    bad = dict(spec, operator={"kind": "grip", "hand": "none", "depth": "2 mm", "velocity": "0 m/s"})
    with pytest.raises(hx.ParameterError, match="operator.hand"):
        SweepSpec.from_mapping(bad).build()


def test_an_atlas_of_a_texture_on_an_object_is_simulate_batch(tmp_path):
    # issue 32: algorithm.object names the base; the egg-crate on a sphere of 40 periods round on
    # a 3-DOF point mass pushed into it, three stiffnesses: the store holds simulate_batch's
    # verdicts run by run; a planar device and an algorithm parameter beside an object are refused
    from haptex.objects import Sphere, object_algorithm
    from haptex.operators import ConstantForce

    spec = {"duration": "0.05 s",
            "algorithm": {"letter": "B", "texture": "egg-crate:0.2mm,2mm", "object": "sphere:12.7323954mm"},
            "device": {"preset": "point-mass", "dimension": 3, "mass": "0.1 kg", "damping": "0.5 N*s/m",
                       "period": "100 us"},
            "operator": {"kind": "push", "force": "1 N"}, "axes": {"stiffness": [
                "0.5 kN/m", "2 kN/m", "8 kN/m"]}}
    ds = sweep(spec, tmp_path / "ball.zarr", workers=1)
    alg = object_algorithm("B", hx.SumOfGratings.egg_crate(0.2e-3, 2e-3), Sphere(12.7323954e-3), 500.0)
    dev = hx.Device.point_mass(0.1, 0.5, 1e-4, dimension=3)
    ref = hx.simulate_batch(alg, dev, ConstantForce([0.0, 0.0, -1.0]), 0.05, stiffness=[500.0, 2000.0, 8000.0])
    np.testing.assert_allclose(ds.deepest_penetration.values, ref.max_penetration, rtol=1e-12)
    from haptex.simulate import REGIMES

    assert [REGIMES[int(r)] for r in ds.regime.values] == list(ref.regime)
    planar = {**spec, "device": {"preset": "pantograph"}}
    with pytest.raises(hx.ParameterError, match="3-DOF"):
        SweepSpec.from_mapping(planar).build()
    extra = {**spec, "algorithm": {**spec["algorithm"], "max_penetration": "1 mm"}}
    with pytest.raises(hx.ParameterError, match="max_penetration is not allowed with algorithm.object"):
        SweepSpec.from_mapping(extra).build()


@needs_data
def test_a_spec_reads_a_measured_file_with_the_keys_its_refusal_names(tmp_path):
    # A SPEC's algorithm.texture may be a measured file; one that does not state its spacing or
    # height unit (../shared/data's grooves-4mm-profile.mat, as published) is refused naming the
    # [algorithm] keys that give them, not options haptex sweep does not have (before 2026-12-01
    # it named --spacing and --height-unit, and no key could give them); with those keys the
    # SPEC's algorithm is on the file's 8,000 samples of 0.5 um (its README), levelled and
    # band-limited as the keys say; a map with undefined heights is refused naming its crop and
    # fill as keys, and read with the crop it names.
    from .test_cli import unknown_options_named

    spec = {"duration": "0.1 s", "algorithm": {"letter": "A", "texture": str(GROOVES), "stiffness": "1 kN/m"},
            "device": {"preset": "pantograph"},
            "operator": {"kind": "hand", "stiffness": "300 N/m", "damping": "1 N*s/m", "velocity": "10 mm/s",
                         "depth": "0.5 mm"}, "axes": {"stiffness": ["1 kN/m", "2 kN/m"]}}
    with pytest.raises(hx.ParameterError) as refused:
        SweepSpec.from_mapping(spec).build()
    msg = str(refused.value)
    assert "give spacing = '0.5um', height_unit = 'mm' in the SPEC's [algorithm]" in msg, msg
    assert not unknown_options_named(["sweep"], msg)
    spec["algorithm"].update(spacing="0.5 um", height_unit="um", level=True, lowpass="20 um")
    alg = SweepSpec.from_mapping(spec).build()[0]
    want = hx.load_texture(GROOVES, spacing=0.5e-6, height_unit="um").leveled().lowpass(20e-6)
    assert alg.texture.x.size == 8000 and np.array_equal(alg.texture.h, want.h)
    spec["algorithm"]["level"] = "yes"
    with pytest.raises(hx.ParameterError, match=r"algorithm.level = 'yes' is not allowed: must be true or false"):
        SweepSpec.from_mapping(spec).build()
    lost = np.sin(np.linspace(0, 6, 32))[:, None] * np.cos(np.linspace(0, 5, 24))[None, :]
    lost[10:13, 5:9] = np.nan  # (an NPY map, written by numpy, a 3 x 4 patch undefined)
    np.save(tmp_path / "lost.npy", lost)
    spec["algorithm"] = {"letter": "A", "texture": str(tmp_path / "lost.npy"), "stiffness": "1 kN/m",
                         "spacing": "1 um", "height_unit": "um"}
    with pytest.raises(hx.ParameterError) as refused:
        SweepSpec.from_mapping(spec).build()
    msg = str(refused.value)
    assert "(crop = 'auto' in the SPEC's [algorithm], takes 32 x 15 samples: crop = '0,31um,9um,23um')" in msg, msg
    assert "(fill_undefined = true in the SPEC's [algorithm])" in msg and not unknown_options_named(["sweep"], msg)
    spec["algorithm"]["crop"] = "0,31um,9um,23um"
    assert SweepSpec.from_mapping(spec).build()[0].texture.h.shape == (32, 15)
    wall = {**spec, "algorithm": {"letter": "W", "stiffness": "1 kN/m", "spacing": "0.5 um"}}
    with pytest.raises(hx.ParameterError, match=r"algorithm.spacing is not allowed with letter W"):
        SweepSpec.from_mapping(wall).build()


def test_a_spec_whose_object_leaves_a_seam_is_refused_naming_a_radius_in_its_own_key():
    # The egg-crate (2 mm period) on a sphere of 20 mm: 62.83 periods round, a seam; the refusal
    # names the nearest radius that holds 63 (63 x 2 mm / 2 pi = 20.0535228296 mm, the definition)
    # as the SPEC writes it, algorithm.object, not haptex sweep's options (before 2026-12-01
    # "--object sphere:...mm at the command line"), and that radius builds.
    from .test_cli import unknown_options_named

    spec = {"duration": "0.05 s", "algorithm": {"letter": "B", "texture": "egg-crate:0.2mm,2mm", "object": "sphere:20mm"},
            "device": {"preset": "point-mass", "dimension": 3, "mass": "0.1 kg", "damping": "0.5 N*s/m",
                       "period": "100 us"}, "operator": {"kind": "push", "force": "1 N"},
            "axes": {"stiffness": ["0.5 kN/m", "2 kN/m"]}}
    with pytest.raises(hx.ParameterError) as refused:
        SweepSpec.from_mapping(spec).build()
    msg = str(refused.value)
    assert "(object = 'sphere:20.0535228296mm' in the SPEC's [algorithm])" in msg, msg
    assert not unknown_options_named(["sweep"], msg)
    assert f"{63 * 2.0 / (2 * np.pi):.12g}" == "20.0535228296"
    spec["algorithm"]["object"] = "sphere:20.0535228296mm"
    assert SweepSpec.from_mapping(spec).build()[0].base.radius == pytest.approx(20.0535228296e-3, rel=1e-12)
