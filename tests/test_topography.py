"""Measured topography straight from the instrument (issue 13): SurfaceTopography's readers
for line scans and areal maps, undefined data, files too large or corrupt, and `design` on
raw data band-limited to what the device renders (the four period limits of Section II-B)."""

import json
import math
import subprocess
import sys

import numpy as np
import pytest

import haptex as hx
from haptex.analysis import rendering_cutoff
from haptex.design import design

from .conftest import DEKTAK, GROOVES, needs_data
from .test_cli import run_main

K0 = 2000.0


def _grating_map(periods=4, per=64, A=50e-6, L=0.5e-3, rows=8):
    """A grating h = A sin(2 pi x / L) sampled ``per`` times a period over ``periods``
    periods along x, constant along y: (x, y, h, A, L)."""
    x = np.arange(periods * per) * (L / per)
    y = np.arange(rows) * (L / per)
    h = A * np.sin(2 * np.pi * x / L)[:, None] * np.ones(rows)[None, :]
    return x, y, h, A, L


def _topography(h, x, y):
    from SurfaceTopography import Topography

    return Topography(h, (x.size * (x[1] - x[0]), y.size * (y[1] - y[0])), unit="m")


# -- round trips through SurfaceTopography's own writers --------------------------------
@pytest.mark.parametrize("suffix, writer", [(".x3p", "to_x3p"), (".gwy", "to_gwy")])
def test_an_areal_grating_written_by_surfacetopography_reads_back_with_its_q(tmp_path, suffix, writer):
    # X3P (ISO 25178-72) and Gwyddion state their physical size and unit: nothing to give.
    # Reference: q_A = sqrt(1 + (2 pi A / l)^2) (Table II, A), the grating's slope being its
    # profile's. The periodic spline's slope errs by theta^4 / 180 relative at theta = 2 pi / 64
    # (5e-7), under the 1e-6 asked.
    x, y, h, A, L = _grating_map()
    f = tmp_path / f"grating{suffix}"
    getattr(_topography(h, x, y), writer)(str(f))
    s = hx.SampledSurface.from_file(f, periodic=True)
    assert s.h.shape == h.shape and s.dx == pytest.approx(x[1] - x[0], rel=1e-12)
    assert np.max(np.abs(s.h - h)) <= 1e-12 * A
    q = hx.characteristic_number(hx.algorithm("A", s, K0)).value
    assert q == pytest.approx(math.sqrt(1 + (2 * np.pi * A / L) ** 2), rel=1e-6)
    # and the same file through load_texture, which picks the surface class from the file
    assert isinstance(hx.load_texture(f), hx.SampledSurface)


def test_an_npy_map_states_no_size_and_needs_spacing_and_unit(tmp_path):
    x, y, h, A, L = _grating_map(rows=6)
    f = tmp_path / "map.npy"
    np.save(f, h / 1e-6)  # heights in micrometres, as a user's script would save them
    with pytest.raises(hx.ParameterError, match=r"map.npy \(NumPy array \(NPY\)\) does not state its height unit or "
                                                r"sample spacing: give --height-unit um --spacing 0.5um at the command line, "
                                                r"height_unit='um', spacing='0.5um' in Python$"):
        hx.SampledSurface.from_file(f)
    s = hx.SampledSurface.from_file(f, spacing=f"{float(x[1] - x[0]) * 1e6!r}um", height_unit="um")
    assert np.max(np.abs(s.h - h)) <= 1e-15 and s.x[-1] == pytest.approx(x[-1], rel=1e-12)


def test_a_line_of_a_map_is_the_profile_of_that_line(tmp_path):
    rng = np.random.default_rng(3)
    x = np.arange(30) * 10e-6
    y = np.arange(12) * 10e-6
    h = rng.normal(0, 1e-6, (30, 12))
    s = hx.SampledSurface(x, y, h)
    row = s.line(row=5)
    assert isinstance(row, hx.SampledProfile) and np.array_equal(row.h, h[:, 5])
    at = s.line(y=37e-6)  # between rows: the bicubic spline's section
    assert np.allclose(at.h, s.height_at(np.stack([x, np.full(x.size, 37e-6)], -1)), rtol=0, atol=1e-18)
    with pytest.raises(hx.ParameterError, match=r"^y = None, row = None is not allowed: give exactly one"):
        s.line()
    with pytest.raises(hx.ParameterError, match=r"^row = 12 is not allowed"):
        s.line(row=12)
    f = tmp_path / "m.x3p"
    _topography(h, x, y).to_x3p(str(f))
    with pytest.raises(hx.ParameterError, match=r"m.x3p: holds an areal map \(30 x 12 samples\), not a line scan: read "
                                                r"it with SampledSurface.from_file"):
        hx.SampledProfile.from_file(f)


@needs_data
def test_both_shared_files_through_the_new_readers():
    # data README: the Dektak CSV is 9600 samples over 1500 um; the .mat states neither
    # spacing nor unit, and is refused in one line naming both
    from haptex._loaders import read_topography

    r = read_topography(DEKTAK)
    assert r.reader == "SurfaceTopography: Plain text (x,y,z coordinates)" and r.h.size == 9600
    with pytest.raises(hx.ParameterError) as err:
        hx.load_texture(GROOVES)
    msg = str(err.value)
    assert "\n" not in msg and "--spacing" in msg and "--height-unit" in msg
    with pytest.raises(hx.ParameterError, match=r"grooves-4mm-profile.mat: holds a line scan \(8000 samples\), not an "
                                                r"areal map"):
        hx.SampledSurface.from_file(GROOVES, spacing="0.5um", height_unit="um")


# -- bad input -----------------------------------------------------------------------------
def test_undefined_regions_of_a_map_are_refused_or_filled_on_request(tmp_path):
    # instruments write NaN where they lost the surface; the X3P stores them as such
    x, y, h, A, L = _grating_map(rows=16)
    h = h.copy()
    h[40:44, 3:6] = np.nan
    f = tmp_path / "holes.x3p"
    _topography(np.ma.masked_invalid(h), x, y).to_x3p(str(f))
    with pytest.raises(hx.ParameterError, match=r"holes.x3p: 12 of 4096 heights are undefined \(NaN: the instrument lost "
                                                r"them\), the first at sample \(40, 3\); crop to the measured part \(--crop auto .*\), or fill them"):
        hx.SampledSurface.from_file(f)
    s = hx.SampledSurface.from_file(f, fill_undefined=True)
    # a harmonic fill of a 4 x 3 hole in a grating of amplitude A stays within the hole's
    # neighbours' range and is finite everywhere
    assert np.all(np.isfinite(s.h))
    assert np.max(np.abs(s.h[40:44, 3:6])) <= A


def test_a_truncated_instrument_file_is_one_line(tmp_path):
    x, y, h, A, L = _grating_map()
    f = tmp_path / "whole.x3p"
    _topography(h, x, y).to_x3p(str(f))
    cut = tmp_path / "cut.x3p"
    cut.write_bytes(f.read_bytes()[: f.stat().st_size // 2])
    with pytest.raises(hx.ParameterError) as err:
        hx.load_texture(cut)
    assert "\n" not in str(err.value) and str(err.value).startswith(str(cut))


def test_a_map_too_large_for_memory_is_refused_before_its_data_are_read(tmp_path, monkeypatch):
    # the estimate is ST_BYTES_PER_SAMPLE bytes a sample, from the size the header states
    from haptex import _loaders

    x, y, h, A, L = _grating_map(rows=64)  # 256 x 64 samples
    f = tmp_path / "big.x3p"
    _topography(h, x, y).to_x3p(str(f))
    need = _loaders.ST_BYTES_PER_SAMPLE * h.size
    monkeypatch.setenv("HAPTEX_MEMORY_BUDGET", str(need - 1))
    monkeypatch.setattr(_loaders, "TEXT_BYTES_FACTOR", 1)  # the file's own size passes
    with pytest.raises(hx.ParameterError, match=r"^path = .* is not allowed: a 256 x 64 XML 3D surface profile \(X3P\) "
                                                r"map would need"):
        hx.SampledSurface.from_file(f)


# -- band-limiting to the device -----------------------------------------------------------
def test_the_cutoff_is_the_limit_it_names_computed_by_hand():
    dev = hx.Device.pantograph()  # T = 100 us, delta = 10 um, F_0 = 400 Hz (Section V)
    # at 0.1 m/s: alpha v T = 5 x 0.1 x 1e-4 = 50 um, beta delta = alpha delta = 50 um,
    # v / F_0 = 0.1 / 400 = 250 um: the structural limit sets l_c
    c = rendering_cutoff(dev, 0.1)
    assert c.period == pytest.approx(250e-6, rel=1e-15) and c.set_by == ("device structural",)
    # at 10 mm/s: v / F_0 = 25 um and alpha v T = 5 um; both reconstruction limits give 50 um
    c = rendering_cutoff(dev, 0.01)
    assert c.period == pytest.approx(50e-6, rel=1e-15)
    assert c.set_by == ("low-speed reconstruction", "high-speed reconstruction")


@needs_data
def test_design_on_the_raw_dektak_scan_analyses_what_the_pantograph_renders():
    p = hx.SampledProfile.from_file(DEKTAK)
    d = design(p, hx.Device.pantograph(), K0, speed=0.1)
    bl = d["band_limit"]
    assert bl["applied"] and bl["cutoff"] == pytest.approx(250e-6) and bl["set_by"] == ["device structural"]
    # by hand: 0.15625 um a sample; 250 um / 32 = 7.8125 um keeps every 50th sample:
    # ceil(9600 / 50) = 192 samples
    assert bl["samples"] == {"raw": 9600, "rendered": 192}
    assert bl["raw"]["shortest_period"] == pytest.approx(2 * 1500e-6 / 9600)  # the raw Nyquist period
    assert d["texture_numbers"]["shortest_period"] == pytest.approx(250e-6)
    # the rendered texture passes the four period limits the cut-off came from
    period_limits = {"scanning velocity", "low-speed reconstruction", "high-speed reconstruction", "device structural"}
    assert all(lim["passed"] for lim in d["limits"] if lim["name"] in period_limits)
    # the data README's 16 um tilt is a 1.5 mm component: the dominant period is the scan
    assert bl["raw"]["dominant_period"] == pytest.approx(1500e-6, rel=1e-3)
    assert 0 < bl["raw"]["rms_removed"] < bl["raw"]["rms"]


def test_band_limited_keeps_the_rendered_texture_and_thins_its_samples():
    # a periodic profile: two sinusoids at 1 mm and 50 um, cut at 200 um: the 1 mm one is kept
    # exactly (Fourier resampling of a band-limited periodic signal is exact)
    n = 4096
    x = np.arange(n) * (2e-3 / n)
    h = 1e-6 * np.sin(2 * np.pi * x / 1e-3) + 0.3e-6 * np.sin(2 * np.pi * x / 50e-6)
    p = hx.SampledProfile(x, h, periodic=True).band_limited(200e-6)
    assert p.h.size == math.ceil(2e-3 * 32 / 200e-6) == 320
    assert np.max(np.abs(p.h - 1e-6 * np.sin(2 * np.pi * p.x / 1e-3))) < 1e-12 * 1e-6
    assert p.shortest_period == 200e-6


@pytest.mark.long  # 8 s (was -m slow, run by nothing)
@needs_data
def test_design_cli_on_the_raw_dektak_scan_and_raw_on_request():
    r = subprocess.run([sys.executable, "-m", "haptex", "design", "--texture", str(DEKTAK), "--json"],
                       capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    out = json.loads(r.stdout)
    assert out["band_limit"]["set_by"] == ["device structural"] and len(out["rows"]) == 8
    r = subprocess.run([sys.executable, "-m", "haptex", "design", "--texture", str(DEKTAK), "--raw"],
                       capture_output=True, text=True, timeout=120)
    # raw, the Nyquist period 0.31 um makes the 1 mm rendering region 3200 periods deep
    assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1
    assert "at most 1000 shortest periods of" in r.stderr and "um or less;" in r.stderr  # (--max-penetration's bound)
    assert "--lowpass for a line scan" in r.stderr


def test_design_cli_reads_an_areal_map_as_a_surface(tmp_path):
    # the file decides: an areal map is a surface, which needs a 3-DOF device (refused at once)
    x, y, h, A, L = _grating_map(periods=2, per=32, A=20e-6, L=2e-3, rows=32)
    f = tmp_path / "g.x3p"
    _topography(h, x, y).to_x3p(str(f))
    r = run_main("design", "--texture", str(f), "--device", "pantograph")
    assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1
    assert "--device pantograph is not allowed with a surface: the pantograph is planar" in r.stderr


@pytest.mark.long  # 9 s (was -m slow, run by nothing)
def test_design_cli_analyses_an_areal_map_on_a_3dof_device(tmp_path):
    x, y, h, A, L = _grating_map(periods=2, per=32, A=20e-6, L=2e-3, rows=32)
    f = tmp_path / "g.x3p"
    _topography(h, x, y).to_x3p(str(f))
    r = subprocess.run([sys.executable, "-m", "haptex", "design", "--texture", str(f), "--periodic",
                        "--device", "serial-arm", "--json"], capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    out = json.loads(r.stdout)
    assert out["texture"].startswith("SampledSurface(64x32") and [row["algorithm"] for row in out["rows"]] == list("WABCDEFG")
    # the grating's slope is its profile's: q_A = sqrt(1 + (2 pi A / l)^2) (Table II)
    q = {row["algorithm"]: row["q"] for row in out["rows"]}
    assert q["A"] == pytest.approx(math.sqrt(1 + (2 * np.pi * A / L) ** 2), rel=1e-4)


@pytest.mark.parametrize("suffix", [".txt", ".asc", ".dat"])
def test_a_text_file_of_x_y_z_rows_is_a_map_of_its_points(tmp_path, suffix):
    # The XYZ layout (one point a row: x, y, height; SurfaceTopography's test corpus's xyz-1.txt,
    # xyz-2.txt) under the extensions its plain-text matrix reader also claims: SurfaceTopography's
    # own detection reads it as points (its XYZ reader is tried before the matrix reader), and
    # haptex tried the readers of the extension first, so it read the three columns as a matrix
    # three samples wide ("x has 3 samples, which is not allowed"). Reference: the rows as
    # written, h = x + 10 y (um) on a 6 x 5 grid of 1 um, in an order of their own.
    xs, ys = np.arange(6.0), np.arange(5.0)
    rows = [(x, y, x + 10 * y) for y in ys for x in xs]
    rows = rows[1::2] + rows[::2]  # (points need no order)
    f = tmp_path / f"points{suffix}"
    f.write_text("".join(f"{x:g} {y:g} {z:g}\n" for x, y, z in rows))
    s = hx.load_texture(f, x_unit="um", height_unit="um")
    assert isinstance(s, hx.SampledSurface) and s.h.shape == (6, 5)
    np.testing.assert_allclose(s.x, xs * 1e-6, atol=1e-18)
    np.testing.assert_allclose(s.y, ys * 1e-6, atol=1e-18)
    np.testing.assert_allclose(s.h, (xs[:, None] + 10 * ys[None, :]) * 1e-6, rtol=1e-12)


def test_a_matlab_matrix_is_an_areal_map_rows_along_y(tmp_path):
    # MATLAB stores a height map as an image: row j is y_j, column i is x_i; haptex's own
    # MATLAB reader (SurfaceTopography's drops non-numeric variables silently) keeps that
    from scipy.io import savemat

    rng = np.random.default_rng(5)
    img = rng.normal(0, 1, (6, 9))  # 6 rows (y) x 9 columns (x), heights in um
    f = tmp_path / "map.mat"
    savemat(f, {"z": img})
    s = hx.SampledSurface.from_file(f, spacing="2um", height_unit="um")
    assert s.h.shape == (9, 6) and np.allclose(s.h, img.T * 1e-6, rtol=1e-15, atol=0)
    assert s.dx == pytest.approx(2e-6) and s.dy == pytest.approx(2e-6)


@needs_data
def test_a_channel_named_twice_is_chosen_by_its_index():
    # di-1.di (Bruker Dimension V, ../shared/data) holds four channels, the first two both named
    # 'Height' (SurfaceTopography's reader lists them: Height, Height, Phase, AmplitudeError).
    # The name alone is refused naming their indexes (before 2026-12-01 it read the first,
    # silently); an index chooses one: channel 1's heights are SurfaceTopography's own for
    # channel_index=1 (nm), unlike channel 0's, and its source names it. An index past the last
    # is refused.
    import SurfaceTopography

    path = DEKTAK.parent / "di-1.di"
    with pytest.raises(hx.ParameterError, match=r"2 channels named 'Height' \(0 and 1\).*--variable 0"):
        hx.load_texture(path, variable="Height")
    reader = SurfaceTopography.open_topography(str(path))
    want = reader.topography(channel_index=1).heights() * 1e-9  # (its unit: nm)
    got = hx.load_texture(path, variable="1")
    assert np.allclose(got.h, want, rtol=1e-12, atol=0.0)
    assert got.source == "di-1.di, channel 1 (Height)"  # (the channel read, wherever the texture is shown)
    assert not np.allclose(hx.load_texture(path, variable="0").h, want)
    with pytest.raises(hx.ParameterError, match=r"variable = '4' is not allowed.*0 to 3"):
        hx.load_texture(path, variable="4")
