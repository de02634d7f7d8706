"""What drives the probe in a simulation: a constant push, an elastic band, a scanning
hand, or a kinematic path; in the plane ([x, z], over a profile) or in space ([x, y, z],
over a surface: give 3-vectors).

Every operator except :class:`KinematicPath` is linear between samples: it adds a force
-K p - C v + g(t) at the handle, with g built from a set-point trajectory s(t),
g = K s(t) + C ds/dt + f0. The simulator integrates that exactly.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from ._validation import ParameterError, fail, finite, matrix2, nonnegative, positions, positive, whole


def _point(name: str, value, what: str) -> np.ndarray:
    """A 2- or 3-vector of finite numbers."""
    allowed = f"{what}: two ([x, z]) or three ([x, y, z]) finite numbers"
    try:
        arr = np.array(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise fail(name, value, allowed) from None
    if arr.shape not in ((2,), (3,)) or not np.all(np.isfinite(arr)):
        raise fail(name, value, allowed)
    return arr


def _impedance(name: str, value, dim: int = 2) -> np.ndarray:
    arr = matrix2(name, value, f"{dim}x{dim} matrix", dim)
    if np.linalg.eigvalsh(0.5 * (arr + arr.T)).min() < 0:
        raise fail(name, arr.tolist(), "positive semi-definite")
    return arr


@dataclass(frozen=True)
class Operator:
    """Linear operator description read by the simulator (see module docstring).

    Parameters
    ----------
    stiffness : ndarray, shape (d, d)
        K (N/m); d = 2 ([x, z]) or 3 ([x, y, z]), the operator's :attr:`dimension`.
    damping : ndarray, shape (d, d)
        C (N s/m).
    force : ndarray, shape (d,)
        Constant force f0 (N).
    setpoint_times : ndarray, shape (n,)
        Breakpoint times of the set-point polyline (s), increasing, starting at 0.
    setpoint_points : ndarray, shape (n, d)
        Set-point positions at those times (m).
    final_velocity : ndarray, shape (d,)
        Set-point velocity after the last breakpoint (m/s).
    rest_length : float
        Elastic band rest length (m); 0 for the others.
    kinematic : bool
        True for :class:`KinematicPath` (position prescribed, no dynamics).
    depth : float
        The scanning hand's set-point depth (m), already applied to the set-point.
    """

    stiffness: np.ndarray = field(default_factory=lambda: np.zeros((2, 2)))
    damping: np.ndarray = field(default_factory=lambda: np.zeros((2, 2)))
    force: np.ndarray = field(default_factory=lambda: np.zeros(2))
    setpoint_times: np.ndarray = field(default_factory=lambda: np.zeros(1))
    setpoint_points: np.ndarray = field(default_factory=lambda: np.zeros((1, 2)))
    final_velocity: np.ndarray = field(default_factory=lambda: np.zeros(2))
    rest_length: float = 0.0
    kinematic: bool = False
    depth: float = 0.0

    @property
    def dimension(self) -> int:
        """2 ([x, z], over a profile) or 3 ([x, y, z], over a surface)."""
        return int(self.force.shape[0])

    @property
    def constant_push(self) -> bool:
        """True for a pure constant force (no spring, no damper): the simulator's fast path."""
        return not self.kinematic and not np.any(self.stiffness) and not np.any(self.damping)

    def setpoint(self, t) -> np.ndarray:
        """Set-point position s(t) (m), shape (..., d), for times t (s).

        Parameters
        ----------
        t : float or array_like, shape (...)
            Times (s).

        Returns
        -------
        numpy.ndarray, shape (..., d)
            s(t) (m).
        """
        t = np.asarray(t, dtype=np.float64)
        ts, ps = self.setpoint_times, self.setpoint_points
        after = np.maximum(t - ts[-1], 0.0)
        return np.stack([np.interp(t, ts, ps[:, i]) + after * self.final_velocity[i] for i in range(ps.shape[1])],
                        axis=-1)


def _identity(dim: int) -> Operator:
    return Operator(stiffness=np.zeros((dim, dim)), damping=np.zeros((dim, dim)), force=np.zeros(dim),
                    setpoint_points=np.zeros((1, dim)), final_velocity=np.zeros(dim))


def ConstantForce(force) -> Operator:
    """A constant push f (N): e.g. ``ConstantForce([0, -1.0])`` presses into the wall in the
    plane, ``ConstantForce([0, 0, -1.0])`` in space.

    Parameters
    ----------
    force : array_like, shape (2,) or (3,)
        [f_x, f_z] or [f_x, f_y, f_z] (N).

    Returns
    -------
    Operator
        The operator: its force (N), shape (d,), at every time.

    Raises
    ------
    ParameterError
        If ``force`` is not two or three finite numbers.
    """
    f = _point("force", force, "a force in newtons")
    return replace(_identity(f.size), force=f)


def ElasticBand(stiffness: float, anchor, rest_length: float = 0.0) -> Operator:
    """An elastic band from an anchor point to the handle: the thrust of Fig. 5.

    Parameters
    ----------
    stiffness : float
        Band stiffness k (N/m), > 0.
    anchor : array_like, shape (2,) or (3,)
        Anchor point [x, z] or [x, y, z] (m); an anchor deep below the wall and off to the
        side pulls obliquely.
    rest_length : float, optional
        L0 (m). The band force is -k (|p - a| - L0) (p - a)/|p - a|. With L0 = 0 it is
        linear and integrated exactly; with L0 > 0 the term k L0 (p - a)/|p - a| is held
        over each sample at its value at the sampling instant (a zero-order hold of the
        band's direction, exact to O(T |v| / |p - a|)).

    Returns
    -------
    Operator
        The operator: the band's force (N) on the handle.

    Raises
    ------
    ParameterError
        For a non-positive stiffness, a negative rest length, or a non-finite anchor.
    """
    k = positive("stiffness", stiffness, "N/m")
    a = _point("anchor", anchor, "a point in metres")
    L0 = nonnegative("rest_length", rest_length, "m")
    return replace(_identity(a.size), stiffness=k * np.eye(a.size), setpoint_points=a[None, :].copy(),
                   rest_length=L0)


def ScanningHand(stiffness, damping, velocity: float | None = None, depth: float = 0.0, start: float = 0.0,
                 path=None, speed: float | None = None, dimension: int | None = None) -> Operator:
    """A hand impedance dragged along a set-point trajectory: the strokes of Figs. 6 and 7.

    The hand pulls the handle towards the set-point s(t) with a spring K and a damper C:
    f = K (s - p) + C (ds/dt - v).

    Parameters
    ----------
    stiffness : float or array_like, shape (d, d)
        Hand stiffness K (N/m).
    damping : float or array_like, shape (d, d)
        Hand damping C (N s/m).
    velocity : float, optional
        Scan along x at this speed (m/s) from (start, -depth): s(t) = (start + v t, -depth),
        or (start + v t, 0, -depth) in space.
    depth : float, optional
        Set-point depth below the nominal surface (m), >= 0: how hard the hand presses,
        "keeping the penetration as constant as possible" (Section V-B).
    start : float, optional
        x of the set-point at t = 0 (m).
    path : array_like, shape (n, d), optional
        Instead of ``velocity``: a set-point polyline (m), [x, z] or [x, y, z] vertices (a
        path in the plane of the surface, at the heights given), followed at ``speed``
        (m/s), shifted down by ``depth``; the set-point stays at the last vertex afterwards.
    speed : float, optional
        Speed along ``path`` (m/s).
    dimension : int, optional
        2 ([x, z]) or 3 ([x, y, z]); default: that of ``path`` or of the matrices given, 2
        when all are scalars.

    Returns
    -------
    Operator
        The operator: the hand's spring-damper force (N) towards its moving set-point.

    Raises
    ------
    ParameterError
        If neither or both of ``velocity`` and ``path`` are given, or a value is invalid
        (matrices of the wrong size for the dimension included).
    """
    if (velocity is None) == (path is None):
        raise ParameterError("velocity and path are not allowed together or both absent: give exactly one")
    dim = _dimension(dimension, stiffness, damping, path)
    K = _impedance("stiffness", stiffness, dim)
    C = _impedance("damping", damping, dim)
    dep = nonnegative("depth", depth, "m")
    down = np.zeros(dim)
    down[-1] = dep
    if velocity is not None:
        v = finite("velocity", velocity, "m/s")
        x0 = finite("start", start, "m")
        vend = np.zeros(dim)
        vend[0] = v
        s0 = -down
        s0[0] = x0
        return replace(_identity(dim), stiffness=K, damping=C, setpoint_points=s0[None, :], final_velocity=vend,
                       depth=dep)
    times, pts = _timed_path(path, speed, dim)
    return replace(_identity(dim), stiffness=K, damping=C, setpoint_times=times, setpoint_points=pts - down,
                   depth=dep)


def _dimension(dimension, *values) -> int:
    """The operator's dimension: given, else from the first array-valued argument."""
    if dimension is not None:
        return whole("dimension", dimension, 2, 3, "(2: [x, z], 3: [x, y, z])")
    for v in values:
        if v is not None and np.ndim(v) >= 1:
            d = np.shape(v)[-1]
            if d in (2, 3):
                return int(d)
    return 2


def KinematicPath(path, speed: float) -> Operator:
    """The probe forced along a polyline at constant speed (an infinitely stiff hand).

    Used to measure loop energies in closed loop: the environment's energy is the
    paper's sum -sum f . dp along the sampled path.

    Parameters
    ----------
    path : array_like, shape (n, 2) or (n, 3)
        Vertices [x, z] or [x, y, z] (m), n >= 2.
    speed : float
        m/s, > 0.

    Returns
    -------
    Operator
        The operator: it imposes the position (m) on the polyline at each time.

    Raises
    ------
    ParameterError
        For a malformed path, a zero-length path or a non-positive speed.
    """
    dim = _dimension(None, path)
    times, pts = _timed_path(path, speed, dim)
    return replace(_identity(dim), setpoint_times=times, setpoint_points=pts, kinematic=True)


def _timed_path(path, speed, dim: int = 2):
    pts = positions(path, "path", dim=dim)
    if pts.ndim != 2 or pts.shape[0] < 2:
        raise ParameterError(f"path has shape {pts.shape}, which is not allowed: must be (n, {dim}) with n >= 2")
    v = positive("speed", speed, "m/s")
    seg = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    if seg.sum() == 0:
        raise fail("path", pts.tolist(), "a polyline of non-zero length")
    keep = np.r_[True, seg > 0]
    pts = pts[keep]
    times = np.r_[0.0, np.cumsum(seg[seg > 0]) / v]
    return times, pts


def path_duration(op: Operator) -> float:
    """Time (s) the set-point takes to reach the end of its polyline.

    Parameters
    ----------
    op : Operator
        A path operator (:func:`KinematicPath`): its polyline and speed.

    Returns
    -------
    float
        The time (s).
    """
    return float(op.setpoint_times[-1]) if math.isfinite(op.setpoint_times[-1]) else math.inf
