/* Plain C reference for haptex's simulator loop (benchmarks only, never part of the package).
 *
 * It does the same work per sample as haptex.simulate._run for a scanning hand:
 * sense (no quantisation), compute algorithm A's or D's force on a Fourier texture (D
 * with the same closest-point search: warm start, cells pruned by Lipschitz and
 * curvature bounds, sampling every step, bracketed Newton, polishing), hold it, pick the damping regime, build the augmented state, advance it with
 * the 10x10 transition matrix and accumulate the two Van Loan quadratic forms and the
 * per-axis environment energies.
 *
 * Input (binary, little-endian float64 unless noted), written by benchmarks/run_sim.py:
 *   int64 code (1 = A, 4 = D), int64 ncomp, int64 n_steps, int64 n_runs
 *   coeffs[3][ncomp], k0, step, T, K[2][2], C[2][2], s0[2], vend[2], p0[2], M, Kc
 *   Phi[2][10][10], Wd[2][10][10], Wo[2][10][10]
 * Output: "samples_per_second <value>" and a checksum on stdout.
 *
 * Build: gcc -O2 -o sim_reference sim_reference.c -lm
 */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#define NZ 10
static int ncomp;
static double *co;

static void tex(double x, double *h, double *s, double *c) {
    double hh = 0, ss = 0, cc = 0;
    for (int i = 0; i < ncomp; i++) {
        double a = co[i], k = co[ncomp + i], arg = k * x + co[2 * ncomp + i];
        double sn = sin(arg), cs = cos(arg);
        hh += a * sn; ss += a * k * cs; cc -= a * k * k * sn;
    }
    *h = hh; *s = ss; *c = cc;
}

static void dphi(double px, double pz, double t, double *f, double *g, double *gp) {
    double h, s, c; tex(t, &h, &s, &c);
    double dz = h - pz;
    *f = (t - px) * (t - px) + dz * dz; *g = (t - px) + dz * s; *gp = 1 + s * s + dz * c;
}

static double refine(double px, double pz, double a, double b) {
    double lo = a, hi = b, t = 0.5 * (a + b), f, g, gp;
    for (int i = 0; i < 100; i++) {
        dphi(px, pz, t, &f, &g, &gp);
        if (g > 0) hi = t; else lo = t;
        double tn = gp > 0 ? t - g / gp : 0.5 * (lo + hi);
        if (!(lo < tn && tn < hi)) tn = 0.5 * (lo + hi);
        if (fabs(tn - t) <= 1e-15 * (1 + fabs(t)) || hi - lo <= 1e-16 * (1 + fabs(t))) { t = tn; break; }
        t = tn;
    }
    return t;
}

static double polish(double px, double pz, double t, double a, double b) {
    double f, g, gp;
    for (int i = 0; i < 60; i++) {
        dphi(px, pz, t, &f, &g, &gp);
        if (gp <= 0) break;
        double tn = fmin(fmax(t - g / gp, a), b);
        if (fabs(tn - t) <= 1e-15 * (1 + fabs(t))) return tn;
        t = tn;
    }
    return t;
}

static double closest(double step, double M, double K, double px, double pz, double guess) {
    double h0, s0, c0; tex(px, &h0, &s0, &c0);
    double dv = h0 - pz, f, g, gp;
    if (dv <= 0) return px;
    double best_t = px, best_f = dv * dv, second = INFINITY; (void)second;
    int found = 0;
    if (guess == guess) {
        double tg = polish(px, pz, guess, px - dv, px + dv);
        dphi(px, pz, tg, &f, &g, &gp);
        if (f < best_f) { best_f = f; best_t = tg; }
    }
    double R = sqrt(best_f);
    int fine = 8; double width = fine * step;
    int nc = (int)ceil(2 * R / width); if (nc < 1) nc = 1;
    width = 2 * R / nc;
    if (width / fine > step) fine = (int)ceil(width / step);
    double dt = width / fine, nb_t = px, nb_f = INFINITY;
    for (int ci = 0; ci < nc; ci++) {
        double a = px - R + ci * width, c = a + 0.5 * width, hc, sc, cc;
        tex(c, &hc, &sc, &cc);
        double dx = fabs(c - px) - 0.5 * width; if (dx < 0) dx = 0;
        double spread = M * 0.5 * width, tay = fabs(sc) * 0.5 * width + K * 0.125 * width * width;
        if (tay < spread) spread = tay;
        double dz = fabs(hc - pz) - spread; if (dz < 0) dz = 0;
        if (dx * dx + dz * dz >= best_f * (1 + 1e-12)) continue;
        double tp = a, fp, gprev; dphi(px, pz, tp, &fp, &gprev, &gp);
        if (fp < nb_f) { nb_f = fp; nb_t = tp; }
        for (int i = 1; i <= fine; i++) {
            double ti = a + i * dt, fi, gi;
            dphi(px, pz, ti, &fi, &gi, &gp);
            if (fi < nb_f) { nb_f = fi; nb_t = ti; }
            if (gprev <= 0 && gi > 0) {
                double t = refine(px, pz, tp, ti);
                dphi(px, pz, t, &f, &g, &gp);
                if (f < best_f) { best_f = f; best_t = t; found = 1; }
            }
            tp = ti; gprev = gi;
        }
    }
    if (nb_f < INFINITY) {
        double t = polish(px, pz, nb_t, nb_t - dt, nb_t + dt);
        dphi(px, pz, t, &f, &g, &gp);
        if ((!found || fabs(t - best_t) > 0.5 * dt) && f < best_f) { best_f = f; best_t = t; }
    }
    return best_t;
}

static double quad(const double *W, const double *z) {
    double acc = 0;
    for (int i = 0; i < NZ; i++) { double row = 0; for (int j = 0; j < NZ; j++) row += W[i * NZ + j] * z[j]; acc += z[i] * row; }
    return acc;
}

/* Render mode: the force of algorithm A or D at n points of a scan x_i = i * 1e-6 m,
 * z_i = h(x_i) - 0.4 mm, with D warm-starting from the previous closest point, as
 * haptex.Renderer does. Prints ns per point. */
static int render_mode(int code, long n, double k0, double step, double M, double Kc) {
    double guess = NAN, acc = 0, ex = 0, ez = 0, lx = 0, lz = 0, lfx = 0, lfz = 0;
    long clamps = 0; int have = 0;
    struct timespec t0, t1;
    clock_gettime(CLOCK_MONOTONIC, &t0);
    for (long i = 0; i < n; i++) {
        double x = i * 1e-6, h, s, c, fx = 0, fz = 0;
        tex(x, &h, &s, &c);
        double z = h - 0.4e-3;
        if (!(isfinite(x) && isfinite(z))) continue;
        tex(x, &h, &s, &c);
        double d = z - h;
        if (d < 0) {
            if (code == 1) fz = -k0 * d;
            else { double tt = closest(step, M, Kc, x, z, guess), th, ts, tc; guess = tt; tex(tt, &th, &ts, &tc);
                   fx = -k0 * (x - tt); fz = -k0 * (z - th); }
        }
        /* the renderer's extra work: finiteness, clamp to 10 N, passivity observer */
        if (!(isfinite(fx) && isfinite(fz))) { fx = 0; fz = 0; }
        double mag = sqrt(fx * fx + fz * fz);
        if (mag > 10.0) { fx *= 10.0 / mag; fz *= 10.0 / mag; clamps++; }
        if (have) { ex -= lfx * (x - lx); ez -= lfz * (z - lz); }
        lx = x; lz = z; lfx = fx; lfz = fz; have = 1;
        acc += fx + fz;
    }
    acc += ex + ez + clamps;
    clock_gettime(CLOCK_MONOTONIC, &t1);
    double el = (t1.tv_sec - t0.tv_sec) + 1e-9 * (t1.tv_nsec - t0.tv_nsec);
    printf("ns_per_point %.6g\nchecksum %.17g\n", el / n * 1e9, acc);
    return 0;
}

int main(int argc, char **argv) {
    if (argc < 2) { fprintf(stderr, "usage: sim_reference input.bin [render]\n"); return 2; }
    FILE *fh = fopen(argv[1], "rb");
    if (!fh) { perror(argv[1]); return 2; }
    int64_t hdr[4];
    if (fread(hdr, 8, 4, fh) != 4) return 2;
    int code = (int)hdr[0]; ncomp = (int)hdr[1]; long n_steps = hdr[2], n_runs = hdr[3];
    co = malloc(sizeof(double) * 3 * ncomp);
    double sc[3 + 4 + 4 + 2 + 2 + 2 + 2], Phi[2 * NZ * NZ], Wd[2 * NZ * NZ], Wo[2 * NZ * NZ];
    if (fread(co, 8, 3 * ncomp, fh) != (size_t)(3 * ncomp) || fread(sc, 8, 19, fh) != 19 ||
        fread(Phi, 8, 200, fh) != 200 || fread(Wd, 8, 200, fh) != 200 || fread(Wo, 8, 200, fh) != 200) return 2;
    fclose(fh);
    double k0 = sc[0], step = sc[1], T = sc[2], *K = sc + 3, *C = sc + 7, *s0 = sc + 11, *vend = sc + 13, *p0 = sc + 15;
    double Mslope = sc[17], Kcurv = sc[18];
    if (argc > 2) return render_mode(code, n_steps, k0, step, Mslope, Kcurv);
    double checksum = 0;
    struct timespec t0, t1;
    clock_gettime(CLOCK_MONOTONIC, &t0);
    for (long run = 0; run < n_runs; run++) {
        double p[2] = {p0[0], p0[1]}, v[2] = {0, 0}, z[NZ], ex = 0, ez = 0, ed = 0, eo = 0, guess = NAN;
        for (long k = 0; k < n_steps; k++) {
            double t = k * T, fx = 0, fz = 0, h, s, c;
            tex(p[0], &h, &s, &c);
            double d = p[1] - h;
            if (d < 0) {
                if (code == 1) { fz = -k0 * d; }
                else { double tt = closest(step, Mslope, Kcurv, p[0], p[1], guess), th, ts, tc; guess = tt;
                       tex(tt, &th, &ts, &tc); fx = -k0 * (p[0] - tt); fz = -k0 * (p[1] - th); }
            }
            double mag = sqrt(fx * fx + fz * fz); (void)mag;
            int reg = p[1] < h ? 1 : 0;
            double sx = s0[0] + vend[0] * t, sz = s0[1] + vend[1] * t, sdx = vend[0], sdz = vend[1];
            z[0] = p[0]; z[1] = p[1]; z[2] = v[0]; z[3] = v[1]; z[4] = fx; z[5] = fz;
            z[6] = K[0] * sx + K[1] * sz + C[0] * sdx + C[1] * sdz;
            z[7] = K[2] * sx + K[3] * sz + C[2] * sdx + C[3] * sdz;
            z[8] = K[0] * sdx + K[1] * sdz; z[9] = K[2] * sdx + K[3] * sdz;
            ed += quad(Wd + reg * NZ * NZ, z); eo += quad(Wo + reg * NZ * NZ, z);
            const double *P = Phi + reg * NZ * NZ;
            double np[4] = {0, 0, 0, 0};
            for (int i = 0; i < 4; i++) for (int j = 0; j < NZ; j++) np[i] += P[i * NZ + j] * z[j];
            ex -= fx * (np[0] - p[0]); ez -= fz * (np[1] - p[1]);
            p[0] = np[0]; p[1] = np[1]; v[0] = np[2]; v[1] = np[3];
        }
        checksum += ex + ez + ed + eo;
    }
    clock_gettime(CLOCK_MONOTONIC, &t1);
    double el = (t1.tv_sec - t0.tv_sec) + 1e-9 * (t1.tv_nsec - t0.tv_nsec);
    printf("samples_per_second %.6g\nchecksum %.17g\n", (double)n_steps * n_runs / el, checksum);
    return 0;
}
