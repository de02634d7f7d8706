"""Measured profiles, band-limited noise, the six rendering limits, the passivity condition
and the design question (issue 6), on synthetic data and on the two real profiles in
../shared/data (skipped, saying why, when that folder is absent)."""

import json
import math
import subprocess
import sys

import numpy as np
import pytest
from scipy.interpolate import CubicSpline

import haptex as hx
from haptex import core
from haptex.design import design

from .conftest import DEKTAK, GROOVES, needs_data
from .test_cli import run_main, unknown_options_named
from .test_probe import _vertical_q



# -- loaders -----------------------------------------------------------------------------
@needs_data
def test_dektak_export_is_read_through_surfacetopography_with_its_units():
    p = hx.SampledProfile.from_file(DEKTAK)
    # issue 13: 9600 samples over 1499.8 um (the last lateral position printed); the header's
    # "Length,1500.0 um" over 9600 samples is 0.15625 um per sample, which the column, printed
    # to 0.1 um, rounds (its stated "Resolution,0.156 um/sample" is itself rounded: 9599 x
    # 0.156 um = 1497.4 um would miss the last position by 2.4 um)
    assert p.x.size == 9600
    assert p.x[-1] - p.x[0] == pytest.approx(1499.8e-6, abs=0.05e-6)
    assert p.dx == pytest.approx(1500e-6 / 9600, rel=1e-9)
    from SurfaceTopography import open_topography

    printed = open_topography(str(DEKTAK)).topography().positions() * 1e-6
    assert np.max(np.abs(p.x - printed)) <= 0.05e-6 * (1 + 1e-6)  # within the printing's half quantum
    assert p.h[0] == pytest.approx(-0.00933e-6, rel=1e-9) and p.h[-1] == pytest.approx(16.58112e-6, rel=1e-9)
    # data README: a tilt of about 16 um over the scan, which leveling removes
    slope = np.polyfit(p.x, p.h, 1)[0]
    assert slope * 1.5e-3 == pytest.approx(16e-6, rel=0.1)
    q = p.leveled()
    assert abs(np.polyfit(q.x, q.h, 1)[0]) < 1e-12
    assert q.height_range[1] - q.height_range[0] < 1e-6  # a polished surface: sub-micrometre


@needs_data
def test_mat_file_needs_spacing_and_unit_and_never_guesses():
    with pytest.raises(hx.ParameterError, match=r"grooves-4mm-profile.mat does not state its sample spacing or height "
                                                r"unit: give --spacing 0.5um --height-unit mm at the command line, "
                                                r"spacing='0.5um', height_unit='mm' in Python$"):
        hx.SampledProfile.from_file(GROOVES)
    with pytest.raises(hx.ParameterError, match="give --height-unit mm at the command line, height_unit='mm'"):
        hx.SampledProfile.from_file(GROOVES, spacing="0.5um")
    g = hx.SampledProfile.from_file(GROOVES, spacing="0.5um", height_unit="um")
    assert g.x.size == 8000 and g.length == pytest.approx(7999 * 0.5e-6)
    assert g.height_range[0] == pytest.approx(-0.622e-6, rel=2e-3)  # grooves about 0.6 units deep


def write(tmp_path, name, text, encoding="utf-8", newline="\n"):
    f = tmp_path / name
    f.write_bytes(text.replace("\n", newline).encode(encoding))
    return f


def test_csv_columns_with_units_from_the_caller(tmp_path):
    x = np.arange(20) * 2.0
    rows = "\n".join(f"{a:.1f},{1000 * math.sin(a / 5):.6f}" for a in x)
    f = write(tmp_path, "p.csv", "x,h\n" + rows + "\n", newline="\r\n")
    with pytest.raises(hx.ParameterError, match=r"does not state its height unit or lateral unit: give --height-unit um "
                                                r"--x-unit um at the command line, height_unit='um', x_unit='um' in Python$"):
        hx.SampledProfile.from_file(f)
    with pytest.raises(hx.ParameterError, match="does not state its lateral unit: give --x-unit um at the command line, x_unit='um' in Python"):
        hx.SampledProfile.from_file(f, height_unit="nm")
    p = hx.SampledProfile.from_file(f, x_unit="um", height_unit="nm")
    assert p.dx == pytest.approx(2e-6) and p.h[5] == pytest.approx(1e-6 * math.sin(2.0), rel=1e-6)


@pytest.mark.parametrize("header", ["x (um),h (nm)", "x [\u00b5m];z [nm]", "X (mm)\tHeight (um)"])
def test_columns_whose_names_state_their_units_are_read_in_them(tmp_path, header):
    # A profile's two columns named with their units ("x (um),h (nm)", as spreadsheets and
    # instruments' exports head them): SurfaceTopography's XYZ reader read past the names and
    # haptex asked for the units the file states (2026-12-02; a table of four or more named
    # columns took them from its names already). Truth: the numbers as written, in the units
    # the names state (numpy); a unit given that contradicts a name's is refused naming both
    import re

    x = np.arange(40) * 2.0
    z = np.round(1000 * np.sin(x / 5), 6)
    sep = re.search(r"[,;\t]", header).group(0)
    f = write(tmp_path, "p.csv", header + "\n" + "\n".join(f"{a:.1f}{sep}{b:.6f}" for a, b in zip(x, z)) + "\n")
    units = re.findall(r"[(\[](.+?)[)\]]", header)
    factor = {"um": 1e-6, "\u00b5m": 1e-6, "nm": 1e-9, "mm": 1e-3}
    p = hx.SampledProfile.from_file(f)
    assert p.dx == pytest.approx(2.0 * factor[units[0]])
    np.testing.assert_allclose(p.h, z * factor[units[1]], rtol=1e-12)
    other = "mm" if units[1] != "mm" else "nm"
    with pytest.raises(hx.ParameterError, match=rf"height_unit = '{other}' is not allowed: .* states its heights' unit"):
        hx.SampledProfile.from_file(f, height_unit=other)
    assert hx.SampledProfile.from_file(f, height_unit=units[1]).h[3] == pytest.approx(p.h[3])  # (the same unit: read)


@pytest.mark.parametrize("sep", [";", "\t", " "])
def test_columns_written_with_a_decimal_comma_are_read_as_written(tmp_path, sep):
    # A profile exported where the comma is the decimal mark (a German or French locale's CSV:
    # Excel and the instruments' software there write "0,0005;0,000063", the cells parted by a
    # semicolon, a tab or a space): the text-column reader split every cell at its comma too,
    # so that "0,0005;0,000063" read as four numbers and x = 0 on every row ("x = 0 does not
    # increase"). Truth: the numbers as written, the comma read as the decimal mark
    x = np.arange(400) * 0.0005  # mm
    z = 0.002 * np.sin(2 * np.pi * x / 0.1)  # mm
    rows = "\n".join(f"{a:.4f}{sep}{b:.6f}".replace(".", ",") for a, b in zip(x, z))
    f = write(tmp_path, "eu.csv", "X [mm]" + sep + "Z [mm]\n" + rows + "\n")
    p = hx.SampledProfile.from_file(f, x_unit="mm", height_unit="mm")
    assert p.x.size == 400 and p.dx == pytest.approx(0.5e-6, rel=1e-9)
    np.testing.assert_allclose(p.h, np.round(z, 6) * 1e-3, rtol=0, atol=1e-15)


@pytest.mark.parametrize("suffix", [".csv", ".txt"])
def test_one_column_written_with_a_decimal_comma_is_read_as_written(tmp_path, suffix):
    # One column of heights exported where the comma is the decimal mark (pandas' to_csv with
    # decimal=",", as a German or French locale's spreadsheet writes it: "0,3456", "-1,3032"):
    # every line split at its comma into "x" and "height", and the file refused for x that
    # does not increase, or for stating positions it does not have ("spacing = 1e-06 is not
    # allowed: ... states its positions", 2026-12-02). Truth: the numbers as pandas wrote
    # them, the comma read as the decimal mark; a two-column file of whole numbers whose first
    # column increases (test_bad_profiles_name_the_file_and_line's) is still x and height
    import pandas as pd

    rng = np.random.default_rng(3)
    h = np.round(rng.normal(0.0, 0.8, 300), 4)  # um
    for sep in (";", ","):  # (with "," pandas quotes each cell, "0,5", as RFC 4180 says)
        f = tmp_path / f"heights{suffix}"
        pd.DataFrame({"height": h}).to_csv(f, index=False, decimal=",", sep=sep)
        assert "0," in f.read_text() and "." not in f.read_text()  # (as written: a comma for the decimal mark)
        p = hx.SampledProfile.from_file(f, spacing="0.5um", height_unit="um")
        assert p.x.size == 300 and p.dx == pytest.approx(0.5e-6)
        np.testing.assert_allclose(p.h, h * 1e-6, rtol=0, atol=1e-18)
    # (small heights, every whole part 0: "0,0012")
    f2 = tmp_path / f"small{suffix}"
    pd.DataFrame({"z": np.abs(h) * 1e-3}).to_csv(f2, index=False, header=False, decimal=",", float_format="%.7f")
    p = hx.SampledProfile.from_file(f2, spacing="0.5um", height_unit="mm")
    np.testing.assert_allclose(p.h, np.round(np.abs(h) * 1e-3, 7) * 1e-3, rtol=0, atol=1e-18)
    with pytest.raises(hx.ParameterError, match="variable = '1' is not allowed: .* is read as text columns"):
        hx.SampledProfile.from_file(f2, spacing="0.5um", height_unit="mm", variable="1")  # (not ignored)


def test_a_table_of_named_columns_is_read_by_the_column_named(tmp_path, capsys):
    # A stylus profilometer's export as its users document it (jonathan-bender/scaling-octo-telegram's
    # README: tab-separated, "Counter, Altitude (um), Encoder1 (um), Encoder2 (um), Row number",
    # the step in a separate parameters file, "X step distance = 0.005 mm"): SurfaceTopography's
    # plain-text matrix reader read it as a map 5 samples wide, and design refused it for
    # spanning "20 um along x" (2026-12-02). A text table of four or more named columns is read
    # by its columns: the heights' named (by name or index, --variable), in the unit its name
    # states ("Altitude (µm)"), the positions from the spacing. Truth: the numbers as written
    from haptex.cli import main

    n = 2000
    alt = np.round(623.3 + 0.5 * np.sin(2 * np.pi * np.arange(n) * 0.005 / 0.4), 4)  # um
    rows = "".join(f"{37 + k}\t{a:.4f}\t-1.4\t0\t1\n" for k, a in enumerate(alt))
    f = tmp_path / "reading.txt"
    f.write_text("Counter\tAltitude (\u00b5m)\tEncoder1 (\u00b5m)\tEncoder2 (\u00b5m)\tRow number\n" + rows,
                 encoding="utf-8")
    with pytest.raises(hx.ParameterError, match=r"reading.txt: a table of 5 named columns \(0 Counter, 1 Altitude "
                       r"\(\u00b5m\), .*4 Row number\): choose the heights' column by its name or its index, "
                       r"--variable 1 at the command line, variable='1' in Python"):
        hx.SampledProfile.from_file(f, spacing="5um")
    for which in ("1", "Altitude (\u00b5m)"):
        p = hx.SampledProfile.from_file(f, spacing="5um", variable=which)
        assert p.x.size == n and p.dx == pytest.approx(5e-6)
        np.testing.assert_allclose(p.h, alt * 1e-6, rtol=1e-12)
    with pytest.raises(hx.ParameterError, match="the file gives no abscissa: give the sample spacing"):
        hx.SampledProfile.from_file(f, variable="1")
    assert main(["design", "--texture", str(f), "--device", "omega-3", "--algorithms", "A", "--quiet"]) == 2
    assert "--variable 1 at the command line" in capsys.readouterr().err
    assert main(["design", "--texture", str(f), "--device", "omega-3", "--algorithms", "A", "--variable", "1",
                 "--spacing", "5um", "--quiet"]) == 0


@pytest.mark.parametrize("decimal", [".", ","])
def test_quoted_cells_are_read_as_written(tmp_path, decimal):
    # A CSV whose every cell is quoted (RFC 4180 allows it; Python's csv.writer with QUOTE_ALL
    # and the software built on it write it: '"0.500","0.479426"') was refused: "no numeric data
    # found" (2026-12-02). Truth: the numbers as Python's csv module wrote them, with a decimal
    # point, and with a decimal comma inside the quotes beside the commas that part the cells
    import csv

    x = np.arange(60) * 0.5  # um
    z = np.round(np.sin(x / 3), 6)  # um
    f = tmp_path / "quoted.csv"
    with open(f, "w", newline="") as fh:
        w = csv.writer(fh, quoting=csv.QUOTE_ALL)
        w.writerow(["x (um)", "z (um)"])
        for a, b in zip(x, z):
            w.writerow([f"{a:.3f}".replace(".", decimal), f"{b:.6f}".replace(".", decimal)])
    p = hx.SampledProfile.from_file(f, x_unit="um", height_unit="um")
    assert p.x.size == 60 and p.dx == pytest.approx(0.5e-6)
    np.testing.assert_allclose(p.h, z * 1e-6, rtol=0, atol=1e-18)


@pytest.mark.parametrize("text, pattern", [
    ("0,1\n1,2\n2,nan\n3,4\n4,5\n", r"p.csv: 1 of 5 heights are undefined \(NaN: the instrument lost them\), the "
                                       r"first at sample 2; crop to the measured part \(.*\), or fill them by interpolation \(--fill-undefined"),
    ("0,1\n1,2\n1,3\n3,4\n4,5\n", r"p.csv, sample 2: x = 1e-06 does not increase"),
    ("0,1\n1,2\n2,3\n", r"p.csv: 3 samples, which is not allowed: at least 4"),
    ("0,1\n1,2\n2,x3\n3,4\n", r"p.csv, line 3: '2,x3' is not numbers"),
])
def test_bad_profiles_name_the_file_and_line(tmp_path, text, pattern):
    f = write(tmp_path, "p.csv", text)
    with pytest.raises(hx.ParameterError, match=pattern):
        hx.SampledProfile.from_file(f, x_unit="um", height_unit="um")


def test_bad_unit_and_unreadable_encoding(tmp_path):
    f = write(tmp_path, "p.csv", "0,1\n1,2\n2,3\n3,4\n")
    with pytest.raises(hx.ParameterError, match=r"^height_unit = 'furlong-ish' is not allowed"):
        hx.SampledProfile.from_file(f, x_unit="um", height_unit="furlong-ish")
    # UTF-16 text, refused by haptex's own reader, is read by SurfaceTopography's
    g = write(tmp_path, "u16.csv", "0,1\n1,2\n2,3\n3,4\n", encoding="utf-16")
    assert hx.SampledProfile.from_file(g, x_unit="um", height_unit="um").h.tolist() == pytest.approx([1e-6, 2e-6, 3e-6, 4e-6])
    b = tmp_path / "junk.dat"
    b.write_bytes(bytes(range(256)) * 4)
    with pytest.raises(hx.ParameterError, match=r"junk.dat: SurfaceTopography recognises none of its formats in it, and it "
                                                r"is not text either"):
        hx.SampledProfile.from_file(b, x_unit="um", height_unit="um")


def test_a_compressed_file_is_refused_as_the_archive_it_is(tmp_path):
    # a gzip file (RFC 1952: it opens with the bytes 1f 8b) or a ZIP archive (PKWARE's APPNOTE:
    # a local file header "PK\x03\x04"), made by Python's own gzip and zipfile, of a text matrix
    # SurfaceTopography reads unpacked: neither it nor haptex's text reader opens them (as
    # SurfaceTopography's corpus's matrix-4.txt.gz and container-*.zip), and the refusal said "not
    # text either (NUL bytes)". It names the archive, what it holds and how to unpack it.
    import gzip
    import zipfile

    text = "\n".join(" ".join(str(i * j) for i in range(6)) for j in range(6)) + "\n"
    g = tmp_path / "map.txt.gz"
    g.write_bytes(gzip.compress(text.encode()))
    with pytest.raises(hx.ParameterError, match=r"map.txt.gz: a gzip-compressed file.*gunzip .*map.txt.gz"):
        hx.load_texture(g, x_unit="um", height_unit="um")
    z = tmp_path / "maps.zip"
    with zipfile.ZipFile(z, "w", zipfile.ZIP_DEFLATED) as archive:
        archive.writestr("one.txt", text)
        archive.writestr("two.txt", text)
    with pytest.raises(hx.ParameterError, match=r"maps.zip: a ZIP archive of 2 files \(one.txt, two.txt\).*unzip"):
        hx.load_texture(z, x_unit="um", height_unit="um")


def test_undefined_heights_are_filled_only_when_asked(tmp_path):
    f = write(tmp_path, "p.csv", "0,1\n1,2\n2,nan\n3,4\n4,5\n5,6\n")
    p = hx.SampledProfile.from_file(f, x_unit="um", height_unit="um", fill_undefined=True)
    # SurfaceTopography fills a line scan's gap linearly between its neighbours (2 and 4 um)
    assert p.h[2] == pytest.approx(3e-6, rel=1e-12)


# -- the spline texture --------------------------------------------------------------------
def test_spline_is_C2_matches_scipy_and_the_compiled_kernel():
    rng = np.random.default_rng(3)
    x = np.arange(40) * 25e-6
    h = 1e-5 * rng.standard_normal(40)
    p = hx.SampledProfile(x, h)
    ref = CubicSpline(x, h)  # not-a-knot, the reference interpolant
    xi = np.linspace(x[0], x[-1], 2001)
    np.testing.assert_allclose(p.height(xi), ref(xi), atol=1e-18)
    np.testing.assert_allclose(p.slope(xi), ref(xi, 1), atol=1e-12)
    np.testing.assert_allclose(p.curvature(xi), ref(xi, 2), rtol=1e-9, atol=1e-6)
    for xv in np.r_[xi[::97], -1e-4, 2e-3]:
        got = core.texture_derivatives(p, [float(xv), 0.0])[[0, 1, 3]]
        ref_k = [float(p.height(xv)), float(p.slope(xv)), float(p.curvature(xv))]
        np.testing.assert_allclose(got, ref_k, rtol=1e-12, atol=1e-15)
    # h'' continuous across the interior knots (C^2): the left interval's end value
    # (one ulp left of the knot) equals the right interval's start value
    knots = x[1:-1]
    left = p.curvature(np.nextafter(knots, -np.inf))
    np.testing.assert_allclose(left, p.curvature(knots), rtol=1e-8, atol=1e-6)
    # exact sup |h'| and |h''| against dense sampling
    dense = np.linspace(x[0], x[-1], 400001)
    assert p.max_slope == pytest.approx(np.abs(p.slope(dense)).max(), rel=1e-6)
    assert p.max_curvature == pytest.approx(np.abs(p.curvature(dense)).max(), rel=1e-6)


@pytest.mark.parametrize("delta", [1e-10, 1e-9])
def test_q_of_b_and_c_on_a_sampled_profile_reads_a_one_sample_spike_of_its_curvature(delta):
    # A spline's h'' is linear on each interval, so B's and C's Jacobians (eqs. 11 and 15, made
    # of h' and h'') peak at a sample; a felt profile refined near its troughs' radius carries
    # the path's curvature spike on one or two samples. One sample of a sine raised by delta
    # (0.1 and 1 nm: h'' there 3 and 30 times the sine's), between the search grid's points
    # (2,048 over 4,096 samples): the search read q 57 and 41 % low before it took every
    # interval's ends (2026-11-27). Truth: scipy's periodic CubicSpline's h', h'' at both ends
    # of every interval and the paper's Jacobians with their 2 x 2 norms in closed form, over
    # 64 depths in (0, 1 mm] (test_probe's _vertical_q, numpy alone)
    n, period = 4096, 2e-3
    x = np.arange(n) * (period / n)
    h = 0.05e-3 * np.sin(2 * np.pi * x / period)
    h[1025] += delta
    p = hx.SampledProfile(x, h, periodic=True, shortest_period=period / 32)  # (as a refined felt profile keeps its first grid's)
    ref = CubicSpline(np.r_[x, period], np.r_[h, h[0]], bc_type="periodic")
    ends = np.r_[x, x + (period / n) * (1 - 1e-9)]
    truth = _vertical_q(ref(ends, 1), ref(ends, 2), np.linspace(1e-3 / 64, 1e-3, 64))
    for letter in "BC":
        got = hx.characteristic_number(hx.algorithm(letter, p, 2000.0)).value
        assert got == pytest.approx(truth[letter], rel=1e-4), letter


def test_periodic_profile_wraps_smoothly():
    x = np.arange(64) * 1e-5
    h = 1e-4 * np.sin(2 * np.pi * x / 64e-5)
    p = hx.SampledProfile(x, h, periodic=True)
    xi = np.linspace(-1e-3, 2e-3, 777)
    np.testing.assert_allclose(p.height(xi + p.period), p.height(xi), atol=1e-15)
    # an exactly periodic sine is reproduced closely by the periodic spline
    np.testing.assert_allclose(p.height(xi), 1e-4 * np.sin(2 * np.pi * xi / 64e-5), atol=1e-4 * 1e-4)


def test_lowpass_band_limits_and_scaled_stretches():
    x = np.arange(4000) * 1e-6
    slow = 1e-5 * np.sin(2 * np.pi * x / 400e-6)  # period 400 um: kept
    fast = 1e-5 * np.sin(2 * np.pi * x / 10e-6)  # period 10 um: removed
    p = hx.SampledProfile(x, slow + fast).lowpass(40e-6)
    mid = slice(500, 3500)  # away from the filter's end effects
    assert np.abs(p.h[mid] - slow[mid]).max() < 0.01 * 1e-5
    assert p.shortest_period == 40e-6
    q = hx.SampledProfile(x, slow, periodic=True).lowpass(40e-6)
    f, amp = q.spectrum()
    assert amp[f > 1 / 40e-6].max() < 1e-20  # periodic: FFT components above the cut-off are gone
    s = p.scaled(10, 2)
    assert s.length == pytest.approx(10 * p.length) and s.max_slope == pytest.approx(p.max_slope * 2 / 10, rel=1e-9)
    with pytest.raises(hx.ParameterError, match="longer than the Nyquist period"):
        p.lowpass(1e-6)


def test_band_limited_noise():
    n = hx.BandLimitedNoise(rms=0.1e-3, shortest_period=0.5e-3, longest_period=5e-3, length=20e-3, seed=7)
    x = np.linspace(0, 20e-3, 200000, endpoint=False)
    h = n.height(x)
    assert np.sqrt(np.mean(h**2)) == pytest.approx(0.1e-3, rel=1e-9)  # exact RMS
    assert n.periods.min() >= 0.5e-3 * (1 - 1e-12) and n.periods.max() <= 5e-3 * (1 + 1e-12)  # in band
    np.testing.assert_allclose(n.height(x + 20e-3), h, atol=1e-15)  # periodic over length
    again = hx.BandLimitedNoise(0.1e-3, 0.5e-3, 5e-3, 20e-3, seed=7)
    np.testing.assert_array_equal(again.height(x[:100]), h[:100])  # reproducible
    other = hx.BandLimitedNoise(0.1e-3, 0.5e-3, 5e-3, 20e-3, seed=8)
    assert not np.allclose(other.height(x[:100]), h[:100])
    assert n.max_slope == pytest.approx(np.abs(n.slope(x)).max(), rel=1e-4)
    with pytest.raises(hx.ParameterError, match="^longest_period = "):
        hx.BandLimitedNoise(1e-4, 2e-3, 1e-3, 20e-3)


# -- device limits ---------------------------------------------------------------------------
def test_section_V_numbers_of_the_rendering_limits():
    # Section V: at v < 0.2 m/s, T = 100 us, l = 1 mm, at least 50 samples a period, and the
    # 200 Hz texture frequency is within the 400 Hz flat band of the device.
    dev = hx.Device.pantograph()
    lim = {x.name: x for x in hx.texture_limits(hx.Sinusoid(0.8e-3, 1e-3), dev, 0.2, 2000.0, samples_per_period=50)}
    assert lim["scanning velocity"].lhs == pytest.approx(1.0)  # exactly 50 samples a period
    assert lim["device structural"].lhs == pytest.approx(200.0) and lim["device structural"].rhs == 400.0
    assert lim["device structural"].passed
    # gain: kappa_0 * 2 pi A / l against sigma_0(B) / (2T)
    assert lim["gain"].lhs == pytest.approx(2000 * 2 * math.pi * 0.8)
    assert lim["gain"].rhs == pytest.approx(dev.passivity_limit) and not lim["gain"].passed
    dev2 = hx.Device.point_mass(0.1, 0.5, 1e-4, position_resolution=15e-6, force_resolution=0.05)
    lim2 = {x.name: x for x in hx.texture_limits(hx.Sinusoid(0.1e-3, 0.05e-3), dev2, 0.05, 100.0)}
    assert lim2["low-speed reconstruction"].lhs == pytest.approx(5 * 15e-6 / 0.05e-3) and not lim2["low-speed reconstruction"].passed
    assert lim2["force reconstruction"].lhs == pytest.approx(5 * 0.05)
    assert lim2["force reconstruction"].rhs == pytest.approx(100 * 0.1e-3) and not lim2["force reconstruction"].passed


def test_a_flat_texture_meets_the_force_reconstruction_limit_vacuously_and_a_faint_one_does_not():
    # limit 4 (Section II-B) asks that the texture's force amplitude span gamma force quanta:
    # with no texture (amplitude 0) there is nothing to reconstruct, and an ideal device (no
    # quantum) read 0 < 0, "violated" (stop 77 noticed: design called a flat texture
    # unreproducible). A faint texture below the quanta still fails, at both sides of it
    ideal = hx.Device.point_mass(0.1, 0.5, 1e-4)
    coarse = hx.Device.point_mass(0.1, 0.5, 1e-4, force_resolution=0.05)

    def met(amplitude, dev):
        lim = {x.name: x for x in hx.texture_limits(hx.Sinusoid(amplitude, 1e-3), dev, 0.05, 100.0)}
        return lim["force reconstruction"].passed

    assert met(0.0, ideal) and met(0.0, coarse)
    assert met(1e-9, ideal)  # (any amplitude spans an ideal device's quanta)
    assert not met(2.4e-3, coarse) and not met(1e-6, coarse)  # (gamma b = 0.25 N; k A = 0.24 N, 1e-4 N)
    assert met(2.6e-3, coarse)  # (0.26 N)


def test_max_passive_stiffness_is_corollary_1():
    dev = hx.Device.point_mass(0.1, 0.5, 1e-4)
    assert hx.max_passive_stiffness(hx.algorithm("W", None, 1.0), dev) == pytest.approx(0.5 / (2 * 1e-4))
    a = hx.algorithm("A", hx.Sinusoid(0.8e-3, 1e-3), 1.0)
    qa = math.sqrt(1 + (2 * math.pi * 0.8) ** 2)
    assert hx.max_passive_stiffness(a, dev) == pytest.approx(2500 / qa, rel=1e-9)
    assert hx.passivity_condition(hx.algorithm("A", a.texture, 2500 / qa * 0.99), dev).holds
    assert not hx.passivity_condition(hx.algorithm("A", a.texture, 2500 / qa * 1.01), dev).holds
    assert hx.max_passive_stiffness(hx.algorithm("D", a.texture, 1.0), dev) == 0.0  # q_D unbounded here


def test_recommended_stiffness_holds_in_simulation_and_twice_the_real_limit_does_not():
    # Corollary 1 gives b/(2T) for the wall; the sampled wall's real limit is ~2b/T (its
    # closed-loop poles). The simulator: no limit cycle at the recommendation, one at 2x.
    m, b, T = 0.1, 0.5, 1e-4
    dev = hx.Device.point_mass(m, b, T)
    k_rec = hx.max_passive_stiffness(hx.algorithm("W", None, 1.0), dev)
    k_real = hx.critical_stiffness(m, b, T)
    assert k_rec < k_real
    push = hx.operators.ConstantForce([0.0, -1.0])
    ok = hx.simulate(hx.algorithm("W", None, k_rec), dev, push, 3.0, initial_position=[0.0, -1.2 / k_rec])
    bad = hx.simulate(hx.algorithm("W", None, 2 * k_real), dev, push, 3.0, initial_position=[0.0, -1.2 / (2 * k_real)])
    assert not ok.oscillating and bad.oscillating


# -- the design question on real profiles ------------------------------------------------------
@needs_data
@pytest.mark.parametrize("which", ["dektak", pytest.param("grooves", marks=pytest.mark.long)])  # (1.7 s: long set)
def test_design_on_real_profiles(which):
    if which == "dektak":
        p = hx.SampledProfile.from_file(DEKTAK).leveled().lowpass(20e-6).scaled(10, 1000)
    else:
        p = hx.SampledProfile.from_file(GROOVES, spacing="0.5um", height_unit="um").leveled().lowpass(10e-6).scaled(10, 100)
    x0 = p.domain[0] + 0.3 * p.length
    window = (x0, x0 + 4 * p.shortest_period)
    d = design(p, hx.Device.pantograph(), 500.0, x_range=window, n_loops=2)
    rows = {r["algorithm"]: r for r in d["rows"]}
    assert set(rows) == set("WABCDEFG")
    assert rows["C"]["conservative"] and rows["W"]["conservative"]  # gradients
    assert not rows["A"]["conservative"] and not rows["E"]["conservative"]
    assert rows["F"]["almost_conservative"]
    assert rows["E"]["q"] == pytest.approx(1.0, abs=1e-9)  # eq. 21, any texture
    assert rows["A"]["q"] <= math.sqrt(1 + p.max_slope**2) * (1 + 1e-9)  # eq. 10 with M (Remark 2)
    for r in rows.values():
        expected = 0.0 if math.isinf(r["q"]) else d["passivity_limit"] / r["q"]
        assert r["max_passive_stiffness"] == pytest.approx(expected)
        assert r["passive_at_stiffness"] == (500.0 <= r["max_passive_stiffness"])
    assert d["recommendation"]
    assert set(d["recommended"]) <= {L for L, r in rows.items() if r["passive_at_stiffness"]}


@needs_data
@pytest.mark.long  # 12 s (was -m slow, run by nothing)
def test_design_cli_on_the_dektak_file():
    r = subprocess.run([sys.executable, "-m", "haptex", "design", "--texture", str(DEKTAK), "--level", "--lowpass",
                        "20um", "--scale", "10,1000", "--stiffness", "500 N/m", "--window", "4mm,4.8mm", "--json"],
                       capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    out = json.loads(r.stdout)
    assert len(out["rows"]) == 8 and len(out["limits"]) == 6


@needs_data
def test_design_cli_refuses_a_mat_file_without_units():
    r = run_main("design", "--texture", str(GROOVES))
    assert r.returncode == 2
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and "grooves-4mm-profile.mat does not state its sample spacing" in lines[0]


# design reads a measured file, export writes its C source, run renders it (on the simulated Falcon)
_READERS = {"design": ("design", "--algorithms", "A", "--quiet"),  # (A alone: the reading is what is tested)
            "export": ("export", "--algorithm", "A", "--stiffness", "1kN/m", "--max-force", "3N", "--quiet"),
            "run": ("run", "--device", "simulated:falcon", "--fast", "--duration", "0.02s", "--quiet")}


@needs_data
@pytest.mark.parametrize("command", sorted(_READERS))
def test_a_file_without_units_is_read_by_every_command_with_the_options_its_refusal_names(command, tmp_path):
    # The MAT file as published (../shared/data/README.md: one variable z, no spacing, no height
    # unit) is refused by each command that reads a texture, naming the options that give them;
    # those options are the refusing command's own, and with them it reads the file (before
    # 2026-12-01 run named --spacing and --height-unit and had neither).
    args = (*_READERS[command], *(("--out", str(tmp_path / "out")) if command == "export" else ()))
    r = run_main(*args, "--texture", str(GROOVES))
    assert r.returncode == 2 and "does not state its sample spacing or height unit" in r.stderr
    assert "give --spacing 0.5um --height-unit mm at the command line" in r.stderr
    assert not unknown_options_named(args, r.stderr)
    r = run_main(*args, "--texture", str(GROOVES), "--spacing", "0.5um", "--height-unit", "mm")
    assert r.returncode == 0, r.stderr


@pytest.mark.parametrize("command", sorted(_READERS))
def test_a_mat_file_of_several_variables_is_read_by_every_command_naming_the_variable(command, tmp_path):
    # A MATLAB file of two variables (written by scipy.io.savemat, the format as published) is
    # refused naming them and the option that chooses one, an option of the refusing command;
    # with it each command reads that variable (before 2026-12-01 no command could: the remedy
    # was Python's variable=...). Design's JSON names the texture read: z's 4,000 samples at 0.5 um,
    # 1.9995 mm (x's 10 samples would be 4.5 um), its source the variable.
    from scipy.io import savemat

    path = tmp_path / "two.mat"
    savemat(path, {"z": 0.1 * np.sin(np.linspace(0.0, 20.0, 4000))[:, None], "x": np.zeros((10, 1))})
    args = (*_READERS[command], *(("--out", str(tmp_path / "out")) if command == "export" else ()),
            "--texture", str(path), "--spacing", "0.5um", "--height-unit", "mm")
    r = run_main(*args)
    assert r.returncode == 2 and "holds variables ['z', 'x']" in r.stderr
    assert "--variable z at the command line" in r.stderr and not unknown_options_named(args, r.stderr)
    r = run_main(*args, "--variable", "z", *(("--json",) if command == "design" else ()))
    assert r.returncode == 0, r.stderr
    if command == "design":
        assert "n=4000, dx=5e-07, length=0.0019995, periodic=False, source='two.mat, variable z'" in json.loads(
            r.stdout)["texture"]


@pytest.mark.parametrize("args,refusal", [
    (("export", "--algorithm", "W", "--stiffness", "1kN/m", "--max-force", "3N", "--level"),
     "--level is not allowed with --algorithm W"),
    (("export", "--algorithm", "W", "--stiffness", "1kN/m", "--max-force", "3N", "--variable", "z"),
     "--variable is not allowed with --algorithm W"),
    (("run", "--device", "simulated:falcon", "--algorithm", "W", "--spacing", "1um"),
     "--spacing is not allowed with --algorithm W"),
    (("run", "--device", "simulated:falcon", "--identify", "--fill-undefined"),
     "--fill-undefined is not allowed with --identify"),
    (("design", "--texture", "sine:0.1mm,1mm", "--variable", "z"),
     "--variable is not allowed with the synthetic texture 'sine:0.1mm,1mm'"),
])
def test_a_reading_option_where_no_file_is_read_is_refused(args, refusal, tmp_path):
    # Nothing given is ignored: an option that says how a file is read, where none is (the smooth
    # wall, the identification run, a synthetic texture), is refused naming it (before
    # 2026-12-01 export's W wrote its source with --level given, exit 0).
    extra = {"export": ("--out", str(tmp_path / "out")), "run": ("--record", str(tmp_path / "log.csv"), "--fast")}
    r = run_main(*args, *extra.get(args[0], ()))
    assert r.returncode == 2 and refusal in r.stderr, r.stderr
    assert not (tmp_path / "out").exists() and not (tmp_path / "log.csv").exists()


@needs_data
@pytest.mark.parametrize("name", ["grooves-4mm-profile.mat", "nc-1.nc"])
def test_simulates_surface_is_synthetic_and_its_refusal_of_a_file_names_a_command_that_reads_it(name):
    # haptex simulate --surface takes the synthetic surfaces its help names; a file (../shared/data's,
    # as published) is refused naming the command that renders it on a simulated device, whose
    # options those are (before 2026-12-01 the grooves file's refusal named --spacing and
    # --height-unit, which simulate has not, and nc-1.nc was simulated unread by its options)
    path = GROOVES.parent / name
    r = run_main("simulate", "scan", "--surface", str(path), "--device", "delta", "--duration", "0.01s")
    assert r.returncode == 2 and "'egg-crate:AMPLITUDE,PERIOD' or 'grating:" in r.stderr, r.stderr
    assert "'haptex run --device simulated:PRESET --texture FILE'" in r.stderr
    assert not unknown_options_named(["run"], "--device simulated:PRESET --texture FILE")


@needs_data
@pytest.mark.parametrize("scale,reason", [
    ("0,1", "scale = '0,1' is not allowed: length_factor = 0 is not allowed: must be a finite number > 0"),
    ("1,nan", "scale = '1,nan' is not allowed: height_factor = nan is not allowed: must be a finite number"),
    ("a,1", "scale = 'a,1' is not allowed: must be 'length_factor,height_factor', two numbers"),
])
def test_a_scale_refused_says_which_factor_and_what_it_may_be(scale, reason):
    # README, "Bad input": the parameter, its value and what is allowed (before 2026-12-01 each
    # read "must be 'length_factor,height_factor'", the factor's own reason dropped)
    r = run_main("design", "--texture", str(DEKTAK), "--scale", scale, "--algorithms", "A", "--quiet")
    assert r.returncode == 2 and reason in r.stderr, r.stderr
