"""
The exported C, compiled and compared
=====================================

``haptex export`` (here :func:`haptex.export.export_c`) writes the C core's own tick files and
this texture's tables for device firmware: C99, ``<math.h>`` only. The firmware's loop calls
``haptex_init`` once and ``haptex_step`` each tick. This example compiles the export with the
machine's C compiler beside a ten-line driver, runs one stroke in and out of the wall over the
texture, and compares every tick's force with :class:`haptex.Renderer`'s.
"""

import shutil
import subprocess
import tempfile
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

import haptex as hx
from haptex.export import export_c

alg = hx.algorithm("F", hx.Sinusoid(0.8e-3, 1e-3), 2000.0)  # the paper's F, with presliding friction
n = 4000
t = np.linspace(0, 1, n)
stroke = np.stack([3e-3 * t, 0.2e-3 - 0.8e-3 * np.sin(np.pi * t)], axis=-1)  # m: in, across, out

renderer = hx.Renderer(alg, max_force=5.0)
expected = np.array([renderer.step(tuple(p)) for p in stroke])

DRIVER = r"""
#include <stdio.h>
#include "haptex_texture.h"
int main(void) {
    haptex_state s; double p[2], f[2];
    if (haptex_init(&s) != 0) return 1;
    while (scanf("%lf %lf", &p[0], &p[1]) == 2) {
        haptex_step(&s, p, f);
        printf("%.17g %.17g\n", f[0], f[1]);
    }
    return 0;
}
"""
cc = shutil.which("cc") or shutil.which("gcc")
with tempfile.TemporaryDirectory() as tmp:
    fw = Path(tmp) / "fw"
    export_c(alg, fw, max_force=5.0)
    (Path(tmp) / "driver.c").write_text(DRIVER)
    print("exported:", ", ".join(sorted(p.name for p in fw.iterdir())))
    if cc is None:
        compiled = expected  # no compiler on this machine: nothing to compare
        print("no C compiler found: the comparison is skipped")
    else:
        # -O0: this example compares every force, it does not time the tick (-O2 compiles in 13 s
        # here, -O0 in 3 s; firmware builds with its own flags)
        subprocess.run([cc, "-std=c99", "-O0", "-I", str(fw), "-o", str(Path(tmp) / "tick"), str(Path(tmp) / "driver.c"),
                        *map(str, sorted(fw.glob("*.c"))), "-lm"], check=True)
        lines = "\n".join(f"{x!r} {z!r}" for x, z in stroke.tolist())
        out = subprocess.run([str(Path(tmp) / "tick")], input=lines, capture_output=True, text=True, check=True)
        compiled = np.array([[float(v) for v in line.split()] for line in out.stdout.splitlines()])

print(f"largest difference over {n} ticks: {np.abs(compiled - expected).max():.3g} N")

# %%
fig, ax = plt.subplots(figsize=(7, 3.6))
ax.plot(stroke[:, 0] * 1e3, expected[:, 0], "C0", lw=3, alpha=0.4, label="Renderer f_x")
ax.plot(stroke[:, 0] * 1e3, expected[:, 1], "C1", lw=3, alpha=0.4, label="Renderer f_z")
ax.plot(stroke[:, 0] * 1e3, compiled[:, 0], "C0:", label="exported C, f_x")
ax.plot(stroke[:, 0] * 1e3, compiled[:, 1], "C1:", label="exported C, f_z")
ax.set_xlabel("x along the stroke (mm)")
ax.set_ylabel("force (N)")
ax.legend(fontsize=8)
fig.tight_layout()
