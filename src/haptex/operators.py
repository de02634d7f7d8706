"""What drives the probe in a simulation: a constant push, an elastic band, a scanning
hand, or a kinematic path.

Every operator except :class:`KinematicPath` is linear between samples: it adds a force
-K p - C v + g(t) at the handle, with g built from a set-point trajectory s(t),
g = K s(t) + C ds/dt + f0. The simulator integrates that exactly.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ._validation import ParameterError, fail, finite, matrix2, nonnegative, positions, positive


def _impedance(name: str, value) -> np.ndarray:
    arr = matrix2(name, value)
    if np.linalg.eigvalsh(0.5 * (arr + arr.T)).min() < 0:
        raise fail(name, arr.tolist(), "positive semi-definite")
    return arr


@dataclass(frozen=True)
class Operator:
    """Linear operator description read by the simulator (see module docstring).

    Attributes
    ----------
    stiffness : ndarray, shape (2, 2)
        K (N/m).
    damping : ndarray, shape (2, 2)
        C (N s/m).
    force : ndarray, shape (2,)
        Constant force f0 (N).
    setpoint_times : ndarray, shape (n,)
        Breakpoint times of the set-point polyline (s), increasing, starting at 0.
    setpoint_points : ndarray, shape (n, 2)
        Set-point positions at those times (m).
    final_velocity : ndarray, shape (2,)
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

    def setpoint(self, t) -> np.ndarray:
        """Set-point position s(t) (m), shape (..., 2), for times t (s)."""
        t = np.asarray(t, dtype=np.float64)
        ts, ps = self.setpoint_times, self.setpoint_points
        x = np.interp(t, ts, ps[:, 0])
        z = np.interp(t, ts, ps[:, 1])
        after = np.maximum(t - ts[-1], 0.0)
        return np.stack([x + after * self.final_velocity[0], z + after * self.final_velocity[1]], axis=-1)


def ConstantForce(force) -> Operator:
    """A constant push f (N), shape (2,): e.g. ``ConstantForce([0, -1.0])`` presses into the wall.

    Raises
    ------
    ParameterError
        If ``force`` is not two finite numbers.
    """
    f = positions(force, "force")
    if f.shape != (2,):
        raise fail("force", force, "two finite numbers [f_x, f_z] in newtons")
    return Operator(force=f.copy())


def ElasticBand(stiffness: float, anchor, rest_length: float = 0.0) -> Operator:
    """An elastic band from an anchor point to the handle: the thrust of Fig. 5.

    Parameters
    ----------
    stiffness : float
        Band stiffness k (N/m), > 0.
    anchor : array_like, shape (2,)
        Anchor point [x, z] (m); an anchor deep below the wall and off to the side pulls
        obliquely.
    rest_length : float, optional
        L0 (m). The band force is -k (|p - a| - L0) (p - a)/|p - a|. With L0 = 0 it is
        linear and integrated exactly; with L0 > 0 the term k L0 (p - a)/|p - a| is held
        over each sample at its value at the sampling instant (a zero-order hold of the
        band's direction, exact to O(T |v| / |p - a|)).

    Raises
    ------
    ParameterError
        For a non-positive stiffness, a negative rest length, or a non-finite anchor.
    """
    k = positive("stiffness", stiffness, "N/m")
    a = positions(anchor, "anchor")
    if a.shape != (2,):
        raise fail("anchor", anchor, "a point [x, z] in metres")
    L0 = nonnegative("rest_length", rest_length, "m")
    return Operator(stiffness=k * np.eye(2), setpoint_times=np.zeros(1), setpoint_points=a[None, :].copy(),
                    rest_length=L0)


def ScanningHand(stiffness, damping, velocity: float | None = None, depth: float = 0.0, start: float = 0.0,
                 path=None, speed: float | None = None) -> Operator:
    """A hand impedance dragged along a set-point trajectory: the strokes of Figs. 6 and 7.

    The hand pulls the handle towards the set-point s(t) with a spring K and a damper C:
    f = K (s - p) + C (ds/dt - v).

    Parameters
    ----------
    stiffness : float or array_like, shape (2, 2)
        Hand stiffness K (N/m).
    damping : float or array_like, shape (2, 2)
        Hand damping C (N s/m).
    velocity : float, optional
        Scan along x at this speed (m/s) from (start, -depth): s(t) = (start + v t, -depth).
    depth : float, optional
        Set-point depth below the nominal surface (m), >= 0: how hard the hand presses,
        "keeping the penetration as constant as possible" (Section V-B).
    start : float, optional
        x of the set-point at t = 0 (m).
    path : array_like, shape (n, 2), optional
        Instead of ``velocity``: a set-point polyline (m), followed at ``speed`` (m/s),
        shifted down by ``depth``; the set-point stays at the last vertex afterwards.
    speed : float, optional
        Speed along ``path`` (m/s).

    Raises
    ------
    ParameterError
        If neither or both of ``velocity`` and ``path`` are given, or a value is invalid.
    """
    K = _impedance("stiffness", stiffness)
    C = _impedance("damping", damping)
    dep = nonnegative("depth", depth, "m")
    if (velocity is None) == (path is None):
        raise ParameterError("velocity and path are not allowed together or both absent: give exactly one")
    if velocity is not None:
        v = finite("velocity", velocity, "m/s")
        x0 = finite("start", start, "m")
        return Operator(stiffness=K, damping=C, setpoint_times=np.zeros(1),
                        setpoint_points=np.array([[x0, -dep]]), final_velocity=np.array([v, 0.0]), depth=dep)
    times, pts = _timed_path(path, speed)
    pts = pts - np.array([0.0, dep])
    return Operator(stiffness=K, damping=C, setpoint_times=times, setpoint_points=pts, depth=dep)


def KinematicPath(path, speed: float) -> Operator:
    """The probe forced along a polyline at constant speed (an infinitely stiff hand).

    Used to measure loop energies in closed loop: the environment's energy is the
    paper's sum -sum f . dp along the sampled path.

    Parameters
    ----------
    path : array_like, shape (n, 2)
        Vertices [x, z] (m), n >= 2.
    speed : float
        m/s, > 0.

    Raises
    ------
    ParameterError
        For a malformed path, a zero-length path or a non-positive speed.
    """
    times, pts = _timed_path(path, speed)
    return Operator(setpoint_times=times, setpoint_points=pts, kinematic=True)


def _timed_path(path, speed):
    pts = positions(path, "path")
    if pts.ndim != 2 or pts.shape[0] < 2:
        raise ParameterError(f"path has shape {pts.shape}, which is not allowed: must be (n, 2) with n >= 2")
    v = positive("speed", speed, "m/s")
    seg = np.hypot(*np.diff(pts, axis=0).T)
    if seg.sum() == 0:
        raise fail("path", pts.tolist(), "a polyline of non-zero length")
    keep = np.r_[True, seg > 0]
    pts = pts[keep]
    times = np.r_[0.0, np.cumsum(seg[seg > 0]) / v]
    return times, pts


def path_duration(op: Operator) -> float:
    """Time (s) the set-point takes to reach the end of its polyline."""
    return float(op.setpoint_times[-1]) if math.isfinite(op.setpoint_times[-1]) else math.inf
