"""Issues 16 and 30, textures leave Python: ``haptex export`` copies the C core's own files
and renders the model's tables and entry points from Jinja2 templates. The exported tick,
compiled with the system's C compiler (-std=c99 -Wall -Wextra -pedantic -Werror), is checked
against the library's NumPy fields (the oracle, 10^5 points) and, being the same C, against
the compiled Renderer bit for bit."""

import ctypes
import functools
import math
import subprocess

import numpy as np
import pytest

import haptex as hx
from haptex import core
from haptex.export import TICK_FILES, export_c

from .cbuild import CC, GROUP, SANITIZE, STRICT, core_objects, sanitizers_work
from .conftest import DEKTAK, K0, A, L, needs_data
from .test_cli import run_main

pytestmark = [pytest.mark.skipif(CC is None, reason="no C compiler on this machine"), pytest.mark.xdist_group(GROUP)]
STRICT = list(STRICT)


def build(out, target, flags=("-O2", "-fPIC"), extra=(), shared=True, tmp_root=None):
    """Compile an export in ``out`` (its generated source, ``extra`` sources, the core's objects)."""
    objs = core_objects(tmp_root or out.parent, tuple(STRICT) + tuple(flags))
    subprocess.run([CC, *STRICT, *flags, *(["-shared"] if shared else []), "-I", str(out), "-o", str(target),
                    str(out / "haptex_texture.c"), *map(str, extra), *objs, "-lm"], check=True, capture_output=True,
                   text=True)


_LOOP = r"""
#include "haptex_texture.h"
/* the test's driver: haptex_step over n positions in C (no ctypes call a tick), each from the
   state s had on entry (a copy: haptex_init would check the tables again each time) when reset
   is nonzero; returns the faults */
long haptex_test_loop(haptex_state *s, const double *p, double *f, long n, int reset)
{
    haptex_state fresh = *s;
    long i;
    for (i = 0; i < n; i++) {
        if (reset)
            *s = fresh;
        (void)haptex_step(s, p + HAPTEX_DIMENSION * i, f + HAPTEX_DIMENSION * i);
    }
    return haptex_faults(s);
}
"""


class Compiled:
    """The exported tick of one algorithm, loaded from a shared library."""

    def __init__(self, alg, tmp_path, objdir, max_force=math.inf, **kw):
        h, c = export_c(alg, tmp_path, max_force, **kw)
        assert '#include "hx_core.h"' in h.read_text() and "haptex_step" in h.read_text()
        so = tmp_path / "libhaptex_texture.so"
        (tmp_path / "loop.c").write_text(_LOOP)
        build(tmp_path, so, extra=[tmp_path / "loop.c"], tmp_root=objdir)
        self.lib = ctypes.CDLL(str(so))
        self.lib.haptex_step.restype = ctypes.c_int
        for name in ("haptex_faults", "haptex_clamps", "haptex_cut", "haptex_work", "haptex_max_work"):
            getattr(self.lib, name).restype = ctypes.c_long
        self.lib.haptex_state_size.restype = ctypes.c_size_t
        self.state = ctypes.create_string_buffer(self.lib.haptex_state_size())
        self.dim = alg.dimension
        self.reset()
        self.p = (ctypes.c_double * self.dim)()
        self.f = (ctypes.c_double * self.dim)()

    def reset(self):
        assert self.lib.haptex_init(self.state) == 0

    def forces(self, p, reset=False):
        """haptex_step over the rows of p (shape (n, dim)) in a C loop: the forces (n, dim)."""
        p = np.ascontiguousarray(p, dtype=np.float64)
        f = np.empty_like(p)
        ptr = ctypes.POINTER(ctypes.c_double)
        self.lib.haptex_test_loop(self.state, p.ctypes.data_as(ptr), f.ctypes.data_as(ptr), ctypes.c_long(len(p)),
                                  ctypes.c_int(1 if reset else 0))
        return f

    def count(self, what):
        return getattr(self.lib, f"haptex_{what}")(self.state)

    def step(self, *p):
        for i, v in enumerate(p):
            self.p[i] = v
        code = self.lib.haptex_step(self.state, self.p, self.f)
        return code, tuple(self.f)


def _stroke_against_the_renderer(alg, tmp_path, objdir):
    """The exported tick and the compiled Renderer (max force 5 N) along one stroke in and
    out of the wall, back and forth over the texture (20,001 ticks): (compiled, renderer, x,
    z, exported forces, renderer forces)."""
    c = Compiled(alg, tmp_path, objdir, max_force=5.0)
    r = hx.Renderer(alg, max_force=5.0)
    t = np.linspace(0.0, 1.0, 20_001)
    x = 3e-3 * np.sin(2 * np.pi * 3 * t)
    z = -0.8e-3 * np.sin(2 * np.pi * 2 * t) + 0.2e-3
    got = c.forces(np.column_stack([x, z]))
    ref = np.array([r.step((a, b)) for a, b in zip(x.tolist(), z.tolist())])
    return c, r, x, z, got, ref


@functools.lru_cache(maxsize=1)
def _dektak():
    """The leveled Dektak profile, read once in a test process (0.5 s a read)."""
    return hx.SampledProfile.from_file(DEKTAK).leveled()


def _textures():
    out = [("sine", hx.Sinusoid(A, L)), ("sum", hx.SumOfSinusoids([0.3e-3, 0.1e-3], [1e-3, 0.25e-3], [0.0, 1.0]))]
    if DEKTAK.exists():
        out.append(("dektak", _dektak()))
    return out


@pytest.mark.parametrize("letter", list("WABCG"))
@pytest.mark.parametrize("name, tex", _textures())
def test_exported_field_equals_the_library_on_1e5_points(tmp_path, objdir, letter, name, tex):
    alg = hx.algorithm(letter, None if letter == "W" else tex, K0,
                       **({"max_penetration": 0.5e-3} if letter in "BCG" else {}))
    c = Compiled(alg, tmp_path, objdir)
    rng = np.random.default_rng(7)
    lo, hi = (tex.domain if getattr(tex, "domain", None) is not None else (0.0, 4e-3))
    span = hi - lo
    x = rng.uniform(lo - 0.1 * span, hi + 0.1 * span, 100_000)  # beyond the ends too (a profile extends)
    z = rng.uniform(-2e-3, 1e-3, x.size) + (tex.height(x) if letter in "ABC" else 0.0)
    ref = alg.force(np.column_stack([x, z]))
    got = c.forces(np.column_stack([x, z]))
    # 1e-12 relative, or a few rounding errors of h (the C loop sums the harmonics in another
    # order than numpy) times kappa_0 where d = z - h nearly cancels
    hmax = max(abs(v) for v in tex.height_range)
    tol = 1e-12 * np.hypot(ref[:, 0], ref[:, 1]) + 16 * np.finfo(float).eps * K0 * hmax
    assert np.all(np.hypot(*(got - ref).T) <= tol), np.max(np.hypot(*(got - ref).T) / tol)
    assert c.count("faults") == 0


def test_exported_F_follows_the_renderer_along_a_stroke(tmp_path, objdir):
    # F keeps a presliding state: along a stroke in and out of the wall, back and forth over
    # the texture, every tick equals the compiled renderer's, and so does the work sum (the
    # environment's -sum f . dp, what path_work integrates)
    alg = hx.algorithm("F", hx.Sinusoid(A, L), K0, friction=0.8, presliding=1e-3, max_penetration=1e-3)
    c, r, x, z, got, ref = _stroke_against_the_renderer(alg, tmp_path, objdir)
    assert np.array_equal(got, ref)  # the same C on the same tables
    work = lambda f: -np.sum(f[:-1, 0] * np.diff(x) + f[:-1, 1] * np.diff(z))  # noqa: E731
    assert work(got) == work(ref)
    assert c.count("clamps") == r.clamps


def test_exported_tick_keeps_the_renderers_safety_rules(tmp_path, objdir):
    # reproducer 3 of issue 17 (a huge force is clamped to max_force, not to zero) and the
    # faults: NaN, inf and positions beyond the workspace give zero force and a nonzero code
    c = Compiled(hx.algorithm("W", None, 1e200), tmp_path, objdir, max_force=5.0)
    code, f = c.step(0.0, -1e-3)
    assert code == 0 and f == (0.0, 5.0) and c.count("clamps") == 1
    for bad in ((math.nan, 0.0), (0.0, math.inf), (0.0, -2e3)):
        code, f = c.step(*bad)
        assert code != 0 and f == (0.0, 0.0)
    assert c.count("faults") == 3
    # a state haptex_init never set up (or whose tables failed its checks) is a fault, not a tick
    c.state = ctypes.create_string_buffer(c.lib.haptex_state_size())
    code, f = c.step(0.0, -1e-3)
    assert code == 1 and f == (0.0, 0.0) and c.count("faults") == 1


# D on the sinusoid and E on the Dektak profile (its sampled spline) in the contributor's loop; the
# other four pairs (1-2 s each) in .ci/run's long set
@pytest.mark.parametrize("name, tex, letter", [
    pytest.param(name, tex, letter, marks=() if (name, letter) in (("sine", "D"), ("dektak", "E")) else pytest.mark.long)
    for name, tex in _textures() for letter in "DE"])
def test_exported_closest_point_algorithms_equal_the_library_on_1e5_points(tmp_path, objdir, letter, name, tex):
    # D and E carry the bounded closest-point search into C (issue 16): from a cold start (as
    # the vectorised field computes) every force equals Algorithm.force to 1e-12 relative, away
    # from the medial axis, where D's force jumps (Remark 6) and either side is right
    alg = hx.algorithm(letter, tex, K0)
    c = Compiled(alg, tmp_path, objdir)
    rng = np.random.default_rng(11)
    lo, hi = (tex.domain if getattr(tex, "domain", None) is not None else (0.0, 4e-3))
    span = hi - lo
    x = rng.uniform(lo - 0.1 * span, hi + 0.1 * span, 100_000)
    z = tex.height(x) - rng.uniform(0.0, 2e-3, x.size) * rng.uniform(0.0, 1.0, x.size) ** 2
    p = np.column_stack([x, z])
    ref = alg.force(p)
    c.reset()
    got = c.forces(p, reset=True)
    tie = hx.closest_point(tex, p).tie
    err = np.hypot(*(got - ref).T)
    # the tick reads the cell table over a periodic profile: its Newton's closest point is
    # certified to 1e-15 (1 + |t|) m (hx_closest.c, convex_min), the field's to the same, so the
    # forces agree to kappa_0 sqrt(1 + h'^2) 2e-15 m beyond the rounding of h
    tol = (1e-12 * np.hypot(ref[:, 0], ref[:, 1]) + 16 * np.finfo(float).eps * K0 * max(abs(v) for v in tex.height_range)
           + 2e-15 * K0 * math.sqrt(1.0 + tex.max_slope ** 2))
    assert np.all((err <= tol) | tie), np.max(err[~tie] / tol[~tie])
    assert tie.mean() < 1e-3


@pytest.mark.parametrize("letter, params", [("D", {}), ("E", {}), ("F", {"stick_deflection": 0.5e-3}),
                                            ("F", {"stick_deflection": 0.0})])
def test_exported_stateful_ticks_follow_the_renderer_along_a_stroke(tmp_path, objdir, letter, params):
    # D and E warm-start their search from the previous tick, F's smooth presliding integrates
    # its flow (Hayward & Armstrong 2000) along the motion: along a stroke in and out of the
    # wall the exported tick equals the compiled renderer's tick by tick
    tex = hx.Sinusoid(A, L)
    kw = {"friction": 0.8, "presliding": 1e-3, "max_penetration": 1e-3} if letter == "F" else {}
    alg = hx.algorithm(letter, tex, K0, **kw, **params)
    c, r, x, z, got, ref = _stroke_against_the_renderer(alg, tmp_path, objdir)
    # the same C on the same tables (D and E: the cell table too), so the same forces, bit
    # for bit, and the same work
    assert np.array_equal(got, ref)
    assert c.count("clamps") == r.clamps and c.count("faults") == 0 and c.count("max_work") == r.max_work


def test_what_cannot_be_exported_is_refused(tmp_path, monkeypatch):
    import re

    from haptex import export as ex

    # a profile of 2,000,001 samples: a cubic's 4 coefficients an interval, 8,000,000 numbers and
    # a few of the layout's, past the 1,000,000 that fit; the refusal names the part that fits,
    # 4 (n - 1) <= 1,000,000 less the layout's few: n within 3 samples of 250,001, and its --crop
    # keeps those n samples (numpy's count of x <= X1)
    x = np.arange(2_000_001) * 1e-7
    big = hx.SampledProfile(x, np.zeros(x.size))
    with pytest.raises(hx.ParameterError, match=r"its tables hold 8,000,0\d\d numbers \(64 MB\), more than the "
                                                r"1,000,000 that fit") as e:
        export_c(hx.algorithm("A", big, K0), tmp_path, 5.0)
    n, x1 = re.search(r"a part of ([\d,]+) samples fits: --crop 0,([\d.]+)mm ", str(e.value)).groups()
    n = int(n.replace(",", ""))
    assert 249_998 <= n <= 250_001 and np.count_nonzero(x <= float(x1) * 1e-3) == n, (n, x1)
    # a felt map's part is not its samples' (the ball reaches past a crop's edge): its remedies
    # are the map's crop and a coarser felt grid, named as the command line takes them
    felt = hx.SampledSurface(np.arange(40) * 1e-6, np.arange(40) * 1e-6, np.zeros((40, 40))).felt_by(3e-6)
    monkeypatch.setattr(ex, "MAX_TABLE", 1000)  # (its 39 x 39 patches, 16 numbers each, past it)
    with pytest.raises(hx.ParameterError, match=r"feel it on a coarser grid: --tip-spacing \S+ fits \(felt_by\(r, "
                                                r"spacing=\S+\) in Python\), or crop the map it is felt on \(--crop"):
        export_c(hx.algorithm("A", felt, K0), tmp_path, 5.0)
    assert ex.EXPORTABLE == "WABCDEFG"
    with pytest.raises(hx.ParameterError, match="max_force = -1 is not allowed"):
        export_c(hx.algorithm("A", hx.Sinusoid(A, L), K0), tmp_path, -1.0)


def test_a_felt_maps_export_refused_for_its_size_names_a_tip_spacing_that_exports(tmp_path, monkeypatch, capsys):
    # A measured map felt by a ball on its own grid is refused for export when its tables pass
    # what fits (mi-1.mi under a 2 um ball: 1,105,997 numbers for the host's 1,000,000). The
    # refusal named "--tip-spacing" with no value; now it names one, and that spacing taken as
    # written exports. Truth: the tables' definition, 16 numbers a bicubic cell (its 16 Hermite
    # coefficients) at least, so a felt grid of n x n samples needs 16 (n - 1)^2 <= the cap: the
    # named spacing cannot be finer than that bound, and is within 1.5 times it (not needlessly
    # coarse); the export at it writes its files (exit status 0).
    import re

    from haptex import export as ex
    from haptex.cli import main

    x = np.arange(48)
    h = 0.5 * np.sin(2 * np.pi * x / 16)[:, None] * np.cos(2 * np.pi * x / 20)[None, :]  # (um, 1 um samples)
    path = tmp_path / "map.npy"
    np.save(path, h)
    monkeypatch.setattr(ex, "MAX_TABLE", 12_000)
    args = ["export", "--algorithm", "A", "--texture", str(path), "--spacing", "1um", "--height-unit", "um",
            "--tip-radius", "3um", "--stiffness", "2kN/m", "--max-force", "3N", "--quiet"]
    assert main(args + ["--out", str(tmp_path / "refused")]) == 2
    msg = capsys.readouterr().err
    assert msg.count("\n") == 1 and "is not allowed for export" in msg
    spacing, unit = re.search(r"--tip-spacing ([0-9.]+)(um|mm) fits", msg).groups()
    d = float(spacing) * (1e-6 if unit == "um" else 1e-3)
    n = int(np.floor(47e-6 / d)) + 1  # (the felt grid's samples an axis: steps of d from the first sample)
    finest = 47e-6 / (np.sqrt(12_000 / 16) + 1)  # (16 (n - 1)^2 <= 12,000, n - 1 = 47 um / d)
    assert 16 * (n - 1) ** 2 <= 12_000 and finest <= d <= 1.5 * finest, (spacing, finest)
    assert main(args + ["--tip-spacing", spacing + unit, "--out", str(tmp_path / "fits")]) == 0
    assert (tmp_path / "fits" / "haptex_texture.c").exists()


def _stabilisers():
    from haptex.renderer import EnergyBounding, PassiveSetPosition, PassivityController

    return [("pc", PassivityController(20.0)), ("pc-stored", PassivityController(20.0, reference="stored", delay=1)),
            ("eba", EnergyBounding(2.0, delay=1)), ("pspm", PassiveSetPosition(2.0))]


@pytest.mark.parametrize("name, stab", _stabilisers(), ids=[n for n, _ in _stabilisers()])
def test_an_exported_stabiliser_ticks_as_the_renderers(tmp_path, objdir, name, stab):
    # the export with a stabiliser set by haptex_init (its mode, damping, period and delay in the
    # generated configuration) is the Renderer with that stabiliser: along a stroke in and out of
    # the wall at 1 kHz every tick's force is the same to the bit, so are the observed energy
    # and the ticks the stabiliser acted (which it does here: the test would pass vacuously
    # otherwise)
    T = 1e-3
    alg = hx.algorithm("B", hx.Sinusoid(A, L), K0, max_penetration=1e-3)
    c = Compiled(alg, tmp_path, objdir, max_force=5.0, passivity_controller=stab, period=T)
    r = hx.Renderer(alg, max_force=5.0, passivity_controller=stab, period=T)
    t = np.linspace(0.0, 1.0, 4001)
    p = np.column_stack([3e-3 * np.sin(2 * np.pi * 3 * t), -0.8e-3 * np.sin(2 * np.pi * 2 * t) + 0.2e-3])
    got = c.forces(p)
    ref = np.array([r.step(tuple(q)) for q in p.tolist()])
    assert np.array_equal(got, ref)
    c.lib.haptex_energy.restype = ctypes.c_double
    c.lib.haptex_controller_active.restype = ctypes.c_long
    assert c.lib.haptex_energy(c.state) == r.energy
    assert c.lib.haptex_controller_active(c.state) == r.controller_active > 0
    text = (tmp_path / "haptex_texture.c").read_text()
    assert f"r->pc.T = {T!r};" in text and f"r->pc.delay = {stab.delay or 0};" in text


def test_an_export_without_a_stabiliser_observes_nothing(tmp_path, objdir):
    c = Compiled(hx.algorithm("B", hx.Sinusoid(A, L), K0, max_penetration=1e-3), tmp_path, objdir, max_force=5.0)
    c.lib.haptex_energy.restype = ctypes.c_double
    c.forces(np.column_stack([np.linspace(0, 3e-3, 500), np.full(500, -0.3e-3)]))
    assert c.lib.haptex_energy(c.state) == 0.0 and "r->pc" not in (tmp_path / "haptex_texture.c").read_text()
    from haptex.renderer import PassivityController

    with pytest.raises(hx.ParameterError, match="period = None is not allowed"):
        export_c(hx.algorithm("W", None, K0), tmp_path / "x", 5.0, passivity_controller=PassivityController(20.0))
    with pytest.raises(hx.ParameterError, match="passivity_controller = 20 is not allowed: must be None or a haptex stabiliser"):
        export_c(hx.algorithm("W", None, K0), tmp_path / "x", 5.0, passivity_controller=20.0, period=1e-3)


def test_haptex_export_at_the_command_line_writes_code_that_compiles(tmp_path):
    # the CLI's output compiles warning-free and takes units like every other command
    out = tmp_path / "fw"
    r = run_main("export", "--algorithm", "G", "--texture", "sine:0.8mm,1mm", "--stiffness",
                 "2 kN/m", "--max-force", "5 N", "--max-penetration", "0.5mm", "--out", str(out))
    assert r.returncode == 0, r.stderr
    subprocess.run([CC, *STRICT, "-o", str(tmp_path / "t"), *map(str, out.glob("*.c")), "-lm", "-Wl,-e,haptex_init",
                    "-nostartfiles"], check=True)
    text = (out / "haptex_texture.c").read_text()
    assert "r->model.prm[HX_P_DZMAX] = 0.0005;" in text and "r->model.prm[HX_P_K0] = 2000.0;" in text
    r = run_main("export", "--algorithm", "A", "--texture", "sine:0.8mm,1mm", "--stiffness", "2000",
                 "--max-force", "5 N", "--out", str(out))
    assert r.returncode == 2 and "stiffness = '2000' is not allowed: a number without a unit" in r.stderr
    # a stabiliser for the device the firmware runs on: its period, delay and damping from the preset
    r = run_main("export", "--algorithm", "B", "--texture", "sine:0.8mm,1mm", "--stiffness", "2 kN/m",
                 "--max-force", "5 N", "--passivity-control", "20 N*s/m", "--device", "pantograph", "--out",
                 str(out))
    assert r.returncode == 0 and "passivity controller (20 N s/m" in r.stdout, r.stderr
    text = (out / "haptex_texture.c").read_text()
    assert "r->pc.mode = HX_STAB_PC;" in text and "r->pc.bmax = 20.0;" in text and "r->pc.T = 0.0001;" in text
    subprocess.run([CC, *STRICT, "-o", str(tmp_path / "t"), *map(str, out.glob("*.c")), "-lm", "-Wl,-e,haptex_init",
                    "-nostartfiles"], check=True)
    for args, what in ((["--stabiliser", "energy-bounding"], "--stabiliser needs --device"),
                       (["--device", "falcon"], "--device is not allowed without --passivity-control")):
        r = run_main("export", "--algorithm", "B", "--texture", "sine:0.8mm,1mm", "--stiffness",
                     "2 kN/m", "--max-force", "5 N", *args, "--out", str(out))
        assert r.returncode == 2 and what in r.stderr and r.stderr.count("\n") == 1, r.stderr


def _surfaces():
    out = [("egg", hx.SumOfGratings.egg_crate(A, L)),
           ("gentle-egg", hx.SumOfGratings.egg_crate(0.1e-3, 2e-3)),  # the convexity certificate's regime
           ("gratings", hx.SumOfGratings([0.2e-3, 0.05e-3], [1e-3, 0.3e-3], [0.3, 2.0], [0.0, 1.0]))]
    if DEKTAK.exists():
        out.append(("extruded-dektak", hx.Extruded(_dektak())))
    return out


def _surface_cases():
    """(name, texture, letter) of the 3-D export's comparison: every letter on every surface; on
    the gentle egg-crate (the convexity certificate's regime) and the extruded Dektak scan only
    D and E, the closest-point searches they exercise, in the contributor's loop, the other
    letters (their fields are the egg-crate's and the gratings' code) in .ci/run's long set."""
    out = []
    for name, tex in _surfaces():
        for letter in "WABCDEG":
            beyond = name in ("gentle-egg", "extruded-dektak") and letter not in "DE"
            out.append(pytest.param(name, tex, letter, marks=[pytest.mark.long] if beyond else []))
    return out


@pytest.mark.parametrize("name, tex, letter", _surface_cases())
def test_exported_3d_field_equals_the_library(tmp_path, objdir, letter, name, tex):
    # issue 16, "p and f of the texture's dimension, 2 or 3": over a surface the C tick equals
    # Algorithm.force in 3-D (10^5 points for the closed forms, 10^4 for D and E, each from a
    # cold start like the vectorised field; D may take either side where the closest point is
    # tied, on the medial axis, where its force jumps)
    alg = hx.algorithm(letter, hx.Flat(2) if letter == "W" else tex, K0,
                       **({"max_penetration": 0.5e-3} if letter in "BCG" else {}))
    c = Compiled(alg, tmp_path, objdir)
    assert "#define HAPTEX_DIMENSION 3" in (tmp_path / "haptex_texture.h").read_text()
    rng = np.random.default_rng(7)
    n = 10_000 if letter in "DE" else 100_000
    dom = tex.domain or ((0.0, 2e-3), (0.0, 2e-3))  # an aperiodic sum: any window
    xy = np.column_stack([rng.uniform(dom[0][0] - 0.1e-3, dom[0][1] + 0.1e-3, n),
                          rng.uniform(dom[1][0] - 0.1e-3, dom[1][1] + 0.1e-3, n)])
    z = rng.uniform(-2e-3, 1e-3, n) + (tex.height_at(xy) if letter in "ABCDE" else 0.0)
    p = np.column_stack([xy, z])
    ref = alg.force(p)
    c.reset()
    got = c.forces(p, reset=True)
    hmax = max(abs(v) for v in tex.height_range)
    tol = 1e-12 * np.linalg.norm(ref, axis=-1) + 64 * np.finfo(float).eps * K0 * (hmax + 2e-3)
    err = np.linalg.norm(got - ref, axis=-1)
    ok = err <= tol
    if letter == "D":
        ok |= hx.closest_point(tex, p).tie
    assert np.all(ok), (np.count_nonzero(~ok), np.max(err[~ok] / tol[~ok]))
    assert c.count("faults") == 0


@pytest.mark.parametrize("stick", [None, 0.15e-3])
def test_exported_3d_f_drags_its_adhesion_point_like_the_library(tmp_path, objdir, stick):
    # F over a surface: the isotropic presliding (sharp: the adhesion point dragged to within
    # d^x_max; smooth: the 1-D flow along d, elastic across) along a stroke in and out of the
    # wall; every tick equals Algorithm.force at the deflection haptex.friction.step_plane gives
    from haptex.friction import step_plane

    egg = hx.SumOfGratings.egg_crate(A, L)
    alg = hx.algorithm("F", egg, K0, friction=0.8, presliding=0.3e-3, max_penetration=1e-3, stick_deflection=stick)
    table = None if stick is None else alg._aux()
    c = Compiled(alg, tmp_path, objdir, max_force=50.0)
    t = np.linspace(0.0, 1.0, 20_001)
    p = np.column_stack([2e-3 * np.sin(2 * np.pi * 3 * t), 1.5e-3 * np.sin(2 * np.pi * 5 * t + 1.0),
                         -0.8e-3 * np.sin(2 * np.pi * 2 * t) + 0.2e-3])
    d = last = None
    for q in p:
        code, f = c.step(*q)
        if q[2] >= 0:
            d = None
            assert f == (0.0, 0.0, 0.0)
            continue
        d = np.zeros(2) if d is None else step_plane(d, q[:2] - last, 0.3e-3, stick, table)
        last = q[:2]
        np.testing.assert_allclose(f, alg.force(q[None, :], d[None, :])[0], rtol=1e-10, atol=1e-12)
    assert c.count("faults") == 0


def test_export_over_a_surface_at_the_command_line(tmp_path):
    out = tmp_path / "fw3"
    r = run_main("export", "--algorithm", "B", "--texture", "egg-crate:0.8mm,1mm", "--stiffness",
                 "2 kN/m", "--max-force", "5 N", "--out", str(out))
    assert r.returncode == 0, r.stderr
    assert "#define HAPTEX_DIMENSION 3" in (out / "haptex_texture.h").read_text()
    assert "p = [x, y, z] (m)" in (out / "haptex_texture.h").read_text()
    subprocess.run([CC, *STRICT, "-c", str(out / "haptex_texture.c"), "-o", str(tmp_path / "t.o")], check=True)


def _stroke3(n=4001):
    t = np.linspace(0.0, 1.0, n)
    return np.column_stack([2e-3 * np.sin(2 * np.pi * 3 * t), 1.5e-3 * np.sin(2 * np.pi * 5 * t + 1.0),
                            -0.6e-3 * np.sin(2 * np.pi * 2 * t) + 0.1e-3])


def test_the_export_is_the_core(tmp_path, objdir):
    """Issue 30, "the export is the core": the exported files are the package's own C files,
    byte for byte, the generated ones hold no C function of the core (only tables and the
    entry points), and the tick over the paper's egg-crate (D, E: the certified search with its
    budget; F) gives the Renderer's forces, work and cut counts bit for bit along a stroke."""
    egg = hx.SumOfGratings.egg_crate(A, L)
    for name in TICK_FILES:
        export_c(hx.algorithm("A", egg, K0), tmp_path / "a", 5.0)
        assert (tmp_path / "a" / name).read_bytes() == (core.SOURCE_DIR / name).read_bytes(), name
    generated = (tmp_path / "a" / "haptex_texture.c").read_text()
    assert "hx_closest_surface" not in generated and "sin(" not in generated
    p = _stroke3()
    # (E's budget: the stroke's searches take at most 276 evaluations, so 150 ends 44 of them)
    for letter, kw in (("D", {}), ("E", {"max_evaluations": 150}), ("F", {})):
        alg = hx.algorithm(letter, egg, K0, **({"friction": 0.8, "presliding": 0.3e-3} if letter == "F" else {}))
        d = tmp_path / letter
        c = Compiled(alg, d, objdir, max_force=5.0, **kw)
        r = hx.Renderer(alg, max_force=5.0, **kw)
        for q in p.tolist():
            _, f = c.step(*q)
            assert f == r.step(q) and c.count("work") == r.last_work, (letter, q)
        assert (c.count("max_work"), c.count("cut"), c.count("clamps")) == (r.max_work, r.cut, r.clamps)
        if letter == "E":
            assert r.cut > 0  # the budget of 150 evaluations ended some searches, in both


def test_a_measured_map_exports(tmp_path, objdir):
    """A height map exports as its bicubic patches (before issue 30 it was refused): D over a
    window of the Zygo MetroPro map shipped in examples/data (MIT, SurfaceTopography's corpus),
    rendered as `design` renders it, equals the Renderer bit for bit along a stroke."""
    from .test_measured_maps import _rendered_metropro

    whole = _rendered_metropro()  # 320 x 240 samples: 1.2 million numbers of patches; a window of it
    tex = hx.SampledSurface(whole.x[:160], whole.y[:120], whole.h[:160, :120], source="metropro-1.dat window")
    (x0, x1), (y0, y1) = tex.domain
    alg = hx.algorithm("D", tex, K0)
    c = Compiled(alg, tmp_path, objdir, max_force=5.0)
    r = hx.Renderer(alg, max_force=5.0)
    rng = np.random.default_rng(3)
    xy = np.column_stack([rng.uniform(x0, x1, 2000), rng.uniform(y0, y1, 2000)])
    p = np.column_stack([xy, tex.height_at(xy) - rng.uniform(-2e-6, 20e-6, 2000)])
    for q in p.tolist():
        assert c.step(*q)[1] == r.step(q)
    assert c.count("max_work") == r.max_work > 1


_FUZZ_DRIVER = r"""
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "haptex_texture.h"

/* Issue 33's sanitizer fuzz: adversarial positions into haptex_step under ASan and UBSan.
   Every force must be finite and within max_force; any sanitizer report aborts. */
static unsigned long long rng = 0x9E3779B97F4A7C15ULL;
static double uniform(void) { rng ^= rng << 13; rng ^= rng >> 7; rng ^= rng << 17; return (rng >> 11) * 0x1p-53; }

int main(int argc, char **argv)
{
    const double max_force = atof(argv[1]);
    (void)argc;
    const long n = atol(argv[2]);
    const double special[] = {0.0, -0.0, 1e-320, -1e-320, 1e-300, 1e300, -1e300, 999.999, -999.999, 1000.0, -1000.0,
                              1000.001, NAN, INFINITY, -INFINITY, 1e-3, -1e-3, 5e-4, -4e-4};
    const int ns = (int)(sizeof special / sizeof special[0]);
    haptex_state s;
    if (haptex_init(&s) != 0) return 2;
    double p[HAPTEX_DIMENSION], f[HAPTEX_DIMENSION];
    long bad = 0;
    for (long k = 0; k < n; ++k) {
        for (int i = 0; i < HAPTEX_DIMENSION; ++i) {
            double u = uniform();
            if (u < 0.3) p[i] = special[(int)(uniform() * ns) % ns];
            else if (u < 0.6) p[i] = (uniform() - 0.5) * 4e-3;           /* near the texture */
            else if (u < 0.8) p[i] = (uniform() - 0.5) * 2e3;            /* anywhere in the workspace */
            else p[i] = ldexp(uniform() - 0.5, (int)(uniform() * 2100) - 1075);  /* any exponent */
        }
        if (uniform() < 0.01) (void)haptex_init(&s);
        (void)haptex_step(&s, p, f);
        double norm = 0.0;
        for (int i = 0; i < HAPTEX_DIMENSION; ++i) {
            if (!isfinite(f[i])) ++bad;
            norm += f[i] * f[i];
        }
        if (sqrt(norm) > max_force * (1.0 + 1e-12)) ++bad;
    }
    printf("%ld %ld %ld\n", bad, haptex_faults(&s), haptex_clamps(&s));
    return bad != 0;
}
"""


# every letter on the sine; on the egg-crate the letters whose surface code differs (D, E: the
# surface search; F: presliding in the plane), the others slow (a build under the sanitizers each)
@pytest.mark.parametrize("letter, texture", [(L, "sine") for L in "WABCDEFG"] + [
    pytest.param(L, "egg", marks=pytest.mark.slow) if L in "AB" else (L, "egg") for L in "ABDEF"])
@pytest.mark.long  # a sanitizer build: 14 s (issue 68)
def test_the_exported_tick_is_clean_under_asan_and_ubsan(tmp_path, objdir, letter, texture):
    """Issue 33's fuzz suite, the exported C: 2e5 adversarial positions (5e4 for D and E over
    the egg-crate) -- NaN, infinities, subnormals, the workspace's edge at 1 km, any
    exponent, and positions near the texture -- into haptex_step compiled with
    -fsanitize=address,undefined and -fno-sanitize-recover=all: no sanitizer report, every
    force finite and at most max_force (the safety rules README states for the tick)."""
    if not sanitizers_work(tmp_path):
        pytest.skip("this compiler cannot build with -fsanitize=address,undefined")
    tex = hx.Sinusoid(A, L) if texture == "sine" else hx.SumOfGratings.egg_crate(A, L)
    if letter == "W":
        tex = None
    alg = hx.algorithm(letter, tex, K0, **({"max_penetration": 0.5e-3} if letter in "BCG" else {}))
    out = tmp_path / "fw"
    export_c(alg, out, 5.0)
    (tmp_path / "fuzz.c").write_text(_FUZZ_DRIVER)
    exe = tmp_path / "fuzz"
    build(out, exe, flags=SANITIZE, extra=[tmp_path / "fuzz.c"], shared=False, tmp_root=objdir)
    n = 50_000 if (letter in "DE" and texture == "egg") else 200_000  # the certified 3-D search: 60 us a tick here
    r = subprocess.run([str(exe), "5.0", str(n)], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0 and "runtime error" not in r.stderr and "AddressSanitizer" not in r.stderr, \
        (r.stdout, r.stderr[-2000:])
    bad, faults, clamps = (int(v) for v in r.stdout.split())
    assert bad == 0 and faults > 0  # the non-finite and out-of-workspace positions were counted as faults


def _icosphere_base(subdivisions, R):
    """trimesh's icosphere of radius R centred at (0, 0, -R), tilted off the y axis, with the
    analytic sphere's (u1, u2) as its UV map (as tests/test_objects.py)."""
    import trimesh

    from haptex.objects import Mesh, Sphere

    m = trimesh.creation.icosphere(subdivisions=subdivisions, radius=R)
    m.apply_transform(trimesh.transformations.rotation_matrix(0.1234, [1.0, 0.3, 0.0]))
    m.apply_translation([0.0, 0.0, -R])
    return m, Mesh(m, uv=Sphere(R).local(np.asarray(m.vertices))[0])


def _exported_and_renderer_on_a_stroke(alg, tmp_path, objdir, n):
    """The exported tick compiled and haptex.Renderer (both with a 5 N ceiling), and their forces
    along n samples of a stroke over an object at the origin, in and out of it, back and forth:
    (compiled, renderer, exported forces, renderer forces)."""
    c = Compiled(alg, tmp_path, objdir, max_force=5.0)
    r = hx.Renderer(alg, max_force=5.0)
    t = np.linspace(0.0, 1.0, n)
    p = np.column_stack([6e-3 * np.sin(2 * np.pi * 3 * t), 2e-3 * np.cos(2 * np.pi * 2 * t),
                         -0.8e-3 * np.sin(2 * np.pi * 5 * t) + 0.1e-3])
    return c, r, c.forces(p), np.array([r.step(tuple(q)) for q in p.tolist()])


# every letter on the analytic bases; on the meshes A on one and F on the other in the
# contributor's loop, the rest (0.6-0.9 s each) in .ci/run's long set
@pytest.mark.parametrize("letter, base_name", [
    pytest.param(letter, base, marks=[pytest.mark.long] if "mesh" in base and (letter, base) not in
                 (("A", "mesh"), ("F", "prism mesh")) else [])
    for base in ("sphere", "cylinder", "mesh", "prism mesh") for letter in ("A", "G", "F")])
def test_an_object_exports_and_ticks_as_the_renderer(tmp_path, objdir, base_name, letter):
    # issue 32: A, G and F (its presliding state in the surface coordinates) on the egg-crate on
    # a sphere, a cylinder and a 1,280-triangle mesh,
    # faceted or swept into prisms along its vertex normals (its corners and per-triangle
    # constants as tables, its hierarchy built by haptex_init):
    # along a stroke over the object, in and out of it, every tick equals the compiled
    # Renderer's bit for bit (the same C: hx_object.c), and so do the work counts
    from haptex.objects import Cylinder, Sphere, object_algorithm

    egg = hx.SumOfGratings.egg_crate(0.2e-3, 2e-3)
    R = 40 * 2e-3 / (2 * np.pi)
    from haptex.objects import Mesh

    base = {"sphere": lambda: Sphere(R), "cylinder": lambda: Cylinder(R),
            "mesh": lambda: _icosphere_base(3, R)[1],
            "prism mesh": lambda: Mesh(_icosphere_base(3, R)[0], uv=_icosphere_base(3, R)[1].uv,
                                       normals="vertex")}[base_name]()
    alg = object_algorithm(letter, egg, base, K0)
    c, r, got, ref = _exported_and_renderer_on_a_stroke(alg, tmp_path, objdir, 5_001)
    assert "HX_BASE_" + base_name.split()[-1].upper() in (tmp_path / "haptex_texture.c").read_text()
    assert np.array_equal(got, ref) and np.abs(ref).max() > 1.0
    assert c.count("max_work") == r.max_work and c.count("clamps") == r.clamps


def test_an_object_at_the_command_line_exports(tmp_path):
    r = run_main("export", "--algorithm", "B", "--texture", "egg-crate:0.2mm,2mm", "--stiffness",
                 "2 kN/m", "--max-force", "5 N", "--object", "sphere:12.7323954mm", "--max-penetration", "0.3mm",
                 "--out", str(tmp_path))
    assert r.returncode == 0, r.stderr  # (B's d^z_max on the object: Remark 3 on the base)
    assert "HX_BASE_SPHERE" in (tmp_path / "haptex_texture.c").read_text()
    assert "max_penetration=0.0003" in r.stdout
    subprocess.run([CC, *STRICT, "-c", str(tmp_path / "haptex_texture.c"), "-o", str(tmp_path / "t.o")], check=True)
    r = run_main("export", "--algorithm", "D", "--texture", "egg-crate:0.2mm,2mm", "--stiffness",
                 "2 kN/m", "--max-force", "5 N", "--object", "sphere:12.7323954mm", "--out", str(tmp_path))
    assert r.returncode == 0, r.stderr  # D on a sphere: the object's closest-point search
    assert "HX_ALG_D" in (tmp_path / "haptex_texture.c").read_text()
    from .test_objects import _ball_obj

    ball, scale = _ball_obj(tmp_path, subdivisions=1)
    r = run_main("export", "--algorithm", "D", "--texture", "egg-crate:0.2mm,2mm", "--stiffness",
                 "2 kN/m", "--max-force", "5 N", "--object", str(ball), "--uv-scale", f"{scale} m",
                 "--out", str(tmp_path / "mesh"))
    assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1 and "base = " in r.stderr, r.stderr


@pytest.mark.parametrize("letter, base_name", [("D", "sphere"), ("E", "sphere"), ("proxy", "sphere"),
                                               ("proxy", "cylinder"), ("proxy", "mesh"), ("D", "prism mesh")])
def test_the_closest_point_and_the_proxy_on_a_curved_base_export_and_tick_as_the_renderer(tmp_path, objdir, letter,
                                                                                          base_name):
    # D and E (the closest point of the textured object: hx_object.c's search, its budget in the
    # tables; on the prism mesh its search over the prisms) and the proxy (Gauss-Newton on the
    # surface's closed-form Jacobian; on a 1,280-facet mesh through its UV map) over a base: the
    # exported tick equals the compiled Renderer's bit for bit along a stroke over the object, in
    # and out of it, and so does the largest work
    from haptex.objects import Cylinder, Sphere, object_algorithm
    from haptex.proxy import GodObject

    R = 40 * 2e-3 / (2 * np.pi)
    egg = hx.SumOfGratings.egg_crate(0.2e-3, 2e-3)
    from haptex.objects import Mesh

    base = {"sphere": lambda: Sphere(R), "cylinder": lambda: Cylinder(R),
            "mesh": lambda: _icosphere_base(3, R)[1],
            "prism mesh": lambda: Mesh(_icosphere_base(3, R)[0], uv=_icosphere_base(3, R)[1].uv,
                                       normals="vertex")}[base_name]()
    alg = GodObject(egg, K0, base) if letter == "proxy" else object_algorithm(letter, egg, base, K0)
    c, r, got, ref = _exported_and_renderer_on_a_stroke(alg, tmp_path, objdir, 1501)
    assert f"HX_ALG_{letter.upper()}" in (tmp_path / "haptex_texture.c").read_text()
    assert np.array_equal(got, ref) and np.abs(ref).max() > 0.5
    assert c.count("max_work") == r.max_work


@pytest.mark.parametrize("tex", [hx.Sinusoid(A, L), hx.SumOfGratings.egg_crate(0.2e-3, 2e-3)], ids=["sine", "egg"])
def test_the_god_object_exports_and_ticks_as_the_renderer(tmp_path, objdir, tex):
    # issue 32: the proxy's C tick (its descent, its history) written for firmware: along a
    # stroke in and out of the wall, back and forth, every tick equals the compiled Renderer's
    # bit for bit, and so does the largest work
    from haptex.proxy import GodObject

    g = GodObject(tex, K0)
    c = Compiled(g, tmp_path, objdir, max_force=5.0)
    assert "HX_ALG_PROXY" in (tmp_path / "haptex_texture.c").read_text()
    r = hx.Renderer(g, max_force=5.0)
    d = g.dimension
    p = _stroke3(3001) if d == 3 else _stroke3(3001)[:, ::2]
    got = c.forces(p)
    ref = np.array([r.step(tuple(q)) for q in p.tolist()])
    assert np.array_equal(got, ref) and np.abs(ref).max() > 0.5  # (in contact: forces of newtons)
    assert c.count("max_work") == r.max_work


@pytest.mark.parametrize("budget, mu", [(None, None), (2e-4, None), (None, 0.5)])
def test_an_exported_vibration_ticks_as_the_renderers(tmp_path, objdir, budget, mu):
    # Issue 54: the data-driven vibration in the exported C (`haptex_init` sets the model set's
    # tables, mass, gain, filter, seed and budget through hx_render_set_vibration, the function
    # the Renderer's binding calls): along a stroke in contact at the set's rate every tick's
    # force equals the Renderer's to the bit, with and without an energy budget; the vibration
    # acts (its force is not zero), and the budget cuts it (or the test would pass vacuously).
    from .test_datadriven import FS, _set

    models = _set()
    models.mu = mu  # (a HaTT set's material friction, on by default where the set has one)
    alg = hx.algorithm("A", hx.Sinusoid(A, L), K0)
    kw = dict(vibration=models, vibration_mass=0.1, seed=7, vibration_budget=budget)
    c = Compiled(alg, tmp_path, objdir, max_force=5.0, **kw)
    r = hx.Renderer(alg, max_force=5.0, **kw)
    n = 4000
    t = np.arange(n) / FS
    p = np.column_stack([0.05 * t, np.full(n, -0.5e-3) + 0.1e-3 * np.sin(2 * np.pi * 3 * t)])
    got = c.forces(p)
    ref, vib = [], []
    for q in p.tolist():
        ref.append(r.step(tuple(q)))
        vib.append(r.vibration_force)
    assert np.array_equal(got, np.array(ref))
    assert np.max(np.abs(vib)) > 0.01
    if budget is not None:
        assert r.vibration_cut > 0
    if mu is not None:
        assert r.friction == (0.5, 0.005) and r.friction_dissipated > 0
    text = (tmp_path / "haptex_texture.c").read_text()
    assert ("hx_vib_channel_set_friction(&r->vib, 0.5, 0.005)" in text) == (mu is not None)
    assert "hx_render_set_vibration(r, VIB" in text and "7ULL" in text
    with pytest.raises(hx.ParameterError, match=r"^vibration_mass = None is not allowed"):
        export_c(alg, tmp_path / "x", 5.0, vibration=models)


def test_haptex_export_takes_a_vibration_for_its_device(tmp_path):
    # --vibration MODELS with --device: the device's mass along x and its servo rate (the models
    # must run at it, as `haptex run --vibration` requires); the output compiles warning-free
    from haptex import datadriven as dd

    from .test_datadriven import _ar

    def models(rate):
        return dd.ModelSet([dd.ArmaModel(_ar((60, 0.97)), [1.0], 1.0, 1.0, rate, v, f)
                            for v, f in ((0.02, 0.5), (0.1, 0.5), (0.06, 2.0))])

    at_1k, at_2k = tmp_path / "m1k.json", tmp_path / "m2k.json"
    models(1000.0).write(at_1k)
    models(2000.0).write(at_2k)
    out = tmp_path / "fw"
    args = ["export", "--algorithm", "A", "--texture", "sine:0.2mm,2mm", "--stiffness", "500 N/m", "--max-force", "5 N",
            "--out", str(out)]
    r = run_main(*args, "--device", "falcon", "--vibration", str(at_1k), "--vibration-budget", "2 mW")
    assert r.returncode == 0 and "a data-driven vibration" in r.stdout, r.stderr
    text = (out / "haptex_texture.c").read_text()
    mass = float(hx.catalogue.preset("falcon").device(dimension=2).mass[0, 0])
    assert f"hx_render_set_vibration(r, VIB, {mass!r}, 1.0, 0.01," in text and "0.002, " in text
    subprocess.run([CC, *STRICT, "-o", str(tmp_path / "t"), *map(str, out.glob("*.c")), "-lm", "-Wl,-e,haptex_init",
                    "-nostartfiles"], check=True)
    for extra, what in ((["--vibration", str(at_1k)], "--vibration needs --device"),
                        (["--device", "falcon", "--vibration", str(at_2k)], "its models run at 2000 Hz, the device's "
                                                                             "servo at 1000 Hz"),
                        (["--vibration-budget", "2 mW"], "--vibration-budget is not allowed without --vibration"),
                        (["--no-material-friction"], "--no-material-friction is not allowed without --vibration")):
        r = run_main(*args, *extra)
        assert r.returncode == 2 and what in r.stderr and len(r.stderr.strip().splitlines()) == 1, r.stderr


def _literals(source: str) -> int:
    """The numbers a generated C source's constant tables hold, counted in the text (each
    ``static const double NAME[N] = { ... };`` block's comma-separated items), not by haptex."""
    import re

    total = 0
    for body in re.findall(r"static const double \w+\[\d+\] = \{(.*?)\};", source, flags=re.S):
        items = [t for t in re.sub(r"/\*.*?\*/", "", body, flags=re.S).replace("\n", " ").split(",") if t.strip()]
        total += len(items)
    return total


@needs_data
@pytest.mark.long  # (an export of a million numbers, 9 s, and two refusals: 20 s)
def test_a_map_too_large_to_export_names_a_crop_that_exports(tmp_path):
    # mi-1.mi (SurfaceTopography's corpus: 256 x 256 samples, 20 um square) holds 16 numbers a
    # bicubic patch, 1,040,411 in all: past the host's 1,000,000 (MAX_TABLE, chosen: 8 MB of
    # constants). Before, the refusal ended "low-pass or window the texture first": no bound,
    # and --lowpass takes a profile only. Now it names a --crop; taken as written, the export's
    # source holds at most 1,000,000 numbers (counted in the written file); a part 3 % longer
    # each side is refused, naming the same bound
    import re

    from .conftest import DATA

    args = ["export", "--algorithm", "A", "--texture", str(DATA / "mi-1.mi"), "--stiffness", "1 kN/m",
            "--max-force", "5 N", "--quiet"]
    r = run_main(*args, "--out", str(tmp_path / "all"))
    assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1, r.stderr
    assert "1,040,411 numbers" in r.stderr and "more than the 1,000,000" in r.stderr, r.stderr
    crop = re.search(r"--crop (\S+)", r.stderr)
    assert crop, r.stderr
    r2 = run_main(*args, "--out", str(tmp_path / "part"), "--crop", crop.group(1))
    assert r2.returncode == 0, r2.stderr
    held = _literals((tmp_path / "part" / "haptex_texture.c").read_text())
    assert 900_000 < held <= 1_000_000, held  # (the bound within a tenth of the cap: it is not a token)
    x0, x1, y0, y1 = crop.group(1).split(",")
    wider = ",".join([x0, f"{float(x1[:-2]) * 1.03:.6g}um", y0, f"{float(y1[:-2]) * 1.03:.6g}um"])
    r3 = run_main(*args, "--out", str(tmp_path / "wider"), "--crop", wider)
    assert r3.returncode == 2 and f"--crop {crop.group(1)}" in r3.stderr, r3.stderr


def test_haptex_export_takes_the_searchs_budget(tmp_path):
    # --max-evaluations (export_c's max_evaluations): D over the egg-crate with a budget of 200
    # evaluations writes it into the search's constants (aux[G_BUDGET], the core's layout) and
    # states it in the header; outside [100, 10^9] it is refused as typed
    from haptex.core import _ext

    args = ["export", "--algorithm", "D", "--texture", "egg-crate:0.1mm,2mm", "--stiffness", "1 kN/m",
            "--max-force", "5 N", "--quiet"]
    r = run_main(*args, "--out", str(tmp_path / "fw"), "--max-evaluations", "200")
    assert r.returncode == 0, r.stderr
    assert "about 200 texture evaluations" in (tmp_path / "fw" / "haptex_texture.h").read_text()
    source = (tmp_path / "fw" / "haptex_texture.c").read_text()
    aux = source[source.index("static const double AUX["):].split("{", 1)[1].split("}", 1)[0]
    assert float(aux.replace("\n", " ").split(",")[_ext.G_BUDGET]) == 200.0
    r = run_main(*args, "--out", str(tmp_path / "no"), "--max-evaluations", "50")
    assert r.returncode == 2 and "--max-evaluations 50 is not allowed" in r.stderr, r.stderr
    # where nothing reads it (A searches nothing; D over a profile is bounded by its tree:
    # renderer.tick_model writes no budget there) it was ignored, exit 0; now refused
    for letter, texture in (("A", "egg-crate:0.1mm,2mm"), ("D", "sine:0.1mm,2mm")):
        r = run_main("export", "--algorithm", letter, "--texture", texture, "--stiffness", "1 kN/m", "--max-force",
                     "5 N", "--quiet", "--out", str(tmp_path / "ignored"), "--max-evaluations", "200")
        assert r.returncode == 2 and f"--max-evaluations is not allowed with --algorithm {letter}" in r.stderr
    assert not (tmp_path / "ignored").exists()
