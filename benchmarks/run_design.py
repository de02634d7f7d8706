"""`haptex design` on raw measured data (issue 13), wall time in one run on this machine:

1. the CLI end to end (a fresh Python each, imports warm) on the paper's sinusoid and on
   the raw Dektak scan with no options, and their ratio (goal <= 4); the sinusoid felt by a
   0.532 mm ball on the omega.3;
2. design() from Python on a 10^6-sample synthetic profile (a random walk, 1 um a sample,
   levelled) and on a 1024 x 1024 areal map (a grating plus noise, 1 um a pixel, read from
   an X3P file SurfaceTopography wrote), each band-limited to what the pantograph (or the
   serial arm, over the map) renders at 0.1 m/s;
3. the CLI on a 1024 x 1024 map of rough band-limited noise (issue 35's goal: within 60 s);
4. that map felt by a ball (``felt_by``: each sample's contact over the grid's offsets, refined
   by Newton steps on the map) of 5, 10 and 20 um (issue 58's goal: within 5 s);
5. felt maps refined for the ball path's curvature near the troughs' radius rho (issue 67):
   the egg-crate (0.1 mm at 2 mm) at 0.95 rho (graded axes) and 1.04 rho (bridged: branched
   cells), two gratings at 63 deg (40 and 30 um, 2 mm and 0.89 mm) at 0.995 times their
   tightest radius (0.633 mm; the uniform grids to their cap) and at 1.2 times (bridged along
   creases at an angle to the axes: each refined grid's branches made both ways). ``python
   benchmarks/run_design.py felt`` runs this part alone;
6. a measured profile felt by a ball: the raw Dektak scan (levelled, 9,600 samples) felt by
   balls of 0.1, 0.5 and 1 mm, each refined for its path's curvature (the gallery's "A measured
   scan as a ball feels it"). ``python benchmarks/run_design.py profile`` runs this part alone.
"""

from __future__ import annotations

import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import haptex as hx
from haptex.design import design

DEKTAK = Path(__file__).resolve().parents[2] / "shared" / "data" / "dektak-stylus-profile.csv"


def cli(*args) -> float:
    t = time.perf_counter()
    r = subprocess.run([sys.executable, "-m", "haptex", "design", *args, "--json"], capture_output=True, text=True)
    if r.returncode != 0:
        raise SystemExit(r.stderr)
    return time.perf_counter() - t


def main() -> None:
    cli("--texture", "sine:0.2mm,2mm")  # warm the imports' caches
    sine = cli("--texture", "sine:0.2mm,2mm")
    print(f"haptex design --texture sine:0.2mm,2mm            {sine:6.1f} s")
    if DEKTAK.exists():
        raw = cli("--texture", str(DEKTAK))
        print(f"haptex design --texture dektak-stylus-profile.csv {raw:6.1f} s  ({raw / sine:.2f} x the sinusoid)")
    else:
        print(f"(the Dektak scan is not at {DEKTAK}: skipped)")
    # the sinusoid felt by a ball just past its troughs' radius (0.51 mm), on the omega.3: its
    # rendered texture band-limited below the kink, where D's and E's loops cross the medial axis
    felt = cli("--texture", "sine:0.2mm,2mm", "--device", "omega-3", "--tip-radius", "0.532mm")
    print(f"haptex design ... --tip-radius 0.532mm (omega-3)  {felt:6.1f} s  ({felt / sine:.2f} x the sinusoid)")

    rng = np.random.default_rng(1)
    n = 10**6
    x = np.arange(n) * 1e-6
    h = np.cumsum(rng.standard_normal(n)) * 1e-8
    prof = hx.SampledProfile(x, h - np.polyval(np.polyfit(x, h, 1), x))
    t = time.perf_counter()
    d = design(prof, hx.Device.pantograph(), 2000.0)
    print(f"design, 10^6-sample profile (1 m)                {time.perf_counter() - t:6.1f} s  "
          f"({d['band_limit']['samples']['raw']} -> {d['band_limit']['samples']['rendered']} samples)")

    from SurfaceTopography import Topography

    m = 1024
    g = np.arange(m) * 1e-6
    X, Y = np.meshgrid(g, g, indexing="ij")
    hm = 2e-6 * np.sin(2 * np.pi * X / 400e-6) * np.cos(2 * np.pi * Y / 300e-6) + 5e-8 * rng.standard_normal((m, m))
    with tempfile.TemporaryDirectory() as tmp:
        f = Path(tmp) / "map.x3p"
        Topography(hm, (m * 1e-6, m * 1e-6), unit="m").to_x3p(str(f))
        t = time.perf_counter()
        surf = hx.SampledSurface.from_file(f)
        read = time.perf_counter() - t
        d = design(surf, hx.Device.serial_arm(), 500.0)
        print(f"design, 1024 x 1024 map (X3P, 1 mm square)        {time.perf_counter() - t:6.1f} s  "
              f"(reading {read:.1f} s; {d['band_limit']['samples']['raw']} -> "
              f"{d['band_limit']['samples']['rendered']} samples)")

        # issue 35's goal map: isotropic band-limited noise, 2 um RMS, wavelengths >= 50 um
        # (the default point mass's cut-off at 0.1 m/s), 1 um pixels: 20 x 20 cut-off periods
        # of rough texture, as a user runs it (the CLI, no options)
        k = np.fft.fftfreq(m, 1e-6)
        K = np.hypot(k[:, None], k[None, :])
        spec = (rng.standard_normal((m, m)) + 1j * rng.standard_normal((m, m))) * (K <= 1 / 50e-6) * (K > 0)
        hn = np.fft.ifft2(spec).real
        hn *= 2e-6 / hn.std()
        f = Path(tmp) / "noise.x3p"
        Topography(hn, (m * 1e-6, m * 1e-6), unit="m").to_x3p(str(f))
        noise = cli("--texture", str(f))
        print(f"haptex design --texture noise.x3p (1024 x 1024)   {noise:6.1f} s")
        rough = hx.SampledSurface.from_file(f)
        for r in (5e-6, 10e-6, 20e-6):
            t = time.perf_counter()
            rough.felt_by(r)
            print(f"felt_by({r * 1e6:g} um), 1024 x 1024 map             {time.perf_counter() - t:6.2f} s")
    felt_near_rho()
    felt_profile()


def felt_near_rho() -> None:
    """Part 5: felt_by near the troughs' radius, wall time of one construction each."""
    import math

    egg, rho = hx.SumOfGratings.egg_crate(0.1e-3, 2e-3), (2e-3) ** 2 / (4 * math.pi**2 * 0.1e-3)
    k = 2 * np.pi * np.array([(1, 0), (1, 2)]) / 2e-3
    two = hx.SumOfGratings([40e-6, 30e-6], 2 * np.pi / np.linalg.norm(k, axis=1), np.arctan2(k[:, 1], k[:, 0]),
                           [0.4, 1.7])
    for tex, r, what in ((egg, 0.95 * rho, "egg-crate, 0.95 rho"), (egg, 0.999 * rho, "egg-crate, 0.999 rho"),
                         (egg, 1.04 * rho, "egg-crate, 1.04 rho"), (two, 0.995 * 0.633e-3, "two gratings, 0.995 rho"),
                         (two, 1.2 * 0.633e-3, "two gratings, 1.2 rho")):
        t = time.perf_counter()
        felt = tex.felt_by(r)
        print(f"felt_by, {what:<24} {time.perf_counter() - t:6.2f} s  ({felt.x.size} x {felt.y.size})")


def felt_profile() -> None:
    """Part 6: the Dektak scan felt by balls, wall time of one construction each."""
    if not DEKTAK.exists():
        print(f"(the Dektak scan is not at {DEKTAK}: skipped)")
        return
    scan = hx.load_texture(DEKTAK).leveled()
    for r in (0.1e-3, 0.5e-3, 1e-3):
        t = time.perf_counter()
        felt = scan.felt_by(r)
        what = f"felt_by({r * 1e3:g} mm), Dektak scan"
        print(f"{what:<40} {time.perf_counter() - t:6.2f} s  ({felt.x.size} samples)")


if __name__ == "__main__":
    if sys.argv[1:] == ["felt"]:
        felt_near_rho()
    elif sys.argv[1:] == ["profile"]:
        felt_profile()
    else:
        main()
