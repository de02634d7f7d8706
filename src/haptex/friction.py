"""Presliding friction with memory: the time-free model of Hayward & Armstrong (2000),
used by algorithm F and by the simulator.

The model keeps an adhesion point w. The presliding deflection is d = x - w.

* **stick** while |d| < d_max: w stays, dd/dx = 1 (an elastic, recoverable deflection);
* **slip** when |d| would exceed d_max: w is dragged so that |d| = d_max, dd/dx = 0.

This is the paper's eq. 24 and reference [32]. The friction force opposes the
deflection; its magnitude at |d| = d_max is the Coulomb (Amontons) force.

Optional smooth stick-to-slip transition (off by default): with a stick zone
z_stick < d_max, the deflection obeys dd/dx = 1 - alpha(d) |d| / d_max while |d| grows,
and dd/dx = 1 while |d| shrinks, with the blend

    alpha(d) = 0                                                    |d| <= z_stick
    alpha(d) = 1/2 + 1/2 sin(pi (|d| - (d_max + z_stick)/2) / (d_max - z_stick))
    alpha(d) = 1                                                    |d| >= d_max

This is the breakaway function of the single-state elasto-plastic model of Dupont,
Hayward, Armstrong & Altpeter (2002) [2]_, written time-free as in Hayward & Armstrong (2000) [32]_.
Its increments are the exact flow of that equation with bounded work for any step: the
elastic part in closed form, the travel X(e) = int de / rate along the ramp tabulated
once per z_stick / d_max (:func:`smooth_table`, relative error < 1e-10) and inverted, and
the flow below the table's last node in closed form. The model is rate independent.

References
----------
.. [32] V. Hayward and B. Armstrong, "A new computational model of friction applied to
   haptic rendering", Experimental Robotics VI, LNCIS 250, Springer, 2000, pp. 403–412.
.. [2] P. Dupont, V. Hayward, B. Armstrong and F. Altpeter, "Single state elastoplastic
   friction models", IEEE Trans. Automatic Control 47(5), 2002, pp. 787–792.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from functools import lru_cache

import numpy as np

from .core import _ext
from ._validation import fail, finite, numbers, positive

__all__ = ["PreslidingState", "step", "phase_of", "presliding_step", "presliding_step_smooth", "smooth_table"]

TABLE_NODES = 2048
"""Nodes of the smooth model's travel table, log-spaced in e = 1 - |d|/d_max over 16 decades."""


_NO_TABLE = np.zeros(1)


def presliding_step(adhesion: float, x: float, d_max: float) -> tuple[float, float]:
    """One update of the sharp presliding model (eq. 24), by the C core.

    Parameters
    ----------
    adhesion : float
        Adhesion point w before the step (m).
    x : float
        New position (m).
    d_max : float
        Maximum presliding deflection (m), > 0.

    Returns
    -------
    (deflection, adhesion) : (float, float)
        The deflection d = x - w after the step (m), |d| <= d_max, and the new adhesion point.
    """
    d, _, _ = _ext.presliding_plane(float(x) - float(adhesion), 0.0, 0.0, 0.0, float(d_max), -1.0, _NO_TABLE)
    return d, float(x) - d


def presliding_step_smooth(deflection: float, dx: float, d_max: float, z_stick: float, tab: np.ndarray) -> float:
    """One update of the smooth presliding model, the exact flow of dd/dx over an increment
    dx (m), by the C core (the plane model along a line).

    Parameters
    ----------
    deflection : float
        Deflection before the step (m).
    dx : float
        Displacement of the probe during the step (m).
    d_max, z_stick : float
        Model parameters (m), 0 <= z_stick < d_max.
    tab : ndarray
        The model's travel table (:func:`smooth_table`).

    Returns
    -------
    float
        Deflection after the step (m), |d| <= d_max.

    Notes
    -----
    Bounded work for any dx: the elastic part is exact; along the ramp the travel
    X(e) = int de / rate is tabulated once (cubic Hermite, relative error < 1e-10) and
    inverted by bisection-safeguarded Newton (at most 60 iterations); below the table's
    last node (e < 1e-16 r) the flow of rate = e + (pi e / 2r)^2 is used in closed form.
    """
    d, _, _ = _ext.presliding_plane(float(deflection), 0.0, float(dx), 0.0, float(d_max), float(z_stick), tab)
    return d


def smooth_table(max_deflection: float, stick_deflection: float) -> np.ndarray:
    """Travel table of the smooth presliding model, read by the compiled step.

    Parameters
    ----------
    max_deflection, stick_deflection : float
        d_max > 0 and z_stick in [0, d_max) (m).

    Returns
    -------
    ndarray, shape (8 + 2 * TABLE_NODES,)
        Header (node count, ln r, node spacing in ln e, the tail's coefficient pi^2/(4 r^2))
        then X_j and dX/dj at e_j = r exp(-j dv), r = 1 - z_stick/d_max, where
        X(e) = int_e^r de' / rate(e') is the travel (in units of d_max) from the start of
        the ramp, rate(e) = 1 - cos^2(pi e / 2r)(1 - e) (Dupont et al. 2002's breakaway
        function written in e).

    Raises
    ------
    ParameterError
        If d_max <= 0 or z_stick is outside [0, d_max).
    """
    dmax = positive("presliding", max_deflection, "m")
    z = finite("stick_deflection", stick_deflection, "m")
    if not 0.0 <= z < dmax:
        raise fail("stick_deflection", stick_deflection, f"a length in [0, presliding = {dmax:g}) m")
    return _table(z / dmax)


@lru_cache(maxsize=64)
def _table(ratio: float) -> np.ndarray:
    r = 1.0 - ratio
    n = TABLE_NODES
    dv = math.log(1e16) / (n - 1)
    j = np.arange(n)

    def speed(jj):  # dX/dj = dv * e / rate(e) at e = r exp(-jj dv); rate = 1 - cos^2 (1 - e) without cancellation
        e = r * np.exp(-jj * dv)
        arg = 0.5 * np.pi * e / r
        return dv * e / (np.sin(arg) ** 2 + e * np.cos(arg) ** 2)

    gx, gw = np.polynomial.legendre.leggauss(10)
    nodes = j[:-1, None] + 0.5 * (gx[None, :] + 1.0)
    pieces = 0.5 * (speed(nodes) @ gw)
    tab = np.zeros(_ext.T_DATA + 2 * n)
    tab[_ext.T_N] = n
    tab[_ext.T_LOGR] = math.log(r)
    tab[_ext.T_DV] = dv
    tab[_ext.T_BETA] = math.pi**2 / (4.0 * r * r)
    tab[_ext.T_DATA:_ext.T_DATA + n] = np.r_[0.0, np.cumsum(pieces)]
    tab[_ext.T_DATA + n:] = speed(j.astype(float))
    tab.setflags(write=False)
    return tab


@dataclass(frozen=True)
class PreslidingState:
    """State of the presliding friction model (Hayward & Armstrong [32]).

    Parameters
    ----------
    adhesion : float
        Adhesion point w (m).
    max_deflection : float
        d_max > 0 (m), the presliding range (the paper's d^x_max).
    stick_deflection : float or None
        z_stick (m), 0 <= z_stick < d_max, for the smooth stick-to-slip variant; ``None``
        (default) for the sharp model of eq. 24.
    position : float
        Position x (m) at which the state was last updated.

    Raises
    ------
    ParameterError
        If d_max <= 0, z_stick outside [0, d_max), or a value is not finite.
    """

    adhesion: float
    max_deflection: float = 1e-3
    stick_deflection: float | None = None
    position: float | None = None

    def __post_init__(self):
        object.__setattr__(self, "adhesion", finite("adhesion", self.adhesion, "m"))
        object.__setattr__(self, "max_deflection", positive("presliding", self.max_deflection, "m"))
        if self.stick_deflection is not None:
            z = finite("stick_deflection", self.stick_deflection, "m")
            if not 0.0 <= z < self.max_deflection:
                raise fail("stick_deflection", self.stick_deflection,
                           f"a length in [0, max_deflection = {self.max_deflection:g}) m, or None")
            object.__setattr__(self, "stick_deflection", z)
        pos = self.adhesion if self.position is None else finite("position", self.position, "m")
        object.__setattr__(self, "position", pos)

    @classmethod
    def at(cls, x: float, max_deflection: float = 1e-3, stick_deflection: float | None = None) -> PreslidingState:
        """A fresh contact at position x (m): adhesion at x, zero deflection.

        Parameters
        ----------
        x : float
            The contact's position (m): the adhesion point.
        max_deflection : float, optional
            d^x_max (m), the presliding range (eq. 24).
        stick_deflection : float, optional
            z_stick (m), 0 <= z_stick < d_max, for the smooth stick-to-slip variant; None
            (default) for the sharp model of eq. 24.
        """
        return cls(adhesion=x, max_deflection=max_deflection, stick_deflection=stick_deflection, position=x)

    @property
    def deflection(self) -> float:
        """Current deflection d = x - w (m)."""
        return self.position - self.adhesion


def step(state: PreslidingState, x: float) -> tuple[float, PreslidingState]:
    """Pure update of the presliding model to a new position.

    Parameters
    ----------
    state : PreslidingState
        State before the move.
    x : float
        New probe position along the surface (m).

    Returns
    -------
    deflection : float
        Presliding deflection d = x - w after the move (m), |d| <= d_max.
    new_state : PreslidingState
        The updated state (the input is not modified).

    Raises
    ------
    ParameterError
        If ``x`` is not finite.

    Notes
    -----
    Sharp model (eq. 24): w stays while |x - w| <= d_max, else w = x -+ d_max. The update
    depends only on the positions visited, not on time: the model is rate independent.
    """
    x = finite("x", x, "m")
    dmax = state.max_deflection
    if state.stick_deflection is None:  # (the C core's sharp step, as the renderer's)
        d, w = presliding_step(state.adhesion, x, dmax)
    else:
        z = state.stick_deflection
        d = presliding_step_smooth(state.deflection, x - state.position, dmax, z, smooth_table(dmax, z))
        w = x - d
    return d, replace(state, adhesion=w, position=x)


def phase_of(deflection: float, max_deflection: float, rtol: float = 1e-12) -> str:
    """``"slip"`` when |d| = d_max (to ``rtol``), else ``"stick"`` (eq. 24).

    Parameters
    ----------
    deflection : float
        The presliding deflection d (m).
    max_deflection : float
        d^x_max (m).
    rtol : float, optional
        Relative tolerance of |d| = d_max.

    Returns
    -------
    str
        ``"slip"`` or ``"stick"``.
    """
    return "slip" if abs(deflection) >= max_deflection * (1 - rtol) else "stick"


def step_plane(deflection, displacement, max_deflection: float, stick_deflection: float | None = None,
               table: np.ndarray | None = None) -> np.ndarray:
    """One step of isotropic presliding in a plane (algorithm F over a surface).

    Parameters
    ----------
    deflection : array_like, shape (2,)
        Deflection d = p_t - w before the step (m), |d| <= d_max.
    displacement : array_like, shape (2,)
        The probe's in-plane displacement over the step (m).
    max_deflection : float
        d_max (m).
    stick_deflection : float, optional
        z_stick (m) of the smooth model; None: the sharp model.
    table : ndarray, optional
        The smooth model's travel table (:func:`smooth_table`), required with it.

    Returns
    -------
    ndarray, shape (2,)
        The deflection after the step (m), |d| <= d_max.

    Raises
    ------
    ParameterError
        If the deflection or the displacement is not two finite real numbers (a bool, text or
        a complex number is not one).

    Notes
    -----
    Sharp model: the adhesion point is dragged to within d_max (d + dp projected onto the
    disk |d| <= d_max): the play operator in the plane. Smooth model: along the deflection's
    direction u (the displacement's if d = 0) |d| follows the 1-D flow of this module exactly
    for the displacement's component u . dp, and the component across u is elastic
    (d += dp - (u . dp) u), the result kept in the disk. A straight stroke from d = 0 keeps d
    along the stroke, so the plane model is the 1-D model there, exactly. The step is first
    order in |dp| on curved paths: integrate along them in small steps.
    """
    allowed = "a finite in-plane vector [x, y] (m), shape (2,)"
    vectors = []
    for name, given in (("deflection", deflection), ("displacement", displacement)):
        v = numbers(name, given, allowed, copy=False)
        if v.shape != (2,) or not np.all(np.isfinite(v)):
            raise fail(name, v.tolist() if v.size <= 3 else f"shape {v.shape}", allowed)
        vectors.append(v)
    return _step_plane(*vectors, max_deflection, stick_deflection, table)


def _step_plane(d, dp, max_deflection, stick_deflection, table) -> np.ndarray:
    """:func:`step_plane` on vectors known to be two finite floats each (a path's own steps:
    F's work along it calls it a sub-step at a time, where the check would cost five times
    the step)."""
    z = -1.0 if stick_deflection is None else float(stick_deflection)
    tab = np.zeros(1) if table is None else table
    dx, dy, _ = _ext.presliding_plane(float(d[0]), float(d[1]), float(dp[0]), float(dp[1]),
                                      float(max_deflection), z, tab)
    return np.array([dx, dy])
