"""Stability atlases on Dask (issue 14), one run on this machine:

1. runs and simulated samples per second of `haptex.sweep` with 1 and 2 local workers, on
   the wall atlas of examples/sweeps/wall.toml (1200 runs x 5 s at T = 100 us: 6e7 samples),
   cluster start-up included and excluded;
2. the overhead per task: 40 blocks through Dask, one a task (submitted together), against
   simulate_batch called directly on the same runs (the issue's baseline) and against the
   task function run in this process, for blocks of 10^5, 10^6 and 10^7 samples (goal
   <= 10 % from 10^5), and one task's round trip; then the same 40 blocks gathered into tasks
   as a sweep sends them (haptex.atlas.TASK_SAMPLES), and a no-op task's cost;
3. the largest sweep run here: the wall atlas at 8 x the stiffness resolution.
"""

from __future__ import annotations

import statistics
import tempfile
import time
from pathlib import Path

import numpy as np

from haptex import simulate_batch
from haptex.atlas import SweepSpec, _run_blocks, _tasks, sweep

WALL = Path(__file__).resolve().parents[1] / "examples" / "sweeps" / "wall.toml"


def timed_sweep(spec, workers: int, out: Path):
    t = time.perf_counter()
    ds = sweep(spec, out, workers=workers)
    return time.perf_counter() - t, ds


def main() -> None:
    spec = SweepSpec.from_file(WALL)
    samples = spec.runs * round(spec.duration / 1e-4)
    with tempfile.TemporaryDirectory() as tmp:
        sweep(spec, Path(tmp) / "warm.zarr", workers=2)  # imports warm
        for w in (1, 2):
            wall, _ = timed_sweep(spec, w, Path(tmp) / f"w{w}.zarr")
            print(f"wall atlas, {w} worker(s): {spec.runs} runs in {wall:.2f} s: {spec.runs / wall:.0f} runs/s, "
                  f"{samples / wall:.3g} samples/s (cluster start-up and store included)")
    # overhead per task: 40 blocks through Dask (submitted together, as a sweep does) against
    # the same 40 blocks run one after the other in this process; and one task's latency
    from haptex.atlas import _client

    client, cluster, _ = _client(None, 1)  # the local cluster a sweep starts, with one worker
    with cluster, client:
        for runs, duration in ((10, "1 s"), (100, "1 s"), (100, "10 s")):
            mapping = dict(spec.mapping, duration=duration,
                           axes={"stiffness": f"0.5-2 kN/m, {40 * runs} log steps"}, block=runs)
            s = SweepSpec.from_mapping(mapping)
            blocks = s.blocks()
            n = runs * round(s.duration / 1e-4)
            whole = [(b, 0, 1) for b in blocks]  # (block, part, parts): each block whole
            _run_blocks(s.mapping, whole[:1], 1)
            client.submit(_run_blocks, s.mapping, whole[:1], 1, pure=False).result()  # warm the worker
            alg, device, op, p0 = s.build()
            values = [s.axes[0].values[b[0]] for b in blocks]

            def batch():  # simulate_batch called directly on the same runs, fixed parts built once
                for v in values:
                    simulate_batch(alg, device, op, s.duration, initial_position=p0, progress=False, stiffness=v)

            direct = statistics.median(_time(batch) for _ in range(3))
            local = statistics.median(_time(lambda: _run_blocks(s.mapping, whole, 1)) for _ in range(3))
            remote = statistics.median(_time(lambda: client.gather([client.submit(_run_blocks, s.mapping, [w], 1, pure=False)
                                                                    for w in whole])) for _ in range(3))
            groups = [[(blocks[i], j, k) for i, j, k in g] for g in _tasks(list(range(len(blocks))), n, 1)]
            grouped = statistics.median(_time(lambda: client.gather([client.submit(_run_blocks, s.mapping, g, 1, pure=False)
                                                                     for g in groups])) for _ in range(3))
            print(f"40 blocks of {n:.0e} samples as a sweep sends them ({len(groups)} tasks): {grouped:.3f} s, overhead "
                  f"{100 * (grouped - direct) / direct:.1f} % against simulate_batch "
                  f"({(grouped - direct) / 40 * 1e3:.2f} ms a block)")
            latency = statistics.median(_time(lambda: client.submit(_run_blocks, s.mapping, whole[:1], 1,
                                                                    pure=False).result()) for _ in range(5))
            print(f"40 tasks of {n:.0e} samples (median of 3): simulate_batch directly {direct:.3f} s, the task "
                  f"function in this process {local:.3f} s, through Dask {remote:.3f} s: overhead "
                  f"{100 * (remote - direct) / direct:.1f} % against simulate_batch "
                  f"({(remote - direct) / 40 * 1e3:.2f} ms a task), {100 * (remote - local) / local:.1f} % against the "
                  f"task function; one task's round trip {latency * 1e3:.1f} ms against {direct / 40 * 1e3:.1f} ms")
    with cluster_for_noop() as (client, n_tasks):
        client.gather([client.submit(_noop, i, pure=False) for i in range(n_tasks)])
        noop = statistics.median(_time(lambda: client.gather([client.submit(_noop, i, pure=False)
                                                              for i in range(n_tasks)])) for _ in range(5))
        print(f"a no-op task (returning 14 small arrays, {n_tasks} submitted together, 1 worker in this process): "
              f"{noop / n_tasks * 1e3:.2f} ms")
    big = dict(spec.mapping, axes=dict(spec.mapping["axes"], stiffness="0.5-20 kN/m, 480 log steps"))
    s = SweepSpec.from_mapping(big)
    with tempfile.TemporaryDirectory() as tmp:
        wall, _ = timed_sweep(s, None, Path(tmp) / "big.zarr")  # the default: a worker process a core
    n = s.runs * round(s.duration / 1e-4)
    print(f"largest sweep: {s.runs} runs x {round(s.duration / 1e-4)} samples = {n:.2g} samples in {wall:.1f} s "
          f"({n / wall:.3g} samples/s, the default: a worker process a core)")


def _noop(i):
    return {f"v{j}": np.zeros(10) for j in range(14)}


class cluster_for_noop:
    """The local cluster a sweep with one worker starts, and 40 tasks."""

    def __enter__(self):
        from haptex.atlas import _client

        self.client, self.cluster, _ = _client(None, 1)
        return self.client, 40

    def __exit__(self, *exc):
        self.client.close()
        self.cluster.close()


def _time(fn) -> float:
    t = time.perf_counter()
    fn()
    return time.perf_counter() - t


if __name__ == "__main__":
    np.seterr(all="ignore")
    main()
