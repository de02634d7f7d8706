"""ns per call of the C99 tick that `haptex export` generates (issue 16): the exported
haptex_step for every algorithm on the paper's sinusoid (F sharp and smooth), for A, D, E
on the levelled Dektak profile (spline tables) and for A-G over the egg-crate (3-D), driven by a C loop over 10^7 positions (10^6
for D and E) sweeping in and out of the wall, compiled with cc -O2. Needs a C compiler."""

import shutil
import subprocess
import tempfile
from pathlib import Path

import haptex as hx
from haptex.export import export_c

DEKTAK = Path(__file__).resolve().parents[2] / "shared" / "data" / "dektak-stylus-profile.csv"

DRIVER = r"""#define _POSIX_C_SOURCE 199309L
#include <stdio.h>
#include <time.h>
#include "haptex_texture.h"
int main(void) {
    haptex_state s; if (haptex_init(&s) != 0) return 1;
    double p[3], f[3], acc = 0.0;
    const long n = N_CALLS;
    struct timespec t0, t1;
    clock_gettime(CLOCK_MONOTONIC, &t0);
    for (long i = 0; i < n; ++i) {
        p[0] = 1e-6 * (double)(i % 4000);
#if HAPTEX_DIMENSION == 3
        p[1] = 1e-6 * (double)(i % 2900);
#endif
        p[HAPTEX_DIMENSION - 1] = -1e-6 * (double)(i % 1500) + 2e-4;
        haptex_step(&s, p, f);
        acc += f[0] + f[HAPTEX_DIMENSION - 1];
    }
    clock_gettime(CLOCK_MONOTONIC, &t1);
    double ns = ((t1.tv_sec - t0.tv_sec) * 1e9 + (t1.tv_nsec - t0.tv_nsec)) / n;
    printf("%.2f %g\n", ns, acc);
    return 0;
}
"""


def main() -> None:
    cc = shutil.which("cc") or shutil.which("gcc")
    if cc is None:
        print("no C compiler: skipped")
        return
    sine = hx.Sinusoid(0.8e-3, 1e-3)
    cases = [(L, "sinusoid", sine, {}) for L in "ABCDEFG"]
    cases.append(("F smooth", "sinusoid", sine, {"stick_deflection": 0.5e-3}))
    if DEKTAK.exists():
        dektak = hx.SampledProfile.from_file(DEKTAK).leveled()
        cases += [(L, "Dektak", dektak, {}) for L in "ADE"]
    egg = hx.SumOfGratings.egg_crate(0.8e-3, 1e-3)
    cases += [(L, "egg-crate (3-D)", egg, {}) for L in "ABCDEFG"]
    print("| algorithm | texture | ns per haptex_step |")
    print("| --- | --- | ---: |")
    for letter, name, tex, kw in cases:
        with tempfile.TemporaryDirectory() as d:
            export_c(hx.algorithm(letter[0], tex, 2000.0, **kw), d, 5.0)  # 2-D or 3-D by the texture
            Path(d, "driver.c").write_text(DRIVER)
            exe = Path(d, "bench")
            n = 1_000_000 if letter in "DE" else 10_000_000
            subprocess.run([cc, "-std=c99", "-O2", f"-DN_CALLS={n}L", "-o", str(exe),
                            *map(str, sorted(Path(d).glob("*.c"))), "-lm"], check=True)  # the driver, the core
            ns = float(subprocess.run([str(exe)], capture_output=True, text=True, check=True).stdout.split()[0])
        print(f"| {letter} | {name} | {ns:.1f} |", flush=True)


if __name__ == "__main__":
    main()
