"""Textures that leave Python: a C99 servo tick for device firmware.

The exported tick *is* haptex's C core: :func:`export_c` copies the core's own files
(:data:`TICK_FILES`, unchanged) and renders, from Jinja2 templates shipped in
``haptex/templates``, one algorithm's tables (the texture's coefficients, D's and E's search
data, F's presliding table) and the entry points ``haptex_init`` and ``haptex_step`` around
the core's ``hx_render_step``. No C is written from Python strings, and no numeric code is
declared twice: the template names the core's enums (``HX_ALG_D``, ``HX_P_K0``, ...).

All eight algorithms export, over every texture the renderer takes (profiles, sums of
gratings, height maps, extruded profiles), with the renderer's safety rules and its per-tick
evaluation budget.
"""

from __future__ import annotations

import math
import shutil
from pathlib import Path

import numpy as np

from . import core as _core
from ._validation import ParameterError, a_path, fail, positive_or_inf
from .algorithms import ALGORITHMS, Algorithm, checked_algorithm
from .core import _ext
from .renderer import (FRICTION_THRESHOLD, MAX_EVALUATIONS, WORKSPACE_LIMIT, Stabiliser, evaluation_budget,
                       friction_settings, stabiliser_period, tick_model, vibration_settings)

EXPORTABLE = "".join(ALGORITHMS)
"""Algorithms :func:`export_c` can write."""

MAX_TABLE = 1_000_000
"""Most numbers (texture coefficients and search data) written into C source: 8 MB of constants."""


def _num(v: float) -> str:
    """A C double literal that reads back to exactly ``v``."""
    v = float(v)
    if math.isinf(v):
        return "HUGE_VAL" if v > 0 else "(-HUGE_VAL)"
    text = repr(v)
    return text if ("e" in text or "." in text) else text + ".0"


def _nums(values) -> list:
    """:func:`_num` of each value of an array (its Python floats: a third of the time of numpy's)."""
    return [_num(v) for v in np.asarray(values, dtype=np.float64).ravel().tolist()]


TICK_FILES = ("hx_core.h", "hx_fields.h", "hx_texture_eval.h", "hx_texture.c", "hx_forces.c", "hx_presliding.c",
              "hx_closest.c", "hx_surface.c", "hx_object.c", "hx_vibration.c", "hx_render.c", "hx_servo.c")
"""The C core's files a servo tick needs, copied unchanged by :func:`export_c`, with the servo
loop's safety rules (hx_servo.c: engagement, ramp, watchdog, ceiling; what ``haptex run``
runs). The core's others: the simulator's loops, hx_sim.c, and the Python binding, _ext.c."""

TARGETS = {
    "host": {"cc": "cc", "flags": ()},
    "cortex-m4": {"cc": "arm-none-eabi-gcc", "flags": ("-mcpu=cortex-m4", "-mthumb", "-mfpu=fpv4-sp-d16",
                                                        "-mfloat-abi=hard"),
                  "qemu": "mps2-an386", "fpu": "single precision: the core's doubles in libgcc's software routines",
                  "flash": 4 * 1024 * 1024},
    "cortex-m7": {"cc": "arm-none-eabi-gcc", "flags": ("-mcpu=cortex-m7", "-mthumb", "-mfpu=fpv5-d16",
                                                        "-mfloat-abi=hard"),
                  "qemu": "mps2-an500", "fpu": "double precision", "flash": 4 * 1024 * 1024},
}
"""What :func:`export_c` writes for: the host's C compiler, or a Cortex-M4F or M7 (Debian's
arm-none-eabi-gcc and newlib; the hard-float ABI of each one's FPU; ``qemu`` the QEMU board the
tests run each on; ``flash`` its code memory in bytes, published: SSRAM1, 4 MB at address 0 on the
MPS2 boards, Arm's Application Notes 386 and 500 and QEMU's ``mps2`` machines, the ``FLASH``
region of the ``mps2.ld`` written beside the export)."""

FIRMWARE_CODE = 256 * 1024
"""Bytes of a board's flash kept for the code beside the tables (chosen: every letter's code and
the objects' linked take 157 kB on a Cortex-M4F, A's alone 29 kB, arm-none-eabi-size
2026-11-29); a Cortex-M export's tables may fill the rest, :func:`table_capacity`."""


def table_capacity(target: str = "host") -> int:
    """The most numbers an export's tables (texture coefficients, search data, a mesh's
    triangles, a vibration's models) may hold for ``target``.

    Parameters
    ----------
    target : {"host", "cortex-m4", "cortex-m7"}, optional
        A key of :data:`TARGETS`.

    Returns
    -------
    int
        :data:`MAX_TABLE` on the host; on a Cortex-M the doubles (8 bytes each) its board's
        flash holds beside :data:`FIRMWARE_CODE`, at most :data:`MAX_TABLE`: 491,520 on
        QEMU's MPS2 boards (4 MiB).

    Raises
    ------
    ParameterError
        For an unknown target.
    """
    flash = _target(target).get("flash")
    return MAX_TABLE if flash is None else min(MAX_TABLE, (flash - FIRMWARE_CODE) // 8)


def _target(target: str) -> dict:
    """TARGETS[target], or the refusal of a target it does not hold."""
    if target not in TARGETS:
        raise fail("target", target, " or ".join(repr(t) for t in TARGETS))
    return TARGETS[target]

FIRMWARE_FLAGS = ("-std=c99", "-O2", "-Wall", "-Wextra", "-Werror", "-ffunction-sections", "-fdata-sections")
"""The flags every exported file compiles with for a Cortex-M (each function and datum in its
own section, so that the linker's garbage collection of sections keeps only what is reached)."""

BOARD_FILES = ("startup.c", "mps2.ld", "main.c")
"""The bare-metal start, memory map and example main written beside a Cortex-M export."""


def build_defines(algorithm) -> tuple[str, ...]:
    """The ``-D`` flags an export of ``algorithm`` compiles with, so that only its code is linked.

    Parameters
    ----------
    algorithm : Algorithm or GodObject
        What is exported.

    Returns
    -------
    tuple of str
        ``-DHX_ONLY_ALG=N`` (N its ``HX_ALG_*`` code: the tick's table keeps only its letter,
        the core's ``hx_fields.h``), and ``-DHX_NO_OBJECTS`` on the plane (the objects' code
        unreached). With ``-ffunction-sections`` and ``-Wl,--gc-sections`` at the link, the rest of
        the core is dropped: A on a Cortex-M4F 157 kB -> 24 kB of flash. Without them the
        same files build every letter, with the same forces.

    Raises
    ------
    ParameterError
        For an object that is not an algorithm (as :func:`export_c`).
    """
    algorithm = checked_algorithm(algorithm, proxy=True)
    on_object = getattr(algorithm, "base", None) is not None
    code = int(getattr(_ext, f"ALG_{algorithm.letter.upper()}"))  # (the template's HX_ALG_<letter>)
    return (f"-DHX_ONLY_ALG={code}",) + (() if on_object else ("-DHX_NO_OBJECTS",))


def firmware_command(out, target: str, *, relative: bool = False, elf: str = "haptex.elf",
                     defines: tuple = ()) -> list:
    """The command that builds an export in ``out`` for ``target``.

    Parameters
    ----------
    out : str or Path
        The export's directory.
    target : str
        A key of :data:`TARGETS`.
    relative : bool, optional
        Name the files relative to ``out`` (as the header states the command).
    elf : str, optional
        The output's name (a Cortex-M's ELF).
    defines : tuple of str, optional
        ``-D`` flags (:func:`build_defines`: only the exported algorithm's code linked).

    Returns
    -------
    list of str
        The compiler and its arguments; ``*.c`` stands for the export's C files (expand it, or
        run the command in a shell).

    Raises
    ------
    ParameterError
        For an unknown target, or an ``out`` that is not a path (a str or os.PathLike,
        PEP 519).
    """
    t = _target(target)
    out = a_path("out", out, "the export's folder's path")
    d = Path(".") if relative else out
    if target == "host":
        return [t["cc"], "-std=c99", "-O2", *defines, "-o", str(d / "tick"), "your_loop.c", str(d / "*.c"), "-lm"]
    return [t["cc"], *t["flags"], *FIRMWARE_FLAGS, *defines, "-nostartfiles", "-T", str(d / "mps2.ld"),
            "-Wl,--gc-sections", "-o", str(d / elf), str(d / "*.c"), "-lm", "-lc", "-lnosys"]


_KINDS = ("TEXTURE_FLAT", "TEXTURE_FOURIER", "TEXTURE_SPLINE", "SURFACE_GRATINGS", "SURFACE_PATCHES")
_PARAMS = ("P_K0", "P_DZMAX", "P_MU", "P_DXMAX", "P_SCALE", "P_ZSTICK")
_STABS = ("STAB_PC", "STAB_PC_STORED", "STAB_EBA", "STAB_PSPM")


def _templates():
    import jinja2

    return jinja2.Environment(loader=jinja2.PackageLoader("haptex", "templates"), undefined=jinja2.StrictUndefined,
                              keep_trailing_newline=True, autoescape=False)


def _tick_tables(algorithm, max_evaluations, cap: int):
    """The tick's arrays as :func:`export_c` writes them: (code, prm, kind, coeffs, aux,
    search_table, base), a textured object's base tables in ``base`` (None on the plane); D's and
    E's cell table over a profile left out where the tables would pass ``cap`` numbers with it
    (the tree alone: the same closest points, more work a tick)."""
    base = None
    if getattr(algorithm, "base", None) is not None:  # a textured object: the base's tables too
        code, prm, kind, coeffs, aux, _ = algorithm.object_spec(max_evaluations)
        base = algorithm.base.core_arrays()
        table = False
    else:
        code, prm, kind, coeffs, aux, table = tick_model(algorithm, max_evaluations)
    coeffs = np.asarray(coeffs, dtype=np.float64)
    if table and coeffs.size + aux.size > cap:
        aux = aux[:int(aux[_ext.A_TABLE])].copy()
        aux[_ext.A_TABLE] = 0.0
        table = False
    return code, prm, kind, coeffs, aux, table, base


def _held(coeffs, aux, base) -> int:
    """The numbers the tables of :func:`_tick_tables` hold."""
    return int(coeffs.size + aux.size + (0 if base is None else base[2].size + base[3].size))


def _plain_map(texture) -> bool:
    """Whether ``texture`` is a sampled profile or map as read (a part of it is its samples in
    a rectangle: what ``--crop`` keeps), not a felt map, a turned or graded one."""
    from .surfaces import SampledSurface
    from .textures import SampledProfile

    if getattr(texture, "_felt_radius", None) is not None:
        return False
    if type(texture) is SampledSurface:
        return texture._gradients is None and texture._knots is None
    return type(texture) is SampledProfile and not texture.resampled


def _part_sizes(texture, f: float) -> tuple:
    """The samples along each axis of a plain sampled texture's part of f (0 <= f <= 1) of them,
    at least 4."""
    return tuple(max(4, int(f * n)) for n in texture.h.shape)


def _part(texture, f: float):
    """The part of a plain sampled texture from its first sample, :func:`_part_sizes` of it."""
    from .surfaces import SampledSurface
    from .textures import SampledProfile

    n = _part_sizes(texture, f)
    if isinstance(texture, SampledSurface):
        i, j = n
        return SampledSurface(texture.x[:i], texture.y[:j], texture.h[:i, :j], periodic=texture.periodic)
    return SampledProfile(texture.x[:n[0]], texture.h[:n[0]], periodic=texture.periodic)


def _held_on(algorithm, texture, max_evaluations, cap: int) -> int:
    """The numbers the tables of ``algorithm`` with ``texture`` in place of its own hold (its
    letter, stiffness and parameters; on its object, the base's tables beside the texture's)."""
    from .algorithms import algorithm as make
    from .objects import object_algorithm

    params = {n: getattr(algorithm, n) for n in ALGORITHMS[algorithm.letter].parameters}
    if getattr(algorithm, "base", None) is None:
        other = make(algorithm.letter, texture, algorithm.stiffness, **params)
    else:
        other = object_algorithm(algorithm.letter, texture, algorithm.base, algorithm.stiffness, **params)
    _, _, _, coeffs, aux, _, base = _tick_tables(other, max_evaluations, cap)
    return _held(coeffs, aux, base)


def _tip_spacing_that_fits(algorithm, held: int, cap: int, max_evaluations, others: int):
    """A felt texture's grid spacing, coarser than its own, at which the texture felt by the
    same ball from the same texture has tables that fit: (the double, the ``--tip-spacing`` text),
    rounded up to 3 digits as the command line writes it, each candidate felt and its tables
    counted as :func:`export_c` counts them (from the cells' count, its tables' share of the
    numbers, then as much coarser as the last count says); None where 8 candidates do not fit
    or the texture cannot be felt on them."""
    from .probe import _stated_length

    tex = algorithm.texture
    source, r = getattr(tex, "_felt_from", None), tex._felt_radius
    if source is None or others >= cap:
        return None
    dim = np.ndim(tex.h)
    d = float(tex.x[1] - tex.x[0])
    for _ in range(8):
        d *= max(1.01, (held + others) / cap) ** (1.0 / dim)  # (the tables grow as the cells, (1 / d)^dim)
        value, text = _stated_length(d, up=True, fits=lambda v, d=d: v >= d)
        try:
            held = _held_on(algorithm, source.felt_by(r, spacing=value), max_evaluations, cap)
        except ParameterError:
            return None
        if held + others <= cap:
            return value, text
        d = value
    return None


def _crop_that_fits(algorithm, cap: int, max_evaluations, others: int):
    """The largest part from a plain sampled texture's first sample, in its proportions, whose
    tables with ``others`` numbers beside them hold at most ``cap`` (bisection on the count
    :func:`export_c` makes): (samples kept along each axis, the ``--crop`` text, the crop tuple
    in m for ``load_texture``), the text read back as the command line reads it keeping no more
    samples; None where 4 samples a side do not fit."""
    from ._loaders import crop_region
    from ._specs import quantity
    from .probe import _stated_length

    tex = algorithm.texture

    def fits(f):
        return _held_on(algorithm, _part(tex, f), max_evaluations, cap) + others <= cap

    if not fits(0.0):
        return None
    lo, hi = 0.0, 1.0
    for _ in range(int(np.ceil(np.log2(max(tex.h.shape)))) + 1):  # (to less than a sample a side)
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if fits(mid) else (lo, mid)
    n = _part_sizes(tex, lo)
    axes = [tex.x] if len(n) == 1 else [tex.x, tex.y]

    def outward(v, up, ok):  # (v rounded away from the part to 6 digits, as the command line writes it)
        if v == 0:
            return "0"
        if v < 0:
            return "-" + _stated_length(-v, up=not up, digits=6, fits=lambda w: ok(-w))[1]
        return _stated_length(v, up=up, digits=6, fits=ok)[1]

    words = []
    for a, k in zip(axes, n):  # (each bound short of the next sample)
        words += [outward(float(a[0]), False, lambda v: True),
                  outward(float(a[k - 1]), True, lambda v, a=a, k=k: k == a.size or v < a[k])]
    typed = tuple(quantity(w, "m", "crop") for w in words)
    kept = crop_region(tex.x, None if len(n) == 1 else tex.y, None, typed)
    if [s.stop - s.start for s in kept] != list(n):
        return None  # (not met on this project's maps: a bound that cannot be written short of the next sample)
    exact = tuple(float(v) for a, k in zip(axes, n) for v in (a[0], a[k - 1]))
    words = ",".join(words)
    return n, words, exact


def _too_large(algorithm, vibration, vib, held: int, meshed: int, cap: int, target: str,
               max_evaluations) -> ParameterError:
    """The refusal of tables holding ``held`` numbers (``meshed`` of them a mesh's triangles)
    where ``cap`` fit on ``target``, naming the remedy that exists: a crop of a sampled texture
    with its bound (taken as written, it is exported), a mesh decimated, a smaller model set."""
    where = (f"the host's MAX_TABLE, {MAX_TABLE * 8 / 1e6:g} MB of constants" if target == "host" else
             f"the {TARGETS[target]['flash'] // (1024 * 1024)} MiB of flash of QEMU's {TARGETS[target]['qemu']} "
             f"board, mps2.ld, less {FIRMWARE_CODE // 1024} KiB kept for the code")
    size = f"its tables hold {held:,} numbers ({held * 8 / 1e6:.3g} MB), more than the {cap:,} that fit ({where})"
    to = "" if target == "host" else f" to {target}"
    if meshed and 2 * meshed >= held:
        return ParameterError(f"object = {algorithm.base!r} is not allowed for export{to}: {size}, {meshed:,} of "
                              f"them its triangles' ({_ext.FACE + 9} a triangle); decimate the mesh first")
    others = 0 if vib is None else vib[0].size
    if others > cap // 2:
        return ParameterError(f"vibration = {vibration!r} is not allowed for export{to}: {size}, its model set's "
                              f"{others:,} of them; fit fewer or shorter models")
    tex = getattr(algorithm, "texture", None)
    if tex is not None and _plain_map(tex):
        found = _crop_that_fits(algorithm, cap, max_evaluations, others)
        if found is not None:
            n, words, bounds = found
            remedy = (f"a part of {' x '.join(f'{k:,}' for k in n)} samples fits: --crop {words} at the command line "
                      f"(crop={bounds!r} in load_texture)")
        else:
            remedy = "not even a part of 4 samples a side fits"
    elif getattr(tex, "_felt_radius", None) is not None:
        found = _tip_spacing_that_fits(algorithm, held - others, cap, max_evaluations, others)
        coarser = ("feel it on a coarser grid (--tip-spacing; felt_by(r, spacing=) in Python)" if found is None else
                   f"feel it on a coarser grid: --tip-spacing {found[1]} fits (felt_by(r, spacing={found[0]!r}) "
                   "in Python)")
        remedy = f"{coarser}, or crop the map it is felt on (--crop at the command line)"
    else:
        remedy = "sample it more coarsely or crop it"
    return ParameterError(f"texture = {tex!r} is not allowed for export{to}: {size}; {remedy}")


def check_settings(max_force: float, max_evaluations: int | None = MAX_EVALUATIONS, target: str = "host") -> float:
    """Refuse :func:`export_c`'s settings that do not depend on the algorithm, before anything
    costly is made for it (the command line checks them before a ball rolls over the texture).

    Parameters
    ----------
    max_force : float
        The force saturation (N), > 0 or inf.
    max_evaluations : int or None
        D's and E's budget of texture evaluations a tick, 100 to 10^9, or None (unbounded).
    target : str
        A key of :data:`TARGETS`.

    Returns
    -------
    float
        ``max_force`` as a float (N).

    Raises
    ------
    ParameterError
        For a max force that is not > 0, a budget out of range, or an unknown target.
    """
    fmax = positive_or_inf("max_force", max_force, "N")
    evaluation_budget(max_evaluations)
    table_capacity(target)
    return fmax


def export_c(algorithm: Algorithm, out, max_force: float, max_evaluations: int | None = MAX_EVALUATIONS,
             passivity_controller: Stabiliser | None = None, period: float | None = None, *, vibration=None,
             vibration_mass: float | None = None, vibration_gain: float = 1.0, velocity_filter: float = 0.01,
             seed: int = 0, vibration_budget: float | None = None,
             vibration_reserve: float | None = None, friction: bool | None = None,
             friction_threshold: float = FRICTION_THRESHOLD, target: str = "host") -> tuple[Path, Path]:
    """Write a servo tick for device firmware into ``out``: the C core's files the tick needs
    (:data:`TICK_FILES`, copied unchanged: the code :class:`haptex.Renderer` runs) and
    ``haptex_texture.h`` / ``haptex_texture.c``, this algorithm's tables and entry points,
    rendered from the package's Jinja2 templates (``haptex/templates``).

    Parameters
    ----------
    algorithm : Algorithm
        Any of W, A-G on any texture the renderer takes: a Fourier series or sampled profile
        (positions [x, z], ``HAPTEX_DIMENSION`` 2), a sum of gratings, a height map or an
        extruded profile ([x, y, z], ``HAPTEX_DIMENSION`` 3); or a god-object over the plane, a
        cylinder or a sphere (:class:`haptex.proxy.GodObject`); or A, B, C, F, G on an object the
        renderer takes (:func:`haptex.objects.object_algorithm`: [x, y, z]; a mesh's corners and
        per-triangle constants become tables, its hierarchy is built by ``haptex_init``).
    out : str or Path
        Directory, created if needed; the files of the same names in it are replaced.
    max_force : float
        Saturation of the force magnitude (N), > 0, or inf for none (as the renderer's).
    max_evaluations : int or None, optional
        D and E over a surface: the evaluation budget of one tick's closest-point search, as
        :class:`haptex.Renderer`'s (default :data:`haptex.renderer.MAX_EVALUATIONS`).
    passivity_controller : Stabiliser, optional
        A stabiliser the exported tick runs on each tick with the passivity observer, as
        :class:`haptex.Renderer` does: :class:`~haptex.renderer.PassivityController` (Hannaford
        & Ryu 2002), :class:`~haptex.renderer.EnergyBounding` or
        :class:`~haptex.renderer.PassiveSetPosition`, set in ``haptex_init``; the observed
        energy is ``haptex_energy`` (J). Default none (and no observer).
    period : float, optional
        The servo period (s, > 0), required with ``passivity_controller``: the tick's velocity
        estimate is dp / period.
    vibration, vibration_mass, vibration_gain, velocity_filter, seed, vibration_budget, vibration_reserve
        A data-driven vibration layered on the tick, set by ``haptex_init`` with its model set's
        tables, as :class:`haptex.Renderer` takes them (``hx_render_set_vibration``: the same
        synthesis, noise and budget, so the exported tick is the Renderer's to the bit).
        ``haptex_step`` must then be called at the set's rate.
    friction, friction_threshold
        The material's kinetic friction beside the vibration, as :class:`haptex.Renderer`
        takes it (``hx_vib_channel_set_friction``; on by default for a set with a mu).
    target : {"host", "cortex-m4", "cortex-m7"}, optional
        What the files are compiled for (:data:`TARGETS`): the header states the compiler's
        flags (the float ABI among them); for a Cortex-M, a bare-metal start (``startup.c``,
        ``mps2.ld``: QEMU's MPS2 boards' memory map, to adapt to a board's) and an example
        ``main.c`` are written beside (:func:`firmware_command` builds them).

    Returns
    -------
    (Path, Path)
        The header and the source generated (the core's files are beside them).

    Raises
    ------
    ParameterError
        For tables (texture coefficients and D's, E's or F's search data) above
        :data:`MAX_TABLE` numbers, a bad ``max_force`` or ``max_evaluations``, a
        ``passivity_controller`` that is not a stabiliser or comes without a ``period``, a
        vibration refused as :class:`haptex.Renderer` refuses it (or whose tables exceed
        :data:`MAX_TABLE`), an unknown ``target``, an ``out`` that is not a path (a str or
        os.PathLike, PEP 519) or is unwritable.

    Notes
    -----
    ``haptex_step`` is :meth:`haptex.Renderer.step` (without the energy observer unless a
    stabiliser is given, then with it and the stabiliser): the same
    C function (``hx_render_step``) on the same arrays (:func:`haptex.renderer.tick_model`),
    so the same safety rules: a non-finite coordinate or one beyond the workspace is a fault
    (zero force, return 1), the force is saturated to ``max_force``, a non-finite force is a
    fault, and the work is bounded and counted (``haptex_work``, ``haptex_cut``).
    """
    algorithm = checked_algorithm(algorithm, proxy=True)
    out = a_path("out", out, "a folder's path")
    from importlib.metadata import version

    from .proxy import GodObject

    fmax = check_settings(max_force, max_evaluations, target)
    pc = passivity_controller
    T = stabiliser_period(pc, period)
    vib = vibration_settings(vibration, vibration_mass, vibration_gain, velocity_filter, seed, vibration_budget,
                             vibration_reserve)
    fric = friction_settings(vibration, friction, friction_threshold)
    cap = table_capacity(target)  # (an unknown target refused there)
    code, prm, kind, coeffs, aux, table, base = _tick_tables(algorithm, max_evaluations, cap)
    held = _held(coeffs, aux, base) + (0 if vib is None else vib[0].size)
    if held > cap:
        meshed = 0 if base is None else base[2].size + base[3].size
        raise _too_large(algorithm, vibration, vib, held, meshed, cap, target, max_evaluations)
    n_tri = 0 if base is None else len(base[2])
    letter = algorithm.letter
    dim = algorithm.dimension
    kinds = {int(getattr(_ext, n)): "HX_" + n for n in _KINDS}
    surface = kind in (_ext.SURFACE_GRATINGS, _ext.SURFACE_PATCHES)
    if isinstance(algorithm, GodObject):
        work = (f"the proxy's descent: at most {_ext.PROXY_STEPS} Newton steps, each backtracked at most "
                f"{_ext.PROXY_HALVINGS} times (one texture evaluation each)")
        aux = np.zeros(0)
        aux_what = ""
    elif letter in "DE" and not surface:
        work = ("the closest-point search, bounded by the texture's bound tree whatever the depth"
                + (" (first its cell table)" if table else ""))
        aux_what = "the closest-point search's data (haptex.closest.table_search_data)"
    elif letter in "DE":
        work = ("the closest-point search on the surface, at most 2,048 cells"
                + ("" if max_evaluations is None else f" and about {max_evaluations} texture evaluations"))
        aux_what = "the closest-point search's constants (haptex.closest.surface_search_data)"
    elif aux.size:
        work = "one texture evaluation and at most 71 steps of the presliding table"
        aux_what = "F's smooth presliding table (haptex.friction.smooth_table)"
    elif n_tri:
        work = (f"the closest point on the mesh through its bounding-volume hierarchy (at most its "
                f"{2 * n_tri - 1} nodes and {n_tri} triangles) and one texture evaluation")
        aux_what = ""
    else:
        work = "one texture evaluation"
        aux_what = ""
    rows, cols = coeffs.shape if coeffs.ndim == 2 else (1, coeffs.size)
    fields = dict(
        target=target, build=" ".join(firmware_command(Path("."), target, relative=True,
                                                        defines=build_defines(algorithm))),
        description=f"{algorithm!r}, max force {fmax:g} N".replace("*/", "* /"), version=version("haptex"),
        core_files=TICK_FILES, dim=dim, coords="[x, z]" if dim == 2 else "[x, y, z]",
        forces="[f_x, f_z]" if dim == 2 else "[f_x, f_y, f_z]", max_force=_num(fmax),
        workspace=_num(WORKSPACE_LIMIT), work=work, code_name=f"HX_ALG_{letter.upper()}", kind_name=kinds[int(kind)],
        params=[("HX_" + n, _num(prm[getattr(_ext, n)])) for n in _PARAMS], rows=rows, cols=cols,
        coeffs=_nums(coeffs), aux=_nums(aux), aux_what=aux_what,
        base=None if base is None else dict(
            kind=f"HX_BASE_{type(algorithm.base).__name__.upper()}", radius=_num(base[1]), n_tri=n_tri,
            prism=int(bool(base[4])),
            tri=_nums(base[2]), face=_nums(base[3]),
            what=repr(algorithm.base)),
        stabiliser=None if pc is None else dict(
            label=pc.label.replace("*/", "* /"),
            mode="HX_" + next(n for n in _STABS if int(getattr(_ext, n)) == pc.mode),
            damping=_num(pc.core_damping), period=_num(T), delay=0 if pc.delay is None else int(pc.delay)),
        vibration=None if vib is None else dict(
            what=f"{vibration!r}".replace("*/", "* /"), values=_nums(vib[0]), mass=_num(vib[1]),
            gain=_num(vib[2]), tau=_num(vib[3]), seed=f"{vib[4]}ULL", budget=_num(-1.0 if vib[5] is None else vib[5]),
            reserve=_num(vib[6]), friction=None if fric is None else dict(mu=_num(fric[0]), threshold=_num(fric[1]))))
    env = _templates()
    try:
        out.mkdir(parents=True, exist_ok=True)
        for name in TICK_FILES:
            shutil.copyfile(_core.SOURCE_DIR / name, out / name)
        if target != "host":
            for name in BOARD_FILES:
                shutil.copyfile(Path(__file__).parent / "templates" / "board" / name, out / name)
        h_path, c_path = out / "haptex_texture.h", out / "haptex_texture.c"
        h_path.write_text(env.get_template("haptex_texture.h.j2").render(**fields))
        c_path.write_text(env.get_template("haptex_texture.c.j2").render(**fields))
    except OSError as exc:
        raise ParameterError(f"out = {str(out)!r} is not allowed: cannot write there ({exc.strerror})") from None
    return h_path, c_path
