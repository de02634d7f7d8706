"""What the explorer computes, without any web code: the controls' text (with units) is
parsed into a texture, an algorithm and a device, and every number the page shows comes
from the library's own functions (:func:`haptex.analysis.field_map`,
:func:`haptex.characteristic_number`, :func:`haptex.loop_energy`,
:func:`haptex.paper_loop`, :func:`haptex.simulate`). The page only draws these arrays.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from .._loaders import remedy_in
from .._specs import quantity, texture_from_spec
from .._validation import ParameterError, fail
from ..catalogue import presets
from ..tables import PAPER_PARAMETERS

#: Textures the texture control offers (value, label).
TEXTURES = [("sine", "sinusoid"), ("sum", "sum of sinusoids"), ("noise", "band-limited noise"),
            ("egg-crate", "areal: egg-crate"), ("grating", "areal: grating"),
            ("file", "measured file (profile or areal map)"), ("image", "image (grey levels as heights)")]
#: Algorithms the algorithm control offers (value, label): Table I and the smooth wall.
ALGORITHM_LABELS = [("W", "W: smooth wall"), ("A", "A: vertical (grooved)"), ("B", "B: normal (grooved)"),
                    ("C", "C: change of height"), ("D", "D: god-object gradient"), ("E", "E: god-object vertical"),
                    ("F", "F: friction modulated"), ("G", "G: force shading")]
#: Devices the device control offers (value, label): the generic models and the product presets of
#: :mod:`haptex.catalogue` (over a profile, in their x-z plane).
DEVICES = [("pantograph", "pantograph (the paper's, planar)"), ("point-mass", "point mass 0.1 kg, 0.5 N s/m"),
           ("serial-arm", "serial 3-DOF arm (surfaces)"), ("delta", "delta (surfaces)"),
           ("touch", "3D Systems Touch"), ("premium-1-5", "Phantom Premium 1.5"), ("falcon", "Novint Falcon"),
           ("omega-3", "Force Dimension omega.3"), ("delta-3", "Force Dimension delta.3"),
           ("sigma-7", "Force Dimension sigma.7"), ("inverse3", "Haply Inverse3 (chosen figures)")]
#: The scanning hand of Section V-B (the CLI's ``simulate scan`` defaults).
HAND_STIFFNESS, HAND_DAMPING, HAND_DEPTH = 300.0, 1.0, 1e-3
#: Hands the scan's hand control offers (value, label): Section V-B's spring and damper (no mass),
#: and the hands of :mod:`haptex.catalogue` (their mass moves with the handle; with sources in
#: ``haptex devices show NAME``).
HANDS = [("section-v-b", "Section V-B: 300 N/m, 1 N s/m"), ("light-touch", "light touch (chosen)"),
         ("firm-grip", "firm grip (van Beek et al. 2015)")]
#: Grid of the arrows and of the maps (points per axis along x, z).
ARROW_GRID, MAP_GRID = (23, 19), (121, 121)
#: On an object: q on its surface, on this grid of surface coordinates (u1, u2), each the
#: largest gain over this many depths (chosen: 41 x 41 x 16, about 0.1 s on a sphere).
SURFACE_GRID, SURFACE_DEPTHS = (41, 41), 16
#: Longest scan the page runs (s of simulated time): about 0.3 s of computing at T = 100 us.
MAX_SCAN_DURATION = 10.0
#: Most vertices a drawn path may keep (loop work costs up to 20 ms a segment for D and E).
MAX_PATH_VERTICES = 400
#: Longest planned computation of the views (s): past it the input is refused before any of
#: it runs (a Python thread cannot be stopped once started; issue 33).
MAX_VIEW_SECONDS = 60.0

READING = ("spacing", "x_unit", "height_unit", "variable", "crop", "fill_undefined", "periodic")
"""The settings that say how a measured file is read (the page's file boxes; a refusal that
asks for one keeps the file)."""


@dataclass
class Settings:
    """What the controls say, as the user typed it (quantities with their units).

    Parameters
    ----------
    texture : str
        One of :data:`TEXTURES`' values.
    amplitude, period : str
        Sinusoid, egg-crate and grating (e.g. "0.8 mm", "1 mm").
    terms : str
        Sum of sinusoids: "A1,L1; A2,L2; ...".
    noise : str
        Band-limited noise: "RMS, SHORTEST, LONGEST, LENGTH[, SEED]".
    file : str or None
        Path of the measured file or image on the server (an upload is saved first).
    file_name : str
        The name the user gave the file (for messages).
    pixel_size, height_range : str
        Image only: a pixel's size and the height from black to white.
    spacing, x_unit, height_unit : str
        Measured file only, where the file does not state them (a MATLAB file, a text file
        of bare numbers): the sample spacing ("0.5 um"), the unit of its positions and of
        its heights ("um"); blank when the file states them.
    variable : str
        Measured file only: the variable (a MATLAB file's) or channel (an SPM file's: its name,
        or its index where two share one) read, where it holds several; blank: a MATLAB file's
        only one, an SPM file's height channel.
    crop : str
        Measured file only: the part kept, "auto" (the largest measured part) or "X0,X1" /
        "X0,X1,Y0,Y1" with units (as ``--crop``); blank: the whole file.
    fill_undefined : bool
        Measured file only: fill its undefined (NaN) heights by interpolation (as
        ``--fill-undefined``) instead of refusing it.
    periodic : bool
        Measured file or image only: read it as one period of a periodic texture (as
        ``--periodic``): what a closed object (a sphere, a cylinder) needs, whose seam it closes.
    algorithm : str
        W or A–G.
    stiffness : str
        kappa_0 (e.g. "2 kN/m").
    max_penetration : str
        d^z_max of B, C, F, G and the depth of the analysed region for all (on an object too:
        Remark 3 on the base, :mod:`haptex.objects`).
    friction, presliding : str
        F's mu and d^x_max.
    device : str
        One of :data:`DEVICES`' values.
    hand : str
        One of :data:`HANDS`' values: the hand that drags the handle in the scan.
    speed, duration : str
        The scan's set-point speed and length.
    section : str
        Over a surface, the ordinate y of the section shown and scanned; "auto" is a
        quarter of the way across the region shown (through the egg-crate's peaks).
    object : str
        Over a surface, the base the texture is on: "plane" (the paper's wall, every
        letter), "sphere:RADIUS" or "cylinder:RADIUS" (A, B, C, F and G; its top at the origin,
        :mod:`haptex.objects`), or "mesh": the closed triangle mesh in ``object_file``
        (:func:`placed_mesh`).
    object_file : str or None
        Path on the server of the uploaded mesh (OBJ, STL, PLY, glTF, ... with texture
        coordinates).
    object_file_name : str
        The name the user gave the mesh file (for messages).
    uv_scale : str
        The mesh's metres per unit of its texture coordinates (e.g. "10 mm").
    """

    texture: str = "sine"
    amplitude: str = f"{PAPER_PARAMETERS['amplitude'] * 1e3:g} mm"
    period: str = f"{PAPER_PARAMETERS['period'] * 1e3:g} mm"
    terms: str = "0.4 mm, 1 mm; 0.1 mm, 0.25 mm"
    noise: str = "0.1 mm, 0.5 mm, 4 mm, 20 mm"
    file: str | None = None
    file_name: str = ""
    pixel_size: str = "10 um"
    height_range: str = "0.2 mm"
    spacing: str = ""
    x_unit: str = ""
    height_unit: str = ""
    variable: str = ""
    crop: str = ""
    fill_undefined: bool = False
    periodic: bool = False
    algorithm: str = "A"
    stiffness: str = f"{PAPER_PARAMETERS['stiffness'] / 1e3:g} kN/m"
    max_penetration: str = f"{PAPER_PARAMETERS['max_penetration'] * 1e3:g} mm"
    friction: str = f"{PAPER_PARAMETERS['friction']:g}"
    presliding: str = f"{PAPER_PARAMETERS['presliding'] * 1e3:g} mm"
    device: str = "pantograph"
    hand: str = "section-v-b"
    speed: str = "10 mm/s"
    duration: str = "1 s"
    section: str = "auto"
    object: str = "plane"
    object_file: str | None = None
    object_file_name: str = ""
    uv_scale: str = "10 mm"


@dataclass(frozen=True)
class Scene:
    """The objects the settings describe (SI units).

    Parameters
    ----------
    settings : Settings
        The page's controls, as text.
    texture : Texture
        The texture.
    algorithm : Algorithm
        The algorithm on it.
    device : Device
        The device.
    max_penetration : float
        d^z_max (m).
    speed : float
        The stroke's speed (m/s).
    duration : float
        The stroke's duration (s).
    section : float
        The y (m) of the section shown over a surface.
    hand : Hand, optional
        A hand of :mod:`haptex.catalogue`; default Section V-B's spring and damper.
    """

    settings: Settings
    texture: object
    algorithm: object
    device: object
    max_penetration: float
    speed: float
    duration: float
    section: float
    hand: object = None  # a catalogue Hand, or None for Section V-B's

    @property
    def dimension(self) -> int:
        """2 over a profile ([x, z]), 3 over a surface ([x, y, z])."""
        return self.algorithm.dimension


@dataclass(frozen=True)
class Views:
    """Everything the page draws for one scene (lengths in m, forces in N).

    Parameters
    ----------
    boundary_x, boundary_h : ndarray, shape (800,)
        The textured boundary z = h(x) (or h(x, y) on the section; on an object, its
        textured surface there, :func:`boundary`).
    boundary_h0 : ndarray, shape (800,)
        The nominal surface under it (0 on the plane; the object's base).
    surface_q : (u1, u2, Q) or None
        On an object, q on its surface: at each surface coordinate of a :data:`SURFACE_GRID`
        the largest gain ||J||_2 / kappa_0 over :data:`SURFACE_DEPTHS` depths to the max
        penetration below the textured surface (u1, u2 in m).
    arrows : FieldMap
        The force on the coarse grid :data:`ARROW_GRID`.
    maps : FieldMap
        Gain ||J||_2/kappa_0 and curl on :data:`MAP_GRID`.
    q : CharacteristicNumber
        q over the rendering region (its ``where`` is marked on the gain map).
    heights : (x, y, h) or None
        Over a surface, the height map (m) on one window in x and y.
    """

    boundary_x: np.ndarray
    boundary_h: np.ndarray
    arrows: object
    maps: object
    q: object
    heights: tuple | None = None
    boundary_h0: np.ndarray | None = None
    surface_q: tuple | None = None

    def __post_init__(self):
        if self.boundary_h0 is None:  # (the plane's nominal surface)
            object.__setattr__(self, "boundary_h0", np.zeros_like(self.boundary_x))


@dataclass(frozen=True)
class Scan:
    """A simulated stroke: time (s), energies per axis absorbed by the environment (J),
    the oscillation verdict (:class:`haptex.Oscillation`) and the energy balance error.

    Parameters
    ----------
    time : ndarray, shape (n,)
        Sample times (s).
    energy : dict
        Axis name -> energy absorbed by the environment over time (J), shape (n,) each.
    oscillation : Oscillation, optional
        The oscillation verdict (:class:`haptex.Oscillation`).
    energy_balance_error : float, optional
        The simulator's energy balance error (relative).
    verdict : str, optional
        One line for the page.
    """

    time: np.ndarray
    energy: dict = field(default_factory=dict)
    oscillation: object = None
    energy_balance_error: float = 0.0
    verdict: str = ""


def build(settings: Settings) -> Scene:
    """The texture, algorithm and device the settings describe.

    Parameters
    ----------
    settings : Settings
        The page's controls.

    Returns
    -------
    Scene
        The texture, algorithm, device and their settings.

    Raises
    ------
    ParameterError
        Naming the control whose text is wrong, its value and what is allowed.
    """
    from ..algorithms import ALGORITHMS, algorithm
    from ..devices import Device
    from ..surfaces import SampledSurface
    from ..textures import Flat

    s = settings
    letter = str(s.algorithm).strip().upper()
    kind = s.texture
    if kind in ("sine", "egg-crate", "grating"):
        tex = texture_from_spec(f"{kind}:{s.amplitude},{s.period}")
    elif kind == "sum":
        tex = texture_from_spec(f"sum:{s.terms}")
    elif kind == "noise":
        tex = texture_from_spec(f"noise:{s.noise}")
    elif kind in ("file", "image"):
        if not s.file:
            raise ParameterError(f"file = None is not allowed for the texture '{kind}': choose a file first")
        try:
            if kind == "image":
                lo_hi = quantity(s.height_range, "m", "height_range")
                tex = SampledSurface.from_image(s.file, quantity(s.pixel_size, "m", "pixel_size"), (0.0, lo_hi),
                                                periodic=bool(s.periodic))
            else:  # what the file does not state (a .mat's spacing, a text file's units); blank: the file says
                tex = texture_from_spec(s.file, spacing=s.spacing.strip() or None, x_unit=s.x_unit.strip() or None,
                                        height_unit=s.height_unit.strip() or None,
                                        variable=s.variable.strip() or None, crop=s.crop.strip() or None,
                                        fill_undefined=bool(s.fill_undefined), periodic=bool(s.periodic))
        except ParameterError as exc:  # (the file's own name; a reading remedy in the page's file boxes)
            said = remedy_in(str(exc), "in the file boxes") if kind == "file" else str(exc)
            raise ParameterError(said.replace(str(s.file), s.file_name or str(s.file))) from None
    else:
        raise fail("texture", kind, "one of " + ", ".join(v for v, _ in TEXTURES))
    dmax = quantity(s.max_penetration, "m", "max_penetration")
    takes = getattr(ALGORITHMS.get(letter), "parameters", ())  # (the registry)
    params = {}
    if "max_penetration" in takes:
        params["max_penetration"] = dmax
    if "friction" in takes:
        params["friction"] = quantity(s.friction, "dimensionless", "friction")
    if "presliding" in takes:
        params["presliding"] = quantity(s.presliding, "m", "presliding")
    stiffness = quantity(s.stiffness, "N/m", "stiffness")
    on_object = str(s.object).strip().lower() != "plane"
    if on_object:  # a textured object: A, B, C, F, G on a sphere, a cylinder or a mesh (haptex.objects)
        from .._specs import object_from_spec
        from ..objects import OBJECT_DESIGN_LETTERS, object_algorithm

        mesh = str(s.object).strip().lower() == "mesh"
        base = None if mesh else object_from_spec(s.object, files=False)
        if tex.dimension != 2:
            raise fail("object", s.object, "'plane' over a profile (an object carries an areal texture: choose the "
                       "egg-crate, a grating, a map or an image)")
        if mesh:
            if not s.object_file:
                raise ParameterError("object = 'mesh' is not allowed without a mesh file: choose one (OBJ, STL, PLY, "
                                     "glTF, ... with texture coordinates)")
            (x0, x1), (y0, y1) = _texture_window(tex)
            try:
                base = placed_mesh(s.object_file, quantity(s.uv_scale, "m", "uv_scale"),
                                   (0.5 * (x0 + x1), 0.5 * (y0 + y1)))
            except ParameterError as exc:
                name = s.object_file_name or "the mesh"
                msg = str(exc).replace(str(s.object_file), name)
                raise ParameterError(msg if name in msg else f"mesh file {name!r}: {msg}") from None
        if letter not in OBJECT_DESIGN_LETTERS:
            raise fail("algorithm", letter,
                       f"one of {', '.join(OBJECT_DESIGN_LETTERS)} on an object (or the object 'plane')")
        try:
            alg = object_algorithm(letter, tex, base, stiffness, **params)
        except ParameterError as exc:  # (a seam's radius as the object box takes it; a file closed by its switch)
            said = str(exc)
            if "--object " in said:
                said = remedy_in(said, "in the object box")
            elif "--periodic" in said and kind in ("file", "image"):
                said = remedy_in(said, "in the file boxes")
            raise ParameterError(said) from None
    elif letter in ALGORITHMS and not ALGORITHMS[letter].textured:
        alg = algorithm(letter, Flat(dimension=2) if tex.dimension == 2 else None, stiffness)
        tex = alg.texture  # the smooth wall ignores the texture: show the flat boundary it renders
    else:
        alg = algorithm(letter, tex, stiffness, **params)
    d = alg.dimension
    dev_kind = s.device
    if dev_kind == "pantograph":
        if d != 2:
            raise ParameterError("device = 'pantograph' is not allowed over a surface: it is planar; choose the "
                                 "point mass, the serial arm or the delta")
        dev = Device.pantograph()
    elif dev_kind == "point-mass":
        dev = Device.point_mass(0.1, 0.5, 1e-4, dimension=d)
    elif dev_kind in ("serial-arm", "delta"):
        if d != 3:
            raise ParameterError(f"device = {dev_kind!r} is not allowed over a profile: it is a 3-DOF device; "
                                 "choose an areal texture, or the pantograph or the point mass")
        dev = Device.serial_arm() if dev_kind == "serial-arm" else Device.delta()
    elif dev_kind in presets():
        dev = presets()[dev_kind].device(dimension=d)
    else:
        raise fail("device", dev_kind, "one of " + ", ".join(v for v, _ in DEVICES))
    if s.hand == "section-v-b":
        hand = None
    elif s.hand in (v for v, _ in HANDS):
        from ..catalogue import hand as _hand

        hand = _hand(s.hand)
    else:
        raise fail("hand", s.hand, "one of " + ", ".join(v for v, _ in HANDS))
    speed = quantity(s.speed, "m/s", "speed")
    if not 0 < speed <= 1.0:
        raise fail("speed", s.speed, "a scan speed in (0, 1 m/s]")
    duration = quantity(s.duration, "s", "duration")
    if not 0 < duration <= MAX_SCAN_DURATION:
        raise fail("duration", s.duration, f"a scan length in (0, {MAX_SCAN_DURATION:g} s]")
    auto = str(s.section).strip().lower() == "auto"
    section = 0.0 if auto else quantity(s.section, "m", "section")
    if d == 2 and section != 0.0:
        raise fail("section", s.section, "'auto' or 0 over a profile (the section applies to areal textures)")
    scene = Scene(settings=replace(s), texture=tex, algorithm=alg, device=dev, max_penetration=dmax, speed=speed,
                  duration=duration, section=section, hand=hand)
    if auto and d == 3:
        _, (y0, y1) = window(scene)
        scene = replace(scene, section=y0 + (y1 - y0) / 4)
    return scene


def window(scene: Scene) -> tuple[tuple[float, float], tuple[float, float] | None]:
    """The region shown (m): the texture's ``domain``, the region its analysis (q) covers
    by default (one period or cell, a sampled texture's extent), else x in [0, 1 mm];
    returns ((x0, x1), (y0, y1)) over a surface and ((x0, x1), None) over a profile.

    Parameters
    ----------
    scene : Scene
        What the page shows.

    Returns
    -------
    tuple
        ((x0, x1), (y0, y1)) over a surface, ((x0, x1), None) over a profile (m).
    """
    return _texture_window(scene.texture)


def _texture_window(tex):
    """:func:`window` of a texture."""
    from ..analysis import default_window

    dom = getattr(tex, "domain", None)
    if tex.dimension == 2:
        if dom is None:
            return (0.0, 1e-3), (0.0, 1e-3)
        return (float(dom[0][0]), float(dom[0][1])), (float(dom[1][0]), float(dom[1][1]))
    if dom is None:
        return default_window(tex), None
    return (float(dom[0]), float(dom[1])), None


def placed_mesh(path, uv_scale: float, anchor):
    """The closed triangle mesh read from ``path`` (``uv_scale`` metres per unit of its texture
    coordinates) moved rigidly into the explorer's frame: its point at surface coordinates
    ``anchor`` (m, shape (2,): the texture window's centre) to (anchor, 0), the mesh's outward
    normal there along +z and the direction of u1 there along +x, so that near it x, y follow
    u1, u2 and the section y = const cuts the mesh where the window lies (a sphere's top is at
    the origin with u = 0 there, likewise).

    Parameters
    ----------
    path : str or os.PathLike
        A closed triangle mesh with texture coordinates (OBJ, PLY, ...; what
        :class:`haptex.objects.Mesh` reads).
    uv_scale : float
        Metres per unit of its texture coordinates.
    anchor : array_like, shape (2,)
        The surface coordinates (m) placed at the explorer's origin.

    Returns
    -------
    Mesh
        The mesh in the explorer's frame, its texture coordinates in metres.

    Raises
    ------
    ParameterError
        For a ``path`` that is not a path (a str or os.PathLike, PEP 519); as
        :class:`haptex.objects.Mesh` (a file that is not a closed manifold mesh with
        texture coordinates, past the memory budget, ...), or where the mesh's UV map does not
        hold ``anchor``.
    """
    import trimesh

    from .._validation import a_path
    from ..objects import Mesh

    base = Mesh(a_path("path", path, "a mesh file's path"), uv_scale=uv_scale)
    anchor = np.asarray(anchor, dtype=float)
    try:
        p = base.point(anchor[None, :], np.zeros(1))[0]
    except ParameterError:
        raise fail("object", str(path), f"a mesh whose UV map ({uv_scale:g} m per unit) holds the texture window's "
                   f"centre, u = ({anchor[0]:g}, {anchor[1]:g}) m: change uv_scale") from None
    _, Ju, _, _, n, _ = base.local(p[None, :])
    n = n[0]
    t = Ju[0, 0] - (Ju[0, 0] @ n) * n
    t /= np.linalg.norm(t)
    R = np.stack([t, np.cross(n, t), n])  # rows: the new x, y, z axes
    verts = (np.asarray(base.mesh.vertices, dtype=float) - p) @ R.T + np.array([anchor[0], anchor[1], 0.0])
    return Mesh(trimesh.Trimesh(verts, np.asarray(base.mesh.faces), process=False), uv=base.uv)


def heights(scene: Scene, x) -> np.ndarray:
    """h(x) on the section shown (m), shape like ``x``.

    Parameters
    ----------
    scene : Scene
        What the page shows.
    x : array_like
        Positions along the section (m).

    Returns
    -------
    numpy.ndarray
        h(x) (m), shape like ``x``.
    """
    tex = scene.texture
    x = np.asarray(x, dtype=np.float64)
    if tex.dimension == 1:
        return tex.height(x)
    return tex.height_at(np.stack([x, np.full_like(x, scene.section)], -1))


def boundary(scene: Scene, x) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The textured and the nominal surface on the section shown: (x, z, z0) (m). On the
    plane z = h(x) and z0 = 0; on an object the surface points at surface coordinates
    (x, section) on the base, and the base's own (exactly on the section for a cylinder; for a
    sphere within its sag, (x^2 + y^2) / 2R, of it).

    Parameters
    ----------
    scene : Scene
        What the page shows.
    x : array_like, shape (n,)
        Positions along the section (m).

    Returns
    -------
    tuple of numpy.ndarray
        (x, z, z0) (m), each shape (n,): the section's abscissae, the textured surface's and the
        nominal surface's heights.
    """
    x = np.asarray(x, dtype=np.float64)
    base = getattr(scene.algorithm, "base", None)
    if base is None:
        return x, heights(scene, x), np.zeros_like(x)
    u = np.stack([x, np.full_like(x, scene.section)], -1)
    top = base.point(u, scene.texture.height_at(u))
    return top[:, 0], top[:, 2], np.interp(top[:, 0], *base.point(u, np.zeros_like(x))[:, ::2].T)


def view_cost(scene: Scene) -> tuple[float, int]:
    """(seconds, field evaluations) the views of ``scene`` are planned to take: q's grid and
    the maps' Jacobians (:mod:`haptex.analysis.cost`: the plans and measured evaluation
    times), and the arrows' and maps' forces.

    Parameters
    ----------
    scene : Scene
        What the page shows.

    Returns
    -------
    tuple of (float, int)
        The planned seconds and field evaluations.
    """
    from ..analysis.cost import analysis_cost, evaluation_time

    alg, dmax = scene.algorithm, scene.max_penetration
    each, each_j = evaluation_time(alg, dmax), evaluation_time(alg, dmax, jacobian=True)
    q = analysis_cost(alg, dmax, seconds_each=(each, each_j), continuity=False)  # (q's grid, as the analysis plans it)
    nj = math.prod(MAP_GRID)
    nf = math.prod(ARROW_GRID) + math.prod(MAP_GRID)
    return q.seconds + nj * each_j + nf * each, int(q.evaluations + nj + nf)


def views(scene: Scene) -> Views:
    """The force arrows, gain and curl maps, q and (over a surface) the height map.

    Parameters
    ----------
    scene : Scene
        What the page shows.

    Returns
    -------
    Views
        The arrows' positions (m) and forces (N), the gain and curl maps, q, and the height map
        over a surface.

    Raises
    ------
    ParameterError
        When the views would take longer than :data:`MAX_VIEW_SECONDS` (planned before
        any of it runs: :func:`view_cost`), saying what to change.
    """
    from ..analysis import characteristic_number, field_map

    seconds, n = view_cost(scene)
    if seconds > MAX_VIEW_SECONDS:
        what = "closest-point searches" if scene.algorithm.penetration_kind == "distance" else "field evaluations"
        raise ParameterError(f"algorithm = {scene.algorithm.letter!r} on this texture is not allowed here: its views "
                             f"need about {seconds:.3g} s ({n:.3g} {what}), more than {MAX_VIEW_SECONDS:g} s; choose "
                             "a smaller map or a shallower max penetration, or run 'haptex design' on it")
    alg, dmax = scene.algorithm, scene.max_penetration
    (x0, x1), yr = window(scene)
    bx, bh, b0 = boundary(scene, np.linspace(x0, x1, 800))
    y = scene.section if scene.dimension == 3 else 0.0
    arrows = field_map(alg, (x0, x1), n=ARROW_GRID, max_penetration=dmax, y=y)
    maps = field_map(alg, (x0, x1), n=MAP_GRID, max_penetration=dmax, y=y)
    q = characteristic_number(alg, max_penetration=dmax)
    hmap = surface = None
    if getattr(alg, "base", None) is not None:  # q on the object's surface, depth by depth
        (u0, u1), (w0, w1) = (x0, x1), yr
        gu, gw = np.linspace(u0, u1, SURFACE_GRID[0]), np.linspace(w0, w1, SURFACE_GRID[1])
        depth = np.linspace(dmax / SURFACE_DEPTHS, dmax, SURFACE_DEPTHS)
        U, W, D = np.meshgrid(gu, gw, depth)
        pts = alg.region_points(np.stack([U, W], -1), D)
        gain = np.linalg.norm(alg.jacobian(pts), ord=2, axis=(-2, -1)) / alg.stiffness
        surface = (gu, gw, gain.max(axis=-1))
    if scene.dimension == 3:
        y0, y1 = yr
        gx, gy = np.linspace(x0, x1, MAP_GRID[0]), np.linspace(y0, y1, MAP_GRID[1])
        X, Y = np.meshgrid(gx, gy)
        hmap = (gx, gy, scene.texture.height_at(np.stack([X, Y], -1)))
    return Views(boundary_x=bx, boundary_h=bh, arrows=arrows, maps=maps, q=q, heights=hmap, boundary_h0=b0,
                 surface_q=surface)


def section_points(scene: Scene, xs, zs) -> np.ndarray:
    """Positions (m) of points drawn on the section: [x, z], or [x, y, z] at y = section.

    Parameters
    ----------
    scene : Scene
        What the page shows.
    xs : array_like, shape (N,)
        The points' x (m).
    zs : array_like, shape (N,)
        Their z (m).

    Returns
    -------
    numpy.ndarray, shape (n, 2) or (n, 3)
        The positions (m).
    """
    xs, zs = np.asarray(xs, dtype=np.float64), np.asarray(zs, dtype=np.float64)
    if scene.dimension == 2:
        return np.stack([xs, zs], -1)
    return np.stack([xs, np.full_like(xs, scene.section), zs], -1)


def simplify(points: np.ndarray) -> np.ndarray:
    """Drop vertices that lie on the straight line through their neighbours (to rounding),
    so that a path dragged with the mouse costs one quadrature per straight piece; the
    path itself is unchanged.

    Parameters
    ----------
    points : ndarray, shape (N, d)
        A closed or open polyline's vertices (m).

    Returns
    -------
    numpy.ndarray, shape (m, d)
        The path's vertices (m), m <= n, the straight runs' inner vertices dropped.
    """
    p = np.asarray(points, dtype=np.float64)
    if len(p) < 3:
        return p
    keep = [0]
    for i in range(1, len(p) - 1):
        a, b, c = p[keep[-1]], p[i], p[i + 1]
        u, w = b - a, c - b
        nu, nw = np.linalg.norm(u), np.linalg.norm(w)
        if nu == 0.0:
            continue
        cross = np.linalg.norm(np.cross(u, w)) if len(u) == 3 else abs(u[0] * w[1] - u[1] * w[0])
        if nw == 0.0 or cross > 1e-9 * nu * nw or np.dot(u, w) < 0:
            keep.append(i)
    keep.append(len(p) - 1)
    return p[keep]


def loop(scene: Scene, xs, zs) -> tuple[float, np.ndarray]:
    """Loop energy (J) of the closed path through the drawn points (m), and the polygon
    used, shape (N + 1, d), closed (last vertex = first).

    Parameters
    ----------
    scene : Scene
        What the page shows.
    xs : array_like, shape (N,)
        The drawn points' x (m).
    zs : array_like, shape (N,)
        Their z (m).

    Returns
    -------
    tuple of (float, numpy.ndarray)
        The loop energy (J) and the closed polygon (m), shape (N + 1, d).

    Raises
    ------
    ParameterError
        If the path has fewer than 3 distinct vertices, or more than
        :data:`MAX_PATH_VERTICES` after straight runs are merged.
    """
    from ..analysis import loop_energy

    pts = section_points(scene, xs, zs)
    distinct = len(np.unique(pts, axis=0)) if pts.size else 0
    if distinct < 3:
        raise ParameterError(f"path has {distinct} distinct points, which is not allowed: draw a closed path with "
                             "at least 3")
    if not np.array_equal(pts[0], pts[-1]):
        pts = np.vstack([pts, pts[:1]])
    pts = simplify(pts)
    if len(pts) - 1 > MAX_PATH_VERTICES:
        raise ParameterError(f"path has {len(pts) - 1} vertices, which is not allowed: at most {MAX_PATH_VERTICES} "
                             "(draw it with fewer turns, or use the polygon tool)")
    return loop_energy(scene.algorithm, pts), pts


def fig3(scene: Scene) -> tuple[np.ndarray, float, float | None, str]:
    """The Fig. 3 loop (eq. 27 for F, eq. 29 for G and W) drawn on the section: polygon
    (m), its loop energy by :func:`haptex.loop_energy` (J), the paper's value (J) and
    where the path comes from.

    Parameters
    ----------
    scene : Scene
        What the page shows (a sinusoid).

    Returns
    -------
    tuple
        (polygon (m), shape (n, d); loop energy (J); the paper's value (J) or None; where the
        path comes from).

    Raises
    ------
    ParameterError
        Over anything but a sinusoid (the paths are defined for one).
    """
    from ..analysis import loop_energy, paper_loop

    path, expected, source = paper_loop(scene.algorithm)
    return path, loop_energy(scene.algorithm, path), expected, source


def scan(scene: Scene) -> Scan:
    """A stroke along x on the section: the scene's hand (Section V-B's, K = 300 N/m,
    C = 1 N s/m, by default; or a hand of :mod:`haptex.catalogue`, its mass moving with the
    handle), its set-point 1 mm below the nominal surface, dragged at ``speed`` for
    ``duration`` on the chosen device, simulated by :func:`haptex.simulate`.

    Parameters
    ----------
    scene : Scene
        What the page shows.

    Returns
    -------
    Scan
        The stroke's times (s), the energy each axis absorbed (J), its oscillation verdict and
        energy balance error.
    """
    from .. import operators as ops
    from ..simulate import simulate

    d = scene.dimension
    (x0, _), _ = window(scene)
    h = scene.hand
    k, c = (HAND_STIFFNESS, HAND_DAMPING) if h is None else (h.stiffness, h.damping)
    device = scene.device if h is None else h.attach(scene.device)
    if d == 2:  # a constant-velocity set-point: the verdict then knows the texture's own rates v / l
        op = ops.ScanningHand(k, c, velocity=scene.speed, depth=HAND_DEPTH, start=x0)
        start = [x0, 0.0]
    else:  # along x on the section y = section
        end = x0 + scene.speed * scene.duration
        op = ops.ScanningHand(k, c, path=[[x0, scene.section, 0.0], [end, scene.section, 0.0]],
                              speed=scene.speed, depth=HAND_DEPTH, dimension=3)
        start = [x0, scene.section, 0.0]
    n = scene.duration / device.period
    res = simulate(scene.algorithm, device, op, scene.duration, initial_position=start,
                   record_every=max(1, int(math.ceil(n / 4000))))
    energy = {"x": res.energy_x, "z": res.energy_z}
    if d == 3:
        energy["y"] = res.energy_y
    osc = res.oscillation
    if res.diverged_at is not None:
        verdict = f"diverged at sample {res.diverged_at} ({res.diverged_quantity})"
    elif osc.oscillating:
        verdict = (f"oscillating along {osc.axis}: {osc.amplitude * 1e3:.3g} mm at {osc.frequency:.4g} Hz, "
                   f"{osc.energy_per_cycle:.3g} J a cycle")
    elif osc.axis is not None and getattr(osc, osc.axis).texture_driven:
        verdict = (f"not oscillating: the {osc.amplitude * 1e3:.3g} mm motion along {osc.axis} at "
                   f"{osc.frequency:.4g} Hz is the texture's own rate v/l")
    else:
        verdict = f"not oscillating (tail amplitude {osc.amplitude * 1e3:.3g} mm, decay ratio {osc.decay_ratio:.3g})"
    return Scan(time=res.time, energy=energy, oscillation=osc, energy_balance_error=res.energy_balance_error,
                verdict=verdict)


# --- a data-driven texture: a model set over (speed, force) ------------------------------
VIBRATION_POINTS = 512
"""Frequencies at which the picked model's spectrum is drawn, 0 to the set's Nyquist rate."""


@dataclass
class Vibration:
    """What the explorer draws of a model set: its operating points and triangles, and the
    spectrum of the model interpolated at the picked (speed, force).

    Parameters
    ----------
    speeds : ndarray, shape (n,)
        The models' speeds (m/s).
    forces : ndarray, shape (n,)
        The models' forces (N).
    edges : list of (ndarray, ndarray)
        Each triangle's closed outline (speed m/s, force N), or the polyline of a set on one line.
    speed : float
        The picked speed (m/s), moved to the hull when outside it.
    force : float
        The picked force (N), likewise.
    clamped : bool
        The pick lay outside the hull.
    frequency : ndarray, shape (VIBRATION_POINTS,)
        Hz, 0 to the set's Nyquist rate.
    psd : ndarray, shape (VIBRATION_POINTS,)
        The one-sided PSD ((m/s²)²/Hz) of :meth:`haptex.datadriven.ModelSet.model_at` there.
    rms : float
        The interpolated model's RMS acceleration (m/s²).
    name : str
        The set's name.
    """

    speeds: np.ndarray
    forces: np.ndarray
    edges: list
    speed: float
    force: float
    clamped: bool
    frequency: np.ndarray
    psd: np.ndarray
    rms: float
    name: str


def vibration(models, speed: float, force: float) -> Vibration:
    """The model set's view at (``speed`` m/s, ``force`` N): the library's interpolation
    (:meth:`haptex.datadriven.ModelSet.weights` and ``model_at``) and the model's spectrum
    (:meth:`haptex.datadriven.ArmaModel.psd`).

    Parameters
    ----------
    models : haptex.datadriven.ModelSet
        The set shown.
    speed : float
        The picked tangential speed (m/s).
    force : float
        The picked normal force (N).

    Returns
    -------
    Vibration

    Raises
    ------
    ParameterError
        For a speed or force that is not finite.
    """
    s = float(speed)
    f = float(force)
    if not (math.isfinite(s) and math.isfinite(f)):
        raise fail("speed", f"{speed}, force = {force}", "a finite speed (m/s) and force (N): click on the plane")
    speeds, forces = models.speeds, models.forces
    idx, lam, clamped = models.weights(s, f)
    at_s, at_f = float(np.dot(lam, speeds[idx])), float(np.dot(lam, forces[idx]))
    model = models.model_at(s, f)
    tri = models.triangles
    if tri is not None and len(tri):
        edges = [(speeds[list(t) + [t[0]]], forces[list(t) + [t[0]]]) for t in np.asarray(tri)]
    else:
        edges = [(speeds, forces)]
    freq = np.linspace(0.0, models.sample_rate / 2, VIBRATION_POINTS)
    return Vibration(speeds, forces, edges, at_s, at_f, bool(clamped), freq, model.psd(freq),
                     math.sqrt(model.output_variance()), models.name)


def example_models():
    """The explorer's model set until one is loaded.

    Returns
    -------
    haptex.datadriven.ModelSet
        :func:`haptex.experiments.vibration_models` (four AR(4) models at 1 kHz, chosen).
    """
    from ..experiments import vibration_models

    return vibration_models()
