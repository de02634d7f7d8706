"""What the commands share: quantities with units, the option groups, devices and stabilisers from
their specs, progress displays, output paths."""

from __future__ import annotations

import functools
from pathlib import Path

import click

from .._specs import READING_KEYS, quantity as _q, split_spec as _split_spec
from .._validation import ParameterError
from ..tables import PAPER_PARAMETERS


class Quantity(click.ParamType):
    """A click parameter written with a unit ("0.8mm", "2 kN/m"), converted to SI."""

    name = "quantity"

    def __init__(self, unit: str):
        self.unit = unit

    def convert(self, value, param, ctx):
        if isinstance(value, float):
            return value
        pname = param.name if param is not None else "value"
        try:
            return _q(value, self.unit, pname)
        except ParameterError as exc:
            self.fail(str(exc), param, ctx)


def _letter(proxy: bool = False):
    """A click callback checking ``--algorithm``: a letter of :data:`haptex.algorithms.ALGORITHMS`
    (any case), or 'proxy' where ``proxy``; refused naming the option (the library's parameter
    is ``letter``)."""

    def check(ctx, param, value):
        from ..algorithms import ALGORITHMS

        if value is None or str(value).strip().upper() in ALGORITHMS or (proxy and str(value).strip().upper() == "PROXY"):
            return value
        allowed = ", ".join(sorted(ALGORITHMS, key=lambda c: (c != "W", c))) + (", or proxy" if proxy else "")
        raise ParameterError(f"--algorithm = {value!r} is not allowed: must be one of {allowed}")

    return check


def _paper_options(func):
    opts = [
        click.option("--stiffness", type=Quantity("N/m"), default=PAPER_PARAMETERS["stiffness"],
                     show_default="2000 N/m", help="Nominal wall stiffness kappa_0, e.g. '2 kN/m'."),
        click.option("--amplitude", type=Quantity("m"), default=PAPER_PARAMETERS["amplitude"],
                     show_default="0.8mm", help="Texture amplitude A, e.g. '0.8mm'."),
        click.option("--period", type=Quantity("m"), default=PAPER_PARAMETERS["period"],
                     show_default="1mm", help="Texture spatial period l, e.g. '1mm'."),
        click.option("--max-penetration", type=Quantity("m"), default=PAPER_PARAMETERS["max_penetration"],
                     show_default="1mm", help="d^z_max: the depth of the analysed region; in a simulation, "
                     "Remark 3's clamp of F (this default) and of B, C and G (only when given)."),
        click.option("--friction", type=Quantity("dimensionless"), default=PAPER_PARAMETERS["friction"],
                     show_default="0.8", help="Algorithm F's friction coefficient mu."),
        click.option("--presliding", type=Quantity("m"), default=PAPER_PARAMETERS["presliding"],
                     show_default="1mm", help="Algorithm F's presliding range d^x_max."),
    ]
    for opt in reversed(opts):
        func = opt(func)
    return func


def _parse_point(text: str, name: str, d: int = 2, what: str | None = None):
    """``d`` comma-separated lengths, each with its unit (m); ``what`` says what they are in a
    refusal (default: a point's coordinates)."""
    parts = [p for p in str(text).replace(";", ",").split(",")]
    if len(parts) != d:
        what = what or {2: "two lengths 'x,z', e.g. '0,-20mm'", 3: "three lengths 'x,y,z', e.g. '0,0,-20mm'",
                        4: "four lengths 'x0,x1,y0,y1', e.g. '0,0.3mm,0,0.3mm'"}[d]
        raise ParameterError(f"{name} = {text!r} is not allowed: must be {what}")
    return [_q(p.strip(), "m", name) for p in parts]


def _parse_path(text: str, d: int = 2):
    pts = [_parse_point(v, "path", d) for v in str(text).split(";") if v.strip()]
    if len(pts) < 2:
        raise ParameterError(f"path = {text!r} is not allowed: must be at least two points "
                             + ("'x,z;x,z;...'" if d == 2 else "'x,y,z;x,y,z;...'"))
    return pts


READING = tuple(k for k in READING_KEYS if k != "crop")
"""The options that say how a measured file is read (:func:`_reading_options`), by parameter name:
:data:`haptex._specs.READING_KEYS` but the crop (``--crop``, :func:`_felt_options`)."""


def _reading_options(func):
    """How a measured file is read, the same for every command that takes one (design, export,
    run): ``--spacing``, ``--x-unit``, ``--height-unit``, ``--variable``, ``--level``,
    ``--lowpass``, ``--scale``, ``--periodic`` and ``--fill-undefined`` (what a loader's refusal
    names), handed to the command as one dict ``reading`` (:func:`haptex._specs.texture_from_spec`'s
    keywords)."""

    @functools.wraps(func)
    def wrapped(*args, **kwargs):
        return func(*args, reading={k: kwargs.pop(k) for k in READING}, **kwargs)

    opts = [
        click.option("--spacing", type=Quantity("m"), default=None,
                     help="Sample spacing when the file does not state it, e.g. '0.5um'."),
        click.option("--x-unit", default=None, help="Unit of the file's x column when it does not state it."),
        click.option("--height-unit", default=None, help="Unit of the file's heights when it does not state it."),
        click.option("--variable", default=None,
                     help="The variable (a MATLAB file's), channel (an SPM file's: its name, or its index where "
                          "two share one) or heights' column (a text table's of named columns: its name or index) "
                          "to read, where the file holds several (default: a MATLAB file's only one, an SPM file's "
                          "height channel)."),
        click.option("--level", is_flag=True, help="Remove the file's best-fit line (a map's: its plane)."),
        click.option("--lowpass", type=Quantity("m"), default=None,
                     help="Band-limit the measured texture to this shortest period."),
        click.option("--scale", default=None, help="'LENGTH_FACTOR,HEIGHT_FACTOR' to stretch the measured texture."),
        click.option("--periodic", is_flag=True, help="Close the measured texture into a periodic one."),
        click.option("--fill-undefined", is_flag=True,
                     help="Fill a measured file's undefined (NaN) heights by interpolation instead of refusing the "
                          "file."),
    ]
    for opt in reversed(opts):
        wrapped = opt(wrapped)
    return wrapped


def _reading_given(ctx) -> list:
    """The reading options (:data:`READING`) given on the command line, as their flags."""
    return [o.opts[-1] for o in ctx.command.params
            if o.name in READING and ctx.get_parameter_source(o.name) == click.core.ParameterSource.COMMANDLINE]


def _felt_options(verb: str):
    """``--crop``, ``--tip-radius`` and ``--tip-spacing``, the same for every command that takes a
    measured texture (design, export, run); ``verb`` says what the command does with the texture
    it feels."""
    def deco(func):
        func = click.option("--tip-spacing", type=Quantity("m"), default=None,
                            help="With --tip-radius: the grid spacing of the felt map, e.g. '2um' (a measured map "
                                 "resampled by its spline; default: its own samples, or a 16th of the ball and of the "
                                 "shortest period of a synthetic texture); a refusal for work names the finest that "
                                 "fits.")(func)
        func = click.option("--tip-radius", type=Quantity("m"), default=0.0, show_default="0: a point probe",
                            help="Radius of the ball the texture is touched with, e.g. '0.5mm': the texture it feels "
                                 f"(the map dilated by the ball) is {verb}.")(func)
        return click.option("--crop", default=None,
                            help="The part of a measured file kept: 'auto' (the largest part without undefined "
                                 "points) or 'X0,X1' (a line scan) / 'X0,X1,Y0,Y1' (a map), each with its unit, e.g. "
                                 "'0.1mm,0.9mm,0,0.5mm'.")(func)
    return deco


def _vibration_options(func, friction: bool = True):
    """``--vibration`` and ``--vibration-budget``, the same for the commands that layer a
    data-driven vibration on a device's tick (run, export; with ``friction``, the tick's
    ``--no-material-friction`` too: the simulator does not render the material's friction)."""
    if friction:
        func = _friction_option(func)
    func = click.option("--vibration-budget", type=Quantity("W"), default=None,
                        help="With --vibration: the power it may supply, spent from an energy tank in the tick "
                             "(e.g. '2 mW').")(func)
    return click.option("--vibration", "vibration_models", type=click.Path(dir_okay=False, path_type=Path),
                        default=None,
                        help="A data-driven vibration layered on the texture (haptex's JSON or HaTT's XML, at the "
                             "device's servo rate): the device's mass along x times its acceleration, along the "
                             "motion.")(func)


def _friction_option(func):
    return click.option("--no-material-friction", "no_material_friction", is_flag=True,
                        help="With --vibration: leave out the material's kinetic friction (mu f_z against the "
                             "motion, mu from the model set, HaTT's <mu>), which is on when the set has a mu.")(func)


def _vibration_options_no_friction(func):
    return _vibration_options(func, friction=False)


def _object_options(what: str):
    """``--object``, ``--uv-scale``, ``--mesh-unit`` and ``--box-uv``, the same for every command that
    takes an object (design, export, run); ``what`` says which letters the command takes there and what it does with them."""
    def deco(func):
        func = click.option("--box-uv", is_flag=True,
                            help="With a mesh without texture coordinates (a CAD part's STL): lay the texture by box "
                                 "projection, each triangle's coordinates on the plane across its normal's largest "
                                 "axis, in metres.")(func)
        func = click.option("--mesh-unit", default=None,
                            help="With a mesh: the unit of its vertices' coordinates, e.g. 'mm' for a CAD part's STL "
                                 "(default: metres; the report gives the mesh's extent).")(func)
        func = click.option("--uv-scale", type=Quantity("m"), default=None,
                            help="With a mesh: metres per unit of its texture coordinates, e.g. '10mm'.")(func)
        return click.option("--object", "object_spec", default=None,
                            help="The texture on an object instead of a plane: 'sphere:RADIUS', 'cylinder:RADIUS' "
                                 "(axis along y), 'plane', or a closed triangle mesh FILE (OBJ, STL, PLY, glTF, ... "
                                 f"with texture coordinates; --uv-scale). {what}")(func)
    return deco


def _device_options(func):
    """One device syntax for every command: --device pantograph|point-mass with its
    parameters as options (or the shorthand 'point-mass:MASS,DAMPING,PERIOD[,RESOLUTION]')."""
    opts = [
        click.option("--device", "device_spec", default=None, show_default="pantograph over a profile, point-mass "
                     "(3-DOF) over a surface",
                     help="'pantograph' or 'point-mass' (parameters below), the shorthand "
                          "'point-mass:MASS,DAMPING,PERIOD[,RESOLUTION]', the generic 3-DOF linkages 'serial-arm' "
                          "and 'delta' (over a surface), a product preset of 'haptex devices' (touch, falcon, "
                          "omega-3, ...; over a profile seen in its x-z plane), or a TOML device file (FILE.toml; "
                          "see haptex.device_from_file)."),
        click.option("--joint-damping", type=Quantity("N*m*s"), default=4.7e-3, show_default="4.7 mN*m*s",
                     help="pantograph: joint damping inside the wall."),
        click.option("--mass", type=Quantity("kg"), default=0.1, show_default="0.1 kg", help="point-mass: mass."),
        click.option("--damping", type=Quantity("N*s/m"), default=0.5, show_default="0.5 N*s/m",
                     help="point-mass: damping."),
        click.option("--sampling-period", type=Quantity("s"), default=1e-4, show_default="100 us", help="T."),
        click.option("--delay", type=int, default=0, show_default=True, help="Whole samples of latency."),
    ]
    for opt in reversed(opts):
        func = opt(func)
    return func


STABILISERS = ("energy-bounding", "set-position")
"""The stabilisers ``--stabiliser`` names (the passivity controller has ``--passivity-control``)."""


def _before_the_ball(tex, tip_radius, base=None):
    """The texture an algorithm's settings are checked on before a ball of ``tip_radius`` (m) rolls
    over ``tex``: where one will and there is no object, a stand-in of its dimension (a 1 um
    sinusoid or grating of 1 mm), since what reads the texture itself (F's max|h| and steepest
    slope, eq. 22, sups over a map's patches) is read on the felt texture after (x3p-2.x3p felt
    by a 2 um ball at 0.536 um: the export 5.0 s on the map as read, 4.6 s); else ``tex`` (an
    object's checks read the texture on it)."""
    if not tip_radius or tex is None or base is not None:
        return tex
    from ..surfaces import Grating
    from ..textures import Sinusoid

    return Sinusoid(1e-6, 1e-3) if tex.dimension == 1 else Grating(1e-6, 1e-3)


def _check_search_budget(max_evaluations, alg) -> None:
    """Refuse ``--max-evaluations`` where nothing reads it: it budgets D's and E's closest-point
    search over a surface or an object (:func:`haptex.renderer.tick_model`); over a profile, an
    extruded one included, the search is bounded by the profile's tree, and the other
    algorithms search nothing."""
    from ..renderer import reads_search_budget

    if max_evaluations is not None and not reads_search_budget(alg):
        letter = getattr(alg, "letter", "proxy")
        on = " over a profile" if letter in ("D", "E") else ""
        raise ParameterError(f"--max-evaluations is not allowed with --algorithm {letter}{on}: it budgets D's and E's "
                             "closest-point search over a surface or an object (a profile's is bounded by its tree)")


def _stabiliser(passivity_control, stabiliser, dev, delay=None):
    """The stabiliser of ``--passivity-control`` or ``--stabiliser`` (one at a time), or None."""
    from ..renderer import EnergyBounding, PassiveSetPosition, PassivityController

    if passivity_control is not None and stabiliser is not None:
        raise ParameterError(f"stabiliser = {stabiliser} is not allowed with --passivity-control: one stabiliser at a "
                             "time")
    if passivity_control is not None:
        return PassivityController(passivity_control, delay=delay)
    if stabiliser is None:
        return None
    if not dev.min_damping > 0:
        raise ParameterError(f"stabiliser = {stabiliser} is not allowed on {dev.name}: its damping is 0, and "
                             "the stabiliser pays only with the device's own dissipation")
    cls = EnergyBounding if stabiliser == "energy-bounding" else PassiveSetPosition
    return cls.for_device(dev, delay)


def _budget_needs_models(models, budget, no_friction: bool = False) -> None:
    """Refuse --vibration-budget (or --no-material-friction) without --vibration MODELS (run,
    export, simulate)."""
    if budget is not None and models is None:
        raise ParameterError("--vibration-budget is not allowed without --vibration MODELS: it is the vibration's")
    if no_friction and models is None:
        raise ParameterError("--no-material-friction is not allowed without --vibration MODELS: the friction is the "
                             "vibration's material's")


def _vibration(path, period: float, mass: float, budget, on: str, friction: bool | None = None) -> dict:
    """The Renderer's (and export_c's) vibration keywords for ``--vibration MODELS`` on a device
    of servo ``period`` (s) whose mass along x (kg) turns acceleration into force; the models
    must run at the device's rate."""
    from ..datadriven import read_models, require_servo_rate

    models = read_models(path)
    require_servo_rate(models, period, "vibration", str(path), on)
    return {"vibration": models, "vibration_mass": float(mass), "vibration_budget": budget,
            **({} if friction is None else {"friction": friction})}


def _catalogued_device(spec: str, dimension: int, delay: int = 0):
    """The device of a preset of 'haptex devices' (with ``delay`` whole periods of computation
    delay) or a TOML device file (FILE.toml), or None for any other spec."""
    from ..catalogue import presets
    from ..catalogue import device_from_file

    if str(spec).lower().endswith(".toml"):
        return device_from_file(spec)
    if spec in presets():
        return presets()[spec].device(delay=delay, dimension=dimension)
    return None


def _build_device(ctx, spec: str, joint_damping, mass, damping, sampling_period, delay, dimension: int = 2):
    """The device an invocation describes, refusing parameters of the other preset; a
    point mass is built with ``dimension`` axes (3 for a surface)."""
    from ..devices import Device

    if spec is None:  # the default: the paper's planar pantograph, or over a surface a 3-DOF point mass
        spec = "pantograph" if dimension == 2 else "point-mass"
    if str(spec).lower().endswith(".toml"):
        _refuse_unused(ctx, {"*": {"joint_damping", "mass", "damping", "sampling_period", "delay"}}, spec,
                       "--device", owner="*", what="write it in the device file")
        return _catalogued_device(spec, dimension)
    kind, _, rest = str(spec).partition(":")
    if kind in ("serial-arm", "delta") and not rest:
        if dimension != 3:
            raise ParameterError(f"--device {kind} is not allowed over a profile: it is a 3-DOF device; simulate it "
                                 "over a surface (--surface) or use the pantograph or a point mass")
        _refuse_unused(ctx, {"*": {"joint_damping", "mass", "damping", "sampling_period"}}, kind, "--device",
                       owner="*", what="the preset gives it (write a TOML device file to change it)")
        return Device.serial_arm(delay=delay) if kind == "serial-arm" else Device.delta(delay=delay)
    if kind == "pantograph" and dimension != 2:
        raise ParameterError("--device pantograph is not allowed with a surface: the pantograph is planar; use "
                             "--device point-mass (built 3-DOF) or a TOML device file with dimension = 3")
    if kind == "pantograph":
        _refuse_unused(ctx, {"point-mass": {"mass", "damping"}}, kind, "--device")
        jd = _q(rest, "N*m*s", "joint_damping") if rest else joint_damping
        return Device.pantograph(joint_damping=jd, period=sampling_period, delay=delay)
    if kind == "point-mass":
        _refuse_unused(ctx, {"pantograph": {"joint_damping"}}, kind, "--device")
        if not rest:
            return Device.point_mass(mass, damping, sampling_period, delay=delay, dimension=dimension)
        _refuse_unused(ctx, {"*": {"mass", "damping", "sampling_period"}}, spec, "--device", owner="*",
                       what="the shorthand already gives it")
        vals = _split_spec(rest, "device", "point-mass", (3, 4))
        delta = _q(vals[3], "m", "position_resolution") if len(vals) == 4 else 0.0
        return Device.point_mass(_q(vals[0], "kg", "mass"), _q(vals[1], "N*s/m", "damping"),
                                 _q(vals[2], "s", "period"), position_resolution=delta, delay=delay,
                                 dimension=dimension)
    from ..catalogue import did_you_mean, presets

    if kind in presets() and not rest:
        _refuse_unused(ctx, {"*": {"joint_damping", "mass", "damping", "sampling_period"}}, kind, "--device",
                       owner="*", what="the preset gives it (write a TOML device file to change it)")
        return _catalogued_device(kind, dimension, delay)
    raise ParameterError(f"device = {spec!r} is not allowed: must be 'pantograph', 'point-mass', "
                         "'point-mass:MASS,DAMPING,PERIOD[,RESOLUTION]', 'serial-arm', 'delta', a preset of "
                         f"'haptex devices' ({', '.join(presets())}) or a TOML device file (FILE.toml)"
                         + did_you_mean(kind))


class _Steps:
    """A rich progress bar over the eight algorithms on stderr, with the time elapsed and an
    estimate of the time left, shown on a terminal only and never with --json or --quiet;
    used as ``with _Steps(n, quiet) as step: f(progress=step)``."""

    def __init__(self, total: int, title: str, quiet: bool):
        from rich.console import Console

        self.console = Console(stderr=True)
        self.show = self.console.is_terminal and not quiet
        self.total, self.title = total, title
        self.weights = {}

    def __enter__(self):
        if not self.show:
            return lambda letter: None
        from rich.progress import (BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn,
                                   TimeRemainingColumn)

        # the time left is rich's estimate from the steps done so far (steps differ: D and E
        # over a measured map take longest), shown once a step has ended
        self.bar = Progress(TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(),
                            TextColumn("left"), TimeRemainingColumn(), console=self.console, transient=True)
        self.bar.__enter__()
        self.task = self.bar.add_task(self.title, total=self.total)
        self.started = None

        def step(letter):
            if self.started is not None:
                self.bar.advance(self.task, self.weights.get(self.started, 1.0))
            self.started = letter
            what = f"algorithm {letter}" if len(letter) == 1 else letter
            self.bar.update(self.task, description=f"{self.title}: {what}")
        return step

    def weigh(self, weights: dict) -> None:
        """Steps of unequal length: each step's share of the bar (its estimated seconds),
        the steps not named 1 s each."""
        if not self.show:
            return
        self.weights = dict(weights)
        done = self.bar.tasks[0].completed
        rest = self.total - done - (1 if self.started is not None else 0)
        self.bar.update(self.task, total=done + 1 + sum(self.weights.values()) + max(0, rest - len(self.weights)))

    def __exit__(self, *exc):
        if self.show:
            self.bar.__exit__(*exc)
        return False


class _Spinner:
    """A rich spinner with the elapsed time on stderr for work whose length is unknown (a
    compiled simulation, reading a file), shown on a terminal only and never with --json or
    --quiet: ``with _Spinner("simulating", quiet) as say: ...; say("next step")``. Off a
    terminal, ``echo=True`` prints each step as a line instead."""

    def __init__(self, text: str, quiet: bool, echo: bool = False):
        from rich.console import Console

        self.console = Console(stderr=True)
        self.text, self.quiet, self.echo = text, quiet, echo

    def __enter__(self):
        from rich.progress import Progress, SpinnerColumn, TextColumn, TimeElapsedColumn

        self.prog = Progress(SpinnerColumn(), TextColumn("{task.description}"), TimeElapsedColumn(),
                             console=self.console, transient=True,
                             disable=self.quiet or not self.console.is_terminal)
        self.prog.__enter__()
        self.task = self.prog.add_task(self.text, total=None)

        def say(text):
            self.prog.update(self.task, description=text)
            if self.echo and not self.quiet and not self.console.is_terminal:
                self.console.print(f"haptex: {text}")
        return say

    def __exit__(self, *exc):
        self.prog.__exit__(*exc)
        return False


def _given_for_letter(ctx, letter: str, names) -> set:
    """The options of ``names`` (keyword parameters of :func:`haptex.algorithm`) given on the
    command line; one that the letter's algorithm does not take (the registry's
    :attr:`haptex.algorithms.Algorithm.parameters`) is refused in one line, naming the letters
    that take it. An unknown letter is left to :func:`haptex.algorithm` to refuse."""
    from click.core import ParameterSource

    from ..algorithms import ALGORITHMS

    key = str(letter).strip().upper()
    given = {n for n in names if ctx.get_parameter_source(n) == ParameterSource.COMMANDLINE}
    for name in sorted(given):
        if key in ALGORITHMS and name not in ALGORITHMS[key].parameters:
            raise _not_taken(name, key)
    return given


def _not_taken(name: str, letter: str) -> ParameterError:
    """The one-line refusal of the option for keyword parameter ``name`` with a letter that does
    not take it, naming the letters that do (the registry)."""
    from ..algorithms import taking

    return ParameterError(f"--{name.replace('_', '-')} is not allowed with --algorithm {letter}: it applies to "
                          f"{', '.join(taking(name))}")


def _refuse_unused(ctx, groups: dict, chosen: str, by: str = "mode", owner: str | None = None,
                   what: str | None = None) -> None:
    """Refuse, in one line, an option given on the command line that the choice ``chosen``
    does not use: ``groups`` maps each choice to the options only it uses (or, with
    ``owner``, the options that choice ``owner`` cannot take; ``what`` says why)."""
    from click.core import ParameterSource

    for key, names in groups.items():
        relevant = (key != chosen) if owner is None else (key == owner)
        if not relevant:
            continue
        for name in sorted(names):
            if ctx.get_parameter_source(name) == ParameterSource.COMMANDLINE:
                flag = "--" + ("path" if name == "path_text" else name.replace("_", "-"))
                where = f"{by} {chosen}" if by != "mode" else f"the {chosen} mode"
                why = what or (f"it applies to {key} only" if owner is None else "it applies to textured algorithms only")
                raise ParameterError(f"{flag} is not allowed with {where}: {why}")


def _check_save_path(save: Path) -> None:
    if save.suffix.lower() not in (".csv", ".npz"):
        raise ParameterError(f"save = {str(save)!r} is not allowed: must end in .csv or .npz")
    parent = save.parent if str(save.parent) else Path(".")
    if not parent.is_dir():
        raise ParameterError(f"save = {str(save)!r} is not allowed: the directory {str(parent)!r} does not exist")


def _check_plot_path(plot: Path) -> None:
    """Refuse, before computing, a figure path matplotlib cannot write."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    formats = sorted(FigureCanvasAgg(Figure()).get_supported_filetypes())
    suffix = plot.suffix.lower().lstrip(".")
    if suffix not in formats:
        raise ParameterError(f"plot = {str(plot)!r} is not allowed: its extension must name a figure format "
                             f"({', '.join(formats)})")
    parent = plot.parent if str(plot.parent) else Path(".")
    if not parent.is_dir():
        raise ParameterError(f"plot = {str(plot)!r} is not allowed: the directory {str(parent)!r} does not exist")


def _fitted(table, width: int | None = None):
    """``table`` laid out to keep every word whole in the terminal's width (issue 57: at 80
    columns names and numbers were cut to '…'): each column gets at least its longest word,
    header included, and at most its longest cell; the room between is shared in proportion to
    what each column would still take; text wraps at spaces. The caption is printed below as a
    paragraph (a caption wider than the table lost its ends). A table whose words alone are wider
    than the terminal keeps them whole and is wider."""
    from rich.console import Console, Group
    from rich.padding import Padding
    from rich.text import Text

    width = Console().width if width is None else width
    lows, highs = [], []
    for col in table.columns:
        cells = [str(cell) for cell in col.cells]
        low = max((len(w) for text in (str(col.header), *cells) for w in text.split()), default=1)
        lows.append(low)
        highs.append(max([low, *(len(text) for text in cells)]))
    n = len(lows)
    table.collapse_padding, table.pad_edge = True, False  # one space between columns, none at the edges
    _, right, _, left = Padding.unpack(table.padding)
    rules = (2 if table.box and table.show_edge else 0) + (n - 1 if table.box else 0)  # (rich counts them)
    room = width - (n - 1) * max(left, right) - rules
    spare, wanted = room - sum(lows), sum(h - lo for lo, h in zip(lows, highs))
    if spare >= wanted:
        widths = highs
    else:
        widths = [lo + (h - lo) * max(spare, 0) // max(wanted, 1) for lo, h in zip(lows, highs)]
    for col, w in zip(table.columns, widths):
        col.width = w
        col.no_wrap = False
        col.overflow = "fold"
    caption, table.caption = table.caption, None
    return Group(table, Text(str(caption))) if caption else table


def _limits_table(wall: dict, title: str):
    """A rich table of :func:`haptex.limits.wall_limits`'s ``as_dict()``."""
    from rich import box
    from rich.table import Table

    t = Table(title=title, box=box.SIMPLE_HEAD,
              caption=f"passive_stiffness {wall['passive_stiffness']:.4g} N/m; stable_stiffness "
                      f"{wall['stable_stiffness']:.4g} N/m with the hand {wall['hand']!r}; {wall['note']}")
    for col in ("limit", "kind", "N/m", "condition", "source"):
        t.add_column(col)
    for lim in wall["limits"]:
        t.add_row(lim["name"], lim["kind"], "n/a" if lim["value"] is None else f"{lim['value']:.4g}",
                  lim["formula"], lim["source"])
    return _fitted(t)


def _jsonable(obj):
    """JSON-ready copy of results (non-finite floats as strings); see haptex.report.jsonable."""
    from ..report import jsonable

    return jsonable(obj)
