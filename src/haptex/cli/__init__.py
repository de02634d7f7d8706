"""The ``haptex`` command: one module a command group, registered on :func:`cli` here.

Every bad input ends as one line on stderr (``haptex: error: ...``) and exit status 2.
"""

from __future__ import annotations

import sys

import click

from .._validation import ParameterError


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="haptex")
def cli():
    """haptex: haptic texture synthesis and energy analysis (Campion & Hayward)."""


def _one_line(exc: click.ClickException) -> str:
    """A usage error in one line plus a hint: click's message, or for a group called without
    its command (click raised the whole help as the error) the commands it has; then where
    the help is."""
    ctx = getattr(exc, "ctx", None)
    path = ctx.command_path if ctx is not None else "haptex"
    msg = exc.format_message()
    if ctx is not None and isinstance(ctx.command, click.Group) and msg.lstrip().startswith("Usage:"):
        msg = f"{path} needs a command: {', '.join(ctx.command.list_commands(ctx))}"
    msg = " ".join(msg.split())
    return msg + (f" (see '{path} --help')" if isinstance(exc, click.UsageError) else "")


def main(argv=None) -> int:
    """Entry point of the ``haptex`` console script; returns the exit status. Warnings are
    held until the command ends: shown after a result, dropped before an error's one line
    (a warning printed above it read as a second error: issue 33).

    Parameters
    ----------
    argv : list of str, optional
        The command line's arguments after ``haptex``; default ``sys.argv[1:]``.
    """
    import warnings

    held = []

    def hold(message, category, filename, lineno, file=None, line=None):
        if len(held) < MAX_HELD_WARNINGS:  # bounded: `haptex explore` may run for days
            held.append((message, category, filename, lineno))

    with warnings.catch_warnings():  # the filters in force are kept; showwarning is restored on exit
        warnings.showwarning = hold
        status = _run(argv)
    if status == 0:
        for w in held:
            warnings.showwarning(*w)
    return status


MAX_HELD_WARNINGS = 100
"""Most warnings held until a command ends (the rest are dropped)."""


def _run(argv) -> int:
    try:
        status = cli.main(args=argv, prog_name="haptex", standalone_mode=False)
        if isinstance(status, int) and status:  # a command's own status (click returns an Exit's code)
            return status
    except click.exceptions.Exit as exc:
        return exc.exit_code
    except click.exceptions.Abort:
        click.echo("haptex: aborted", err=True)
        return 1
    except click.ClickException as exc:
        click.echo(f"haptex: error: {_one_line(exc)}", err=True)
        return 2
    except ParameterError as exc:  # one line, whatever text of the user's the message quotes
        msg = _as_typed(str(exc), sys.argv[1:] if argv is None else list(argv))
        click.echo("haptex: error: " + msg.replace("\r", "\\r").replace("\n", "\\n"), err=True)
        return 2
    except OSError as exc:  # the file system refused: still one line, never a traceback
        click.echo(f"haptex: error: {exc.strerror or exc}: {exc.filename or ''}".rstrip(": "), err=True)
        return 2
    return 0


_LIBRARY_NAMES = {"max_damping": ("passivity_control",), "period": ("sampling_period",),
                  "stiffness": ("band_stiffness",)}
"""Library parameters the command line's options name otherwise (the passivity controller's
largest damping, the device's sampling period, the elastic band's stiffness): the options that
may have given them, taken where the value typed is the value refused."""


def _as_typed(msg: str, argv) -> str:
    """A library refusal that names its parameter in Python and SI (``tip_radius = 0.0001 is not
    allowed...``) as the command line gave it (``--tip-radius 0.1mm is not allowed...``): where
    the command has an option of that name (or of :data:`_LIBRARY_NAMES`), the user typed it, and
    what they typed is that value (the option's own conversion, to the message's digits); else
    the message as it is."""
    import re

    m = re.match(r"([a-z][a-z_]*) = (\S+)(?: [A-Za-z][A-Za-z/*^0-9]*)? is not allowed", msg)  # (and its unit, "9 N")
    command = cli.commands.get(argv[0]) if argv else None
    if isinstance(command, click.Group) and len(argv) > 1:  # (a subcommand's own options: simulate scan)
        command = command.commands.get(argv[1])
    if m is None or command is None:
        return msg
    for name in (m.group(1),) + _LIBRARY_NAMES.get(m.group(1), ()):
        option = next((p for p in command.params if p.name == name and isinstance(p, click.Option)), None)
        typed = None if option is None else _typed(option, argv)
        if typed is None:
            continue
        try:
            value = option.type.convert(typed, option, None)
        except (click.ClickException, ParameterError, ValueError, TypeError):
            continue
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            continue
        if (f"{value:g}" if isinstance(value, float) else str(value)) == m.group(2):
            return f"{option.opts[-1]} {typed}" + msg[msg.index(" is not allowed", m.end(2)):]
    return msg


def _typed(option, argv):
    """What the user typed for ``option`` (its last occurrence), or None."""
    typed = None
    for i, arg in enumerate(argv):
        for flag in option.opts:
            if arg == flag and i + 1 < len(argv):
                typed = argv[i + 1]
            elif arg.startswith(flag + "="):
                typed = arg[len(flag) + 1:]
    return typed


# the commands, one module a group (click's layout for an application of this size)
from .atlas import atlas, sweep  # noqa: E402
from .datadriven import fit_cmd, vibration  # noqa: E402
from .design import design  # noqa: E402
from .device import identify_command, run_device  # noqa: E402
from .devices import devices  # noqa: E402
from .explore import explore  # noqa: E402
from .export import export  # noqa: E402
from .paper import reproduce, table  # noqa: E402
from .simulate import simulate  # noqa: E402

for _command in (table, reproduce, simulate, design, export, sweep, run_device, identify_command, fit_cmd, vibration,
                 explore, atlas, devices):
    cli.add_command(_command)
del _command

if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
