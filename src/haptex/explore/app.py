"""The explorer's page, on Bokeh (server, widgets and plots). It holds no physics: each
control change rebuilds a :class:`~haptex.explore.model.Scene` and draws what
:mod:`haptex.explore.model` computes with the library's functions.

Stable element ids (for tests and scripts): ``#algorithm``, ``#texture``, ``#stiffness``,
``#device``, ``#hand``, ``#q-value``, ``#loop-energy``, ``#fig3-loop``, ``#run-scan``,
``#scan-verdict``, ``#message``, ``#field-view``, ``#gain-view``, ``#curl-view``,
``#scan-view``, ``#height-view``; the data-driven texture's ``#vibration-file``,
``#vibration-models`` (its operating points: click to pick one), ``#vibration-spectrum`` and
``#vibration-readout``.
"""

from __future__ import annotations

import atexit
import base64
import dataclasses
import functools
import html
import logging
import multiprocessing
import os
import shutil
import signal
import tempfile
import time
import weakref
from concurrent.futures import ProcessPoolExecutor

import numpy as np

from .._validation import ParameterError
from ..algorithms import ALGORITHMS
from . import model

log = logging.getLogger("haptex.explore")

MM = 1e3  # the page draws lengths in mm
SESSION_THREADS = max(1, (os.cpu_count() or 1) - 1)
"""Threads of one session's computation (the machine's cores but one: the event loop and the
other sessions keep a core)."""
RECOMPUTE_BUDGET = 10.0
"""Seconds after which a served page says that its computation is still running (the view
keeps the previous input meanwhile; the result then replaces it when it ends, unless the
session closes first, which stops its worker process)."""
UPLOAD_BYTES = 50 * 2**20
"""Largest file one upload may carry (the server's websocket messages are sized to it)."""
SESSION_UPLOAD_BYTES = 200 * 2**20
"""Most bytes one session may upload in all."""

_WORKERS: weakref.WeakSet = weakref.WeakSet()  # the served sessions' live workers (stopped at exit)
_ROOT: list[str] = []  # this process's temporary folder of the explorer (the sessions' folders are inside it)


def _root() -> str:
    """This process's temporary folder of the explorer, made at its first session and removed
    at exit (and when :func:`serve` ends), whatever became of the sessions."""
    if not _ROOT:
        _ROOT.append(tempfile.mkdtemp(prefix=f"haptex-explore-{os.getpid()}-"))
    return _ROOT[0]


def _context():
    """Workers are forked from a forkserver: a clean single-threaded process that imported the
    library and computed the default views once (:mod:`._warm`), so that a session's first
    computation neither re-imports the library nor inherits the server's threads."""
    ctx = multiprocessing.get_context("forkserver")
    ctx.set_forkserver_preload(["haptex.explore._warm"])
    return ctx


WORKER_NICENESS = 10
"""How much lower than the server's a worker process's scheduling priority is (``os.nice``):
under load, the server's event loop answers a new page before any session's computation
gets the core (chosen; 10 of Linux's 0-19)."""


def _lower_priority() -> None:
    try:
        os.nice(WORKER_NICENESS)
    except (OSError, AttributeError):  # no nice() on this platform: the same priority as the server
        pass


class _Worker:
    """One served session's computations, in a process of its own (started at its first
    computation), so that no computation holds the server's GIL (issue 56: a thread of the
    server's process took the GIL from its event loop under load). :meth:`stop` kills the
    process: a closed session's computation, however long, ends with it."""

    def __init__(self):
        self._executor = None
        _WORKERS.add(self)

    def submit(self, fn, *args):
        if self._executor is not None and getattr(self._executor, "_broken", False):
            self.stop()  # its process died (killed, out of memory): the next computation gets a new one
        if self._executor is None:
            self._executor = ProcessPoolExecutor(1, mp_context=_context(), initializer=_lower_priority)
        return self._executor.submit(fn, *args)

    def stop(self) -> None:
        executor, self._executor = self._executor, None
        if executor is None:
            return
        processes = list((getattr(executor, "_processes", None) or {}).values())
        executor.shutdown(wait=False, cancel_futures=True)
        for process in processes:
            if process.is_alive():
                process.kill()


def _stop_all() -> None:
    """Stop every session's worker and remove this process's temporary folder."""
    for worker in list(_WORKERS):
        worker.stop()
    while _ROOT:
        shutil.rmtree(_ROOT.pop(), ignore_errors=True)


atexit.register(_stop_all)


def _attempt(what, fn):
    """Run one computation: ("ok", result) or ("error", the one line to show); never raises
    (the server must survive anything a control can send). The C core's batch loops run on
    :data:`SESSION_THREADS` threads within it, so that one session's computation leaves the
    other cores to the server and the other sessions."""
    from .. import core

    try:
        with core.threads(SESSION_THREADS):
            return "ok", fn()
    except ParameterError as exc:
        return "error", str(exc)
    except Exception as exc:  # noqa: BLE001
        log.exception("explorer: %s failed", what)
        return "error", f"{what} failed: {type(exc).__name__}: {exc}"


def _outcome(what, future):
    """A finished future's outcome; a worker that was stopped or died is one line too."""
    try:
        return future.result()
    except BaseException as exc:  # noqa: BLE001 (the pool's BrokenProcessPool, a cancellation)
        return "error", f"{what} stopped: its worker process ended ({type(exc).__name__})"


def _build_views(settings):
    """The scene of ``settings`` and its views (a worker's recomputation)."""
    scene = model.build(settings)
    return scene, model.views(scene)


def _waits(message: str) -> bool:
    """Whether a file's refusal asks for what the page's file boxes give (its spacing, its units,
    one of its variables, a crop or the fill of its undefined heights): the file is kept for them."""
    return any(w in message for w in ("does not state", "holds variables", "heights are undefined"))


def _span(ident: str, text: str) -> str:
    return f'<span id="{ident}">{html.escape(text)}</span>'


class ExplorerPage:
    """One browser tab's page: controls, five views and the readouts.

    Parameters
    ----------
    doc : bokeh.document.Document
        The document to fill (one per browser session).
    settings : model.Settings, optional
        Initial control values; the paper's Section V-A parameters by default.
    offload : bool, optional
        Run each computation in the session's own worker process and draw its result on the
        next tick (what :func:`serve` does, so that no session stalls the server); by
        default each computation runs in the callback (a notebook, a test).
    """

    def __init__(self, doc, settings: model.Settings | None = None, offload: bool = False):
        from bokeh.layouts import column, row
        from bokeh.events import Tap
        from bokeh.models import (Arrow, Button, CheckboxGroup, ColumnDataSource, Div, FileInput, FreehandDrawTool,
                                  Legend, LinearColorMapper, PolyDrawTool, Range1d, Select, TextInput, VeeHead)
        from bokeh.palettes import Magma256, RdBu11, Viridis256, interp_palette
        from bokeh.plotting import figure

        self.doc = doc
        self.settings = settings or model.Settings()
        self.scene = None
        # served: each computation in this session's own worker process, off the server's event
        # loop and its GIL, so that one session's work never stalls another's page (issues 33, 56)
        self.offload = offload
        self._worker = _Worker() if offload else None
        self._running = None  # (what, start time) of the computation in the worker
        self._pending = None  # the latest request made while it ran: run next (older ones are dropped)
        self.uploaded = 0
        if offload:
            doc.on_session_destroyed(lambda context, w=self._worker: w.stop())
        # uploaded files, removed with the session (and, served, with the server's folder at its exit)
        self.tmpdir = tempfile.mkdtemp(prefix="session-", dir=_root())
        doc.on_session_destroyed(lambda context, d=self.tmpdir: shutil.rmtree(d, ignore_errors=True))
        s = self.settings

        def text(name, title, value, ident=None):
            w = TextInput(title=title, value=value, width=220, html_id=ident or name.replace("_", "-"))
            w.on_change("value", lambda attr, old, new, name=name: self._set(name, new))
            return w

        def choice(name, title, options):
            w = Select(title=title, value=getattr(s, name), options=options, width=220, html_id=name)
            w.on_change("value", lambda attr, old, new, name=name: self._set(name, new, w))
            return w

        self.w_texture = choice("texture", "texture", model.TEXTURES)
        self.w_amplitude = text("amplitude", "amplitude A", s.amplitude)
        self.w_period = text("period", "period l", s.period)
        self.w_terms = text("terms", "sum: A1, l1; A2, l2; ...", s.terms)
        self.w_noise = text("noise", "noise: rms, shortest, longest, length[, seed]", s.noise)
        self.w_file = FileInput(title="file (profile, areal map or image)", width=220, html_id="texture-file")
        # the file's name and contents arrive together; read them once both are set
        self.w_file.on_change("value", lambda a, o, n: self.doc.add_next_tick_callback(
            lambda: self._upload(self.w_file, "file", "file_name")))
        self.w_spacing = text("spacing", "file: sample spacing (if unstated)", s.spacing)
        self.w_x_unit = text("x_unit", "file: position unit (if unstated)", s.x_unit, "x-unit")
        self.w_height_unit = text("height_unit", "file: height unit (if unstated)", s.height_unit, "height-unit")
        self.w_variable = text("variable", "file: variable or channel (if several)", s.variable)
        self.w_crop = text("crop", "file: crop (auto, or X0,X1[,Y0,Y1])", s.crop)
        self.w_fill = CheckboxGroup(labels=["file: fill undefined heights"], active=[0] if s.fill_undefined else [],
                                    width=220, html_id="fill-undefined")
        self.w_fill.on_change("active", lambda attr, old, new: self._set("fill_undefined", bool(new)))
        self.w_periodic = CheckboxGroup(labels=["file: periodic (one period: closes an object's seam)"],
                                        active=[0] if s.periodic else [], width=220, html_id="file-periodic")
        self.w_periodic.on_change("active", lambda attr, old, new: self._set("periodic", bool(new)))
        self.w_pixel = text("pixel_size", "image: pixel size", s.pixel_size)
        self.w_hrange = text("height_range", "image: black-to-white height", s.height_range)
        self.w_algorithm = choice("algorithm", "algorithm", model.ALGORITHM_LABELS)
        self.w_stiffness = text("stiffness", "stiffness κ0", s.stiffness)
        self.w_dmax = text("max_penetration", "max penetration d_max", s.max_penetration)
        self.w_friction = text("friction", "F: friction μ", s.friction)
        self.w_presliding = text("presliding", "F: presliding d^x_max", s.presliding)
        self.w_section = text("section", "areal: section at y =", s.section)
        self.w_object = text("object", "areal: on an object (plane, sphere:R, cylinder:R, mesh)", s.object)
        self.w_mesh = FileInput(title="mesh file (OBJ, STL, PLY, glTF; with texture coordinates)", width=220,
                                html_id="mesh-file")
        self.w_mesh.on_change("value", lambda a, o, n: self.doc.add_next_tick_callback(
            lambda: self._upload(self.w_mesh, "object_file", "object_file_name")))
        self.w_uv_scale = text("uv_scale", "mesh: metres per texture-coordinate unit", s.uv_scale, "uv-scale")
        self.w_device = choice("device", "device", model.DEVICES)
        self.w_hand = choice("hand", "scan: hand", model.HANDS)
        self.w_speed = text("speed", "scan speed", s.speed)
        self.w_duration = text("duration", "scan duration", s.duration)
        self.b_fig3 = Button(label="Fig. 3 loop", width=105, html_id="fig3-loop")
        self.b_fig3.on_click(self._fig3)
        self.b_clear = Button(label="clear path", width=105, html_id="clear-path")
        self.b_clear.on_click(self._clear)
        self.b_scan = Button(label="Run scan", button_type="primary", width=220, html_id="run-scan")
        self.b_scan.on_click(self._scan)

        self.d_message = Div(text=_span("message-text", ""), width=900, html_id="message",
                             styles={"color": "#b00020", "font-weight": "bold"})
        self.d_q = Div(text="q = " + _span("q-value", "…"), width=460)
        self.d_loop = Div(text="loop energy ΔE = " + _span("loop-energy", "–") + " J", width=460)
        self.d_scan = Div(text="scan: " + _span("scan-verdict", "–"), width=460)
        self.d_timing = Div(text="", width=460, styles={"color": "#666"})

        # --- views -------------------------------------------------------------------
        self.src_boundary = ColumnDataSource(dict(x=[], h=[], h0=[]))
        self.src_arrows = ColumnDataSource(dict(x0=[], z0=[], x1=[], z1=[], mag=[]))
        self.src_path = ColumnDataSource(dict(xs=[], ys=[]))
        self.src_gain = ColumnDataSource(dict(image=[], x=[], y=[], dw=[], dh=[]))
        self.src_qmark = ColumnDataSource(dict(x=[], z=[]))
        self.src_qmark_xy = ColumnDataSource(dict(x=[], y=[]))
        self.src_curl = ColumnDataSource(dict(image=[], x=[], y=[], dw=[], dh=[]))
        self.src_energy = ColumnDataSource(dict(t=[], x=[], y=[], z=[]))
        self.src_heights = ColumnDataSource(dict(image=[], x=[], y=[], dw=[], dh=[]))
        self.src_section = ColumnDataSource(dict(x=[], y=[]))
        self.x_range, self.z_range = Range1d(0, 1), Range1d(-1, 1)
        opts = dict(width=460, height=380, x_range=self.x_range, y_range=self.z_range, x_axis_label="x (mm)",
                    y_axis_label="z (mm)", match_aspect=False, min_border_left=60, min_border_right=20,
                    min_border_top=30, min_border_bottom=50)

        self.f_field = figure(title="force field (arrows: direction, colour: |f|); draw a closed path",
                              tools="pan,wheel_zoom,reset", html_id="field-view", name="field", **opts)
        self.mag_mapper = LinearColorMapper(palette=Viridis256, low=0, high=1)
        colour = {"field": "mag", "transform": self.mag_mapper}
        self.f_field.add_layout(Arrow(x_start="x0", y_start="z0", x_end="x1", y_end="z1", source=self.src_arrows,
                                      line_color=colour, line_width=1.5,
                                      end=VeeHead(size=5, line_color=colour, fill_color=colour)))
        self._boundary(self.f_field, legend=True)
        path = self.f_field.multi_line("xs", "ys", source=self.src_path, line_width=2.5, color="#d62728")
        free = FreehandDrawTool(renderers=[path], num_objects=1)
        poly = PolyDrawTool(renderers=[path], num_objects=1)
        self.f_field.add_tools(free, poly)
        self.f_field.toolbar.active_drag = free
        self.src_path.on_change("data", self._path_changed)

        self.f_gain = figure(title="‖J‖₂/κ0 over the rendering region (star: q, if on this section)", tools="pan,wheel_zoom,reset",
                             html_id="gain-view", name="gain", **opts)
        self.gain_mapper = LinearColorMapper(palette=Magma256, low=0, high=1, nan_color=(0, 0, 0, 0))
        self.f_gain.image("image", "x", "y", "dw", "dh", source=self.src_gain, color_mapper=self.gain_mapper)
        self._boundary(self.f_gain)
        self.f_gain.scatter("x", "z", source=self.src_qmark, marker="star", size=18, fill_color="cyan",
                            line_color="black")

        self.f_curl = figure(title="curl ∂f_z/∂x − ∂f_x/∂z (N/m)", tools="pan,wheel_zoom,reset",
                             html_id="curl-view", name="curl", **opts)
        self.curl_mapper = LinearColorMapper(palette=interp_palette(tuple(reversed(RdBu11)), 255), low=-1, high=1)
        self.f_curl.image("image", "x", "y", "dw", "dh", source=self.src_curl, color_mapper=self.curl_mapper)
        self._boundary(self.f_curl)
        for f, mapper, label in ((self.f_field, self.mag_mapper, "|f| (N)"), (self.f_gain, self.gain_mapper, "‖J‖₂/κ0"),
                                 (self.f_curl, self.curl_mapper, "N/m")):
            f.add_layout(_colour_bar(mapper, label), "right")

        self.f_scan = figure(title="scan: energy absorbed by the texture per axis (falls: texture supplies)",
                             width=460, height=300, x_axis_label="t (s)", y_axis_label="E (mJ)",
                             tools="pan,wheel_zoom,reset", html_id="scan-view", name="scan")
        self.scan_lines = {axis: self.f_scan.line("t", axis, source=self.src_energy, color=colour, line_width=2)
                           for axis, colour in (("x", "#1f77b4"), ("y", "#2ca02c"), ("z", "#ff7f0e"))}
        self.scan_legend = Legend(items=[], location="top_left")
        self.f_scan.add_layout(self.scan_legend)

        self.f_heights = figure(title="height map h(x, y) (mm); line: the section shown; star: where q is", width=460, height=380,
                                x_axis_label="x (mm)", y_axis_label="y (mm)", tools="pan,wheel_zoom,reset",
                                html_id="height-view", name="heights")
        self.height_mapper = LinearColorMapper(palette=Viridis256, low=0, high=1)
        self.f_heights.image("image", "x", "y", "dw", "dh", source=self.src_heights, color_mapper=self.height_mapper)
        self.f_heights.line("x", "y", source=self.src_section, color="white", line_width=2, line_dash="dashed")
        self.f_heights.scatter("x", "y", source=self.src_qmark_xy, marker="star", size=18, fill_color="cyan",
                               line_color="black")
        self.f_heights.add_layout(_colour_bar(self.height_mapper, "h (mm)"), "right")
        # on an object: q on its surface (the largest gain over depth at each surface coordinate)
        self.src_surface_q = ColumnDataSource(dict(image=[], x=[], y=[], dw=[], dh=[]))
        self.f_surface_q = figure(title="on the object: ‖J‖₂/κ0, the largest over depth, at surface coordinates "
                                  "(u1, u2) (mm)", width=460, height=380, x_axis_label="u1 (mm)",
                                  y_axis_label="u2 (mm)", tools="pan,wheel_zoom,reset", html_id="surface-q")
        self.surface_q_mapper = LinearColorMapper(palette=Viridis256, low=0, high=1)
        self.f_surface_q.image("image", "x", "y", "dw", "dh", source=self.src_surface_q,
                               color_mapper=self.surface_q_mapper)
        self.f_surface_q.add_layout(_colour_bar(self.surface_q_mapper, "‖J‖₂/κ0"), "right")

        # --- a data-driven texture: a model set over (speed, force), its spectrum where picked ---
        self.vibration_models = model.example_models()
        self.vibration_pick = (0.05, 0.5)  # m/s, N (chosen: inside the example set)
        self.w_vibration = FileInput(title="vibration models (haptex JSON, HaTT XML)", width=220,
                                     html_id="vibration-file")
        self.w_vibration.on_change("value", lambda a, o, n: self.doc.add_next_tick_callback(self._vibration_upload))
        self.src_vib_points = ColumnDataSource(dict(speed=[], force=[]))
        self.src_vib_edges = ColumnDataSource(dict(xs=[], ys=[]))
        self.src_vib_pick = ColumnDataSource(dict(speed=[], force=[]))
        self.src_vib_psd = ColumnDataSource(dict(f=[], db=[]))
        self.f_vib_models = figure(title="vibration models: operating points (click to pick one)", width=460,
                                   height=300, x_axis_label="speed (mm/s)", y_axis_label="normal force (N)",
                                   tools="pan,wheel_zoom,reset", html_id="vibration-models", name="vibration-models")
        self.f_vib_models.multi_line("xs", "ys", source=self.src_vib_edges, color="#999", line_width=1)
        self.f_vib_models.scatter("speed", "force", source=self.src_vib_points, size=8, color="#1f77b4")
        self.f_vib_models.scatter("speed", "force", source=self.src_vib_pick, marker="cross", size=16,
                                  line_width=3, color="#d62728")
        self.f_vib_models.on_event(Tap, lambda event: self._vibration_pick(event.x / MM, event.y))
        self.f_vib_spectrum = figure(title="the interpolated model's spectrum", width=460, height=300,
                                     x_axis_label="frequency (Hz)", y_axis_label="PSD (dB re 1 (m/s²)²/Hz)",
                                     tools="pan,wheel_zoom,reset", html_id="vibration-spectrum",
                                     name="vibration-spectrum")
        self.f_vib_spectrum.line("f", "db", source=self.src_vib_psd, line_width=2, color="#1f77b4")
        self.d_vibration = Div(text="vibration: " + _span("vibration-readout", "–"), width=460,
                               html_id="vibration-box")

        texture_box = column(self.w_texture, self.w_amplitude, self.w_period, self.w_terms, self.w_noise, self.w_file,
                             self.w_spacing, self.w_x_unit, self.w_height_unit, self.w_variable, self.w_crop,
                             self.w_fill, self.w_periodic, self.w_pixel, self.w_hrange, self.w_section,
                             self.w_object, self.w_mesh,
                             self.w_uv_scale)
        controls = column(texture_box, self.w_algorithm, self.w_stiffness, self.w_dmax, self.w_friction,
                          self.w_presliding, self.w_device, self.w_hand, self.w_speed, self.w_duration,
                          row(self.b_fig3, self.b_clear), self.b_scan, self.w_vibration, width=240)
        readouts = column(self.d_q, self.d_loop, self.d_scan, self.d_timing)
        views = column(row(self.f_field, self.f_gain), row(self.f_curl, column(readouts, self.f_scan)),
                       row(self.f_heights, self.f_surface_q), self.d_vibration,
                       row(self.f_vib_models, self.f_vib_spectrum))
        doc.add_root(column(self.d_message, row(controls, views)))
        doc.title = "haptex explore"
        self._show_controls()
        self._vibration_pick(*self.vibration_pick)
        if offload:
            # served: the first computation starts on the session's first tick. Its result is handed
            # back from the worker thread by doc.add_next_tick_callback, which is safe only once the
            # session exists: a computation that ended while Bokeh was still making the session
            # collided with it ("A callback of the same type has already been added with this ID",
            # HTTP 500 on the page, seen in the fuzz suite once the C core made the first views fast)
            doc.add_next_tick_callback(lambda: self._recompute(first=True))
        else:
            self._recompute(first=True)

    # --- building blocks ---------------------------------------------------------------
    def _boundary(self, f, legend: bool = False) -> None:
        labels = ({"legend_label": "textured surface"}, {"legend_label": "nominal surface"}) if legend else ({}, {})
        f.line("x", "h", source=self.src_boundary, color="black", line_width=2, **labels[0])
        f.line("x", "h0", source=self.src_boundary, color="#999", line_width=1.5, line_dash="dotted", **labels[1])
        if legend:
            f.legend.location = "bottom_right"
            f.legend.label_text_font_size = "8pt"
            f.legend.background_fill_alpha = 0.6

    def _message(self, text: str = "") -> None:
        self.d_message.text = _span("message-text", text)

    def _show_controls(self) -> None:
        from bokeh.models import LegendItem

        k = self.settings.texture
        letter = self.settings.algorithm
        self.w_amplitude.visible = self.w_period.visible = k in ("sine", "egg-crate", "grating")
        self.w_terms.visible = k == "sum"
        self.w_noise.visible = k == "noise"
        self.w_file.visible = k in ("file", "image")
        self.w_pixel.visible = self.w_hrange.visible = k == "image"
        for w in (self.w_spacing, self.w_x_unit, self.w_height_unit, self.w_variable, self.w_crop, self.w_fill):
            w.visible = k == "file"
        self.w_periodic.visible = k in ("file", "image")
        self.w_section.visible = self.w_object.visible = self.scene is not None and self.scene.dimension == 3
        self.w_mesh.visible = self.w_uv_scale.visible = (self.w_object.visible
                                                         and str(self.settings.object).strip().lower() == "mesh")
        takes = getattr(ALGORITHMS.get(str(letter).strip().upper()), "parameters", ())  # (the registry)
        self.w_friction.visible = "friction" in takes
        self.w_presliding.visible = "presliding" in takes
        self.f_heights.visible = self.scene is not None and self.scene.dimension == 3
        self.f_surface_q.visible = self.scene is not None and getattr(self.scene.algorithm, "base", None) is not None
        axes = "xyz" if self.f_heights.visible else "xz"
        for axis, line in self.scan_lines.items():
            line.visible = axis in axes
        self.scan_legend.items = [LegendItem(label=f"E_{a}", renderers=[self.scan_lines[a]]) for a in axes]

    # --- callbacks ---------------------------------------------------------------------
    def _set(self, name: str, value, selector=None) -> None:
        """One control changed: recompute, or keep the previous view and say why in one line.
        A refused choice in a selector is undone there too, so that the selectors show
        what the views show; a refused text stays in its box for the user to correct."""
        old = getattr(self.settings, name)
        if value == old:  # back to what the views show (after a refusal, or a selector's undo)
            if selector is None:
                self._message("")
            return
        setattr(self.settings, name, value)
        if name == "texture" and value in ("file", "image") and not self.settings.file:
            self._show_controls()  # wait for the file, keeping the view
            self._message(f"texture = {value!r}: choose a file to load (the view shows the previous texture "
                          "until then)")
            return
        if name in ("object", "uv_scale") and str(self.settings.object).strip().lower() == "mesh" \
                and not self.settings.object_file:
            self._show_controls()  # wait for the mesh (its scale kept for it), keeping the view
            self._message("object = 'mesh': choose a mesh file with texture coordinates and give its scale (the view "
                          "shows the previous object until then)")
            return
        def undo():
            if name in ("texture", *model.READING) and self.settings.texture == "file" and _waits(self.d_message.text):
                self._show_controls()  # kept: the file waits for what it does not state, in the boxes shown
                return
            setattr(self.settings, name, old)
            if selector is not None:
                message = self.d_message.text
                selector.value = old  # re-enters _set with the old value: a no-op
                self.d_message.text = message
            self._show_controls()

        self._recompute(on_fail=undo)
        self._show_controls()

    @staticmethod
    def _received(widget) -> tuple[str, str]:
        """A file widget's (name, base64 contents)."""
        try:
            name = widget.filename or "upload"
        except Exception:  # bokeh's UnsetValueError: no name was sent
            name = "upload"
        return name, widget.value or ""

    def _save(self, name: str, value: str, prefix: str = "") -> str | None:
        """An uploaded file (``value`` its base64 contents) saved under the session's directory
        as ``prefix`` + its name, within the upload budgets: its path, or None with the refusal
        in one line."""
        name = os.path.basename(name) or "upload"
        path = os.path.join(self.tmpdir, prefix + name)
        size = len(value) * 3 // 4  # base64: 4 characters a 3 bytes
        if size > UPLOAD_BYTES or self.uploaded + size > SESSION_UPLOAD_BYTES:
            self._message(f"file = {name!r} is not allowed: {size / 2**20:.3g} MiB; an upload may carry at most "
                          f"{UPLOAD_BYTES / 2**20:.0f} MiB and a session {SESSION_UPLOAD_BYTES / 2**20:.0f} MiB in all "
                          f"({self.uploaded / 2**20:.3g} MiB so far)")
            return None
        try:
            with open(path, "wb") as fh:
                fh.write(base64.b64decode(value))
        except (OSError, ValueError) as exc:
            self._message(f"file = {name!r} could not be received: {exc}")
            return None
        self.uploaded += size
        return path

    def _upload(self, widget, field: str, name_field: str) -> None:
        """A file arrived in ``widget``: saved under the session's directory (within the upload
        budgets) and set as the settings' ``field`` (its name as ``name_field``): the texture's
        file, or the object's mesh."""
        name, value = self._received(widget)
        name = os.path.basename(name) or "upload"
        path = self._save(name, value, "mesh-" if field == "object_file" else "")
        if path is None:
            return
        before = (getattr(self.settings, field), getattr(self.settings, name_field))
        setattr(self.settings, field, path)
        setattr(self.settings, name_field, name)

        def undo():  # a file that lacks only its spacing, units or variable is kept, for the boxes below it
            if not _waits(self.d_message.text):
                setattr(self.settings, field, before[0])
                setattr(self.settings, name_field, before[1])
            self._show_controls()

        self._recompute(on_fail=undo)
        self._show_controls()

    def _vibration_pick(self, speed: float, force: float) -> None:
        """Draw the model set and the spectrum of its model at (``speed`` m/s, ``force`` N), the
        point moved to the set's hull when outside it (said in the readout); cheap enough to
        compute in the callback (one interpolation and 512 values of a spectrum)."""
        try:
            v = model.vibration(self.vibration_models, speed, force)
        except ParameterError as exc:
            self._message(str(exc))
            return
        self.vibration_pick = (v.speed, v.force)
        self.src_vib_points.data = dict(speed=v.speeds * MM, force=v.forces)
        self.src_vib_edges.data = dict(xs=[e[0] * MM for e in v.edges], ys=[e[1] for e in v.edges])
        self.src_vib_pick.data = dict(speed=[v.speed * MM], force=[v.force])
        self.src_vib_psd.data = dict(f=v.frequency, db=10 * np.log10(np.maximum(v.psd, 1e-300)))
        where = " (moved to the hull of the models)" if v.clamped else ""
        text = (f"{v.name or 'model set'}: at {v.speed * MM:.4g} mm/s, {v.force:.4g} N{where}: "
                f"{v.rms:.3g} m/s² rms")
        self.d_vibration.text = "vibration: " + _span("vibration-readout", text)

    def _vibration_upload(self) -> None:
        """The model file's widget changed: its name and contents to :meth:`_vibration_file`."""
        self._vibration_file(*self._received(self.w_vibration))

    def _vibration_file(self, name: str, value: str) -> None:
        """A model file arrived (``value`` its base64 contents): read it
        (:func:`haptex.datadriven.read_models`), within the upload budgets, and show it at the
        pick (moved into its hull); a refused file is one line, the previous set kept."""
        from ..datadriven import read_models

        path = self._save(name, value, "models-")
        if path is None:
            return
        try:
            models = read_models(path)
        except ParameterError as exc:
            self._message(str(exc))
            return
        self.vibration_models = models
        self._message("")
        self._vibration_pick(*self.vibration_pick)

    def _run(self, what: str, fn, apply, on_fail=None) -> None:
        """Compute ``fn()`` and pass its result to ``apply`` (on the document's thread); a
        refusal is one line in the page, then ``on_fail()``. Offloaded: ``fn`` runs in this
        session's thread, a request made while another runs waits for it (only the latest
        such request is kept), and past :data:`RECOMPUTE_BUDGET` the page says so. Offloaded,
        ``fn`` and its result cross to the worker process by pickle."""
        if not self.offload:
            self._finish(what, time.perf_counter(), _attempt(what, fn), apply, on_fail)
            return
        if self._running is not None:
            self._pending = (what, fn, apply, on_fail)
            self._message(f"{self._running[0]} is still being computed; then: {what}")
            return
        t0 = time.perf_counter()
        self._running = (what, t0)
        try:
            future = self._worker.submit(_attempt, what, fn)
        except Exception as exc:  # noqa: BLE001 (no worker could be started: say so, keep the view)
            self._running = None
            self._message(f"{what} could not start: {type(exc).__name__}: {exc}")
            return
        doc = self.doc

        def done(f):
            try:
                doc.add_next_tick_callback(functools.partial(self._finish, what, t0, _outcome(what, f), apply, on_fail))
            except Exception:  # noqa: BLE001 (the session closed meanwhile: nothing to draw)
                pass

        future.add_done_callback(done)
        doc.add_timeout_callback(functools.partial(self._overdue, future, what), int(RECOMPUTE_BUDGET * 1000))

    def _overdue(self, future, what: str) -> None:
        if not future.done():
            self._message(f"{what} is still being computed after {RECOMPUTE_BUDGET:g} s; the views show the previous "
                          "input until it ends")

    def _finish(self, what: str, t0: float, outcome, apply, on_fail) -> None:
        self._running = None
        status, value = outcome
        if status == "ok":
            self._message("")
            apply(value)
            self.d_timing.text = _span("timing-text", f"{what} in {time.perf_counter() - t0:.2f} s")
        else:
            self._message(value)
            if on_fail is not None:
                message = self.d_message.text
                on_fail()
                self.d_message.text = message
        if self._pending is not None:
            pending, self._pending = self._pending, None
            self._run(*pending)

    def _recompute(self, first: bool = False, on_fail=None) -> None:
        settings = dataclasses.replace(self.settings)  # what this computation sees, whatever the page does next

        def apply(out):
            scene, v = out
            self.scene = scene
            self._draw(scene, v)
            if not first:
                self._clear()
            self._show_controls()

        self._run("recompute", functools.partial(_build_views, settings), apply, on_fail)

    def _draw(self, scene, v) -> None:
        x0, x1 = float(v.boundary_x[0]), float(v.boundary_x[-1])
        z = v.maps.z
        self.x_range.start, self.x_range.end = x0 * MM, x1 * MM
        self.z_range.start, self.z_range.end = float(z[0]) * MM, float(z[-1]) * MM
        self.src_boundary.data = dict(x=v.boundary_x * MM, h=v.boundary_h * MM, h0=v.boundary_h0 * MM)
        a = v.arrows
        X, Z = np.meshgrid(a.x, a.z)
        f = a.force
        mag = np.hypot(f[..., 0], f[..., 1])
        top = float(mag.max()) if mag.size and mag.max() > 0 else 1.0
        step = max((a.x[1] - a.x[0]), (a.z[1] - a.z[0])) * 0.9  # the longest arrow: one grid step
        scale = np.where(mag > 0, step * np.sqrt(mag / top) / np.maximum(mag, 1e-300), 0.0)
        on = mag > 0  # no arrow where the field is zero (outside the wall)
        self.src_arrows.data = dict(x0=X[on] * MM, z0=Z[on] * MM, x1=(X + f[..., 0] * scale)[on] * MM,
                                    z1=(Z + f[..., 1] * scale)[on] * MM, mag=mag[on])
        self.mag_mapper.high = top
        m = v.maps
        box = dict(x=[x0 * MM], y=[float(z[0]) * MM], dw=[(x1 - x0) * MM], dh=[float(z[-1] - z[0]) * MM])
        gain = m.gain
        finite = gain[np.isfinite(gain)]
        self.gain_mapper.high = max(float(np.percentile(finite, 99.5)) if finite.size else 1.0, 1.0)
        self.src_gain.data = dict(image=[gain], **box)
        q = v.q
        where = q.where if q.where is not None else None
        shown = where is not None and np.all(np.isfinite(where))
        on_section = shown and (len(where) == 2 or abs(where[1] - scene.section) <= 1e-9 + 1e-6 * abs(x1 - x0))
        self.src_qmark.data = dict(x=[where[0] * MM], z=[where[-1] * MM]) if on_section else dict(x=[], z=[])
        self.src_qmark_xy.data = (dict(x=[where[0] * MM], y=[where[1] * MM]) if shown and len(where) == 3
                                  else dict(x=[], y=[]))
        q_text = "unbounded" if q.unbounded else f"{q.value:.4g}"
        at = ""
        if where is not None and len(where) == 3:
            at = f" (at y = {where[1] * MM:.3g} mm)"
        self.d_q.text = f"q ({scene.algorithm.letter}) = " + _span("q-value", q_text) + at
        curl = m.curl
        c = float(np.percentile(np.abs(curl[np.isfinite(curl)]), 99)) if np.isfinite(curl).any() else 0.0
        self.curl_mapper.low, self.curl_mapper.high = -max(c, 1e-9), max(c, 1e-9)
        self.src_curl.data = dict(image=[np.where(np.isfinite(curl), curl, 0.0)], **box)
        if v.heights is not None:
            gx, gy, h = v.heights
            self.height_mapper.low, self.height_mapper.high = float(h.min()) * MM, float(max(h.max(), h.min() + 1e-12)) * MM
            self.src_heights.data = dict(image=[h * MM], x=[gx[0] * MM], y=[gy[0] * MM], dw=[(gx[-1] - gx[0]) * MM],
                                         dh=[(gy[-1] - gy[0]) * MM])
            self.src_section.data = dict(x=[gx[0] * MM, gx[-1] * MM], y=[scene.section * MM] * 2)
        if v.surface_q is not None:
            gu, gw, g = v.surface_q
            self.surface_q_mapper.low, self.surface_q_mapper.high = float(g.min()), float(max(g.max(), g.min() + 1e-12))
            self.src_surface_q.data = dict(image=[g], x=[gu[0] * MM], y=[gw[0] * MM], dw=[(gu[-1] - gu[0]) * MM],
                                           dh=[(gw[-1] - gw[0]) * MM])

    def _show_loop(self, energy: float, polygon: np.ndarray, expected=None, source: str = "") -> None:
        xs, zs = polygon[:, 0] * MM, polygon[:, -1] * MM
        self._drawing = True
        try:
            self.src_path.data = dict(xs=[list(xs)], ys=[list(zs)])
        finally:
            self._drawing = False
        extra = ""
        if expected is not None:
            extra = f" (the paper: {expected:.6g} J; {source})"
        elif source:
            extra = f" ({source})"
        self.d_loop.text = "loop energy ΔE = " + _span("loop-energy", f"{energy:.6g}") + " J" + html.escape(extra)

    _drawing = False

    def _path_changed(self, attr, old, new) -> None:
        if self._drawing or self.scene is None:
            return
        xs, ys = new.get("xs", []), new.get("ys", [])
        if not xs or len(xs[-1]) < 3:
            return
        px, pz = np.asarray(xs[-1], dtype=float) / MM, np.asarray(ys[-1], dtype=float) / MM
        scene = self.scene

        def apply(out):
            energy, polygon = out
            self._show_loop(energy, polygon, source=f"{len(polygon) - 1} vertices, closed")

        self._run("loop energy", functools.partial(model.loop, scene, px, pz), apply)

    def _fig3(self) -> None:
        if self.scene is None:
            return
        scene = self.scene

        def apply(out):
            path, energy, expected, source = out
            self._show_loop(energy, path, expected, source)

        self._run("Fig. 3 loop", functools.partial(model.fig3, scene), apply)

    def _clear(self) -> None:
        self._drawing = True
        try:
            self.src_path.data = dict(xs=[], ys=[])
        finally:
            self._drawing = False
        self.d_loop.text = "loop energy ΔE = " + _span("loop-energy", "–") + " J"

    def _scan(self) -> None:
        if self.scene is None:
            return
        scene = self.scene

        def apply(out):
            e = out.energy
            zeros = np.zeros_like(out.time)
            self.src_energy.data = dict(t=out.time, x=e["x"] * 1e3, y=e.get("y", zeros) * 1e3, z=e["z"] * 1e3)
            self.d_scan.text = "scan: " + _span("scan-verdict", out.verdict)
            hand = "Section V-B's hand" if scene.hand is None else f"the {scene.hand.key} hand"
            self.d_scan.text += html.escape(f" ({scene.duration:g} s on the {scene.device.name}, {hand}; energy "
                                            f"balance error {out.energy_balance_error:.1g})")

        self._run("scan", functools.partial(model.scan, scene), apply)


def _colour_bar(mapper, label):
    from bokeh.models import ColorBar

    return ColorBar(color_mapper=mapper, title=label, width=10)


def app(doc) -> ExplorerPage:
    """Fill a Bokeh document with the explorer (a Bokeh application's entry point).

    In a Jupyter notebook: ``from bokeh.io import output_notebook, show;
    output_notebook(); show(haptex.explore.app)``.

    Parameters
    ----------
    doc : bokeh.document.Document

    Returns
    -------
    ExplorerPage
    """
    return ExplorerPage(doc)


def _served(doc) -> ExplorerPage:
    """The page a served session gets: its computations off the server's event loop."""
    return ExplorerPage(doc, offload=True)


def serve(port: int = 5006, address: str = "127.0.0.1", open_browser: bool = True, block: bool = True,
          announce=None):
    """Serve the explorer at ``http://ADDRESS:PORT/``.

    Parameters
    ----------
    port : int
        TCP port in [1, 65535], or 0 for any free port (read it from ``server.port``).
    address : str
        Interface to listen on; the loopback interface by default (the page runs the
        library on this machine: do not expose it to a network you do not trust).
    open_browser : bool
        Open the page in the default browser.
    block : bool
        Run the server's event loop until interrupted (Ctrl-C); else return the started
        server (its loop must then be run by the caller, or by a thread).
    announce : callable, optional
        Called with the page's URL (the port chosen when ``port`` is 0) once the server
        listens, before it blocks.

    Returns
    -------
    bokeh.server.server.Server

    Raises
    ------
    ParameterError
        If the port is out of range or already in use.
    """
    from bokeh.application import Application
    from bokeh.application.handlers.function import FunctionHandler
    from bokeh.server.server import Server

    if not (isinstance(port, int) and 0 <= port <= 65535):
        raise ParameterError(f"port = {port!r} is not allowed: must be a whole number in [0, 65535]")
    if port == 0:
        import socket

        with socket.socket() as probe:
            probe.bind((address, 0))
            port = probe.getsockname()[1]
    origins = [f"{host}:{port}" for host in ("127.0.0.1", "localhost", address)]
    # the workers' forkserver started (and warmed: the library's imports and one-time set-up)
    # before the server listens, so that no session waits for it
    from multiprocessing import forkserver

    _context()
    forkserver.ensure_running()
    try:
        server = Server({"/": Application(FunctionHandler(_served))}, port=port, address=address,
                        allow_websocket_origin=sorted(set(origins)), num_procs=1,
                        websocket_max_message_size=UPLOAD_BYTES * 4 // 3 + 2**20)  # an upload, base64, and room
    except OSError as exc:
        raise ParameterError(f"port = {port} is not allowed: cannot listen on {address}:{port} "
                             f"({exc.strerror or exc})") from None
    server.start()
    if announce is not None:
        announce(f"http://{address}:{server.port}/")
    if open_browser:
        server.io_loop.add_callback(server.show, "/")
    if block:
        def terminate(signum, frame):  # SIGTERM ends the server as Ctrl-C does: workers stopped, folders removed
            raise KeyboardInterrupt

        previous = signal.signal(signal.SIGTERM, terminate)
        try:
            server.io_loop.start()
        except KeyboardInterrupt:
            pass
        finally:
            signal.signal(signal.SIGTERM, previous)
            server.stop()
            _stop_all()
    return server
