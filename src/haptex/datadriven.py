"""Data-driven textures: ARMA models of a tool's vibration, indexed by speed and force.

The field's second language of haptic textures (Romano & Kuchenbecker, "Creating realistic
virtual textures from contact acceleration data", IEEE Trans. Haptics 5(2), 109–119, 2012;
Culbertson, Lopez Delgado & Kuchenbecker, "One hundred data-driven haptic texture models and
open-source methods for rendering on 3D objects", IEEE Haptics Symposium 2014, the Penn
Haptic Texture Toolkit, HaTT): a tool dragged over a real surface records its high-frequency
acceleration with its normal force and tangential speed; the signal at each steady operating
point is fitted by an ARMA model; the models sit at the vertices of a triangulation over
(speed, force), and the renderer interpolates their line spectral frequencies (LSF), variance
and gain at the current speed and force and filters white noise through the result:

    y_n = -sum_{i=1..p} a_i y_{n-i} + gain * (e_n + sum_{i=1..q} b_i e_{n-i}),  e_n ~ N(0, variance).

The synthesis runs in the C core (``hx_vibration.c``: one tick a sample, the triangle found
from the last one, a counter-based noise generator, so that a run is reproducible); this
module reads and writes model sets, fits them from recordings, and holds the NumPy oracle of
the interpolation (:meth:`ModelSet.model_at`) and the models' spectra (:meth:`ArmaModel.psd`).

Units are SI: speed in m/s, force in N, acceleration in m/s², variance in (m/s²)², frequency
in Hz. HaTT's files give speeds in mm/s; :func:`read_hatt` converts them.
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
from pathlib import Path

import numpy as np

from ._validation import ParameterError, _fmt, fail, positive

FORMAT = "haptex-arma-models"
"""The ``format`` field of haptex's own model files (:meth:`ModelSet.write`)."""

FORMAT_VERSION = 1
"""The version of haptex's model files this release reads and writes."""

MAX_ORDER = 64
"""Largest AR or MA order the C core's tick takes (``HX_VIB_MAX_ORDER``)."""

MAX_MODELS = 512
"""Most models a set may hold (``HX_VIB_MAX_MODELS``): the tick's search tests each triangle
at most once, and a set has at most twice as many triangles as models."""

MAX_SAMPLES = 50_000_000
"""Most samples one :meth:`ModelSet.synthesize` call produces (400 MB of float64)."""

G = 9.80665
"""Standard gravity (m/s²), for accelerations given in g."""

_ACC_UNITS = {"m/s^2": 1.0, "m/s2": 1.0, "m/s²": 1.0, "g": G}


# ---------------------------------------------------------------------------------------
# line spectral frequencies
# ---------------------------------------------------------------------------------------


def poly_to_lsf(a) -> np.ndarray:
    """Line spectral frequencies of a minimum-phase polynomial.

    Parameters
    ----------
    a : array_like, shape (p + 1,)
        Polynomial ``[1, a_1, ..., a_p]`` in z⁻¹ (the AR or MA part of a model), its roots
        strictly inside the unit circle.

    Returns
    -------
    numpy.ndarray, shape (p,)
        The angles (rad) of the roots of P(z) = A(z) + z^-(p+1) A(1/z) and
        Q(z) = A(z) - z^-(p+1) A(1/z) on the unit circle, ascending in (0, π), their
        trivial roots at z = ±1 left out (Itakura 1975; Soong & Juang, ICASSP 1984).

    Raises
    ------
    ParameterError
        If ``a`` does not start with 1, is not finite, or is not minimum phase (its LSF
        would not interlace, and an interpolation of them would not be stable).

    Notes
    -----
    Our own routine (the roots of P and Q by :func:`numpy.roots`): the one Python package
    with one, ``spectrum``, builds a C extension from source for it. Its inverse,
    :func:`lsf_to_poly`, is the C core's.
    """
    a = np.asarray(a, dtype=float)
    if a.ndim != 1 or a.size < 1 or not np.all(np.isfinite(a)) or a[0] != 1.0:
        raise fail("a", a, "a finite polynomial [1, a_1, ..., a_p] (the leading coefficient 1)")
    p = a.size - 1
    if p == 0:
        return np.empty(0)
    if np.max(np.abs(np.roots(a))) >= 1.0:
        raise fail("a", a, "minimum phase (every root inside the unit circle): a stable AR part or an invertible MA part")
    ext = np.concatenate([a, [0.0]])
    w = []
    for poly in (ext + ext[::-1], ext - ext[::-1]):
        ang = np.angle(np.roots(poly))
        w.append(ang[(ang > 1e-12) & (ang < np.pi - 1e-12)])
    w = np.sort(np.concatenate(w))
    if w.size != p or np.any(np.diff(w) <= 0):
        raise fail("a", a, "a polynomial whose line spectral frequencies are distinct (roots well inside the unit circle)")
    return w


def lsf_to_poly(w) -> np.ndarray:
    """Polynomial of ascending line spectral frequencies (the C core's ``hx_lsf_to_poly``).

    Parameters
    ----------
    w : array_like, shape (p,)
        Line spectral frequencies (rad), strictly ascending in (0, π), p <= :data:`MAX_ORDER`.

    Returns
    -------
    numpy.ndarray, shape (p + 1,)
        ``[1, a_1, ..., a_p]``: minimum phase whenever ``w`` ascends (Soong & Juang 1984).

    Raises
    ------
    ParameterError
        If ``w`` does not ascend strictly within (0, π) or is longer than :data:`MAX_ORDER`.
    """
    from .core import _ext

    w = np.ascontiguousarray(w, dtype=float)
    if w.ndim != 1 or w.size > MAX_ORDER or not np.all((w > 0) & (w < np.pi)) or np.any(np.diff(w) <= 0):
        raise fail("w", w, f"at most {MAX_ORDER} frequencies ascending strictly in (0, pi) rad")
    a = np.empty(w.size + 1)
    _ext.lsf_to_poly(w, a)
    return a


# ---------------------------------------------------------------------------------------
# one model
# ---------------------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True, eq=False)
class ArmaModel:
    """One ARMA model of a tool's vibration at one operating point.

    Parameters
    ----------
    ar : array_like, shape (p + 1,)
        AR polynomial ``[1, a_1, ..., a_p]`` (leading 1), stable.
    ma : array_like, shape (q + 1,)
        MA polynomial ``[1, b_1, ..., b_q]`` (leading 1), invertible; ``[1]`` for an AR model.
    variance : float
        Variance of the driving white noise e ((m/s²)²), >= 0.
    gain : float
        Gain applied to the MA part's output (HaTT's ``gain``; 1 for haptex's fits).
    sample_rate : float
        Rate (Hz) at which the model runs.
    speed : float, optional
        Tangential speed (m/s) of its operating point (NaN when not known).
    force : float, optional
        Normal force (N) of its operating point (NaN when not known).

    Raises
    ------
    ParameterError
        If a polynomial does not start with 1 or is not minimum phase, an order exceeds
        :data:`MAX_ORDER`, or the variance, gain or rate are not finite (rate > 0, variance >= 0).
    """

    ar: np.ndarray
    ma: np.ndarray
    variance: float
    gain: float
    sample_rate: float
    speed: float = math.nan
    force: float = math.nan

    def __post_init__(self):
        for name in ("ar", "ma"):
            v = np.array(getattr(self, name), dtype=float)
            if v.ndim != 1 or v.size < 1 or v.size - 1 > MAX_ORDER:
                raise fail(name, getattr(self, name), f"a polynomial [1, c_1, ..., c_n] with n <= {MAX_ORDER}")
            v.setflags(write=False)
            object.__setattr__(self, name, v)
        object.__setattr__(self, "_lsf", (_lsf_of("ar", self.ar), _lsf_of("ma", self.ma)))
        var = float(self.variance)
        if not (math.isfinite(var) and var >= 0):
            raise fail("variance", self.variance, "a finite number >= 0 ((m/s^2)^2)")
        if not math.isfinite(float(self.gain)):
            raise fail("gain", self.gain, "a finite number")
        object.__setattr__(self, "variance", var)
        object.__setattr__(self, "gain", float(self.gain))
        object.__setattr__(self, "sample_rate", positive("sample_rate", self.sample_rate, "Hz"))
        object.__setattr__(self, "speed", float(self.speed))
        object.__setattr__(self, "force", float(self.force))

    @property
    def order(self) -> tuple[int, int]:
        """(p, q): the AR and MA orders."""
        return self.ar.size - 1, self.ma.size - 1

    @property
    def ar_lsf(self) -> np.ndarray:
        """The AR part's line spectral frequencies (rad), shape (p,)."""
        return self._lsf[0]

    @property
    def ma_lsf(self) -> np.ndarray:
        """The MA part's line spectral frequencies (rad), shape (q,)."""
        return self._lsf[1]

    def psd(self, frequency) -> np.ndarray:
        """One-sided power spectral density of the model's output.

        Parameters
        ----------
        frequency : array_like, shape (n,)
            Frequencies (Hz) in [0, sample_rate / 2].

        Returns
        -------
        numpy.ndarray, shape (n,)
            ``2 variance gain² |B(e^{jω})|² / |A(e^{jω})|² / sample_rate`` ((m/s²)²/Hz) with
            ω = 2π f / sample_rate: the density :func:`scipy.signal.welch` estimates from a
            long synthesis (one-sided, so its integral over [0, fs/2] is the output's variance).

        Raises
        ------
        ParameterError
            If a frequency is negative, above the Nyquist frequency or not finite.
        """
        from scipy.signal import freqz

        f = np.asarray(frequency, dtype=float)
        if not np.all(np.isfinite(f)) or np.any(f < 0) or np.any(f > self.sample_rate / 2 * (1 + 1e-12)):
            raise fail("frequency", frequency, f"frequencies in [0, {self.sample_rate / 2:g}] Hz (the Nyquist frequency)")
        _, h = freqz(self.ma, self.ar, worN=np.atleast_1d(f).ravel(), fs=self.sample_rate)
        out = 2.0 * self.variance * self.gain**2 * np.abs(h) ** 2 / self.sample_rate
        return out.reshape(f.shape)

    def output_variance(self) -> float:
        """Variance of the model's stationary output ((m/s²)²): the integral of :meth:`psd`."""
        from scipy.signal import dimpulse

        # the impulse response's energy: sum h_k^2, h of gain B / A, to 1e-12 of its sum
        n = 4096
        while True:
            _, (h,) = dimpulse((self.ma * self.gain, self.ar, 1.0), n=n)
            h = h.ravel()
            if abs(h[-1]) < 1e-9 * max(np.max(np.abs(h)), 1e-300) or n >= 2**20:
                return float(self.variance * np.sum(h * h))
            n *= 4


def _lsf_of(name: str, poly: np.ndarray) -> np.ndarray:
    try:
        w = poly_to_lsf(poly)
    except ParameterError as exc:
        raise ParameterError(str(exc).replace("a = ", f"{name} = ", 1)) from None
    w.setflags(write=False)
    return w


# ---------------------------------------------------------------------------------------
# a set of models
# ---------------------------------------------------------------------------------------


class ModelSet:
    """ARMA models at operating points (speed, force), triangulated and interpolated.

    Parameters
    ----------
    models : sequence of ArmaModel
        One model a vertex, each with a finite ``speed`` (m/s, >= 0) and ``force`` (N, >= 0);
        all of the same orders (p, q) and sample rate; at most :data:`MAX_MODELS`.
    triangles : array_like of int, shape (m, 3), optional
        The triangulation's vertex indices (0-based). Default: the Delaunay triangulation
        (:class:`scipy.spatial.Delaunay`) of the operating points scaled by their largest
        speed and force.
    mu : float, optional
        The surface's Coulomb friction coefficient, when its recording gives one (HaTT's ``mu``).
    name : str, optional
        What the set is of (a material's name).

    Raises
    ------
    ParameterError
        If the models disagree in order or rate, an operating point is missing, negative or
        repeated, or a triangle's index is out of range.

    Notes
    -----
    Between the vertices the models are interpolated by the barycentric weights of the
    operating point in its triangle: their LSF, variance and gain (Culbertson et al. 2014).
    Models whose operating points lie on one line (a recording at one force, or at one
    speed) are ordered along it and interpolated along that polyline; a point off the line
    is moved to it (counted as clamped).
    An interpolation of ascending LSF ascends, so every interpolated model is stable. Outside
    the hull the operating point is moved to the hull's closest point (counted).
    """

    def __init__(self, models, triangles=None, *, mu: float | None = None, name: str = ""):
        models = tuple(models)
        if not models or not all(isinstance(m, ArmaModel) for m in models):
            raise fail("models", models, "a non-empty sequence of ArmaModel")
        if len(models) > MAX_MODELS:
            raise fail("models", f"{len(models)} models", f"at most {MAX_MODELS} models")
        orders = {m.order for m in models}
        rates = {m.sample_rate for m in models}
        if len(orders) != 1:
            raise fail("models", f"orders {sorted(orders)}", "models of one order (p, q): their LSF are interpolated")
        if len(rates) != 1:
            raise fail("models", f"rates {sorted(rates)} Hz", "models at one sample rate")
        sp = np.array([m.speed for m in models])
        fo = np.array([m.force for m in models])
        for name_, v, unit in (("speed", sp, "m/s"), ("force", fo, "N")):
            bad = ~(np.isfinite(v) & (v >= 0))
            if bad.any():
                k = int(np.argmax(bad))
                raise fail(f"models[{k}].{name_}", float(v[k]), f"a finite number >= 0 ({unit}): the model's operating point")
        self.models = models
        self.speeds, self.forces = sp, fo
        self.sample_rate = models[0].sample_rate
        self.mu = None if mu is None else float(mu)
        self.name = str(name)
        self.speed_scale = float(sp.max()) if sp.max() > 0 else 1.0
        self.force_scale = float(fo.max()) if fo.max() > 0 else 1.0
        pts = np.column_stack([sp / self.speed_scale, fo / self.force_scale])
        if len(models) > 1 and len(np.unique(np.round(pts, 12), axis=0)) != len(models):
            raise fail("models", "repeated operating points", "one model per (speed, force)")
        if len(models) >= 2 and triangles is None and _collinear(pts):
            # one line (one force, or one speed): the models in order along it, a polyline
            d = pts[-1] - pts[0] if len(pts) == 2 else np.linalg.svd(pts - pts.mean(axis=0))[2][0]
            d = d * np.sign(d[int(np.argmax(np.abs(d)))])  # ascending in the coordinate that varies most
            order = np.argsort(pts @ d, kind="stable")
            models = tuple(models[i] for i in order)
            sp, fo, pts = sp[order], fo[order], pts[order]
            self.models, self.speeds, self.forces = models, sp, fo
            self.triangles = np.zeros((0, 3), dtype=np.int64)
        else:
            self.triangles = self._triangulate(pts, triangles)
        self.last_counts = {"clamped": 0, "faults": 0, "max_work": 0}
        self.report: FitReport | None = None  # set by fit()
        self.ignored: tuple[str, ...] = ()  # set by read_hatt: the file's tags read past on purpose
        self._packed = self._pack()

    def _triangulate(self, pts, triangles):
        n = len(pts)
        if triangles is None:
            if n < 3:
                return np.zeros((0, 3), dtype=np.int64)
            from scipy.spatial import Delaunay

            return np.asarray(Delaunay(pts).simplices, dtype=np.int64)
        t = np.asarray(triangles)
        if t.ndim != 2 or t.shape[1] != 3 or t.dtype.kind not in "iu" or (n >= 3 and len(t) == 0):
            raise fail("triangles", triangles, "an (m, 3) array of integer vertex indices")
        if len(t) > 2 * MAX_MODELS:
            raise fail("triangles", f"{len(t)} triangles", f"at most {2 * MAX_MODELS}")
        bad = (t < 0) | (t >= n)
        if bad.any():
            k = int(np.argmax(bad.any(axis=1)))
            raise fail(f"triangles[{k}]", t[k].tolist(), f"indices in [0, {n - 1}] (0-based; the set has {n} models)")
        return t.astype(np.int64)

    def _pack(self) -> np.ndarray:
        p, q = self.models[0].order
        head = np.zeros(8)
        head[:7] = [len(self.models), len(self.triangles), p, q, self.sample_rate, self.speed_scale, self.force_scale]
        rows = [np.concatenate([[m.speed, m.force, m.variance, m.gain], m.ar_lsf, m.ma_lsf]) for m in self.models]
        return np.ascontiguousarray(np.concatenate([head, *rows, self.triangles.ravel().astype(float)]))

    # ---- the NumPy oracle of the C core's interpolation -------------------------------

    def weights(self, speed: float, force: float) -> tuple[np.ndarray, np.ndarray, bool]:
        """The models that carry weight at an operating point, and their weights.

        Parameters
        ----------
        speed : float
            Tangential speed (m/s).
        force : float
            Normal force (N).

        Returns
        -------
        index : numpy.ndarray of int, shape (k,)
            The models (k = 1, 2 or 3).
        weight : numpy.ndarray, shape (k,)
            Their barycentric weights (sum 1, each >= 0).
        clamped : bool
            Whether the point lay outside the triangulation's hull and was moved to its
            closest point.

        Raises
        ------
        ParameterError
            If speed or force is not finite.
        """
        s, f = _finite("speed", speed, "m/s"), _finite("force", force, "N")
        n = len(self.models)
        if n == 1:
            return np.array([0]), np.array([1.0]), False
        x, y = self.speeds / self.speed_scale, self.forces / self.force_scale
        u, w = s / self.speed_scale, f / self.force_scale
        if len(self.triangles):
            t = self.triangles
            x0, y0, x1, y1, x2, y2 = x[t[:, 0]], y[t[:, 0]], x[t[:, 1]], y[t[:, 1]], x[t[:, 2]], y[t[:, 2]]
            d = (y1 - y2) * (x0 - x2) + (x2 - x1) * (y0 - y2)
            with np.errstate(divide="ignore", invalid="ignore"):
                l0 = ((y1 - y2) * (u - x2) + (x2 - x1) * (w - y2)) / d
                l1 = ((y2 - y0) * (u - x2) + (x0 - x2) * (w - y2)) / d
            l2 = 1.0 - l0 - l1
            inside = (d != 0) & (l0 >= -1e-12) & (l1 >= -1e-12) & (l2 >= -1e-12)
            if inside.any():
                k = int(np.argmax(inside))
                lam = np.clip([l0[k], l1[k], l2[k]], 0.0, None)
                return t[k].copy(), lam, False
            edges = np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]])
        else:  # on one line: the polyline through the models in order
            edges = np.column_stack([np.arange(n - 1), np.arange(1, n)])
        a, b = edges[:, 0], edges[:, 1]
        dx, dy = x[b] - x[a], y[b] - y[a]
        L = dx * dx + dy * dy
        with np.errstate(divide="ignore", invalid="ignore"):
            sp = np.where(L > 0, ((u - x[a]) * dx + (w - y[a]) * dy) / L, 0.0)
        sp = np.clip(sp, 0.0, 1.0)
        d2 = (x[a] + sp * dx - u) ** 2 + (y[a] + sp * dy - w) ** 2
        k = int(np.argmin(d2))
        return edges[k].copy(), np.array([1.0 - sp[k], sp[k]]), bool(len(self.triangles) or d2[k] > 1e-24)

    def model_at(self, speed: float, force: float) -> ArmaModel:
        """The model interpolated at an operating point (Culbertson et al. 2014).

        Parameters
        ----------
        speed : float
            Tangential speed (m/s).
        force : float
            Normal force (N).

        Returns
        -------
        ArmaModel
            LSF, variance and gain weighted barycentrically (:meth:`weights`), the LSF turned
            into polynomials by :func:`lsf_to_poly`; its ``speed`` and ``force`` are the point
            asked for.

        Raises
        ------
        ParameterError
            If speed or force is not finite.
        """
        idx, lam, _ = self.weights(speed, force)
        ms = [self.models[i] for i in idx]
        ar_w = sum(l * m.ar_lsf for l, m in zip(lam, ms))
        ma_w = sum(l * m.ma_lsf for l, m in zip(lam, ms))
        return ArmaModel(lsf_to_poly(ar_w), lsf_to_poly(ma_w), sum(l * m.variance for l, m in zip(lam, ms)),
                         sum(l * m.gain for l, m in zip(lam, ms)), self.sample_rate, float(speed), float(force))

    # ---- synthesis (the C core) -------------------------------------------------------

    def synthesize(self, speed, force, duration: float | None = None, *, seed: int = 0) -> np.ndarray:
        """Synthesise the vibration along a course of operating points (the C core's tick).

        Parameters
        ----------
        speed : float or array_like, shape (n,)
            Tangential speed (m/s): one value, or one a sample.
        force : float or array_like, shape (n,)
            Normal force (N): one value, or one a sample.
        duration : float, optional
            Length (s) of the signal when speed and force are both scalars; otherwise their
            length sets it and ``duration``, if given, must agree with it.
        seed : int, optional
            Seed of the noise (0 to 2⁶⁴ - 1): the same seed gives the same signal, on any
            machine (splitmix64 and Box-Muller, ``hx_vibration.c``).

        Returns
        -------
        numpy.ndarray, shape (n,)
            Acceleration (m/s²) at :attr:`sample_rate`. :attr:`last_counts` gives the samples
            whose operating point was moved to the hull (``clamped``), those with a non-finite
            one (``faults``, 0 m/s² for them) and the largest work of a sample.

        Raises
        ------
        ParameterError
            If the lengths disagree, no length is given, the signal would exceed
            :data:`MAX_SAMPLES` samples, or the seed is not an integer in range.
        """
        from .core import _ext

        sp = np.atleast_1d(np.asarray(speed, dtype=float))
        fo = np.atleast_1d(np.asarray(force, dtype=float))
        if sp.ndim != 1 or fo.ndim != 1:
            raise fail("speed", speed, "a number or a one-dimensional array (m/s)")
        if sp.size == 1 and fo.size == 1:
            if duration is None:
                raise fail("duration", duration, "a duration (s) when speed and force are single values")
            t = positive("duration", duration, "s")
            if t * self.sample_rate > MAX_SAMPLES:
                raise fail("duration", duration, f"at most {MAX_SAMPLES / self.sample_rate:g} s "
                           f"({MAX_SAMPLES} samples at {self.sample_rate:g} Hz)")
            n = max(1, int(round(t * self.sample_rate)))
        else:
            n = max(sp.size, fo.size)
            if sp.size not in (1, n) or fo.size not in (1, n):
                raise fail("force", f"{fo.size} values", f"one value or {sp.size} (one a sample, as speed)")
            if n > MAX_SAMPLES:
                raise fail("speed", f"{n} samples", f"at most {MAX_SAMPLES} samples")
            if duration is not None and abs(float(duration) * self.sample_rate - n) > 1:
                raise fail("duration", duration, f"{n / self.sample_rate:g} s (the length of speed and force) or None")
        if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or not 0 <= int(seed) < 2**64:
            raise fail("seed", seed, "an integer in [0, 2**64)")
        sp = np.ascontiguousarray(np.broadcast_to(sp, (n,)), dtype=float)
        fo = np.ascontiguousarray(np.broadcast_to(fo, (n,)), dtype=float)
        out = np.empty(n)
        clamped, faults, work = _ext.vibration(self._packed, sp, fo, out, int(seed))
        self.last_counts = {"clamped": int(clamped), "faults": int(faults), "max_work": int(work)}
        return out

    # ---- files ------------------------------------------------------------------------

    def to_dict(self) -> dict:
        """haptex's model file as a dict (:data:`FORMAT`, version :data:`FORMAT_VERSION`, SI units)."""
        return {
            "format": FORMAT,
            "version": FORMAT_VERSION,
            "name": self.name,
            "sample_rate_hz": self.sample_rate,
            "mu": self.mu,
            "triangles": self.triangles.tolist(),
            "models": [{"speed_m_per_s": m.speed, "force_n": m.force, "ar": m.ar.tolist(), "ma": m.ma.tolist(),
                        "variance_m2_per_s4": m.variance, "gain": m.gain} for m in self.models],
        }

    def write(self, path) -> Path:
        """Write the set in haptex's own format (JSON, SI units; read back by :func:`read_models`).

        Parameters
        ----------
        path : str or os.PathLike
            File to write (``.json``); its folder must exist.

        Returns
        -------
        pathlib.Path
            The file written. Floats are written with Python's shortest round-tripping
            representation, so a set read back is equal to the one written, bit for bit.

        Raises
        ------
        ParameterError
            If the folder does not exist.
        """
        path = Path(path)
        if not path.parent.is_dir():
            raise fail("path", str(path), "a file in an existing folder")
        path.write_text(json.dumps(self.to_dict(), indent=1) + "\n")
        return path

    def __repr__(self) -> str:
        p, q = self.models[0].order
        return (f"ModelSet({self.name!r}: {len(self.models)} ARMA({p},{q}) models at {self.sample_rate:g} Hz, "
                f"speed 0-{self.speeds.max():g} m/s, force 0-{self.forces.max():g} N, {len(self.triangles)} triangles)")


@dataclasses.dataclass(frozen=True)
class SetCheck:
    """What :func:`check_models` found on one model set.

    Parameters
    ----------
    name : str
        The set's name (HaTT's ``<material>``).
    models, triangles : int
        Its counts.
    speed_range : tuple of float
        Smallest and largest operating speed (m/s).
    force_range : tuple of float
        Smallest and largest operating force (N).
    order : tuple of int
        (p, q).
    points : int
        Random operating points drawn in the rectangle of the ranges.
    unstable : int
        Of those, the interpolated models with an AR root on or outside the unit circle
        (by :func:`numpy.roots`, not by the LSF algebra).
    max_root : float
        The largest AR root modulus met.
    middle : tuple of float
        The set's middle operating point (m/s, N): half its largest speed and force.
    rms_model : float
        The model's stationary rms acceleration there (m/s²): sqrt(variance · gain² · Σh²),
        h the impulse response of B/A by :func:`scipy.signal.dimpulse`.
    rms_synthesis : float
        The rms of the C core's synthesis there (m/s²), after its first second.
    seconds : float
        Length of that synthesis (s).
    """

    name: str
    models: int
    triangles: int
    speed_range: tuple[float, float]
    force_range: tuple[float, float]
    order: tuple[int, int]
    points: int
    unstable: int
    max_root: float
    middle: tuple[float, float]
    rms_model: float
    rms_synthesis: float
    seconds: float

    @property
    def rms_error(self) -> float:
        """Relative difference of the synthesis's rms from the model's (0 where both are 0; inf
        where the model's is 0 and the synthesis's is not)."""
        if self.rms_model == 0:
            return 0.0 if self.rms_synthesis == 0 else math.inf
        return self.rms_synthesis / self.rms_model - 1.0


def check_models(models: ModelSet, *, points: int = 1000, seconds: float = 20.0, seed: int = 0) -> SetCheck:
    """Check a model set on its own terms: every interpolated model stable, synthesis at its power.

    Parameters
    ----------
    models : ModelSet
        The set (a HaTT file read by :func:`read_hatt`, or a fit).
    points : int, optional
        Random operating points, uniform over [0, largest speed] x [0, largest force]; a point
        outside the triangulation is interpolated at its closest point, as the renderer does.
    seconds : float, optional
        Length (s) of the synthesis at the set's middle operating point; its first second
        (the filter's start from rest) is left out of the rms.
    seed : int, optional
        Seed of the points and the synthesis's noise.

    Returns
    -------
    SetCheck

    Raises
    ------
    ParameterError
        If ``points`` is not an integer in [1, 10^6] or ``seconds`` not in (1, 3600] s.

    Notes
    -----
    The oracle shares nothing with the interpolation: the stability is judged from the roots of
    the interpolated AR polynomial, and the expected rms from the impulse response (scipy),
    while the set interpolates LSF (Culbertson et al. 2014) and synthesises in the C core.
    """
    if isinstance(points, bool) or not isinstance(points, int | np.integer) or not 1 <= points <= 10**6:
        raise fail("points", points, "an integer in [1, 1000000]")
    t = positive("seconds", seconds, "s")
    if not 1.0 < t <= 3600.0:
        raise fail("seconds", seconds, "a length in (1, 3600] s")
    rng = np.random.default_rng(seed)
    vmax, fmax = float(models.speeds.max()), float(models.forces.max())
    unstable, worst = 0, 0.0
    for v, f in zip(rng.uniform(0, vmax, points), rng.uniform(0, fmax, points)):
        m = models.model_at(v, f)
        r = float(np.max(np.abs(np.roots(m.ar)))) if m.order[0] else 0.0
        worst = max(worst, r)
        unstable += r >= 1.0
    mid = (vmax / 2, fmax / 2)
    m = models.model_at(*mid)
    y = models.synthesize(mid[0], mid[1], t, seed=seed)[int(models.sample_rate):]
    return SetCheck(models.name, len(models.models), len(models.triangles), (float(models.speeds.min()), vmax),
                    (float(models.forces.min()), fmax), models.models[0].order, int(points), int(unstable), worst, mid,
                    math.sqrt(m.output_variance()), float(np.sqrt(np.mean(y * y))), t)


def _collinear(pts: np.ndarray) -> bool:
    """Whether scaled operating points lie on one line (to 1e-9 of their spread)."""
    if len(pts) < 3:
        return True
    sv = np.linalg.svd(pts - pts.mean(axis=0), compute_uv=False)
    return bool(sv[1] <= 1e-9 * max(sv[0], 1e-300))


def _finite(name, value, unit):
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise fail(name, value, f"a finite number ({unit})") from None
    if not math.isfinite(v):
        raise fail(name, value, f"a finite number ({unit})")
    return v


# ---------------------------------------------------------------------------------------
# reading
# ---------------------------------------------------------------------------------------

MAX_FILE_BYTES = 64 * 2**20
"""Largest model file read (64 MiB; HaTT's largest are a few hundred kB)."""


def read_models(path) -> ModelSet:
    """Read a model set: haptex's own JSON (:meth:`ModelSet.write`) or HaTT's XML (:func:`read_hatt`).

    Parameters
    ----------
    path : str or os.PathLike
        The file; its content, not its name, says which format it is.

    Returns
    -------
    ModelSet

    Raises
    ------
    ParameterError
        If the file is missing, too large (:data:`MAX_FILE_BYTES`), of neither format, or
        its content is refused (the field, its value and what is allowed).
    """
    data = _read_bytes(path)
    head = data.lstrip()[:1]
    if head == b"<":
        return _parse_hatt(data, path)
    if head == b"{":
        return _parse_json(data, path)
    raise fail("path", str(path), "a model file: haptex's JSON (haptex fit writes one) or HaTT's XML")


def _read_bytes(path) -> bytes:
    p = Path(os.fspath(path))
    if not p.is_file():
        raise fail("path", str(path), "an existing model file")
    if p.stat().st_size > MAX_FILE_BYTES:
        raise fail("path", str(path), f"a model file of at most {MAX_FILE_BYTES // 2**20} MiB")
    return p.read_bytes()


def _parse_json(data: bytes, path) -> ModelSet:
    try:
        d = json.loads(data)
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise fail("path", str(path), f"valid JSON ({exc})") from None
    if not isinstance(d, dict) or d.get("format") != FORMAT:
        raise fail("format", d.get("format") if isinstance(d, dict) else d, f"{FORMAT!r}")
    if d.get("version") != FORMAT_VERSION:
        raise fail("version", d.get("version"), f"{FORMAT_VERSION} (this release's); a newer haptex reads newer files")
    fs = d.get("sample_rate_hz")
    models = []
    raw = d.get("models")
    if not isinstance(raw, list):
        raise fail("models", raw, "a list of models")
    for k, m in enumerate(raw):
        if not isinstance(m, dict):
            raise fail(f"models[{k}]", m, "an object with speed_m_per_s, force_n, ar, ma, variance_m2_per_s4, gain")
        missing = [f for f in ("speed_m_per_s", "force_n", "ar", "ma", "variance_m2_per_s4", "gain") if f not in m]
        if missing:
            raise fail(f"models[{k}]", f"without {missing[0]}", "every field of a model (see the file formats page)")
        try:
            models.append(ArmaModel(m["ar"], m["ma"], m["variance_m2_per_s4"], m["gain"], fs, m["speed_m_per_s"],
                                    m["force_n"]))
        except (ParameterError, TypeError, ValueError) as exc:
            raise ParameterError(f"models[{k}]: {exc}") from None
    tri = d.get("triangles")
    return ModelSet(models, None if tri is None else np.asarray(tri, dtype=np.int64).reshape(-1, 3),
                    mu=d.get("mu"), name=d.get("name", ""))


_HATT_IGNORED = {
    "htmlPicture": "a picture of the material (a path on the authors' Windows machine)",
    "htmlLinuxPicture": "the same picture's path on Linux",
    "renderPicture": "the texture image HaTT's demo draws on its sphere",
    "DTpicture": "a picture of the triangulation (Windows path)",
    "LinuxDTpicture": "the same picture's path on Linux",
}
"""The tags of HaTT's files that :func:`read_hatt` ignores on purpose, with what they hold:
pictures for HaTT's own viewer, none of them part of the models."""

_SPEED_UNITS = {"mm/s": 1e-3, "m/s": 1.0}
_FORCE_UNITS = {"N": 1.0}


def read_hatt(path, *, acceleration_unit: str | None = None) -> ModelSet:
    """Read a model set in the Penn Haptic Texture Toolkit's XML format, as HaTT publishes it.

    Parameters
    ----------
    path : str or os.PathLike
        A HaTT model file (``Models_<material>.xml``; Culbertson, Lopez Delgado &
        Kuchenbecker 2014). HaTT's files are licensed for non-profit research without
        redistribution: haptex ships none; its tests write sets in the same layout.
    acceleration_unit : {"m/s^2", "g"}, optional
        The unit of the recorded acceleration the models were fitted to, for a file without
        ``<AccelUnits>`` (every published file has it: ``m/s^2``); the variances are scaled to
        (m/s²)². Given for a file whose ``<AccelUnits>`` says otherwise, it is refused.

    Returns
    -------
    ModelSet
        Speeds converted from the file's ``<SpeedUnits>`` (mm/s) to m/s, forces in N, its own
        triangles (``<tri>``, 1-based in the file), its ``mu`` (the material's kinetic
        friction coefficient), its ``SampleRate`` (Hz), named by its ``<material>``; its
        ``ignored`` lists the tags read past on purpose (:data:`_HATT_IGNORED`: pictures).

    Raises
    ------
    ParameterError
        If a tag is missing or not a number, a count (``numMod``, ``numTri``,
        ``numARCoeff``, ``numMACoeff``) disagrees with what it counts, a ``<tri>`` has other
        than three vertices or one out of range, ``maxSpeed``/``maxForce`` are not the lists'
        largest, ``mu`` is negative, a unit is not one HaTT uses, a model is unstable or not
        finite, its ``ARlsf`` or ``MAlsf`` disagree with its coefficients, or the XML declares
        entities (an entity-expansion bomb is refused by defusedxml before anything is
        expanded). The message names the tag, and the triangle's or model's number.

    Notes
    -----
    The layout of the 100 published files (checked against each of them; see the data-driven
    guide): ``<modelSet texture="N">`` holds ``material``, ``AccelUnits``, ``SpeedUnits``,
    ``ForceUnits``, ``SampleRate``, ``mu``, ``numMod``, ``numTri``, ``maxSpeed``, ``maxForce``,
    ``speedList`` and ``forceList`` (one ``<value>`` a model), **one** ``<tri type="array">``
    **element per triangle** (three ``<value>`` vertex numbers, 1-based), ``numARCoeff``,
    ``numMACoeff`` and one ``<model>`` a vertex with ``modNum``, ``ARcoeff``, ``MAcoeff``
    (each with its leading 1), ``ARlsf``, ``MAlsf`` (rad), ``var``, ``gain``, ``speedMod`` and
    ``forceMod``; and the picture paths of :data:`_HATT_IGNORED`. Tags beyond these are listed
    in ``ignored`` too.
    """
    unit = None
    if acceleration_unit is not None:
        unit = _ACC_UNITS.get(str(acceleration_unit).strip())
        if unit is None:
            raise fail("acceleration_unit", acceleration_unit, "'m/s^2' or 'g'")
    return _parse_hatt(_read_bytes(path), path, unit)


_HATT_READ = {"material", "AccelUnits", "SpeedUnits", "ForceUnits", "SampleRate", "mu", "numMod", "numTri",
              "maxSpeed", "maxForce", "speedList", "forceList", "tri", "numARCoeff", "numMACoeff", "model"}


def _parse_hatt(data: bytes, path, unit: float | None = None) -> ModelSet:
    import defusedxml.ElementTree as ET
    from defusedxml import DefusedXmlException

    try:
        root = ET.fromstring(data, forbid_dtd=True)
    except DefusedXmlException as exc:
        raise fail("path", str(path), f"XML without a DTD or entities (refused: {type(exc).__name__})") from None
    except ET.ParseError as exc:
        raise fail("path", str(path), f"well-formed XML ({exc})") from None
    if root.tag != "modelSet":
        raise fail("root tag", root.tag, "'modelSet' (a HaTT model file)")

    def child(el, tag, where):
        c = el.find(tag)
        if c is None:
            raise fail(f"{where}<{tag}>", "missing", "present (HaTT's layout)")
        return c

    def values(c, name):
        texts = [e.text or "" for e in c] if len(c) else [(c.text or "").replace(",", " ")]
        try:
            v = np.array([float(x) for t in texts for x in t.split()], dtype=float)
        except ValueError:
            raise fail(name, " ".join(texts).strip()[:40], "numbers") from None
        if not np.all(np.isfinite(v)):
            raise fail(name, np.round(v, 6).tolist() if v.size <= 8 else "non-finite values", "finite numbers")
        return v

    def numbers(el, tag, where):
        return values(child(el, tag, where), f"{where}<{tag}>")

    def number(el, tag, where):
        v = numbers(el, tag, where)
        if v.size != 1:
            raise fail(f"{where}<{tag}>", v, "one number")
        return float(v[0])

    def text(tag, default, allowed):
        c = root.find(tag)
        if c is None:
            return default
        t = (c.text or "").strip()
        if t not in allowed:
            raise fail(f"<{tag}>", t, " or ".join(repr(a) for a in allowed) + " (the units HaTT's files use)")
        return t

    acc = text("AccelUnits", None, tuple(_ACC_UNITS))
    if acc is not None and unit is not None and _ACC_UNITS[acc] != unit:
        raise fail("acceleration_unit", f"{unit:g} m/s^2", f"the file's own <AccelUnits> ({acc!r}), or left out")
    unit = _ACC_UNITS[acc] if acc is not None else (1.0 if unit is None else unit)
    v_unit = _SPEED_UNITS[text("SpeedUnits", "mm/s", tuple(_SPEED_UNITS))]
    text("ForceUnits", "N", tuple(_FORCE_UNITS))

    fs = number(root, "SampleRate", "")
    if not fs > 0:
        raise fail("<SampleRate>", fs, "a rate > 0 (Hz)")
    mu = number(root, "mu", "")
    if mu < 0:
        raise fail("<mu>", mu, "a kinetic friction coefficient >= 0")
    n_mod = number(root, "numMod", "")
    n_tri = number(root, "numTri", "")
    speeds = numbers(root, "speedList", "") * v_unit
    forces = numbers(root, "forceList", "")
    tri_els = root.findall("tri")
    if not tri_els:
        raise fail("<tri>", "missing", "present (HaTT's layout: one <tri> element per triangle)")
    tris = []
    for k, el in enumerate(tri_els):
        t = values(el, f"<tri> {k + 1}")
        if t.size != 3:
            raise fail(f"<tri> {k + 1}", t.tolist(), "three vertex indices (one <tri> element per triangle, as "
                       "HaTT's files have)")
        tris.append(t)
    tri = np.array(tris)
    model_els = root.findall("model")
    for tag, count, what, of in (("numMod", n_mod, len(model_els), "<model> elements"),
                                 ("numMod", n_mod, speeds.size, "<speedList> values"),
                                 ("numMod", n_mod, forces.size, "<forceList> values"),
                                 ("numTri", n_tri, len(tri), "<tri> elements")):
        if count != what:
            raise fail(f"<{tag}>", count, f"{what:g}, the count of its {of}")
    bad = (tri != np.round(tri)) | (tri < 1) | (tri > n_mod)
    if bad.any():
        k, j = divmod(int(np.argmax(bad)), 3)
        raise fail(f"<tri> {k + 1}", tri[k, j], f"vertex indices in [1, {n_mod:g}] (1-based)")
    for tag, lst in (("maxSpeed", speeds / v_unit), ("maxForce", forces)):
        if root.find(tag) is not None:
            given = number(root, tag, "")
            if lst.size and abs(given - lst.max()) > 1e-6 * max(1.0, abs(given)):
                raise fail(f"<{tag}>", given, f"the largest of its list ({lst.max():g})")
    orders = {}
    for tag in ("numARCoeff", "numMACoeff"):
        if root.find(tag) is not None:
            orders[tag] = number(root, tag, "")
    models = []
    for k, el in enumerate(model_els):
        where = f"<model> {k + 1}: "
        if el.find("modNum") is not None and number(el, "modNum", where) != k + 1:
            raise fail(f"{where}<modNum>", number(el, "modNum", where), f"{k + 1}, its place in the file")
        ar, ma = numbers(el, "ARcoeff", where), numbers(el, "MAcoeff", where)
        for tag, poly in (("numARCoeff", ar), ("numMACoeff", ma)):
            if tag in orders and poly.size - 1 != orders[tag]:
                raise fail(f"{where}<{'AR' if tag == 'numARCoeff' else 'MA'}coeff>", f"{poly.size} values",
                           f"{orders[tag]:g} coefficients after the leading 1 (<{tag}>)")
        s, f = number(el, "speedMod", where) * v_unit, number(el, "forceMod", where)
        if abs(s - speeds[k]) > 1e-9 * max(1.0, abs(s)) or abs(f - forces[k]) > 1e-9 * max(1.0, abs(f)):
            raise fail(f"{where}<speedMod>, <forceMod>", (s / v_unit, f), f"the set's lists' entry {k + 1}: "
                       f"{speeds[k] / v_unit:g}, {forces[k]:g}")
        try:
            m = ArmaModel(ar, ma, number(el, "var", where) * unit**2, number(el, "gain", where), fs, s, f)
        except ParameterError as exc:
            raise ParameterError(f"{where}{exc}") from None
        for tag, ours in (("ARlsf", m.ar_lsf), ("MAlsf", m.ma_lsf)):
            given = numbers(el, tag, where)
            if not _lsf_agree(given, ours, fs):
                raise fail(f"{where}<{tag}>", given, f"the LSF of its coefficients ({np.round(ours, 4).tolist()} rad, "
                           "or the same in Hz or as fractions of pi)")
        models.append(m)
    material = root.find("material")
    name = (material.text or "").strip() if material is not None else ""
    try:
        out = ModelSet(models, tri.astype(np.int64) - 1, mu=mu, name=name or Path(os.fspath(path)).stem)
    except ParameterError as exc:
        raise ParameterError(f"<modelSet>: {exc}") from None
    out.ignored = tuple(dict.fromkeys(c.tag for c in root if c.tag not in _HATT_READ))
    return out


def _lsf_agree(given: np.ndarray, ours: np.ndarray, fs: float) -> bool:
    if given.size != ours.size:
        return False
    if given.size == 0:
        return True
    g = np.sort(given)
    return any(np.allclose(g * s, ours, rtol=1e-3, atol=1e-4) for s in (1.0, np.pi, 2 * np.pi / fs))


# ---------------------------------------------------------------------------------------
# fitting from recordings
# ---------------------------------------------------------------------------------------


def dft321(acceleration, block: int | None = None) -> np.ndarray:
    """Reduce a three-axis acceleration to one axis, keeping its spectrum (DFT321).

    Parameters
    ----------
    acceleration : array_like, shape (n, 3)
        Acceleration (m/s²) along three orthogonal axes.
    block : int, optional
        Reduce the signal block by block, each of ``block`` samples: half-overlapping blocks
        under a square-root Hann window, each reduced on its own and overlap-added under the
        same window (weighted overlap-add: the squared windows sum to 1, so a signal along one
        fixed direction comes back unchanged and the power of two blocks of different
        directions is kept through their overlap). Default: the whole signal as one block. A
        recording whose direction of vibration changes from stroke to stroke is reduced block
        by block, as Landin et al. do over short windows: over the whole of it, each
        frequency's magnitude pools every stroke's and its phase is the sum's, which spreads
        one stroke's power over the others (:func:`fit` reduces over blocks of its windows'
        length).

    Returns
    -------
    numpy.ndarray, shape (n,)
        The signal whose DFT has, in each block and at each frequency, the magnitude
        sqrt(|A_x|² + |A_y|² + |A_z|²) and the phase of A_x + A_y + A_z (Landin, Romano,
        McMahan & Kuchenbecker, "Dimensional reduction of high-frequency accelerations for
        haptic rendering", EuroHaptics 2010): its power spectrum is the sum of the three axes'.

    Raises
    ------
    ParameterError
        If the array is not (n, 3) with n >= 2, not finite, or ``block`` is not an integer
        >= 4.
    """
    a = np.asarray(acceleration, dtype=float)
    if a.ndim != 2 or a.shape[1] != 3 or a.shape[0] < 2:
        raise fail("acceleration", f"shape {a.shape}", "an (n, 3) array (three axes, m/s^2)")
    if not np.all(np.isfinite(a)):
        raise fail("acceleration", "non-finite samples", "finite numbers (m/s^2)")
    n = a.shape[0]
    if block is None:
        return _dft321_rows(a[None])[0]
    if isinstance(block, bool) or not isinstance(block, int | np.integer) or block < 4:
        raise fail("block", block, "an integer >= 4 (samples)")
    hop = min(int(block), n + n % 2) // 2
    L = 2 * hop
    w = np.sqrt(0.5 - 0.5 * np.cos(2 * np.pi * np.arange(L) / L))  # sqrt of the periodic Hann window
    k = -(-n // hop)  # blocks of hop samples holding the signal, then one on each side
    xp = np.zeros(((k + 2) * hop, 3))
    xp[hop : hop + n] = a
    frames = np.lib.stride_tricks.sliding_window_view(xp, L, axis=0)[::hop]  # (k + 1, 3, L)
    y = _dft321_rows(np.swapaxes(frames, 1, 2) * w[None, :, None]) * w  # (k + 1, L)
    out = np.zeros(xp.shape[0])
    out[: (k + 1) * hop] += y[:, :hop].ravel()
    out[hop : (k + 2) * hop] += y[:, hop:].ravel()
    return out[hop : hop + n]


def _dft321_rows(a: np.ndarray) -> np.ndarray:
    """DFT321 of each block: ``a`` of shape (k, m, 3) -> (k, m)."""
    spec = np.fft.rfft(a, axis=1)
    mag = np.sqrt(np.sum(np.abs(spec) ** 2, axis=2))
    phase = np.angle(spec.sum(axis=2))
    return np.fft.irfft(mag * np.exp(1j * phase), n=a.shape[1], axis=1)


@dataclasses.dataclass(frozen=True)
class FitReport:
    """What :func:`fit` did: the choices it made and what it kept.

    Parameters
    ----------
    order : tuple of int
        (p, q): the AR and MA orders.
    criterion : str
        How p was chosen ("BIC over the segments, p = 1 to max_order", or "given").
    segments : int
        Steady windows kept, of ``windows`` in the recording.
    windows : int
        Windows of ``segment`` seconds in the recording.
    cells : int
        Operating-point cells (one model each).
    sample_rate : float
        Rate (Hz) of the models.
    highpass : float
        Cut-off (Hz) of the high-pass that removed the hand's motion.
    axes : int, optional
        Axes of the recorded acceleration (3: reduced by :func:`dft321` over each window).
    notes : tuple of str, optional
        What the fit could not settle and what to do (the order at its cap).
    """

    order: tuple[int, int]
    criterion: str
    segments: int
    windows: int
    cells: int
    sample_rate: float
    highpass: float
    axes: int = 1
    notes: tuple[str, ...] = ()


def fit(acceleration, speed, normal_force, sample_rate: float, *, rate: float | None = None,
        order: int | None = None, ma_order: int = 0, max_order: int = 30, segment: float = 0.2,
        highpass: float = 20.0, steadiness: float = 0.2, min_speed: float = 0.005, min_force: float = 0.05,
        grid: int = 6, name: str = "") -> ModelSet:
    """Fit a model set to a recording of a tool dragged over a surface.

    Parameters
    ----------
    acceleration : array_like, shape (n,) or (n, 3)
        The tool's acceleration (m/s²); three axes are reduced to one by :func:`dft321` over
        each window of ``segment`` seconds (after the high-pass and the resampling), so that
        strokes in different directions are each reduced along their own.
    speed : array_like, shape (n,)
        Tangential speed (m/s), >= 0.
    normal_force : array_like, shape (n,)
        Normal force (N).
    sample_rate : float
        Rate (Hz) of the recording.
    rate : float, optional
        Rate (Hz) of the models (the renderer's servo rate); default ``sample_rate``. The
        recording is resampled (:func:`scipy.signal.resample_poly`).
    order : int, optional
        The AR order p; default: the p in 1..``max_order`` that minimises the Bayesian
        information criterion summed over the segments.
    ma_order : int, optional
        The MA order q (0: AR models, fitted by Yule-Walker, always stable; > 0: ARMA by
        :class:`statsmodels.tsa.arima.model.ARIMA`, stationary and invertible).
    max_order : int, optional
        Largest p tried when ``order`` is not given (<= :data:`MAX_ORDER`).
    segment : float, optional
        Length (s) of the windows in which the operating point is judged steady.
    highpass : float, optional
        Cut-off (Hz) of the 4th-order Butterworth high-pass (zero phase) that removes the
        hand's motion and keeps the texture band.
    steadiness : float, optional
        Largest relative standard deviation of speed and of force in a steady window.
    min_speed : float, optional
        Slowest mean speed (m/s) of a kept window (a tool at rest records no texture).
    min_force : float, optional
        Least mean normal force (N) of a kept window (out of contact below it).
    grid : int, optional
        Steady windows are pooled in ``grid`` x ``grid`` cells over their speed and force
        range, one model a cell (at the cell's mean operating point).
    name : str, optional
        The set's name.

    Returns
    -------
    ModelSet
        Its :attr:`~ModelSet.report` is the :class:`FitReport`.

    Raises
    ------
    ParameterError
        If the arrays disagree in length, hold NaN, a speed is negative, the recording is too
        short for the order (fewer than 10 p samples in a cell) or has no steady window.

    Notes
    -----
    The steps of Romano & Kuchenbecker (2012) and Culbertson et al. (2014): one axis, the
    texture band, steady segments, one model per operating point, the set triangulated.
    Yule-Walker and Levinson-Durbin are statsmodels' (:func:`~statsmodels.regression.linear_model.yule_walker`,
    :func:`~statsmodels.tsa.stattools.levinson_durbin`).
    """
    from scipy.signal import butter, resample_poly, sosfiltfilt

    fs = positive("sample_rate", sample_rate, "Hz")
    acc = np.asarray(acceleration, dtype=float)
    if not (acc.ndim == 1 or (acc.ndim == 2 and acc.shape[1] == 3)):
        raise fail("acceleration", f"shape {np.shape(acceleration)}", "an (n,) or (n, 3) array (m/s^2)")
    n = acc.shape[0]
    v = np.asarray(speed, dtype=float)
    F = np.asarray(normal_force, dtype=float)
    for nm, arr, unit in (("acceleration", acc, "m/s^2"), ("speed", v, "m/s"), ("normal_force", F, "N")):
        if arr.shape[:1] != (n,) or (arr is not acc and arr.ndim != 1):
            raise fail(nm, f"shape {arr.shape}", f"({n},): one value per sample of acceleration")
        bad = ~np.isfinite(arr)
        if bad.ndim == 2:
            bad = bad.any(axis=1)
        if bad.any():
            k = int(np.argmax(bad))
            raise fail(nm, f"{arr[k] if arr.ndim == 1 else arr[k].tolist()} at sample {k}", f"finite numbers ({unit})")
    if np.any(v < 0):
        k = int(np.argmax(v < 0))
        raise fail("speed", f"{v[k]:g} m/s at sample {k}", "speeds >= 0 (m/s; the tangential speed's magnitude)")
    out_fs = fs if rate is None else positive("rate", rate, "Hz")
    if ma_order < 0 or ma_order > MAX_ORDER or int(ma_order) != ma_order:
        raise fail("ma_order", ma_order, f"an integer in [0, {MAX_ORDER}]")
    if not 1 <= max_order <= MAX_ORDER or int(max_order) != max_order:
        raise fail("max_order", max_order, f"an integer in [1, {MAX_ORDER}]")
    if order is not None and (not 1 <= order <= MAX_ORDER or int(order) != order):
        raise fail("order", order, f"an integer in [1, {MAX_ORDER}]")
    if isinstance(grid, bool) or not isinstance(grid, int | np.integer) or not 1 <= grid <= 100:
        raise fail("grid", grid, "an integer in [1, 100] (cells a side)")
    from ._validation import in_range, nonnegative

    in_range("steadiness", steadiness, 0.0, 1.0)
    nonnegative("min_speed", min_speed, "m/s")
    nonnegative("min_force", min_force, "N")
    hp = positive("highpass", highpass, "Hz")
    if hp >= out_fs / 2:
        raise fail("highpass", hp, f"below the models' Nyquist frequency, {out_fs / 2:g} Hz")
    seg = positive("segment", segment, "s")
    # the texture band, then the models' rate
    if n < 64:
        raise fail("acceleration", f"{n} samples", "a recording of at least 64 samples")
    acc = sosfiltfilt(butter(4, hp, "highpass", fs=fs, output="sos"), acc, axis=0)
    if out_fs != fs:
        from fractions import Fraction

        r = Fraction(out_fs / fs).limit_denominator(1000)
        if abs(float(r) - out_fs / fs) > 1e-6 * out_fs / fs:
            raise fail("rate", out_fs, f"a rate in a ratio of integers up to 1000 to {fs:g} Hz")
        t_in = np.arange(n) / fs
        acc = resample_poly(acc, r.numerator, r.denominator, axis=0)
        t_out = np.arange(acc.shape[0]) / out_fs
        v, F = np.interp(t_out, t_in, v), np.interp(t_out, t_in, F)
    w = int(round(seg * out_fs))
    if w < 16:
        raise fail("segment", seg, f"at least {16 / out_fs:g} s (16 samples at {out_fs:g} Hz)")
    nwin = acc.shape[0] // w
    if nwin < 1:
        raise fail("acceleration", f"{acc.shape[0] / out_fs:g} s", f"a recording longer than one segment ({seg:g} s)")
    if acc.ndim == 2:  # three axes: DFT321 over each window, where the stroke's direction holds
        acc = dft321(acc[: nwin * w], block=w)
    A = acc[: nwin * w].reshape(nwin, w)
    V = v[: nwin * w].reshape(nwin, w)
    FF = F[: nwin * w].reshape(nwin, w)
    mv, mf = V.mean(axis=1), FF.mean(axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        steady = ((V.std(axis=1) <= steadiness * mv) & (FF.std(axis=1) <= steadiness * np.abs(mf))
                  & (mv >= min_speed) & (mf >= min_force))
    if not steady.any():
        raise fail("speed", f"no steady window of {seg:g} s (of {nwin})",
                   f"a recording with windows where speed >= {min_speed:g} m/s and force >= {min_force:g} N vary by "
                   f"at most {steadiness:.0%} (or a larger steadiness)")
    idx = np.flatnonzero(steady)
    gs, gf = _cells(mv[idx], grid), _cells(mf[idx], grid)
    held_v, held_f = _held(mv[idx], gs), _held(mf[idx], gf)
    cells = {}
    for k, c in zip(idx, zip(gs, gf)):
        cells.setdefault(c, []).append(k)
    groups = [np.array(ks) for ks in cells.values()]
    labels = list(cells)
    p_max = int(max_order if order is None else order)
    shortest = min(len(g) * w for g in groups)
    if shortest < 10 * p_max:
        raise fail("segment", seg, f"cells of at least {10 * p_max} samples for order {p_max} "
                   f"(the shortest has {shortest}): longer segments, a lower order or a coarser grid")
    from statsmodels.tsa.stattools import acovf, levinson_durbin

    notes = []
    sig = []  # innovation variance of each cell at orders 1..p_max
    for g in groups:
        # the cell's runs of consecutive windows, each one stretch of signal: the biased
        # autocovariance over a run (positive definite, so Levinson's AR is stable) has a bias
        # (N - k) / N small at run lengths N, where over single windows it misplaced
        # resonances near the unit circle
        ac, total = np.zeros(p_max + 1), 0
        for run in np.split(g, np.flatnonzero(np.diff(g) != 1) + 1):
            x = A[run].ravel()
            ac += acovf(x - x.mean(), adjusted=False, fft=True, nlag=p_max) * x.size
            total += x.size
        _, _, _, s, phi = levinson_durbin(ac / total, nlags=p_max, isacov=True)
        sig.append((np.asarray(s)[1:], np.asarray(phi), total))
    if order is None:
        bic = np.zeros(p_max)
        for s, _, m in sig:
            bic += m * np.log(np.maximum(s, 1e-300)) + np.arange(1, p_max + 1) * np.log(m)
        p = int(np.argmin(bic)) + 1
        crit = f"BIC summed over the cells, p = 1 to {p_max}"
        if p == p_max:
            notes.append(f"the order reached its cap (p = {p_max}): the information criterion still fell there, so "
                         "a higher order may fit better (max_order up to "
                         f"{MAX_ORDER}, --order); a high-pass at or inside the texture band (here {hp:g} Hz) is "
                         "itself a steep edge that takes many poles: a lower --highpass lowers the order")
    else:
        p = p_max
        crit = "given"
    models = []
    for (cv, cf), g, (s, phi, m) in zip(labels, groups, sig):
        # a held speed or force is the same for every model at it (the triangles then have no
        # slivers); otherwise the cell's own mean
        op_v = held_v.get(cv, float(mv[g].mean()))
        op_f = held_f.get(cf, float(mf[g].mean()))
        if ma_order == 0:
            ar = np.concatenate([[1.0], -phi[1 : p + 1, p]])  # statsmodels: column p holds order p's coefficients
            models.append(ArmaModel(ar, [1.0], float(s[p - 1]), 1.0, out_fs, op_v, op_f))
        else:
            models.append(_arma_cell(A[g], p, int(ma_order), out_fs, op_v, op_f))
    report = FitReport((p, int(ma_order)), crit, int(idx.size), int(nwin), len(models), out_fs, hp,
                       3 if np.ndim(acceleration) == 2 else 1, tuple(notes))
    s = ModelSet(models, name=name)
    s.report = report
    return s


def _cells(x: np.ndarray, grid: int) -> np.ndarray:
    """Cell labels of the windows' mean operating points ``x`` along one axis: in order of value,
    a new cell where the next value is more than half a grid width (the range / ``grid``) past the
    last, or a grid width past the cell's first. Equal-width cells for values spread over the
    range; one cell for each of a few discrete operating points (a window's mean scatters a
    little around each: a fixed grid's edge could fall among them and split one point in two)."""
    lo, hi = float(x.min()), float(x.max())
    if hi - lo <= 1e-9 * max(abs(hi), 1e-300):
        return np.zeros(x.size, dtype=int)
    width = (hi - lo) / grid
    order = np.argsort(x, kind="stable")
    xs = x[order]
    labels = np.empty(x.size, dtype=int)
    cell, first = 0, xs[0]
    for i, value in enumerate(xs):
        if i and (value - xs[i - 1] > 0.5 * width or value - first > width):
            cell, first = cell + 1, value
        labels[order[i]] = cell
    return labels


HELD = 0.02
"""Largest spread of a cell's window means, relative to their mean, for :func:`fit` to take its
speed (or force) as held: the models at it share one value, the mean over all its windows
(chosen: the windows of a held speed scatter by 0.01-0.3 % in haptex's scans; a hand's free
strokes spread over a cell's width, a tenth of the range or more)."""


def _held(x: np.ndarray, labels: np.ndarray) -> dict:
    """The cells of :func:`_cells` whose window means ``x`` lie within :data:`HELD` of their mean:
    {label: that mean}."""
    out = {}
    for c in np.unique(labels):
        v = x[labels == c]
        mean = float(v.mean())
        if float(v.max() - v.min()) <= HELD * abs(mean):
            out[int(c)] = mean
    return out


def _arma_cell(x: np.ndarray, p: int, q: int, fs: float, v: float, f: float) -> ArmaModel:
    import warnings

    from statsmodels.tsa.arima.model import ARIMA

    series = (x - x.mean(axis=1, keepdims=True)).ravel()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # statsmodels' convergence chatter; the result is checked below
        res = ARIMA(series, order=(p, 0, q), trend="n", enforce_stationarity=True, enforce_invertibility=True).fit()
    ar = np.concatenate([[1.0], -np.asarray(res.arparams)])
    ma = np.concatenate([[1.0], np.asarray(res.maparams)])
    return ArmaModel(ar, ma, float(res.params[-1]), 1.0, fs, v, f)


# ---------------------------------------------------------------------------------------
# recordings
# ---------------------------------------------------------------------------------------

RECORDING_COLUMNS = {
    "time_s": "time (s), uniformly sampled; or give the sample rate",
    "acc_m_s2": "acceleration along one axis (m/s²); or the three columns acc_x_m_s2, acc_y_m_s2, acc_z_m_s2",
    "speed_m_s": "tangential speed (m/s), >= 0",
    "force_n": "normal force (N)",
}
"""The columns of a recording's CSV file (header row, one sample a row)."""


@dataclasses.dataclass(frozen=True, eq=False)
class Recording:
    """A tool's acceleration, speed and normal force, sampled together.

    Parameters
    ----------
    acceleration : numpy.ndarray, shape (n,) or (n, 3)
        Acceleration (m/s²).
    speed : numpy.ndarray, shape (n,)
        Tangential speed (m/s).
    normal_force : numpy.ndarray, shape (n,)
        Normal force (N).
    sample_rate : float
        Rate (Hz).
    ignored : tuple of str, optional
        The file's columns no quantity was read from (:func:`read_recording`).
    speed_source : str, optional
        Where the speed came from: the file's column, or the positions' derivative.
    """

    acceleration: np.ndarray
    speed: np.ndarray
    normal_force: np.ndarray
    sample_rate: float
    ignored: tuple = ()
    speed_source: str = "given"

    def fit(self, **kwargs) -> ModelSet:
        """Fit a model set to this recording.

        Parameters
        ----------
        **kwargs
            :func:`fit`'s keyword arguments (``rate``, ``order``, ``ma_order``, ...).

        Returns
        -------
        ModelSet
        """
        return fit(self.acceleration, self.speed, self.normal_force, self.sample_rate, **kwargs)

    def write(self, path) -> Path:
        """Write the recording as CSV with :data:`RECORDING_COLUMNS` (17 significant digits).

        Parameters
        ----------
        path : str or os.PathLike
            The file (``.csv``); its folder must exist.

        Returns
        -------
        pathlib.Path

        Raises
        ------
        ParameterError
            If the folder does not exist.
        """
        path = Path(path)
        if not path.parent.is_dir():
            raise fail("path", str(path), "a file in an existing folder")
        a = np.asarray(self.acceleration)
        acc_cols = ["acc_m_s2"] if a.ndim == 1 else ["acc_x_m_s2", "acc_y_m_s2", "acc_z_m_s2"]
        t = np.arange(len(self.speed)) / self.sample_rate
        data = np.column_stack([t, a.reshape(len(t), -1), self.speed, self.normal_force])
        np.savetxt(path, data, delimiter=",", fmt="%.17g", header=",".join(["time_s", *acc_cols, "speed_m_s", "force_n"]),
                   comments="")
        return path


RECORDING_QUANTITIES = {"time": "s", "acceleration": "m/s^2", "speed": "m/s", "force": "N", "position": "m"}
"""The quantities a recording's columns may be named for (``--column QUANTITY=COLS:UNIT``), with
their SI units: ``acceleration`` one or three columns, ``force`` the normal force, ``speed``
the tangential speed, or ``position`` one to three columns along the surface (the speed is then
derived: :data:`SPEED_FILTER`), ``time`` (else a sample rate)."""

SPEED_FILTER = (0.021, 3)
"""The Savitzky-Golay filter (window in s, polynomial order) whose first derivative of the
positions gives the speed when a recording has positions and no speed (chosen: 21 ms, cubic,
as the identification's derivatives; it passes the hand's motion, < 10 Hz, within 0.1 %)."""


def read_recording(path, *, sample_rate: float | None = None, columns=None) -> Recording:
    """Read a recording: CSV, NPZ or HDF5, with haptex's column names or the rig's own.

    Parameters
    ----------
    path : str or os.PathLike
        A CSV file with a header row naming its columns (any order), an ``.npz`` or an HDF5
        file (``.h5``/``.hdf5``): :func:`haptex._columns.read_table`.
    sample_rate : float, optional
        Rate (Hz), when the file has no time column.
    columns : sequence of str, optional
        Column specs ``QUANTITY=COL[,COL...][:UNIT]`` (:data:`RECORDING_QUANTITIES`), e.g.
        ``["acceleration=az:g", "force=fz:N", "position=x,y:mm", "time=t:ms"]``. A quantity
        not given is taken from haptex's own names (:data:`RECORDING_COLUMNS`) when the file
        has them. Columns named by neither are ignored and listed in ``Recording.ignored``.

    Returns
    -------
    Recording

    Raises
    ------
    ParameterError
        If the file is missing or larger than the memory budget allows, a named column is
        missing (the file's columns are listed), a quantity is missing (acceleration, force,
        and speed or position), a value is not a finite number, the times are not uniform,
        or neither times nor a sample rate are given.

    Notes
    -----
    Without a speed, the speed along the surface is the norm of the positions' first
    derivative by a Savitzky-Golay filter (:data:`SPEED_FILTER`; Savitzky & Golay, Anal. Chem.
    36(8), 1964), computed on the recording's own samples.
    """
    from scipy.signal import savgol_filter

    from ._columns import ColumnSpec, parse_column, read_table, take

    table = read_table(path, "recording")
    given = [parse_column(c, RECORDING_QUANTITIES) for c in (columns or ())]
    named = {c.quantity for c in given}
    if len(named) != len(given):
        raise fail("--column", [c.quantity for c in given], "each quantity once")
    own = {"time": ("time_s",), "speed": ("speed_m_s",), "force": ("force_n",)}
    own["acceleration"] = (("acc_m_s2",) if "acc_m_s2" in table else
                           ("acc_x_m_s2", "acc_y_m_s2", "acc_z_m_s2"))
    for q, cols in own.items():
        if q not in named and all(c in table for c in cols):
            given.append(ColumnSpec(q, cols, RECORDING_QUANTITIES[q], 1.0))
    got, ignored = take(table, given, "recording")
    for q in ("acceleration", "force"):
        if q not in got:
            raise fail("column", f"{q} missing", f"--column {q}=COLUMN[:UNIT], or haptex's {own[q][0]} "
                       f"({RECORDING_COLUMNS.get(own[q][0], '')})")
    if "speed" not in got and "position" not in got:
        raise fail("column", "speed missing", "--column speed=COLUMN[:UNIT] or --column position=X[,Y]:UNIT "
                   "(the speed is then derived), or haptex's speed_m_s")
    acc, force = got["acceleration"], got["force"]
    if acc.shape[1] not in (1, 3):
        raise fail("--column", f"acceleration with {acc.shape[1]} columns", "one column or three (x, y, z)")
    if force.shape[1] != 1:
        raise fail("--column", f"force with {force.shape[1]} columns", "one column: the normal force")
    if "time" in got:
        dt = np.diff(got["time"][:, 0])
        if dt.size < 1 or dt.min() <= 0 or dt.max() - dt.min() > 1e-6 * dt.mean():
            raise fail("time", "non-uniform or not increasing", "uniformly sampled times (s), increasing")
        fs = 1.0 / float(dt.mean())
        if sample_rate is not None and abs(fs - float(sample_rate)) > 1e-6 * fs:
            raise fail("sample_rate", sample_rate, f"None or {fs:g} Hz (the file's times)")
    elif sample_rate is None:
        raise fail("sample_rate", None, "a rate (Hz) for a recording without a time column")
    else:
        fs = positive("sample_rate", sample_rate, "Hz")
    if "speed" in got:
        speed, source = got["speed"][:, 0], "the file's speed"
    else:
        pos = got["position"]
        window = max(5, 2 * int(round(SPEED_FILTER[0] * fs / 2)) + 1)
        if window > len(pos):
            raise fail("position", f"{len(pos)} samples", f"at least {window} samples to derive the speed")
        vel = savgol_filter(pos, window, SPEED_FILTER[1], deriv=1, delta=1.0 / fs, axis=0)
        speed = np.sqrt(np.sum(vel * vel, axis=1))
        source = (f"the positions' derivative ({pos.shape[1]} axes; Savitzky-Golay, {window} samples, "
                  f"order {SPEED_FILTER[1]})")
    return Recording(acc[:, 0] if acc.shape[1] == 1 else acc, speed, force[:, 0], fs, tuple(ignored), source)


def spectral_difference(recorded, synthesized, sample_rate: float, band=(20.0, 450.0)) -> float:
    """Mean absolute difference (dB) of two signals' power spectra over a band.

    Parameters
    ----------
    recorded, synthesized : array_like, shape (n,) and (m,)
        Accelerations (m/s²) at ``sample_rate``.
    sample_rate : float
        Rate (Hz).
    band : tuple of float, optional
        (low, high) frequencies (Hz) compared.

    Returns
    -------
    float
        mean over the band of |10 log10(P_synth / P_rec)| (dB), each spectrum estimated by
        :func:`scipy.signal.welch` (Hann windows of 0.1 s or the signal, half overlapping):
        the spectral measure of the HaTT papers (Culbertson et al. 2014).

    Raises
    ------
    ParameterError
        If the band is not within (0, sample_rate / 2) or a signal is shorter than 64 samples.
    """
    from scipy.signal import welch

    fs = positive("sample_rate", sample_rate, "Hz")
    lo, hi = (float(b) for b in band)
    if not 0 < lo < hi <= fs / 2:
        raise fail("band", band, f"(low, high) with 0 < low < high <= {fs / 2:g} Hz")
    x, y = np.asarray(recorded, dtype=float), np.asarray(synthesized, dtype=float)
    if x.size < 64 or y.size < 64:
        raise fail("recorded", f"{min(x.size, y.size)} samples", "signals of at least 64 samples")
    nper = int(min(max(64, round(0.1 * fs)), x.size, y.size))
    f, px = welch(x, fs, nperseg=nper)
    _, py = welch(y, fs, nperseg=nper)
    sel = (f >= lo) & (f <= hi)
    return float(np.mean(np.abs(10 * np.log10(np.maximum(py[sel], 1e-300) / np.maximum(px[sel], 1e-300)))))


# ---------------------------------------------------------------------------------------
# a surface from a recording
# ---------------------------------------------------------------------------------------

SURFACE_BAND = (40.0, 450.0)
"""The vibration band (Hz) :func:`height_spectrum` reads by default (chosen: from twice
:func:`fit`'s 20 Hz high-pass, where that zero-phase filter takes under 0.04 dB, to the HaTT
papers' 450 Hz)."""
MAX_SURFACE_SAMPLES = 1 << 24
"""Most samples :func:`surface_from` synthesises (a 16 M-sample profile, 128 MiB)."""


def height_spectrum(models: ModelSet, wavenumber, *, band=SURFACE_BAND) -> np.ndarray:
    """The height spectrum of the surface whose scanning would give the models' vibration.

    A point following a profile h(x) at speed v has the acceleration a(t) = v² h''(vt),
    whose one-sided power spectral density is S_a(f) = (2 pi f)^4 S_h(f / v) / v, S_h the
    profile's one-sided height spectrum over the wavenumber k (cycles/m). Each model at a
    speed v > 0 thus gives S_h(k) = v S_a(k v) / (2 pi k v)^4 where k v lies in ``band``.
    The models that cover k are combined by their geometric mean (each AR estimate scatters
    about the truth; the least of them, tried first, sat 1.5-5 dB low on a known profile).
    Noise in the recording adds power where the vibration is weak: trust the band where it
    dominates the sensor's floor.

    Parameters
    ----------
    models : ModelSet
        Fitted or read models; their forces are not used (a point follower's vibration does not
        depend on how hard it presses).
    wavenumber : array_like, shape (n,)
        Spatial frequencies k (cycles/m), > 0.
    band : (float, float), optional
        The vibration band (Hz) trusted, within (0, sample_rate / 2]; default
        :data:`SURFACE_BAND`.

    Returns
    -------
    numpy.ndarray, shape (n,)
        S_h(k) (m² per cycle/m, i.e. m³; its integral over k is the height's variance); NaN
        where no model's band covers k.

    Raises
    ------
    ParameterError
        If a wavenumber is not positive and finite, the band is outside (0, sample_rate / 2],
        or no model has a positive speed.
    """
    k = np.asarray(wavenumber, dtype=float)
    if not np.all(np.isfinite(k) & (k > 0)):
        raise fail("wavenumber", wavenumber, "finite spatial frequencies > 0 (cycles/m)")
    lo, hi = (float(b) for b in band)
    fs = models.sample_rate
    if not 0 < lo < hi <= fs / 2:
        raise fail("band", band, f"(low, high) with 0 < low < high <= {fs / 2:g} Hz, the models' Nyquist frequency")
    moving = [m for m in models.models if m.speed > 0]
    if not moving:
        raise fail("models", models, "a model set with at least one model at a speed > 0")
    logs, count = np.zeros(k.shape), np.zeros(k.shape)
    for m in moving:
        f = k * m.speed
        inside = (f >= lo) & (f <= hi)
        if inside.any():
            sh = m.speed * m.psd(f[inside]) / (2 * np.pi * f[inside]) ** 4
            logs[inside] += np.log(np.maximum(sh, 1e-300))
            count[inside] += 1
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(count > 0, np.exp(logs / np.maximum(count, 1)), np.nan)


def surface_from(models: ModelSet, length: float, spacing: float | None = None, *, band=SURFACE_BAND,
                 seed: int = 0, areal: bool = False):
    """A profile whose scanning gives the models' vibration: the data-driven texture as a
    geometric one, which the conservative algorithms render passively.

    The profile's height spectrum is :func:`height_spectrum` on the harmonics of 1/length
    (zero where no model covers them: the recording says nothing there), with independent
    phases uniform in [0, 2 pi) from ``numpy.random.default_rng(seed)``; its amplitudes are
    exact, sqrt(2 S_h(k) / length) a harmonic, so its variance is the spectrum's integral.
    A point following it at any speed v has the acceleration spectrum
    (2 pi f)^4 S_h(f / v) / v: the speed scales the vibration, which interpolating models
    between speeds does not do (compare them at speeds held out of the fit).

    Parameters
    ----------
    models : ModelSet
        The vibration models (fitted from a recording or read).
    length : float
        The profile's length (m), periodic over it; its longest wavelength.
    spacing : float, optional
        Sample spacing (m); default a tenth of the shortest wavelength the models cover
        (the slowest model's speed over the band's top; chosen so that the profile's spline
        gives h'' within a few per cent there).
    band : (float, float), optional
        As :func:`height_spectrum`.
    seed : int, optional
        Seed of the phases.
    areal : bool, optional
        An isotropic surface on the square cell ``length`` x ``length`` instead (chosen: a
        recording along one line cannot show how the surface varies across it; the models,
        like HaTT's, are the same in every direction). Its 2-D spectrum is the isotropic one
        whose lines along x have, averaged over the lines, the profile's spectrum: a line of
        an isotropic surface also collects the oblique components of shorter wavelengths, so
        the radial spectrum is found by non-negative least squares
        (:func:`scipy.optimize.nnls`, relative errors) over the harmonics the models cover;
        exact amplitudes and uniform phases, as the profile's.

    Returns
    -------
    SampledProfile or SampledSurface
        Periodic over ``length`` (and across it when ``areal``), heights in m.

    Raises
    ------
    ParameterError
        For a non-positive length or spacing, more than :data:`MAX_SURFACE_SAMPLES` samples
        (an areal surface: more than :data:`MAX_AREAL_SIDE` a side), a spectrum that no model
        covers at any harmonic, or as :func:`height_spectrum`.
    """
    from .textures import SampledProfile

    L = positive("length", length, "m")
    moving = [m.speed for m in models.models if m.speed > 0]
    if not moving:
        raise fail("models", models, "a model set with at least one model at a speed > 0")
    dx = min(moving) / float(band[1]) / 10 if spacing is None else positive("spacing", spacing, "m")
    n = int(math.ceil(L / dx))
    if areal and n > MAX_AREAL_SIDE:
        raise fail("spacing", dx, f"at least {L / MAX_AREAL_SIDE:.3g} m for a {L:g} m square surface (at most "
                                  f"{MAX_AREAL_SIDE} samples a side), or a shorter length")
    if n > MAX_SURFACE_SAMPLES:
        raise fail("spacing", dx, f"at least {L / MAX_SURFACE_SAMPLES:.3g} m for a {L:g} m profile (at most "
                                  f"{MAX_SURFACE_SAMPLES} samples)")
    n += n % 2
    k = np.arange(1, n // 2) / L
    sh = height_spectrum(models, k, band=band)
    covered = np.isfinite(sh)
    if not covered.any():
        raise fail("length", L, f"a profile whose harmonics of 1/length reach the band the models cover "
                                f"({band[0]:g}-{band[1]:g} Hz at {min(moving):g}-{max(moving):g} m/s)")
    if areal:
        return _isotropic_surface(np.where(covered, sh / L, np.nan), n, L, seed,
                                  f"surface from {models.name or 'a model set'} ({band[0]:g}-{band[1]:g} Hz, isotropic)")
    amp = np.where(covered, np.sqrt(2 * np.nan_to_num(sh) / L), 0.0)
    phase = np.random.default_rng(seed).uniform(0.0, 2 * np.pi, k.size)
    spec = np.zeros(n // 2 + 1, dtype=complex)
    spec[1:n // 2] = 0.5 * n * amp * np.exp(1j * phase)
    h = np.fft.irfft(spec, n)
    x = np.arange(n) * (L / n)
    return SampledProfile(x, h, periodic=True, source=f"surface from {models.name or 'a model set'} "
                                                      f"({band[0]:g}-{band[1]:g} Hz)")


MAX_AREAL_SIDE = 1024
"""Most samples a side of :func:`surface_from`'s areal surface (8 MiB of heights)."""


def _isotropic_radial(line: np.ndarray) -> np.ndarray:
    """The radial spectrum g (variance a 2-D harmonic, at integer radii 1..m) of the isotropic
    surface whose lines along x hold ``line`` (variance a harmonic i = 1..m, NaN where nothing
    is asked). A line at i
    collects every (i, j): line[i] = sum_j g(sqrt(i^2 + j^2)), g linear between integer radii."""
    from scipy.optimize import nnls

    m = line.size
    asked = np.isfinite(line) & (line > 0)
    top = int(np.flatnonzero(asked).max()) + 1  # no radius beyond the highest harmonic asked
    i, j = np.meshgrid(np.arange(1, m + 1), np.arange(-m, m + 1), indexing="ij")
    rho = np.hypot(i, j)
    inside = rho <= top
    r0 = np.floor(rho[inside]).astype(int)
    t = rho[inside] - r0
    M = np.zeros((m, top))
    rows = (i[inside] - 1)
    np.add.at(M, (rows, r0 - 1), 1.0 - t)
    more = (t > 0) & (r0 < top)
    np.add.at(M, (rows[more], r0[more]), t[more])
    A = M[asked] / line[asked][:, None]
    g, _ = nnls(A, np.ones(int(asked.sum())), maxiter=50 * top)
    return np.concatenate([g, np.zeros(m - top)])


def _isotropic_surface(line: np.ndarray, n: int, L: float, seed: int, source: str):
    """A periodic n x n map on the cell L x L whose lines along x have, on average, the per-harmonic
    variances ``line`` (i = 1..n/2 - 1): its radial spectrum by :func:`_isotropic_radial`, exact
    amplitudes, phases uniform in [0, 2 pi) from ``seed``."""
    from .surfaces import SampledSurface

    m = n // 2 - 1
    g = _isotropic_radial(line[:m])
    iy = np.fft.fftfreq(n, 1.0 / n)  # the y harmonics, signed
    ix = np.arange(n // 2 + 1)
    rho = np.hypot(iy[:, None], ix[None, :])
    r0 = np.floor(rho).astype(int)
    t = rho - r0
    gg = np.concatenate([[0.0], g, [0.0, 0.0]])  # radius 0 and beyond m: nothing
    r0c = np.minimum(r0, m + 1)
    V = (1.0 - t) * gg[r0c] + t * gg[np.minimum(r0c + 1, m + 1)]
    V[:, 0] = 0.0  # (the pure-y column and the Nyquist ones: no line along x sees them)
    V[:, n // 2] = 0.0
    V[n // 2, :] = 0.0
    V[rho > m] = 0.0
    phase = np.random.default_rng(seed).uniform(0.0, 2 * np.pi, V.shape)
    Z = 0.5 * n * n * np.sqrt(2.0 * V) * np.exp(1j * phase)
    h = np.fft.irfft2(Z, s=(n, n)).T  # [x, y]
    x = np.arange(n) * (L / n)
    return SampledSurface(x, x.copy(), h, periodic=True, source=source)


# ---------------------------------------------------------------------------------------
# a geometric texture as a vibration: what a point following it records
# ---------------------------------------------------------------------------------------

VIBRATION_BAND = (20.0, 450.0)
"""Hz: the band of the HaTT papers' spectra (:func:`spectral_difference`'s default)."""
MAX_FOLLOWER_SAMPLES = 1 << 20
"""Most height samples :func:`follower_vibration` reads along x (8 MiB)."""


@dataclasses.dataclass(frozen=True)
class FollowerVibration:
    """The vibration a point following a texture along x at a constant speed records.

    Parameters
    ----------
    speed : float
        The scan's speed (m/s).
    band : tuple of float
        (low, high): the vibration band (Hz).
    rms : float
        RMS acceleration in the band (m/s²): a = v² h''(v t).
    wavelengths : tuple of float
        (v / high, v / low): the texture's wavelengths (m) the band holds at this speed.
    covered : tuple of float or None
        The part of the band (Hz) the texture's sampled extent resolves (a wavelength up to
        the span analysed, down to two samples); None when it resolves none of it.
    share : float
        The share of the texture's height variance in the band (0-1).
    peak_frequency : float or None
        The frequency (Hz) of the in-band component furthest above the hand's vibrotactile
        detection threshold; None without one.
    margin_db : float or None
        20 log10(displacement amplitude / :func:`haptex.perception.detection_threshold`) there
        (dB; > 0: above threshold, for a tip that follows the surface rigidly).
    """

    speed: float
    band: tuple
    rms: float
    wavelengths: tuple
    covered: tuple | None
    share: float
    peak_frequency: float | None
    margin_db: float | None

    def as_dict(self) -> dict:
        """The figures as a JSON-ready dict (SI units).

        Returns
        -------
        dict
        """
        return {k: (list(v) if isinstance(v, tuple) else v) for k, v in dataclasses.asdict(self).items()}


FOLLOWER_LINES = 16
"""Lines along x, evenly across its domain in y, over which :func:`follower_vibration` averages a
surface's spectrum when no line is named (chosen)."""


def _line_spectrum(texture, y) -> tuple[np.ndarray, np.ndarray, float, bool]:
    """(wavenumbers 1/m, peak amplitudes m, the span analysed m, exact) of the heights along x:
    a sum of sinusoids' own lines, else a periodogram of its samples over its domain (a
    surface's averaged over :data:`FOLLOWER_LINES` lines across it, or on the line ``y``)."""
    from scipy.signal import periodogram

    if getattr(texture, "periods", None) is not None and texture.dimension == 1:
        k = 1.0 / np.atleast_1d(np.asarray(texture.periods, dtype=float))
        a = np.abs(np.atleast_1d(np.asarray(texture.amplitudes, dtype=float)))
        return k, a, math.inf, True
    dom = texture.domain
    if dom is None:
        raise fail("texture", repr(texture), "a texture with a domain (a sampled texture or a periodic one)")
    (x0, x1) = dom if texture.dimension == 1 else dom[0]
    span = float(x1 - x0)
    short = float(texture.shortest_period) if texture.shortest_period else span / 1024
    n = int(min(MAX_FOLLOWER_SAMPLES, max(4096, math.ceil(8 * span / short))))
    periodic = bool(getattr(texture, "periodic", True))  # (an analytic texture's domain is a period)
    x = x0 + span * np.arange(n) / n if periodic else np.linspace(x0, x1, n)
    if texture.dimension == 1:
        rows = [texture.height(x)]
    else:
        (y0, y1) = dom[1]
        ys = [float(y)] if y is not None else list(y0 + (y1 - y0) * (np.arange(FOLLOWER_LINES) + 0.5) / FOLLOWER_LINES)
        rows = [texture.height_at(np.column_stack([x, np.full(n, yi)])) for yi in ys]
    dx = x[1] - x[0]
    p = 0.0
    for h in rows:
        k, pr = periodogram(h, fs=1.0 / dx, window="boxcar" if periodic else "hann",
                            detrend="constant" if periodic else "linear", scaling="spectrum")
        p = p + pr / len(rows)
    return k[1:], np.sqrt(2.0 * p[1:]), span, False


def follower_vibration(texture, speed: float, *, band=VIBRATION_BAND, y: float | None = None) -> FollowerVibration:
    """The vibration a point following ``texture`` along x at ``speed`` records, in a band.

    A geometric texture in the data-driven language: a tip that follows h(x) at speed v has
    the acceleration a(t) = v² h''(v t), each height component of wavenumber k (1/m) and peak
    amplitude A a vibration at f = v k of amplitude (2 pi f)² A. Its displacement is A, which
    :func:`haptex.perception.detection_threshold` says whether a hand feels.

    Parameters
    ----------
    texture : Texture
        A profile, or a surface read along x; a sum of sinusoids by its own lines, any other
        over its domain (one period, or the sampled range), by a periodogram of its heights
        (:func:`scipy.signal.periodogram`: a Hann window and a linear detrend unless it is
        periodic).
    speed : float
        m/s, > 0.
    band : tuple of float, optional
        (low, high) in Hz, 0 < low < high.
    y : float, optional
        On a surface, the line along x read (m); default the average over
        :data:`FOLLOWER_LINES` lines evenly across its domain in y.

    Returns
    -------
    FollowerVibration

    Raises
    ------
    ParameterError
        For a speed that is not > 0, a band that is not (low, high) with 0 < low < high, or a
        texture without a domain (an aperiodic sum over a surface).
    """
    from .perception import detection_threshold

    v = positive("speed", speed, "m/s")
    lo, hi = (float(b) for b in band)
    if not 0 < lo < hi or not math.isfinite(hi):
        raise fail("band", band, "(low, high) in Hz with 0 < low < high")
    k, a, span, exact = _line_spectrum(texture, y)
    f = v * k
    inside = (f >= lo) & (f <= hi) & (a > 1e-15 * max(float(a.max(initial=0.0)), 1e-300))
    acc = (2 * np.pi * f[inside]) ** 2 * a[inside]
    total = float(np.sum(a**2))
    covered = None
    if exact:
        covered = (lo, hi)
    else:
        dx = span / max(1, k.size * 2)
        c_lo, c_hi = max(lo, v / span), min(hi, v / (2 * dx))
        covered = (c_lo, c_hi) if c_lo < c_hi else None
    peak = margin = None
    if inside.any():
        m = 20 * np.log10(a[inside] / detection_threshold(f[inside]))
        i = int(np.argmax(m))
        peak, margin = float(f[inside][i]), float(m[i])
    return FollowerVibration(v, (lo, hi), float(np.sqrt(np.sum(acc**2) / 2)), (v / hi, v / lo), covered,
                             float(np.sum(a[inside] ** 2) / total) if total > 0 else 0.0, peak, margin)


# ---------------------------------------------------------------------------------------
# energy at the port
# ---------------------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class VibrationEnergy:
    """The mean power a vibration channel supplies at a device's port.

    Parameters
    ----------
    power : float
        Mean power (W) the vibration force supplies to the handle and the hand holding it
        (> 0: the channel is an active source).
    to_hand : float
        The part (W) dissipated in the hand's damping.
    to_device : float
        The part (W) dissipated in the device's own damping.
    rms_force : float
        RMS of the vibration force (N).
    effective_mass : float
        Mass (kg) by which the acceleration is turned into a force.
    period : float
        The servo period (s): the force is held over each (zero-order hold).
    """

    power: float
    to_hand: float
    to_device: float
    rms_force: float
    effective_mass: float
    period: float

    def gain_for(self, budget: float) -> float:
        """The factor on the vibration that keeps its mean power within ``budget``.

        Parameters
        ----------
        budget : float
            Power (W) the channel may supply, >= 0.

        Returns
        -------
        float
            min(1, sqrt(budget / power)): the power scales with the gain squared.

        Raises
        ------
        ParameterError
            If the budget is negative or not finite.
        """
        from ._validation import nonnegative

        b = nonnegative("budget", budget, "W")
        return 1.0 if self.power <= b else math.sqrt(b / self.power)


def require_servo_rate(models, period: float, name: str = "vibration", value=None, on: str | None = None) -> None:
    """Refuse models that do not run at a device's servo rate.

    The vibration channel's tick is one sample of the set (Culbertson et al. 2014 resample
    HaTT's 10 kHz models for this reason), so a set, or a model, must run at 1 / ``period``:
    :func:`port_energy`, :func:`haptex.simulate`, and ``haptex run``, ``export`` and
    ``simulate`` with ``--vibration`` check it here.

    Parameters
    ----------
    models : ModelSet or ArmaModel
        Its ``sample_rate`` (Hz) is checked.
    period : float
        The device's servo period (s).
    name, value : str, object, optional
        The parameter the refusal names, and its value (default: the models' rate).
    on : str, optional
        The device the refusal names.

    Raises
    ------
    ParameterError
        If ``models.sample_rate * period`` is not 1 within 1e-6; the message names both
        rates and the fit that gives the device's (``fit(..., rate=)``, ``haptex fit --rate``).
    """
    rate = float(models.sample_rate)
    if abs(rate * period - 1.0) <= 1e-6:
        return
    servo = 1.0 / period
    shown = f"{rate:g} Hz" if value is None else value
    shown = repr(shown) if isinstance(shown, str) else _fmt(shown)  # (a file's path whole)
    raise ParameterError(f"{name} = {shown} is not allowed{f' on {on}' if on else ''}: must be a model at the "
                         f"device's servo rate, {servo:g} Hz: its models run at {rate:g} Hz, the device's servo at "
                         f"{servo:g} Hz (fit them at that rate: haptex.datadriven.fit(..., rate={servo:g}), or "
                         f"haptex fit RECORDING --rate '{servo:g} Hz')")


def port_energy(model: ArmaModel, device, hand=None, *, axis: int = 0, mass: float | None = None) -> VibrationEnergy:
    """The mean power a vibration supplies when displayed as a force on a device held by a hand.

    Parameters
    ----------
    model : ArmaModel
        The vibration (acceleration, m/s²), at the device's servo rate.
    device : Device
        The device (:class:`haptex.Device`, e.g. a preset's); its mass and damping along
        ``axis`` are the handle's.
    hand : Hand, optional
        The hand holding the handle (:func:`haptex.catalogue.hand`): its mass, damping and
        stiffness act on the handle; default none (a free handle).
    axis : int, optional
        The device axis the force acts along (the direction of motion).
    mass : float, optional
        Effective mass (kg) turning acceleration into force (HaTT's display on a Phantom:
        force = mass x acceleration); default the device's own mass along ``axis``.

    Returns
    -------
    VibrationEnergy

    Raises
    ------
    ParameterError
        If the model's rate is not the device's servo rate (to 1e-6), the axis is out of
        range, or the mass is not > 0.

    Notes
    -----
    Exact for the sampled system: the force sequence f_k (one-sided PSD S_f = m² S_a) is held
    over each period T on the handle and hand, M = m_d + m_h, B = b_d + b_h, K = k_h, whose
    zero-order-hold transfer from f_k to x_k is H(z) (:func:`scipy.signal.cont2discrete`).
    The work of f_k over its period is f_k (x_{k+1} - x_k), so the mean power is

        P = (1 / T) ∫_0^{1/(2T)} S_f(f) Re[(e^{j2πfT} - 1) H(e^{j2πfT})] df,

    and, the stored energy being stationary, it is dissipated in the two dampers in the ratio
    b_h : b_d. This is the energy an energy-based stabiliser (a passivity observer,
    Hannaford & Ryu 2002; energy bounding, Kim & Ryu 2004) sees as supplied at the port.
    """
    from scipy.signal import cont2discrete, freqz

    T = float(device.period)
    require_servo_rate(model, T, "model")
    dim = np.atleast_2d(device.mass).shape[0]
    if not (isinstance(axis, int | np.integer) and 0 <= axis < dim):
        raise fail("axis", axis, f"an axis of the device, 0 to {dim - 1}")
    md = float(np.atleast_2d(device.mass)[axis, axis])
    bd = float(np.atleast_2d(device.damping)[axis, axis])
    m_eff = md if mass is None else positive("mass", mass, "kg")
    mh = bh = kh = 0.0
    if hand is not None:
        mh, bh, kh = float(hand.mass), float(hand.damping), float(hand.stiffness)
    M, B, K = md + mh, bd + bh, kh
    num, den, _ = cont2discrete(([1.0], [M, B, K]), T, method="zoh")
    n = 1 << 15  # the midpoint rule: no sample at f = 0, where a free handle's H has its pole (z = 1)
    df = 0.5 / T / n
    f = (np.arange(n) + 0.5) * df
    _, h = freqz(np.ravel(num), den, worN=f, fs=1.0 / T)
    g = np.real((np.exp(2j * np.pi * f * T) - 1.0) * h)
    s_f = m_eff**2 * model.psd(f)
    power = float(np.sum(s_f * g) * df / T)
    share = (lambda b: power * b / B) if B > 0 else (lambda b: 0.0)
    return VibrationEnergy(power, share(bh), share(bd), m_eff * math.sqrt(model.output_variance()), m_eff, T)
