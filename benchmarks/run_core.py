"""The C core (issue 30): the cost of one call across the binding, and the fields' throughput.

1. binding: ns per call of hx_field on one point through the extension's C API function
   (METH_FASTCALL, five buffers acquired and checked per call) and through ctypes on the
   same exported symbol (a Structure built once, pointers passed), and the floor of any
   call from Python (a C API function doing nothing: len(())); a felt map's one-point
   evaluation on its own table (checked once when made) and on a copy (checked on each call);
2. throughput: force and Jacobian of W, A, B, C, G on 10^6 points by the core (one
   thread, GIL released) against the NumPy fields, over the paper's sinusoid (2-D) and the
   egg-crate (3-D).

Run: python benchmarks/run_core.py (or python benchmarks/run.py --only core).
"""

from __future__ import annotations

import ctypes
import time
import timeit

import numpy as np

import haptex as hx
from haptex import core
from haptex.core import _ext


class _Texture(ctypes.Structure):
    _fields_ = [("kind", ctypes.c_int), ("c", ctypes.POINTER(ctypes.c_double)), ("rows", ctypes.c_long),
                ("cols", ctypes.c_long)]


class _Model(ctypes.Structure):
    _fields_ = [("code", ctypes.c_int), ("prm", ctypes.c_double * _ext.N_PARAMS), ("tex", _Texture)]


def _per_call(fn, n=200_000) -> float:
    """Best of 5 of n calls, ns per call."""
    return min(timeit.repeat(fn, number=n, repeat=5)) / n * 1e9


def binding() -> None:
    alg = hx.algorithm("B", hx.Sinusoid(0.8e-3, 1e-3), 2000.0)
    code, prm, kind, coeffs, _ = alg.kernel_spec()
    p = np.array([[1e-4, -2e-4]])
    f = np.empty((1, 2))
    j = np.empty((1, 2, 2))
    fastcall = _per_call(lambda: _ext.field(code, prm, kind, coeffs, p, f, j))
    lib = ctypes.CDLL(_ext.__file__)
    lib.hx_field.restype = ctypes.c_int
    lib.hx_field.argtypes = [ctypes.POINTER(_Model)] + [ctypes.POINTER(ctypes.c_double)] * 3
    m = _Model(code, (ctypes.c_double * _ext.N_PARAMS)(*prm),
               _Texture(kind, coeffs.ctypes.data_as(ctypes.POINTER(ctypes.c_double)), *coeffs.shape))
    p3 = (ctypes.c_double * 3)(1e-4, 0.0, -2e-4)
    f3 = (ctypes.c_double * 3)()
    j9 = (ctypes.c_double * 9)()
    mp = ctypes.byref(m)
    via_ctypes = _per_call(lambda: lib.hx_field(mp, p3, f3, j9))
    assert abs(f3[2] - f[0, 1]) <= 1e-12 * abs(f[0, 1])
    floor = _per_call(lambda: len(()))
    print("| binding | ns per call (one point, B over the sinusoid, force and Jacobian) |")
    print("| --- | ---: |")
    print(f"| C API, METH_FASTCALL, five buffers checked | {fastcall:.0f} |")
    print(f"| ctypes on the exported hx_field, arguments prebuilt | {via_ctypes:.0f} |")
    print(f"| floor: a C API call that does nothing (len(())) | {floor:.0f} |")
    # a felt map with branched cells, whose check reads every cell's start: its own table (a
    # read-only copy checked once when made, _ext.checked) against a copy of it, checked whole on
    # each call as any other array is (every call before 2026-12-01)
    rho = 2e-3**2 / (4 * np.pi**2 * 0.1e-3)  # (the egg-crate's bowls' radius, 1.01 mm)
    felt = hx.SumOfGratings.egg_crate(0.1e-3, 2e-3).felt_by(1.1 * rho)
    kind, table = felt.kernel_data()
    copy = table.copy()
    xy = np.array([[1e-4, 2e-4]])
    out = np.empty((1, 6))
    once = _per_call(lambda: _ext.texture(kind, table, xy, out), 20_000)
    each = _per_call(lambda: _ext.texture(kind, copy, xy, out), 2_000)
    cells = int(table[0, _ext.PATCH_NX] * table[0, _ext.PATCH_NY])
    print(f"\n| egg-crate felt by 1.1 rho ({cells:,} cells, {table.nbytes / 1e6:.0f} MB, branched): one point's h "
          "and derivatives | ns per call |")
    print("| --- | ---: |")
    print(f"| its table, checked once when made | {once:.0f} |")
    print(f"| a copy, checked whole on each call | {each:.0f} |")


def throughput(points: int = 1_000_000) -> None:
    rng = np.random.default_rng(0)
    cases = [("2-D, sinusoid", hx.Sinusoid(0.8e-3, 1e-3), None),
             ("3-D, egg-crate", hx.SumOfGratings.egg_crate(0.8e-3, 1e-3), hx.Flat(2))]
    print("\n| case | alg | NumPy force + Jacobian (s) | C core (s, one thread) | ratio |")
    print("| --- | --- | ---: | ---: | ---: |")
    for label, tex, flat in cases:
        n = tex.dimension + 1
        p = np.column_stack([rng.uniform(0, 1e-3, (points, n - 1)), rng.uniform(-1.8e-3, 1e-3, points)])
        for letter in "WABCG":
            alg = hx.algorithm(letter, (flat if n == 3 else None) if letter == "W" else tex, 2000.0)
            best = {}
            for name, fn in (("numpy", lambda: alg.force_and_jacobian(p)), ("core", lambda: core.field(alg, p))):
                times = []
                for _ in range(3):
                    t = time.perf_counter()
                    fn()
                    times.append(time.perf_counter() - t)
                best[name] = min(times)
            print(f"| {label} | {letter} | {best['numpy']:.3f} | {best['core']:.3f} | "
                  f"{best['numpy'] / best['core']:.1f}x |")


def main() -> None:
    binding()
    throughput()


if __name__ == "__main__":
    main()
