"""The servo tick over textured objects (issue 32): A on the egg-crate (a Fourier texture,
0.2 mm high, 2 mm period) on the plane, on a sphere of radius 12.7 mm and on trimesh's
icosphere of that radius with 5,120, 81,920 and 327,680 triangles (the goal: a 10^5-triangle
mesh, median <= 5 us, worst case bounded and counted), faceted, and at 5,120 and 81,920
swept into prisms along its vertex normals; then A, F, D, E and the proxy on the sphere, the
proxy on the meshes and D on the prism mesh.

Per object: Renderer.step from Python (median, 99th percentile and largest single call, the
timer's own cost subtracted), the C core's tick alone (mean per call in Renderer.run's C
loop), and the work counted per tick (mesh: nodes and triangles visited, plus one texture
evaluation), over a 10 mm/s stroke sampled at 10 kHz (1 um a call) 0.3 mm inside, along x with
a 0.3 mm sway in y, back and forth over +-20 mm (on the meshes: the analytic sphere's points). The
plane's row is the reference in the same run.

Run:  python benchmarks/run_objects.py [--calls 100000]
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

import haptex as hx
from haptex.objects import Mesh, Plane, Sphere, object_algorithm

EGG = hx.SumOfGratings.egg_crate(0.2e-3, 2e-3)
R = 40 * 2e-3 / (2 * math.pi)


def icosphere(subdivisions):
    import trimesh

    m = trimesh.creation.icosphere(subdivisions=subdivisions, radius=R)
    m.apply_transform(trimesh.transformations.rotation_matrix(0.1234, [1.0, 0.3, 0.0]))
    m.apply_translation([0.0, 0.0, -R])
    return Mesh(m, uv=Sphere(R).local(np.asarray(m.vertices))[0])


def prism(base):
    """The same mesh swept into prisms along its vertex normals (Mesh(normals="vertex"))."""
    return Mesh(base.mesh, uv=base.uv, normals="vertex")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--calls", type=int, default=100_000)
    n = ap.parse_args().calls
    s = np.arange(n) * 1e-6  # back and forth over +-20 mm at 1 um a call
    x = (40e-3 / math.pi) * np.arcsin(np.sin(math.pi * s / 40e-3))
    probe = np.empty(10000)
    for i in range(probe.size):
        t0 = time.perf_counter_ns()
        probe[i] = time.perf_counter_ns() - t0
    timer = float(np.median(probe))
    print(f"{'object':28} {'triangles':>9} {'build':>8} {'step median':>12} {'p99':>8} {'max':>8} "
          f"{'C tick':>8} {'work median / max':>18}")
    for name, make in (("plane", Plane), ("sphere R = 12.7 mm", lambda: Sphere(R)),
                       ("icosphere, 4 subdivisions", lambda: icosphere(4)),
                       ("icosphere, 6 subdivisions", lambda: icosphere(6)),
                       ("icosphere, 7 subdivisions", lambda: icosphere(7)),
                       ("prism icosphere, 4 subd.", lambda: prism(icosphere(4))),
                       ("prism icosphere, 6 subd.", lambda: prism(icosphere(6)))):
        base = make()
        alg = object_algorithm("A", EGG, base, 2000.0)
        ut = np.column_stack([x, 0.3e-3 * np.sin(2 * math.pi * x / 5e-3)])
        where = alg if not isinstance(base, Mesh) else object_algorithm("A", EGG, Sphere(R), 2000.0)
        pts = np.ascontiguousarray(where.region_points(ut, np.full(n, 0.3e-3)))  # (on a mesh: the sphere's)
        t0 = time.perf_counter()
        r = hx.Renderer(alg)
        build = time.perf_counter() - t0
        times, work = np.empty(n), np.empty(n, dtype=np.int64)
        step = r.step
        rows = [tuple(p) for p in pts.tolist()]
        for i, p in enumerate(rows):
            t0 = time.perf_counter_ns()
            step(p)
            times[i] = time.perf_counter_ns() - t0 - timer
            work[i] = r.last_work
        out = np.zeros_like(pts)
        r.reset()
        t0 = time.perf_counter()
        r._core.run(pts, out)
        tick = (time.perf_counter() - t0) / n
        tri = len(base._faces) if isinstance(base, Mesh) else 0
        print(f"{name:28} {tri:9d} {build * 1e3:6.0f} ms {np.median(times) / 1e3:9.2f} us "
              f"{np.percentile(times, 99) / 1e3:5.2f} us {times.max() / 1e3:5.1f} us {tick * 1e6:5.2f} us "
              f"{int(np.median(work)):8d} / {int(work.max())}")

    # the other letters on the sphere, along the same stroke (D and E: the closest point of the
    # textured object, certified, the renderer's default budget; the proxy: its descent), and the
    # proxy on the meshes (its descent through their UV maps)
    from haptex.proxy import GodObject

    m = min(n, 20_000)
    sphere = Sphere(R)
    ut = np.column_stack([x[:m], 0.3e-3 * np.sin(2 * math.pi * x[:m] / 5e-3)])
    pts = np.ascontiguousarray(object_algorithm("A", EGG, sphere, 2000.0).region_points(ut, np.full(m, 0.3e-3)))
    print(f"\n{'letter, object':28} {'step median':>12} {'p99':>8} {'max':>8} {'C tick':>8} {'work median / max':>18}"
          f" {'cut':>5}")
    cases = [(L, "sphere", lambda: sphere) for L in ("A", "F", "D", "E", "proxy")]
    cases += [("proxy", "icosphere, 4 subd.", lambda: icosphere(4)),
              ("proxy", "icosphere, 6 subd.", lambda: icosphere(6)),
              ("proxy", "prism icosphere, 4 subd.", lambda: prism(icosphere(4))),
              ("D", "prism icosphere, 4 subd.", lambda: prism(icosphere(4)))]
    for letter, where, make in cases:
        base = make()
        alg = GodObject(EGG, 2000.0, base) if letter == "proxy" else object_algorithm(letter, EGG, base, 2000.0)
        r = hx.Renderer(alg)
        times, work = np.empty(m), np.empty(m, dtype=np.int64)
        for i, p in enumerate(tuple(q) for q in pts.tolist()):
            t0 = time.perf_counter_ns()
            r.step(p)
            times[i] = time.perf_counter_ns() - t0 - timer
            work[i] = r.last_work
        cut = r.cut
        out = np.zeros_like(pts)
        r.reset()
        t0 = time.perf_counter()
        r._core.run(pts, out)
        tick = (time.perf_counter() - t0) / m
        print(f"{letter + ', ' + where:28} {np.median(times) / 1e3:9.2f} us {np.percentile(times, 99) / 1e3:5.2f} us "
              f"{times.max() / 1e3:5.1f} us {tick * 1e6:5.2f} us {int(np.median(work)):8d} / {int(work.max())} "
              f"{cut:5d}")


if __name__ == "__main__":
    main()
