/* Plain C reference for haptex's simulator fast path (benchmarks only, never part of the package).
 *
 * The simple case: N runs of a point-mass device with diagonal mass and damping, pushed
 * by a constant force, rendering algorithm A over h = sum_i a_i sin(k_i . x + phi_i) (a profile,
 * d = 2, or a sum of gratings, d = 3). Per sample and per axis: the exact zero-order hold of
 * the mass-damper (p+ = p + a_pv v + a_pw w, v+ = a_vv v + a_vw w, w the held force), the
 * damping energy it dissipates (c_vv v^2 + c_vw v w + c_ww w^2), the operator's work f0 . dp
 * and the per-axis environment energy E_i -= f_i dp_i. The coefficients come from haptex
 * (haptex.simulate._fast_coefficients), regime 1 inside the textured surface, 0 outside.
 * One thread, runs one after the other.
 *
 * Input (binary float64 unless noted), written by benchmarks/run_sim.py:
 *   int64 d, int64 ncomp, int64 n_steps, int64 n_runs
 *   k0, f0[d], coeffs[d + 1][ncomp] (amplitudes, wave-vector components, phases), fast[2][d][7]
 * Output: "samples_per_second <value>" and a checksum.
 *
 * Build: gcc -O2 -o fast_reference fast_reference.c -lm
 */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

int main(int argc, char **argv)
{
    if (argc < 2) return 2;
    FILE *fh = fopen(argv[1], "rb");
    if (!fh) return 2;
    int64_t hdr[4];
    if (fread(hdr, sizeof hdr, 1, fh) != 1) return 2;
    int d = (int)hdr[0], nc = (int)hdr[1];
    long n_steps = (long)hdr[2], n_runs = (long)hdr[3];
    double k0, f0[3], co[4 * 64], fast[2 * 3 * 7];
    if (fread(&k0, sizeof k0, 1, fh) != 1 || fread(f0, sizeof(double), d, fh) != (size_t)d
        || fread(co, sizeof(double), (d + 1) * nc, fh) != (size_t)((d + 1) * nc)
        || fread(fast, sizeof(double), 2 * d * 7, fh) != (size_t)(2 * d * 7)) return 2;
    fclose(fh);
    struct timespec t0, t1;
    clock_gettime(CLOCK_MONOTONIC, &t0);
    double checksum = 0.0;
    for (long r = 0; r < n_runs; ++r) {
        double p[3] = {0, 0, 0}, v[3] = {0, 0, 0}, e[3] = {0, 0, 0}, ed = 0.0, eo = 0.0;
        for (long k = 0; k < n_steps; ++k) {
            double h = 0.0;
            for (int i = 0; i < nc; ++i) {
                double arg = co[(d) * nc + i];
                for (int j = 0; j < d - 1; ++j) arg += co[(1 + j) * nc + i] * p[j];
                h += co[i] * sin(arg);
            }
            double pen = p[d - 1] - h, f[3] = {0, 0, 0};
            if (pen < 0.0) f[d - 1] = -k0 * pen;
            const double *c = fast + (pen < 0.0 ? d * 7 : 0);
            for (int i = 0; i < d; ++i, c += 7) {
                double w = f[i] + f0[i];
                double np_ = p[i] + c[0] * v[i] + c[1] * w;
                double nv = c[2] * v[i] + c[3] * w;
                ed += v[i] * (c[4] * v[i] + c[5] * w) + c[6] * w * w;
                eo += f0[i] * (np_ - p[i]);
                e[i] -= f[i] * (np_ - p[i]);
                p[i] = np_;
                v[i] = nv;
            }
        }
        checksum += p[d - 1] + e[0] + e[d - 1] + ed + eo;
    }
    clock_gettime(CLOCK_MONOTONIC, &t1);
    double el = (t1.tv_sec - t0.tv_sec) + 1e-9 * (t1.tv_nsec - t0.tv_nsec);
    printf("samples_per_second %.6g\nchecksum %.17g\n", (double)n_steps * n_runs / el, checksum);
    return 0;
}
