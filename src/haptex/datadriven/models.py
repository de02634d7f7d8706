"""One ARMA model, a set of them over (speed, force) interpolated by LSF, and its check."""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path

import numpy as np

from .._validation import ParameterError, fail, finite, nonnegative, numbers, out_file, positive, random_seed, whole
from .lsf import MAX_ORDER, lsf_to_poly, poly_to_lsf

FORMAT = "haptex-arma-models"
"""The ``format`` field of haptex's own model files (:meth:`ModelSet.write`)."""

FORMAT_VERSION = 1
"""The version of haptex's model files this release reads and writes."""


MAX_MODELS = 512
"""Most models a set may hold (``HX_VIB_MAX_MODELS``): the tick's search tests each triangle
at most once, and a set has at most twice as many triangles as models."""

MAX_SAMPLES = 50_000_000
"""Most samples one :meth:`ModelSet.synthesize` call produces (400 MB of float64)."""

G = 9.80665
"""Standard gravity (m/s²), for accelerations given in g."""

_ACC_UNITS = {"m/s^2": 1.0, "m/s2": 1.0, "m/s²": 1.0, "g": G}



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
            try:
                v = np.array(getattr(self, name), dtype=float)
            except (TypeError, ValueError):
                v = None
            if v is None or v.ndim != 1 or v.size < 1 or v.size - 1 > MAX_ORDER:
                raise fail(name, getattr(self, name), f"a polynomial [1, c_1, ..., c_n] with n <= {MAX_ORDER}")
            v.setflags(write=False)
            object.__setattr__(self, name, v)
        object.__setattr__(self, "_lsf", (_lsf_of("ar", self.ar), _lsf_of("ma", self.ma)))
        object.__setattr__(self, "variance", nonnegative("variance", self.variance, "(m/s^2)^2"))
        object.__setattr__(self, "gain", finite("gain", self.gain))
        object.__setattr__(self, "sample_rate", positive("sample_rate", self.sample_rate, "Hz"))
        for name, unit in (("speed", "m/s"), ("force", "N")):  # (NaN: the operating point not stated)
            value = getattr(self, name)
            if not (isinstance(value, float | np.floating) and math.isnan(value)):
                value = nonnegative(name, value, unit)
            object.__setattr__(self, name, value)

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
            If a frequency is negative, above the Nyquist frequency, not finite or not a real
            number (a bool, text or a complex number).
        """
        from scipy.signal import freqz

        f = numbers("frequency", frequency, f"frequencies in [0, {self.sample_rate / 2:g}] Hz", copy=False)
        if not np.all(np.isfinite(f)) or np.any(f < 0) or np.any(f > self.sample_rate / 2 * (1 + 1e-12)):
            raise fail("frequency", frequency, f"frequencies in [0, {self.sample_rate / 2:g}] Hz (the Nyquist frequency)")
        _, h = freqz(self.ma, self.ar, worN=np.atleast_1d(f).ravel(), fs=self.sample_rate)
        out = 2.0 * self.variance * self.gain**2 * np.abs(h) ** 2 / self.sample_rate
        return out.reshape(f.shape)

    def output_variance(self) -> float:
        """Variance of the model's stationary output ((m/s²)²): the integral of :meth:`psd`.

        Returns
        -------
        float
            The stationary output's variance ((m/s²)²).
        """
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
        self.report = None  # the FitReport, set by fit()
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
            If speed or force is not finite, or negative (HaTT's speed is the tangential speed's
            magnitude and its force the normal force: both >= 0).
        """
        s, f = _finite("speed", speed, "m/s"), _finite("force", force, "N")
        for name, v, unit in (("speed", s, "m/s, the tangential speed's magnitude"), ("force", f, "N, the normal force")):
            if v < 0.0:
                raise fail(name, v, f"a number >= 0 ({unit})")
        n = len(self.models)
        if n == 1:  # (one model: everywhere its own point's, moved there unless at it)
            m = self.models[0]
            return np.array([0]), np.array([1.0]), bool(s != m.speed or f != m.force)
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
            If the lengths disagree, a speed or force is not a real number (a bool, text or
            a complex number), no length is given, the signal would exceed
            :data:`MAX_SAMPLES` samples, or the seed is not an integer in range.
        """
        from ..core import _ext

        sp = np.atleast_1d(numbers("speed", speed, "a number or a one-dimensional array (m/s)", copy=False))
        fo = np.atleast_1d(numbers("force", force, "a number or a one-dimensional array (N)", copy=False))
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
        seed = random_seed("seed", seed)
        sp = np.ascontiguousarray(np.broadcast_to(sp, (n,)), dtype=float)
        fo = np.ascontiguousarray(np.broadcast_to(fo, (n,)), dtype=float)
        out = np.empty(n)
        clamped, faults, work = _ext.vibration(self._packed, sp, fo, out, seed)
        self.last_counts = {"clamped": int(clamped), "faults": int(faults), "max_work": int(work)}
        return out

    # ---- files ------------------------------------------------------------------------

    def to_dict(self) -> dict:
        """haptex's model file as a dict (:data:`FORMAT`, version :data:`FORMAT_VERSION`, SI units).

        Returns
        -------
        dict
            The set in haptex's model file layout, SI units.
        """
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
        path = out_file("path", path)
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
    points = whole("points", points, 1, 10**6)
    t = positive("seconds", seconds, "s")
    if not 1.0 < t <= 3600.0:
        raise fail("seconds", seconds, "a length in (1, 3600] s")
    seed = random_seed("seed", seed)
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


