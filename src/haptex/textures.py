"""Height profiles h(x) over the nominal surface z = 0.

A texture turns user parameters into the compact arrays that the compiled kernels read
(see :mod:`haptex._kernels`) and offers vectorised NumPy evaluation of the height, slope
and curvature for analysis. All lengths are in metres.
"""

from __future__ import annotations

import math
from fractions import Fraction
from functools import cached_property

import numpy as np
from scipy.optimize import minimize_scalar

from . import _kernels
from ._validation import ParameterError, fail, finite, nonnegative, positive


class Texture:
    """Base class of height profiles h(x) (metres) along the scan direction x (metres).

    Subclasses provide :meth:`height`, :meth:`slope`, :meth:`curvature` and
    :meth:`kernel_data`. Analysis code relies on :attr:`max_slope` (the Lipschitz bound M
    of Remark 2 in Campion & Hayward), :attr:`shortest_period`, :attr:`period` (``None``
    when the profile is not periodic) and :attr:`height_range`.
    """

    def height(self, x):  # pragma: no cover - abstract
        raise NotImplementedError

    def slope(self, x):  # pragma: no cover - abstract
        raise NotImplementedError

    def curvature(self, x):  # pragma: no cover - abstract
        raise NotImplementedError

    def kernel_data(self) -> tuple[int, np.ndarray]:  # pragma: no cover - abstract
        raise NotImplementedError

    @property
    def peak_magnitude(self) -> float:
        """max |h(x)| (m)."""
        lo, hi = self.height_range
        return max(abs(lo), abs(hi))

    @property
    def closest_point_step(self) -> float:
        """Sampling step (m) used by the closest-point search: 1/64 of the shortest period."""
        return self.shortest_period / 64.0


class SumOfSinusoids(Texture):
    """A sum of sinusoids h(x) = sum_k a_k sin(2 pi x / l_k + phi_k).

    Parameters
    ----------
    amplitudes : array_like, shape (n,)
        Amplitudes a_k >= 0 (m).
    periods : array_like, shape (n,)
        Spatial periods l_k > 0 (m).
    phases : array_like, shape (n,), optional
        Phases phi_k (rad); zero by default.

    Raises
    ------
    ParameterError
        If the arrays are empty or of different lengths, an amplitude is negative, a
        period is not > 0, or any value is not finite.

    Notes
    -----
    Remark 2 of Campion & Hayward extends the single-sinusoid results to sums of
    sinusoids, with 2 pi A / l replaced by the Lipschitz bound M = sup |h'|.
    :attr:`max_slope` is that sup, computed over one common period when the periods are
    commensurate (ratios rational with denominators <= 1000), and otherwise the
    triangle-inequality bound sum_k 2 pi a_k / l_k, which is rigorous but may be loose
    (:attr:`max_slope_is_exact` tells which).
    """

    def __init__(self, amplitudes, periods, phases=None):
        a = _vector("amplitudes", amplitudes)
        l = _vector("periods", periods)
        ph = np.zeros_like(a) if phases is None else _vector("phases", phases)
        if not (a.shape == l.shape == ph.shape):
            raise ParameterError(
                f"amplitudes, periods and phases have lengths {a.size}, {l.size}, {ph.size}, "
                "which is not allowed: they must have the same length"
            )
        for i, v in enumerate(a):
            nonnegative(f"amplitudes[{i}]", v, "m")
        for i, v in enumerate(l):
            positive(f"periods[{i}]", v, "m")
        self.amplitudes = a
        self.periods = l
        self.phases = ph
        self._coeffs = np.ascontiguousarray(np.vstack([a, 2 * np.pi / l, ph]))

    def __repr__(self) -> str:
        return (
            f"SumOfSinusoids(amplitudes={self.amplitudes.tolist()}, "
            f"periods={self.periods.tolist()}, phases={self.phases.tolist()})"
        )

    # -- evaluation -------------------------------------------------------------------
    def _args(self, x):
        x = np.asarray(x, dtype=np.float64)
        return x[..., None] * self._coeffs[1] + self._coeffs[2]

    def height(self, x):
        """Height h(x) (m) for x of any shape (m); returns the same shape."""
        return np.sin(self._args(x)) @ self.amplitudes

    def slope(self, x):
        """Slope h'(x) (dimensionless) for x of any shape (m)."""
        return np.cos(self._args(x)) @ (self.amplitudes * self._coeffs[1])

    def curvature(self, x):
        """Second derivative h''(x) (1/m) for x of any shape (m)."""
        return -(np.sin(self._args(x)) @ (self.amplitudes * self._coeffs[1] ** 2))

    def kernel_data(self) -> tuple[int, np.ndarray]:
        """(kind, coeffs) for the compiled kernels: ``TEXTURE_FOURIER`` and a (3, n)
        array of amplitudes (m), wavenumbers 2 pi / l (rad/m) and phases (rad)."""
        return _kernels.TEXTURE_FOURIER, self._coeffs

    # -- summary numbers --------------------------------------------------------------
    @property
    def shortest_period(self) -> float:
        """Shortest spatial period among the components with a non-zero amplitude (m)."""
        live = self.periods[self.amplitudes > 0]
        return float((live if live.size else self.periods).min())

    @cached_property
    def period(self) -> float | None:
        """Common (fundamental) period of the profile (m), or ``None`` if the periods are
        not commensurate with ratio denominators <= 1000."""
        live = self.periods[self.amplitudes > 0]
        if live.size == 0:
            return float(self.periods.max())
        base = float(live.min())
        num, den = 1, 0
        for p in live:
            fr = Fraction(float(p) / base).limit_denominator(1000)
            if abs(float(fr) * base - p) > 1e-9 * p:
                return None
            num = math.lcm(num, fr.numerator)
            den = math.gcd(den, fr.denominator)
        return base * num / den

    def _extreme(self, fun) -> float:
        """sup over x of |fun(x)|, by dense sampling of one period and bounded refinement."""
        period = self.period
        n = int(min(max(64 * period / self.shortest_period, 1024), 2_000_000))
        x = np.linspace(0.0, period, n, endpoint=False)
        y = np.abs(fun(x))
        dx = period / n
        best = float(y.max())
        for i in np.argsort(y)[-8:]:
            r = minimize_scalar(
                lambda t: -abs(float(fun(np.array([t]))[0])),
                bounds=(x[i] - dx, x[i] + dx),
                method="bounded",
                options={"xatol": 1e-12 * period},
            )
            best = max(best, -float(r.fun))
        return best

    @cached_property
    def max_slope_is_exact(self) -> bool:
        """True when :attr:`max_slope` is the computed sup rather than an upper bound."""
        return self.period is not None

    @cached_property
    def max_slope(self) -> float:
        """Lipschitz bound M = sup |h'(x)| (dimensionless), Remark 2."""
        if self.period is None:
            return float(np.sum(2 * np.pi * self.amplitudes / self.periods))
        return self._extreme(self.slope)

    @cached_property
    def max_curvature(self) -> float:
        """sup |h''(x)| (1/m); an upper bound when the profile is not periodic."""
        if self.period is None:
            return float(np.sum(self.amplitudes * (2 * np.pi / self.periods) ** 2))
        return self._extreme(self.curvature)

    @cached_property
    def height_range(self) -> tuple[float, float]:
        """(min h, max h) in metres; the bound (-sum a, sum a) when not periodic."""
        total = float(self.amplitudes.sum())
        if self.period is None:
            return (-total, total)
        period = self.period
        n = int(min(max(64 * period / self.shortest_period, 1024), 2_000_000))
        x = np.linspace(0.0, period, n, endpoint=False)
        h = self.height(x)
        # the sampling error of an extremum is below max|h''| dx^2 / 8
        pad = self.max_curvature * (period / n) ** 2 / 8
        return (max(float(h.min()) - pad, -total), min(float(h.max()) + pad, total))


class Sinusoid(SumOfSinusoids):
    """A single sinusoid h(x) = A sin(2 pi x / l + phase), the texture of the paper.

    Parameters
    ----------
    amplitude : float
        A >= 0 (m).
    period : float
        Spatial period l > 0 (m).
    phase : float, optional
        Phase (rad), default 0.

    Raises
    ------
    ParameterError
        If ``amplitude`` < 0, ``period`` <= 0 or any value is not finite.

    Notes
    -----
    ``max_slope`` is 2 pi A / l exactly (Section IV-A, eq. 10) and ``max_curvature`` is
    4 pi^2 A / l^2.
    """

    def __init__(self, amplitude, period, phase=0.0):
        self.amplitude = nonnegative("amplitude", amplitude, "m")
        self.period_ = positive("period", period, "m")
        phase = finite("phase", phase, "rad")
        super().__init__([self.amplitude], [self.period_], [phase])

    def __repr__(self) -> str:
        return f"Sinusoid(amplitude={self.amplitude:g}, period={self.period_:g}, phase={self.phases[0]:g})"

    @property
    def period(self) -> float:  # type: ignore[override]
        return self.period_

    @property
    def max_slope(self) -> float:  # type: ignore[override]
        return 2 * np.pi * self.amplitude / self.period_

    @property
    def max_slope_is_exact(self) -> bool:  # type: ignore[override]
        return True

    @property
    def max_curvature(self) -> float:  # type: ignore[override]
        return 4 * np.pi**2 * self.amplitude / self.period_**2

    @property
    def height_range(self) -> tuple[float, float]:  # type: ignore[override]
        return (-self.amplitude, self.amplitude)


class Flat(Texture):
    """The untextured nominal surface h(x) = 0 (used by algorithm W)."""

    period = None
    max_slope = 0.0
    max_slope_is_exact = True
    max_curvature = 0.0
    height_range = (0.0, 0.0)
    shortest_period = 1e-3  # only sets the closest-point step; any positive value works

    def __repr__(self) -> str:
        return "Flat()"

    def height(self, x):
        """h(x) = 0 (m)."""
        return np.zeros(np.shape(x))

    slope = height
    curvature = height

    def kernel_data(self) -> tuple[int, np.ndarray]:
        """(``TEXTURE_FLAT``, empty coefficients)."""
        return _kernels.TEXTURE_FLAT, _kernels.empty_coeffs()


def _vector(name: str, values) -> np.ndarray:
    try:
        arr = np.atleast_1d(np.asarray(values, dtype=np.float64))
    except (TypeError, ValueError):
        raise fail(name, values, "a 1-D sequence of finite numbers") from None
    if arr.ndim != 1 or arr.size == 0:
        raise fail(name, values, "a non-empty 1-D sequence of finite numbers")
    if not np.all(np.isfinite(arr)):
        raise fail(name, values, "a 1-D sequence of finite numbers (no NaN or inf)")
    return np.ascontiguousarray(arr)
