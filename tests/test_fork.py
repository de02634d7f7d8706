"""Issue 17, reproducer 9: after haptex has run its parallel loops (since issue 30 the C core's,
on Python threads with the GIL released; numba, whose GNU OpenMP layer killed forked workers
with "fork() called from a process already using GNU OpenMP" and hung pool.map, is gone), a
fork-based multiprocessing pool still works."""

import subprocess
import sys
import textwrap


def test_a_fork_pool_works_after_a_parallel_kernel():
    # in a fresh interpreter, so that the threading layer is the one haptex chooses at import
    code = textwrap.dedent("""
        import multiprocessing as mp, numpy as np, haptex as hx
        tex = hx.Sinusoid(0.8e-3, 1e-3)
        hx.closest_point(tex, np.column_stack([np.linspace(0, 1e-3, 4000), np.full(4000, -1e-3)]))  # C, threads
        egg = hx.SumOfGratings.egg_crate(0.1e-3, 2e-3)  # C, threads
        hx.closest_point(egg, np.column_stack([np.linspace(0, 1e-3, 400), np.zeros(400), np.full(400, -1e-3)]))
        from haptex.operators import ConstantForce  # the C batch on threads (the general loop: a delay)
        hx.simulate_batch(hx.algorithm("A", tex, 1000.0), hx.Device.point_mass().replace(delay=1),
                          ConstantForce([0.0, -1.0]), 0.01, stiffness=[500.0, 1000.0])
        def work(z):
            return float(hx.algorithm("D", tex, 1000.0).force([[0.0, z]])[0, 1])
        with mp.get_context("fork").Pool(2) as pool:
            out = pool.map_async(work, [-1e-4, -2e-4, -3e-4, -4e-4]).get(timeout=120)
        print("ok", out)
    """)
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr[-2000:]
    layer, rest = run.stdout.split(" ", 1)
    assert layer == "ok"
    # D's force below the valley at x = 0 (h = 0): kappa_0 times a distance <= the depth
    values = [float(v) for v in rest.strip(" []\n").split(",")]
    assert all(0 < v <= 1000.0 * d * (1 + 1e-12) for v, d in zip(values, (1e-4, 2e-4, 3e-4, 4e-4)))

