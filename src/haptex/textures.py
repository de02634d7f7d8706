"""Height profiles h(x) over the nominal surface z = 0.

A texture turns user parameters into the compact arrays that the compiled kernels read
(see :mod:`haptex.core`) and offers vectorised NumPy evaluation of the height, slope
and curvature for analysis. All lengths are in metres.
"""

from __future__ import annotations

import math
from fractions import Fraction
from functools import cached_property

import numpy as np

from .core import _ext
from .probe import (MAX_SAMPLES as MAX_PROBE_SAMPLES, _check_ball_fits, _check_work, _coarsest_spacing, _grid_contacts,
                    _spacing, _steps_text)
from ._validation import (MAX_LENGTH, ParameterError, check_count, fail, finite, flag, in_range, nonnegative,
                          not_a_texture, numbers, positive, random_seed, scale_factors, whole)


MAX_HARMONICS = 100_000
"""Most harmonics a Fourier texture may have (each evaluation of h costs one per harmonic)."""


def checked_texture(texture, name: str = "texture") -> "Texture":
    """``texture`` as given where it is a :class:`Texture`, else a refusal naming what makes one:
    the first check of every public function that takes a texture.

    Parameters
    ----------
    texture : Texture
        A profile h(x) or a surface h(x, y) (m).
    name : str, optional
        The parameter's name in the refusal.

    Returns
    -------
    Texture
        ``texture`` itself.

    Raises
    ------
    ParameterError
        For anything else (a spec as the command line writes it, "sine:0.2mm,2mm", among them),
        naming a class that makes it (``haptex.Sinusoid(0.8e-3, 1e-3)``, SI units) and
        :func:`haptex.load_texture` for a measured file.
    """
    if isinstance(texture, Texture):
        return texture
    raise not_a_texture(texture, name)


class Texture:
    """Base class of textures: height profiles h(x) and surfaces h(x, y) (metres).

    A texture knows its :attr:`dimension`: 1 for a profile over the scan direction x, 2
    for a surface over the plane (x, y). The algorithms and the analysis read it through
    :meth:`height_at`, :meth:`gradient` and :meth:`hessian` on in-plane coordinates of
    shape (..., dimension), so one implementation serves both (a profile is the 1-D case
    of a surface). Profiles also provide :meth:`height`, :meth:`slope`, :meth:`curvature`
    on abscissae of any shape, and :meth:`kernel_data` for the compiled kernels. Analysis
    code relies on :attr:`max_slope` (the Lipschitz bound M = sup |grad h| of Remark 2 in
    Campion & Hayward), :attr:`shortest_period`, :attr:`period` (``None`` when the
    texture is not periodic) and :attr:`height_range`. A texture read from a file whose
    instrument states its tip has that radius (m) in ``instrument_tip`` (a Dektak's stylus;
    :func:`haptex.probe.reliability_cutoff`), else None.
    """

    dimension = 1
    instrument_tip: float | None = None  # the measuring tip's radius (m), where a file states it

    def height_at(self, xt):
        """The height h at in-plane positions (m).

        Parameters
        ----------
        xt : array_like, shape (..., dimension)
            In-plane positions (m): [x] on a profile, [x, y] on a surface.

        Returns
        -------
        numpy.ndarray
            shape (...): h (m).
        """
        return self.height(xt[..., 0])

    def gradient(self, xt):
        """The gradient of h at in-plane positions.

        Parameters
        ----------
        xt : array_like, shape (..., dimension)
            In-plane positions (m): [x] on a profile, [x, y] on a surface.

        Returns
        -------
        numpy.ndarray
            shape (..., dimension): grad h (m/m).
        """
        return self.slope(xt[..., 0])[..., None]

    def hessian(self, xt):
        """The Hessian of h at in-plane positions.

        Parameters
        ----------
        xt : array_like, shape (..., dimension)
            In-plane positions (m): [x] on a profile, [x, y] on a surface.

        Returns
        -------
        numpy.ndarray
            shape (..., dimension, dimension): the second derivatives of h (1/m).
        """
        return self.curvature(xt[..., 0])[..., None, None]

    def _jet(self, xt, hessian: bool = True):
        """(:meth:`height_at`, :meth:`gradient`, :meth:`hessian` or None) at in-plane positions
        xt (..., dimension) (m): shapes (...), (..., dimension), (..., dimension, dimension). A
        texture that evaluates them together (a height map's patches) answers in one call."""
        return self.height_at(xt), self.gradient(xt), (self.hessian(xt) if hessian else None)

    def height(self, x):  # pragma: no cover - abstract
        raise NotImplementedError

    def slope(self, x):  # pragma: no cover - abstract
        raise NotImplementedError

    def curvature(self, x):  # pragma: no cover - abstract
        raise NotImplementedError

    def kernel_data(self) -> tuple[int, np.ndarray]:  # pragma: no cover - abstract
        raise NotImplementedError

    def felt_by(self, tip_radius: float, *, spacing: float | None = None) -> "Texture":
        """The texture a ball of radius ``tip_radius`` (m) feels: :func:`haptex.probe.felt_by`.

        Parameters
        ----------
        tip_radius : float
            The ball's radius r (m), >= 0 (0: the paper's point probe, this texture itself).
        spacing : float, optional
            Grid spacing (m) for an analytic texture (see :func:`haptex.probe.felt_by`).

        Returns
        -------
        Texture
            A :class:`SampledProfile` (or :class:`~haptex.SampledSurface`) of the heights (m)
            of the ball's lowest point resting on this texture.

        Raises
        ------
        ParameterError
            As :func:`haptex.probe.felt_by`.
        """
        r = in_range("tip_radius", tip_radius, 0.0, MAX_LENGTH, "m")  # (past a kilometre, past any work bound)
        if r == 0.0:
            return self
        out = self._felt(r, spacing)
        out._felt_radius = r  # (what it was felt by, and what: an export's refusal names a --tip-spacing that fits)
        out._felt_from = self
        return out

    def _felt(self, r: float, spacing: float | None) -> "Texture":
        """A profile's felt texture (a ball of radius r > 0, m): the ball's centre path at each grid
        point, its contact point found on the grid and refined on this texture itself, and the
        path's slope there the contact's (the envelope theorem), so that a kink where the ball
        bridges a trough is a slope jump between two points and not an overshoot of a spline.
        With no spacing given the grid is halved while the segments' curvature at the grid points
        differs from the path's (its own there, from the contact's: h''(s) phi' / (phi' - h''(s)),
        phi' = r^2 / (r^2 - u^2)^(3/2); beside a kink the path's one-sided limit there,
        :func:`_kink_limits`, which the segments beside it take at their end by it), by more
        than PROFILE_CURVATURE_SLACK of the path's largest, within PROFILE_REFINE_SAMPLES: near
        the troughs' radius the path's curvature, kappa / (1 - r kappa), spikes over a few
        hundred nm, and beside a kink it is largest at the kink itself, which B, C and G read.
        Each finer grid's contacts are followed from the last grid's (:func:`_seeded_contacts`);
        a refined profile keeps the first grid's shortest period (its analyses' grids and
        limits)."""
        x, h, periodic, source = _profile_grid(self, r, spacing)
        hf, sf, kinks, miss, contact, bowed = _contact_path(self, x, h, r, periodic)
        shortest = None  # (the first grid's, once refined)
        while (spacing is None and PROFILE_CURVATURE_SLACK < miss < math.inf
               and 2 * x.size <= PROFILE_REFINE_SAMPLES):  # (infinite: a grid point at a fold, on every grid)
            finer = _profile_grid(self, r, 0.5 * float(x[1] - x[0]), followed=True)
            more = _contact_path(self, finer[0], finer[1], r, finer[2], seed=(x, contact))
            if shortest is None:
                shortest = self.shortest_period if isinstance(self, SampledProfile) else 2.0 * float(x[1] - x[0])
            (x, h, periodic, source), (hf, sf, kinks, miss, contact, bowed) = finer, more
        out = SampledProfile(x, hf, periodic=periodic, slopes=sf, shortest_period=shortest,
                             source=f"{source} felt by a ball of r = {r * 1e3:g} mm")
        out.kinks = kinks
        out.curvature_miss, out.convex_miss = float(miss), float(bowed)
        return out

    @property
    def peak_magnitude(self) -> float:
        """max |h(x)| (m)."""
        lo, hi = self.height_range
        return max(abs(lo), abs(hi))


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
        period is not > 0, or any value is not a finite real number (a bool, text or a
        complex number is not one).

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
        self._coeffs = np.ascontiguousarray(self.coefficients(a, l, ph))

    @staticmethod
    def coefficients(amplitudes, periods, phases) -> np.ndarray:
        """The compiled kernels' coefficients (:meth:`kernel_data`) of sums of sinusoids,
        elementwise over leading axes. No checks (the constructor's).

        Parameters
        ----------
        amplitudes : array_like, shape (..., n)
            a_k (m).
        periods : array_like, shape (..., n)
            l_k (m), > 0.
        phases : array_like, shape (..., n)
            phi_k (rad).

        Returns
        -------
        numpy.ndarray, shape (..., 3, n)
            a_k, the wavenumbers 2 pi / l_k (rad/m) and the phases.
        """
        a, per, ph = np.broadcast_arrays(*(np.asarray(v, dtype=np.float64) for v in (amplitudes, periods, phases)))
        return np.stack([a, 2 * np.pi / per, ph], axis=-2)

    def __repr__(self) -> str:
        return (
            f"SumOfSinusoids(amplitudes={self.amplitudes.tolist()}, "
            f"periods={self.periods.tolist()}, phases={self.phases.tolist()})"
        )

    # -- evaluation -------------------------------------------------------------------
    def _series(self, x, fun, weights):
        """sum_k weights_k fun(k_k x + phi_k), in chunks of x so that the (points x harmonics)
        temporary stays below 32 MiB whatever the sizes."""
        x = np.asarray(x, dtype=np.float64)
        flat = x.reshape(-1)
        out = np.empty(flat.size)
        step = max(1, (4 * 1024**2) // self.amplitudes.size)
        for i in range(0, flat.size, step):
            out[i:i + step] = fun(flat[i:i + step, None] * self._coeffs[1] + self._coeffs[2]) @ weights
        return out.reshape(x.shape)

    def height(self, x):
        """The height h(x) = sum_k a_k sin(2 pi x / l_k + phi_k).

        Parameters
        ----------
        x : array_like
            Positions along the profile (m), any shape.

        Returns
        -------
        numpy.ndarray
            The same shape: h(x) (m).
        """
        return self._series(x, np.sin, self.amplitudes)

    def slope(self, x):
        """The slope h'(x).

        Parameters
        ----------
        x : array_like
            Positions along the profile (m), any shape.

        Returns
        -------
        numpy.ndarray
            The same shape: h'(x) (dimensionless).
        """
        return self._series(x, np.cos, self.amplitudes * self._coeffs[1])

    def curvature(self, x):
        """The second derivative h''(x).

        Parameters
        ----------
        x : array_like
            Positions along the profile (m), any shape.

        Returns
        -------
        numpy.ndarray
            The same shape: h''(x) (1/m).
        """
        return -self._series(x, np.sin, self.amplitudes * self._coeffs[1] ** 2)

    def kernel_data(self) -> tuple[int, np.ndarray]:
        """(kind, coeffs) for the compiled kernels: ``TEXTURE_FOURIER`` and a (3, n)
        array of amplitudes (m), wavenumbers 2 pi / l (rad/m) and phases (rad).

        Returns
        -------
        tuple of (int, numpy.ndarray)
            ``TEXTURE_FOURIER`` and the coefficients, shape (3, n): amplitudes (m),
            wavenumbers (rad/m), phases (rad).
        """
        return _ext.TEXTURE_FOURIER, self._coeffs

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
        return common_period(live)

    def _extreme(self, fun) -> float:
        """sup over x of |fun(x)|, by dense sampling of one period and bounded refinement."""
        period = self.period
        n = int(min(max(64 * period / self.shortest_period, 1024), 2_000_000))
        x = np.linspace(0.0, period, n, endpoint=False)
        y = np.abs(fun(x))
        dx = period / n
        best = float(y.max())
        from scipy.optimize import minimize_scalar

        for i in np.argsort(y, kind="stable")[-8:]:
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

    def spectrum(self) -> tuple[np.ndarray, np.ndarray]:
        """Line spectrum: spatial frequencies 1/l_k (1/m) and amplitudes a_k (m), shape (n,).

        Returns
        -------
        tuple of numpy.ndarray
            Spatial frequencies 1/l_k (1/m) and amplitudes a_k (m), each shape (n,).
        """
        order = np.argsort(self.periods, kind="stable")[::-1]
        return 1.0 / self.periods[order], self.amplitudes[order]

    @property
    def domain(self) -> tuple[float, float] | None:
        """Abscissa interval (m) analysed by default: one period, or None if aperiodic."""
        return None if self.period is None else (0.0, float(self.period))

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

    Examples
    --------
    >>> tex = hx.Sinusoid(amplitude=0.8e-3, period=1e-3)
    >>> round(tex.max_slope, 4)  # 2 pi A / l
    5.0265
    >>> float(tex.height(0.25e-3))  # a crest
    0.0008
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
        """l (m)."""
        return self.period_

    @property
    def max_slope(self) -> float:  # type: ignore[override]
        """2 pi A / l, exactly (Section IV-A's M)."""
        return 2 * np.pi * self.amplitude / self.period_

    @property
    def max_slope_is_exact(self) -> bool:  # type: ignore[override]
        """True: :attr:`max_slope` is the closed form."""
        return True

    @property
    def max_curvature(self) -> float:  # type: ignore[override]
        """4 pi^2 A / l^2 (1/m), exactly."""
        return 4 * np.pi**2 * self.amplitude / self.period_**2

    @property
    def height_range(self) -> tuple[float, float]:  # type: ignore[override]
        """(-A, A) (m)."""
        return (-self.amplitude, self.amplitude)


class BandLimitedNoise(SumOfSinusoids):
    """A stochastic, band-limited profile, periodic over ``length``, reproducible from ``seed``.

    h(x) = sum_k a sin(2 pi k x / length + phi_k) over every harmonic k whose period
    length / k lies in [shortest_period, longest_period], with equal amplitudes a (a flat
    amplitude spectrum in the band) and independent phases uniform in [0, 2 pi) drawn by
    ``numpy.random.default_rng(seed)``; a = rms sqrt(2 / n) so the profile's RMS height
    is exactly ``rms``.

    Parameters
    ----------
    rms : float
        RMS height (m), >= 0.
    shortest_period, longest_period : float
        Band limits (m), 0 < shortest <= longest <= length.
    length : float
        Period of the whole profile (m).
    seed : int
        Seed of the phases.

    Raises
    ------
    ParameterError
        For out-of-range values or a band that contains no harmonic of 1/length.
    """

    def __init__(self, rms, shortest_period, longest_period, length, seed=0):
        rms = nonnegative("rms", rms, "m")
        lmin = positive("shortest_period", shortest_period, "m")
        lmax = positive("longest_period", longest_period, "m")
        L = positive("length", length, "m")
        if not lmin <= lmax <= L:
            raise fail("longest_period", lmax, f"in [shortest_period = {lmin:g}, length = {L:g}] m")
        k_lo, k_hi = math.ceil(L / lmax - 1e-9), math.floor(L / lmin + 1e-9)
        check_count("shortest_period", lmin, k_hi - k_lo + 1, MAX_HARMONICS,
                    f"harmonics of 1/length = {1 / L:g} 1/m (each evaluation of h costs one per harmonic)")
        k = np.arange(k_lo, k_hi + 1)
        k = k[k >= 1]
        if k.size == 0:
            raise fail("shortest_period", lmin, f"a band that contains a harmonic of 1/length = {1 / L:g} 1/m")
        seed = random_seed("seed", seed)
        rng = np.random.default_rng(seed)
        phases = rng.uniform(0.0, 2 * np.pi, k.size)
        amp = rms * math.sqrt(2.0 / k.size)
        self.rms = rms
        self.length = L
        self.seed = int(seed)
        super().__init__(np.full(k.size, amp), L / k, phases)

    def __repr__(self) -> str:
        return (f"BandLimitedNoise(rms={self.rms:g}, shortest_period={self.periods.min():g}, "
                f"longest_period={self.periods.max():g}, length={self.length:g}, seed={self.seed})")

    @property
    def period(self) -> float:  # type: ignore[override]
        """The length (m) over which the noise repeats."""
        return self.length


SAMPLES_PER_CUTOFF = 32
"""Samples per shortest period kept by ``band_limited`` (profiles and surfaces)."""


class SampledProfile(Texture):
    """A measured height profile, evaluated by a C^2 cubic spline through its samples.

    Parameters
    ----------
    x : array_like, shape (n,)
        Abscissae (m), strictly increasing, n >= 4. Uniform spacing is used as is; a
        non-uniform one is resampled onto a uniform grid of the same number of points by
        the spline through the given samples (``resampled`` tells).
    h : array_like, shape (n,)
        Heights (m), finite.
    periodic : bool, optional
        Close the profile into a periodic texture (the last sample joins the first one
        ``dx`` later; period n dx) with a periodic spline. Otherwise a not-a-knot spline
        over [x_0, x_n-1], extended beyond the ends by straight lines with the end
        slopes (C^1 there), and analysed over the sampled range.
    shortest_period : float, optional
        The shortest period present (m); default the Nyquist period 2 dx. ``lowpass`` sets
        it to its cut-off.
    source : str, optional
        Where the heights came from (a file, a construction).
    slopes : array_like, shape (n,) or (m, 2), optional
        The slope at each sample (dimensionless), when it is known exactly: the profile is
        then the cubic Hermite interpolant through heights and slopes instead of the C^2
        spline. Shape (m, 2), one row an interval (m = n periodic, n - 1 otherwise): the
        slopes at its start and end, which may differ from the neighbouring interval's (a
        kink at a sample: a felt texture's ball path). Needs a uniform grid.

    Attributes
    ----------
    kinks : numpy.ndarray, shape (k, 2)
        For a felt texture, the places (m) where the ball's contact jumps across a trough and
        the slope jump there (dimensionless): the forces of B, C and G (eqs. 11, 14, 28: they
        read the slope) jump there; A's, D's, E's and F's do not (below a V-shaped kink the
        closest point is the kink itself). Empty otherwise.
    curvature_miss : float or None
        For a felt profile: how far its segments' curvature misses the ball path's, as a
        fraction of the path's largest (at its grid points, and at the kinks' one-sided limits,
        which the segments beside a kink take at their end by it), on the grid it was made on;
        with no spacing given the grid is halved while this passes ``PROFILE_CURVATURE_SLACK`` (1 %), within
        ``PROFILE_REFINE_SAMPLES``. q of B, C and G (which read the curvature, eqs. 11, 14, 28)
        is then within about this fraction of q on the ball's path. None for any other profile.
    convex_miss : float or None
        For a felt profile: how far its most convex curvature (its segments' least h'', where
        negative) misses the path's most convex at its grid points, as a fraction of that, and
        its segments' ends against the path's where either is convex, beside no kink. q of D,
        d_max / (R - d_max) below the most convex point of radius R (eq. 18), is then off by
        about ``convex_miss`` (1 + q). Reported, not refined by: on `Sinusoid(0.1 mm, 2 mm)` at
        0.99 times its troughs' radius 3.1 % on 262,144 samples (its most convex curvature 2.8 %
        above the crest's closed form), 6.5 % when refined to 524,288; 0.16 % at 0.95 times.
        None for any other profile.

    Raises
    ------
    ParameterError
        For mismatched lengths, fewer than 4 samples, values that are not finite real
        numbers (a bool, text or a complex number is not one), x not strictly
        increasing (the message gives the first offending index), a ``periodic`` that is not
        True or False, or ``slopes`` not numbers of the shapes above.

    Notes
    -----
    The spline's coefficients are what the compiled kernels read (``TEXTURE_SPLINE``).
    ``max_slope`` (Remark 2's M) and ``max_curvature`` are exact for the spline: its
    derivative is quadratic and its second derivative linear on each interval.
    """

    def __init__(self, x, h, periodic: bool = False, shortest_period: float | None = None, source: str = "",
                 slopes=None):
        x = _vector("x", x)
        h = _vector("h", h)
        if x.size != h.size:
            raise ParameterError(f"x and h have lengths {x.size} and {h.size}, which is not allowed: they must match")
        if x.size < 4:
            raise ParameterError(f"the profile has {x.size} samples, which is not allowed: at least 4 are needed")
        for name, v in (("x", x), ("h", h)):
            big = np.nonzero(~(np.abs(v) <= MAX_LENGTH))[0]
            if big.size:
                i = int(big[0])
                raise ParameterError(f"{name}[{i}] = {v[i]:g} is not allowed: samples must lie within "
                                     f"+-{MAX_LENGTH:g} m (check the unit)")
        dx_all = np.diff(x)
        if not np.all(dx_all > 0):
            i = int(np.argmax(~(dx_all > 0))) + 1
            raise ParameterError(f"x[{i}] = {x[i]:g} is not allowed: x must increase strictly (x[{i - 1}] = {x[i - 1]:g})")
        from scipy.interpolate import CubicSpline

        n = x.size
        dx = (x[-1] - x[0]) / (n - 1)
        self.resampled = bool(np.max(np.abs(dx_all - dx)) > 1e-6 * dx)
        if self.resampled:
            xu = x[0] + dx * np.arange(n)
            h = CubicSpline(x, h)(xu)
            x = xu
        self.x = x
        self.h = h
        self.dx = float(dx)
        self.periodic = flag("periodic", periodic)
        self.source = source
        self.kinks = np.zeros((0, 2))
        self.curvature_miss = self.convex_miss = None
        if slopes is not None:
            from scipy.interpolate import PPoly

            try:
                sl = np.asarray(slopes, dtype=float)
            except (TypeError, ValueError):
                raise fail("slopes", slopes, "an array of finite slopes (dimensionless), shape (n,) or (m, 2)") from None
            m_int = h.size if self.periodic else h.size - 1
            if sl.shape == (h.size,):
                sl = np.column_stack([sl, np.r_[sl[1:], sl[:1]]])[:m_int]
            if sl.shape != (m_int, 2) or self.resampled or not np.all(np.isfinite(sl)):
                raise fail("slopes", f"shape {np.shape(slopes)}", f"({h.size},) or ({m_int}, 2) finite slopes on a "
                           "uniform grid")
            he = np.r_[h, h[0]] if self.periodic else h
            xe = np.r_[x, x[-1] + dx] if self.periodic else x
            d = np.diff(he) / dx  # the cubic Hermite segment of each interval, its end slopes sl[i]
            c = np.array([(sl[:, 0] + sl[:, 1] - 2 * d) / dx**2, (3 * d - 2 * sl[:, 0] - sl[:, 1]) / dx, sl[:, 0],
                          he[:-1]])
            spline = PPoly(c, xe)
        elif self.periodic:
            xe = np.r_[x, x[-1] + dx]
            spline = CubicSpline(xe, np.r_[h, h[0]], bc_type="periodic")
        else:
            spline = CubicSpline(x, h, bc_type="not-a-knot")
        m = spline.c.shape[1]
        coeffs = np.zeros((4, m + 2))
        coeffs[:, :m] = spline.c
        coeffs[:, m] = [x[0], dx, 1.0 if self.periodic else 0.0, m]
        s_left = float(spline(x[0], 1))
        s_right = float(spline(spline.x[-1], 1))
        coeffs[:, m + 1] = [float(spline(x[0])), s_left, float(spline(spline.x[-1])), s_right]
        self._coeffs = np.ascontiguousarray(coeffs)
        self._m = m
        nyquist = 2 * dx
        self._shortest = nyquist if shortest_period is None else max(positive("shortest_period", shortest_period, "m"),
                                                                     nyquist)

    def __repr__(self) -> str:
        src = f", source={self.source!r}" if self.source else ""
        return (f"SampledProfile(n={self.x.size}, dx={self.dx:g}, length={self.length:g}, "
                f"periodic={self.periodic}{src})")

    # -- evaluation (plain NumPy twin of the compiled TEXTURE_SPLINE evaluation) ------------
    def _eval(self, x, order):
        try:
            x = np.asarray(x, dtype=np.float64)
        except (TypeError, ValueError):
            raise fail("x", x, "positions along the profile (m): finite numbers") from None
        if not np.isfinite(x).all():
            raise fail("x", x if x.ndim == 0 else f"an array holding {x[~np.isfinite(x)].flat[0]}",
                       "positions along the profile (m): finite numbers")
        c = self._coeffs
        m, dx, x0 = self._m, self.dx, self.x[0]
        L = m * dx
        u = x - x0
        if self.periodic:
            u = np.mod(u, L)
        if u.ndim:  # (the cells' indices in place, the four coefficients in one gather: the
            i = (u / dx).astype(np.int64)  # felt path's golden sections call this on a few
            np.maximum(i, 0, out=i)  # hundred points at a time, where numpy's calls are the cost)
            np.minimum(i, m - 1, out=i)
            a3, a2, a1, a0 = c.take(i, axis=1)
        else:
            i = min(max(int(u / dx), 0), m - 1)
            a3, a2, a1, a0 = c[:, i]
        t = u - i * dx
        if order == 0:
            val = ((a3 * t + a2) * t + a1) * t + a0
        elif order == 1:
            val = (3 * a3 * t + 2 * a2) * t + a1
        else:
            val = 6 * a3 * t + 2 * a2
        if not self.periodic:  # (the straight extensions, where a position is off the sampled range)
            hl, sl, hr, sr = c[:, m + 1]
            if not u.ndim:
                if u < 0:
                    val = hl + sl * u if order == 0 else (sl if order == 1 else 0.0)
                elif u > L:
                    val = hr + sr * (u - L) if order == 0 else (sr if order == 1 else 0.0)
                return np.asarray(val, dtype=np.float64)  # (0-d, as numpy's where gave it)
            for side, at, lin in ((u < 0, 0.0, (hl, sl)), (u > L, L, (hr, sr))):
                if side.any():
                    val[side] = lin[0] + lin[1] * (u[side] - at) if order == 0 else (lin[1] if order == 1 else 0.0)
        return val

    def height(self, x):
        """h(x), the spline's (or the Hermite interpolant's) value.

        Parameters
        ----------
        x : array_like
            Positions along the profile (m), any shape.

        Returns
        -------
        numpy.ndarray
            The same shape: h(x) (m).

        Raises
        ------
        ParameterError
            If a position is not a finite number.
        """
        return self._eval(x, 0)

    def slope(self, x):
        """h'(x).

        Parameters
        ----------
        x : array_like
            Positions along the profile (m), any shape.

        Returns
        -------
        numpy.ndarray
            The same shape: h'(x) (dimensionless).

        Raises
        ------
        ParameterError
            If a position is not a finite number.
        """
        return self._eval(x, 1)

    def curvature(self, x):
        """h''(x); 0 on the straight extensions of a non-periodic profile.

        Parameters
        ----------
        x : array_like
            Positions along the profile (m), any shape.

        Returns
        -------
        numpy.ndarray
            The same shape: h''(x) (1/m).

        Raises
        ------
        ParameterError
            If a position is not a finite number.
        """
        return self._eval(x, 2)

    def kernel_data(self) -> tuple[int, np.ndarray]:
        """(``TEXTURE_SPLINE``, coefficients) for the compiled kernels.

        Returns
        -------
        tuple of (int, numpy.ndarray)
            ``TEXTURE_SPLINE`` and the spline's coefficients, shape (4, m + 2): the
            intervals' cubics (m), then the grid and the ends' values and slopes.
        """
        return _ext.TEXTURE_SPLINE, self._coeffs

    # -- summary numbers ---------------------------------------------------------------------
    @property
    def length(self) -> float:
        """Length covered by the spline (m): n dx if periodic, (n - 1) dx otherwise."""
        return self._m * self.dx

    @property
    def period(self) -> float | None:  # type: ignore[override]
        """n dx for a periodic profile, else None."""
        return self.length if self.periodic else None

    @property
    def domain(self) -> tuple[float, float]:
        """The sampled range [x_0, x_0 + length] (m), analysed by default."""
        return float(self.x[0]), float(self.x[0] + self.length)

    @property
    def shortest_period(self) -> float:
        """Shortest period present (m): the low-pass cut-off, else the Nyquist period 2 dx."""
        return self._shortest

    @cached_property
    def max_slope(self) -> float:
        """Exact sup |h'| of the spline (Remark 2's M)."""
        c = self._coeffs[:, : self._m]
        a3, a2, a1 = c[0], c[1], c[2]
        vals = [np.abs(a1), np.abs((3 * a3 * self.dx + 2 * a2) * self.dx + a1)]
        with np.errstate(divide="ignore", invalid="ignore"):
            tv = np.where(a3 != 0, -a2 / (3 * a3), -1.0)
        inside = (tv > 0) & (tv < self.dx)
        vals.append(np.where(inside, np.abs((3 * a3 * tv + 2 * a2) * tv + a1), 0.0))
        return float(max(v.max() for v in vals))

    max_slope_is_exact = True

    @cached_property
    def max_curvature(self) -> float:
        """Exact sup |h''| of the spline (1/m)."""
        c = self._coeffs[:, : self._m]
        return float(max(np.abs(2 * c[1]).max(), np.abs(6 * c[0] * self.dx + 2 * c[1]).max()))

    @cached_property
    def height_range(self) -> tuple[float, float]:
        """(min h, max h) over the spline's range (m)."""
        x = self.x[0] + np.linspace(0, self.length, 8 * self._m + 1)
        hh = self.height(x)
        pad = self.max_curvature * (self.dx / 8) ** 2 / 8
        return float(hh.min() - pad), float(hh.max() + pad)

    def spectrum(self) -> tuple[np.ndarray, np.ndarray]:
        """Single-sided amplitude spectrum of the samples: spatial frequency (1/m) and
        amplitude (m), from numpy's rfft (amplitude 2|H_k|/n, DC and Nyquist not doubled).

        Returns
        -------
        tuple of numpy.ndarray
            Spatial frequencies (1/m) and amplitudes (m), each shape (n // 2 + 1,).
        """
        n = self.h.size
        H = np.fft.rfft(self.h - self.h.mean())
        amp = 2 * np.abs(H) / n
        amp[0] = abs(self.h.mean())
        if n % 2 == 0:
            amp[-1] /= 2
        return np.fft.rfftfreq(n, self.dx), amp

    # -- helpers -----------------------------------------------------------------------------
    def _new(self, x, h, shortest=None, periodic=None):
        return SampledProfile(x, h, self.periodic if periodic is None else periodic,
                              self._shortest if shortest is None else shortest, self.source)

    def leveled(self) -> SampledProfile:
        """The profile minus its least-squares straight line (removes tilt and offset).

        Returns
        -------
        SampledProfile
            The levelled profile (m), on the same grid.
        """
        line = np.polyval(np.polyfit(self.x - self.x[0], self.h, 1), self.x - self.x[0])
        return self._new(self.x, self.h - line)

    def lowpass(self, shortest_period: float) -> SampledProfile:
        """Band-limit the profile to periods >= ``shortest_period`` (m), as Section II asks.

        Periodic profiles: the FFT components above the cut-off frequency are removed.
        Others: a zero-phase 4th-order Butterworth filter (scipy.signal.sosfiltfilt).

        Parameters
        ----------
        shortest_period : float
            The cut-off period (m).

        Returns
        -------
        SampledProfile

        Raises
        ------
        ParameterError
            If the cut-off is not above the Nyquist period 2 dx, or is longer than the scan.
        """
        lc = positive("shortest_period", shortest_period, "m")
        length = float(self.x[-1] - self.x[0])
        if not 2 * self.dx < lc <= length:
            raise fail("shortest_period", lc, f"longer than the Nyquist period 2 dx = {2 * self.dx:g} m and at most the "
                       f"scan's length, {length:g} m (a longer cut-off leaves no period of the scan)")
        if self.periodic:
            H = np.fft.rfft(self.h)
            f = np.fft.rfftfreq(self.h.size, self.dx)
            H[f > 1.0 / lc] = 0.0
            hf = np.fft.irfft(H, self.h.size)
        else:
            from scipy.signal import butter

            hf = zero_phase_lowpass(butter(4, (1.0 / lc) / (0.5 / self.dx), output="sos"), self.h, 0)
        return self._new(self.x, hf, shortest=lc)

    def band_limited(self, shortest_period: float, samples_per_period: int = SAMPLES_PER_CUTOFF) -> SampledProfile:
        """What a device renders of this profile: band-limited to periods >= ``shortest_period``
        (:meth:`lowpass`, when the profile holds shorter ones) and resampled to at least
        ``samples_per_period`` samples per shortest period, so that every analysis grid
        scales with the rendered texture, not with the instrument's sample count.

        Periodic profiles are resampled in the Fourier domain (exact for the band-limited
        profile); others are decimated by the largest whole factor that keeps the samples
        per period (no interpolation: every kept sample is a filtered sample).

        Parameters
        ----------
        shortest_period : float
            l_c (m), e.g. :func:`haptex.analysis.rendering_cutoff`'s.
        samples_per_period : int, optional
            Samples per l_c kept (default 32: a cubic spline's curvature then errs by about
            (2 pi / 32)^2 / 12 = 0.3 % at l_c).

        Returns
        -------
        SampledProfile
            ``self`` when it is already band-limited and not oversampled.

        Raises
        ------
        ParameterError
            For a non-positive period or fewer than 4 samples per period.
        """
        prof, h, (step,) = _band_limited_samples(self, shortest_period, samples_per_period, (self.dx,))
        if h is None:
            return prof
        return SampledProfile(self.x[0] + step * np.arange(h.size), h, self.periodic, prof._shortest, self.source)

    def scaled(self, length_factor: float = 1.0, height_factor: float = 1.0) -> SampledProfile:
        """Stretch the profile: x by ``length_factor`` and h by ``height_factor``
        (a 1.5 mm scan can be felt as a 15 mm texture).

        Parameters
        ----------
        length_factor : float, optional
            Factor on x, > 0.
        height_factor : float, optional
            Factor on the heights, finite.

        Returns
        -------
        SampledProfile

        Raises
        ------
        ParameterError
            For a length factor not > 0 or a height factor not finite, or either so large that
            the scaled samples would lie beyond +-MAX_LENGTH (1000 m; the largest it takes is
            said).
        """
        lf, hf = scale_factors(length_factor, height_factor, float(np.abs(self.x).max()), float(np.abs(self.h).max()))
        return self._new(self.x * lf, self.h * hf, shortest=self._shortest * lf)

    @classmethod
    def from_file(cls, path, *, spacing=None, x_unit=None, height_unit=None, variable=None, x_column=0,
                  height_column=1, periodic: bool = False, fill_undefined: bool = False, crop=None) -> SampledProfile:
        """Load a measured line scan.

        Every format SurfaceTopography reads (some 40 instrument formats: Dektak CSV and
        OPDx, Wyko OPD, Zygo DATX and MetroPro, Digital Surf SUR, X3P, SDF, Gwyddion,
        Keyence, Olympus, Sensofar, Bruker/Veeco, NT-MDT, plain text, HDF5, NPY, ...) with
        its stated physical size and unit; MATLAB ``.mat`` files and text columns
        SurfaceTopography does not recognise by haptex's own readers (see ``_loaders``).
        Positions printed rounded (a Dektak export's 0.1 um) are taken as the uniform
        grid they round. An areal map is refused: read it with
        ``SampledSurface.from_file`` and take ``.line(...)``.

        Parameters
        ----------
        path : str or Path
        spacing : float or str, optional
            Sample spacing ("0.5um" or metres). Required when the file states no physical
            size (a .mat vector, a single text column, an NPY array); never guessed.
        x_unit, height_unit : str, optional
            Units of the file's positions and heights ("um", "nm", "mm", "m"). Required
            when the file does not state them, refused when it does; never guessed.
        variable : str, optional
            The variable of a .mat file, the channel of a multi-channel instrument file (its
            name, or its index where two share a name), or the heights' column of a text table
            of four or more named columns (its name or index; the positions then from
            ``spacing``, the unit the one its name states, "Altitude (um)", where not given);
            default its only variable, or the instrument's height channel.
        x_column, height_column : int, optional
            Columns of a text file (0-based; x_column=None for heights only). Other than
            (0, 1) the file is read by haptex's text reader.
        periodic : bool, optional
            See :class:`SampledProfile`.
        fill_undefined : bool, optional
            Fill undefined (NaN) heights by SurfaceTopography's interpolation; by default a
            file with undefined heights is refused, naming how many and where.
        crop : "auto" or (float, float), optional
            The part of the scan kept: ``"auto"``, its longest run of defined samples, or
            ``(x0, x1)`` in metres.

        Raises
        ------
        ParameterError
            One line naming the file for an unknown format, a truncated or corrupt file,
            an unparseable or refused unit, undefined heights, non-increasing x, fewer than
            4 samples, a missing spacing or unit, an areal map, or a file too large for the
            memory budget.
        """
        from ._loaders import read_topography

        r = read_topography(path, spacing=spacing, x_unit=x_unit, height_unit=height_unit, variable=variable,
                            x_column=x_column, height_column=height_column, fill_undefined=fill_undefined, crop=crop)
        if r.areal:
            raise ParameterError(f"{path}: holds an areal map ({r.x.size} x {r.y.size} samples), not a line scan: read "
                                 "it with SampledSurface.from_file (haptex reads it as a surface at the command line) "
                                 "and take one line with .line(y=...) or .line(row=...)")
        out = cls(r.x, r.h, periodic=periodic, source=r.source)
        out.instrument_tip = r.instrument_tip
        return out


def zero_phase_lowpass(sos, h: np.ndarray, axis: int) -> np.ndarray:
    """scipy.signal.sosfiltfilt of ``h`` along ``axis``, its edge padding (3 (2 sections + 1)
    samples by default) shortened to the samples there are: a short scan (a 5 x 10 NetCDF
    map, a 10-sample text column) is filtered instead of ending in scipy's 'padlen' error.
    Each line's least-squares straight line along ``axis`` is taken out before and put back
    after: a tilted scan's ramp would otherwise start the filter's transient at each end, which
    at a cut-off of thousands of samples spans most of the scan (the Dektak scan of
    ``examples/data``, tilted by 16 um: its 1.5 mm component 2.6 times and its 0.4 mm one 5-7
    times the measured, where levelled the filter keeps them).

    Parameters
    ----------
    sos : ndarray, shape (n_sections, 6)
        Second-order sections (scipy.signal.butter(..., output="sos")).
    h : ndarray
        Heights (m), at least 2 samples along ``axis``.
    axis : int
        The axis filtered.

    Returns
    -------
    ndarray
        Filtered heights (m), the shape of ``h``.
    """
    from scipy.signal import sosfiltfilt

    n = h.shape[axis]
    shape = [1] * h.ndim
    shape[axis] = n
    t = np.linspace(-1.0, 1.0, n).reshape(shape)
    mean = h.mean(axis=axis, keepdims=True)
    slope = np.sum(t * (h - mean), axis=axis, keepdims=True) / np.sum(t * t)
    trend = mean + slope * t
    return sosfiltfilt(sos, h - trend, axis=axis, padlen=min(3 * (2 * len(sos) + 1), n - 1)) + trend


def _band_limited_samples(tex, shortest_period, samples_per_period, steps):
    """The shared work of ``band_limited`` for a profile (steps (dx,)) or a map (dx, dy):
    (the texture low-passed to ``shortest_period`` when it holds shorter periods, its
    samples thinned along every axis or None when no axis was thinned, the new steps)."""
    lc = positive("shortest_period", shortest_period, "m")
    per = whole("samples_per_period", samples_per_period, 4, 10**6)
    filtered = tex.lowpass(lc) if lc > tex._shortest else tex
    keep = max(lc, tex._shortest)
    h, new = filtered.h, []
    for axis, step in enumerate(steps):
        h, step = _decimated(h, axis, step, keep, tex.periodic, per)
        new.append(step)
    return filtered, (None if h is filtered.h else h), tuple(new)


def _decimated(h: np.ndarray, axis: int, step: float, lc: float, periodic: bool, per: int):
    """Samples of a texture band-limited to periods >= lc, thinned along ``axis`` to at least
    ``per`` samples per lc: (h, step) unchanged when they are not more than twice as dense,
    else the new samples and spacing (Fourier resampling of a periodic texture, decimation
    by a whole factor otherwise)."""
    n = h.shape[axis]
    if periodic:
        m = max(int(math.ceil(n * step * per / lc)), 4)
        if 2 * m > n:
            return h, step
        from scipy.signal import resample

        return resample(h, m, axis=axis), n * step / m
    k = int((lc / per) // step)
    if k < 2 or (n - 1) // k + 1 < 4:
        return h, step
    return np.take(h, np.arange(0, n, k), axis=axis), k * step


class Flat(Texture):
    """The untextured nominal surface h = 0 (used by algorithm W).

    Parameters
    ----------
    dimension : {1, 2}, optional
        1: a profile (positions [x, z]); 2: a surface (positions [x, y, z]).

    Raises
    ------
    ParameterError
        For another dimension.
    """

    period = None
    domain = None
    max_slope = 0.0
    max_slope_is_exact = True
    max_curvature = 0.0
    height_range = (0.0, 0.0)
    shortest_period = 1e-3  # only sets the closest-point step; any positive value works

    def __init__(self, dimension: int = 1):
        self.dimension = whole("dimension", dimension, 1, 2, "(1: a profile h(x), 2: a surface h(x, y))")

    def __repr__(self) -> str:
        return "Flat()" if self.dimension == 1 else "Flat(dimension=2)"

    def _felt(self, r: float, spacing: float | None) -> "Flat":
        return self  # a ball rests on a plane at the plane

    def height(self, x):
        """h(x) = 0, as are h'(x) and h''(x) (``slope`` and ``curvature`` are this method).

        Parameters
        ----------
        x : array_like
            Positions along the profile (m), any shape.

        Returns
        -------
        numpy.ndarray
            The same shape: zeros (m, dimensionless, 1/m).
        """
        return np.zeros(np.shape(x))

    slope = height
    curvature = height

    def gradient(self, xt):
        """grad h = 0.

        Parameters
        ----------
        xt : array_like, shape (..., dimension)
            In-plane positions (m): [x] on a profile, [x, y] on a surface.

        Returns
        -------
        numpy.ndarray
            zeros, shape (..., dimension).
        """
        return np.zeros(np.shape(xt)[:-1] + (self.dimension,))

    def hessian(self, xt):
        """The Hessian of h = 0.

        Parameters
        ----------
        xt : array_like, shape (..., dimension)
            In-plane positions (m): [x] on a profile, [x, y] on a surface.

        Returns
        -------
        numpy.ndarray
            zeros, shape (..., dimension, dimension).
        """
        return np.zeros(np.shape(xt)[:-1] + (self.dimension, self.dimension))

    def kernel_data(self) -> tuple[int, np.ndarray]:
        """(``TEXTURE_FLAT``, empty coefficients).

        Returns
        -------
        tuple of (int, numpy.ndarray)
            ``TEXTURE_FLAT`` and an empty array.
        """
        return _ext.TEXTURE_FLAT, np.zeros((3, 0))

    def spectrum(self) -> tuple[np.ndarray, np.ndarray]:
        """Empty: a flat surface has no texture.

        Returns
        -------
        tuple of numpy.ndarray
            Two empty arrays: spatial frequencies (1/m) and amplitudes (m).
        """
        return np.zeros(0), np.zeros(0)


def common_period(periods) -> float | None:
    """The least common multiple of positive periods.

    Parameters
    ----------
    periods : array_like, shape (n,)
        Periods (m), > 0.

    Returns
    -------
    float or None
        The common period (m), or None when two of them are not commensurate with a ratio of
        denominator <= 1000 (to 1e-9 relative).
    """
    base = float(np.min(periods))
    num, den = 1, 0
    for p in periods:
        fr = Fraction(float(p) / base).limit_denominator(1000)
        if abs(float(fr) * base - p) > 1e-9 * p:
            return None
        num = math.lcm(num, fr.numerator)
        den = math.gcd(den, fr.denominator)
    return base * num / den


def _vector(name: str, values) -> np.ndarray:
    arr = np.atleast_1d(numbers(name, values, "a 1-D sequence of finite numbers", copy=False))
    if arr.ndim != 1 or arr.size == 0:
        raise fail(name, values, "a non-empty 1-D sequence of finite numbers")
    if not np.all(np.isfinite(arr)):
        raise fail(name, values, "a 1-D sequence of finite numbers (no NaN or inf)")
    return np.ascontiguousarray(arr)


GOLDEN_STEPS = 48
"""Golden-section steps refining each contact point within two grid intervals at most (chosen:
the bracket shrinks by 0.618^48 ~ 1e-10); fewer where the bracket reaches sqrt(eps) r first,
past which the ball's height, flat at its top, no longer tells its points apart (on the
Dektak scan's 307,168 intervals of 4.9 nm felt by a 0.5 mm ball, 15; Newton polishes from there,
CONTACT_NEWTON_STEPS)."""
#: Newton steps on the ball's contact condition after the golden section (:func:`_contact_path`;
#: chosen: from the golden section's 1e-11 m two reach the last bits; from a contact past the
#: bracket, where it runs fast, two more)
CONTACT_NEWTON_STEPS = 4


def _contact_path(texture, x, h, r, periodic, seed=None):
    """The ball's centre path on the grid x: (heights c(x) - r (n,), each interval's end slopes
    (m, 2), the kinks (k, 2): place and slope jump, the segments' curvature miss, a fraction
    of the path's largest curvature, the contacts x + u (n,), m, and the convex miss, a fraction
    of the path's most convex curvature: the profile's ``convex_miss``).

    c(x) = max over |u| <= r of [H(x + u) + sqrt(r^2 - u^2)], H the texture's own height: the
    maximum over the grid's offsets first (each grid point's arg-max contact), then refined by
    golden-section search on H within one interval either side of it and by Newton on the contact
    condition H'(x + u) = u / sqrt(r^2 - u^2) (CONTACT_NEWTON_STEPS); the slope is H' at the
    contact (the envelope theorem: the path's normal is the contact's). Given ``seed``, a
    coarser grid's (abscissae, contacts) from this function, the grid's offsets are not all
    searched (:func:`_seeded_contacts`: the contacts between the two seeds about each point, in
    work that grows with the grid, not with the ball's width). A kink is an interval
    across which the contact moves more than three intervals and the ball bridges the texture
    (:func:`_bridges`), with the slope jump across it; the segments either side of it take the
    path's curvature on their side of the kink (its one-sided limit, :func:`_kink_limits`) at
    their end by it, in place of their slope there (:func:`_curvature_ends`). The miss is the
    largest of the segments' ends' against the path's there (at a grid point, or that limit),
    beside no kink."""
    n = x.size
    dx = float(x[1] - x[0])
    idx = np.arange(n)
    first, last = texture.domain if not periodic else (None, None)  # (a bounded profile's sampled range)
    rival = None  # (the points with a second candidate that may be the higher, and it)
    if seed is not None:
        u0, rival = _seeded_contacts(texture, x, r, periodic, *seed)
        u0 = u0 - x
    elif periodic:
        u0 = _grid_contacts(h, (dx,), r, periodic)[1][0] * dx
    else:  # the contact stays on the sampled range (beyond it the grid repeats its end heights)
        u0 = (np.clip(idx + _grid_contacts(h, (dx,), r, periodic)[1][0], 0, n - 1) - idx) * dx

    def polish(u0, at=slice(None)):  # golden-section search within an interval either side of u0
        xa = x[at]  # (at the points ``at``): (u, its value)

        def g(u):
            return texture.height(xa + u) + np.sqrt(np.maximum(r * r - u * u, 0.0))

        # (what the ball reaches: within r, and on a bounded profile its sampled range)
        reach_lo, reach_hi = (np.full(xa.shape, -r), np.full(xa.shape, r)) if periodic else \
            (np.maximum(-r, first - xa), np.minimum(r, last - xa))
        lo, hi = np.maximum(u0 - dx, reach_lo), np.minimum(u0 + dx, reach_hi)
        phi = (math.sqrt(5.0) - 1.0) / 2.0
        a, b = lo.copy(), hi.copy()
        c1, c2 = b - phi * (b - a), a + phi * (b - a)
        g1, g2 = g(c1), g(c2)
        floor = math.sqrt(np.finfo(float).eps) * r  # (g's top: its points apart by rounding alone)
        steps = min(GOLDEN_STEPS, max(1, math.ceil(math.log(floor / (2 * dx)) / math.log(phi))))
        for _ in range(steps):
            left = g1 > g2
            b = np.where(left, c2, b)
            a = np.where(left, a, c1)
            c2n = np.where(left, c1, a + phi * (b - a))
            c1n = np.where(left, b - phi * (b - a), c2)
            gn = g(np.where(left, c1n, c2n))
            g2, g1 = np.where(left, g1, gn), np.where(left, gn, g2)
            c1, c2 = c1n, c2n
        golden = 0.5 * (a + b)
        # g is flat at its top: the golden section tells u only to about sqrt(eps) of it (1e-11 m
        # for a 1 mm ball), and the slope H'(x + u) to H'' times that (1.7e-8 near the troughs'
        # radius, curvature 2.8 % off over 7.6 nm intervals); and where the contact runs faster
        # than the ball (1 / (1 - r kappa) times) it may lie past the bracket. Newton on g' = 0
        # from there, a step kept where g'' < 0 and the ball reaches (and, on a bounded profile,
        # the sampled range), gives u to the last bits; kept where g is not lower (to rounding)
        u = golden
        for _ in range(CONTACT_NEWTON_STEPS):
            root = np.sqrt(np.maximum(r * r - u * u, 1e-300))
            d1 = texture.slope(xa + u) - u / root
            d2 = texture.curvature(xa + u) - r * r / root**3
            with np.errstate(divide="ignore", invalid="ignore"):
                un = u - d1 / d2
            u = np.where((d2 < 0) & (un >= reach_lo) & (un <= reach_hi), un, u)
        flat = 1e-14 * r  # (g's rounding: a few ulps of the ball's height)
        gu, gg = g(u), g(golden)
        newton = gu >= gg - flat
        u, gu = np.where(newton, u, golden), np.where(newton, gu, gg)
        grid = g(u0)
        keep = grid > gu + flat  # never below the start's own value
        return np.where(keep, u0, u), np.where(keep, grid, gu)

    u, c = polish(u0)
    if rival is not None and rival[0].size:
        pts, s2 = rival
        u2, c2 = polish(s2 - x[pts], pts)
        higher = c2 > c[pts]
        u[pts[higher]], c[pts[higher]] = u2[higher], c2[higher]
    held = np.zeros(n, dtype=bool)
    if not periodic:  # a contact held at the sampled range's end: the ball pivots on that point
        below, above = u <= first - x + 1e-6 * dx, u >= last - x - 1e-6 * dx
        held = below | above
        u = np.where(below, first - x, np.where(above, last - x, u))
        c = np.where(held, texture.height(x + u) + np.sqrt(np.maximum(r * r - u * u, 0.0)), c)
    slope = texture.slope(x + u)
    # (the envelope theorem for the constrained maximum: the path's slope is the ball's there)
    slope[held] = u[held] / np.sqrt(np.maximum(r * r - u[held] ** 2, 1e-300))
    contact = u + x
    m = n if periodic else n - 1
    nxt = (np.arange(m) + 1) % n
    ahead = contact[nxt] + (n * dx if periodic else 0.0) * (nxt == 0)
    at = np.flatnonzero(np.abs(ahead - contact[:m]) > 3 * dx)
    ends = np.column_stack([slope[:m], slope[nxt]])
    # In an interval where the contact moves more than three intervals, a cubic through both exact
    # end slopes overshoots them (by 40 % when a kink sits a sixth from one end). The path has a
    # kink (a slope jump) there only where the ball bridges the surface between the two contacts,
    # which needs it to curve more than the ball somewhere there (r kappa > 1, kappa = h'' / (1 +
    # h'^2)^1.5: tangent from above at both ends, the gap closes only past such a point); elsewhere
    # the contact runs on, 1 / (1 - r kappa) times as fast as the ball near the troughs' radius,
    # and the path is smooth (on a sinusoid at 0.8 to 1.05 times that radius 6 to 8 such intervals
    # a period had been named kinks). There the segment is the quadratic whose slope runs
    # linearly between the end slopes with the interval's mean (_kink_ends: the slope never
    # leaves them); across a kink it is straight at the interval's mean, its slope jumping at
    # both ends as the path's does at the kink (a ramp of the slope jump over one interval there
    # read q of B, C, G 344 for the path's 2.73). The kink sits at a sample to within an interval.
    hh = c - r
    delta = (np.r_[hh, hh[0]][1:m + 1] - hh[:m]) / dx
    bridged = _bridges(texture, contact[at], ahead[at], r)
    run, at = at[~bridged], at[bridged]  # (the contact running fast; the kinks)
    ends[run, 0], ends[run, 1] = _kink_ends(ends[run, 0], ends[run, 1], delta[run])
    ends[at, 0] = ends[at, 1] = delta[at]
    # the segments' curvature at their ends against the path's own there (differentiating the
    # contact condition h'(x + u) = u / sqrt(r^2 - u^2)), beside no kink: the largest miss, as a
    # fraction of the path's largest curvature (for the caller's refinement)
    curv = _path_curvature(texture, contact, u, r)
    curv[held] = -r * r / np.maximum(r * r - u[held] ** 2, 1e-300) ** 1.5  # (a circle of radius r about it)
    target = np.column_stack([curv[:m], curv[nxt]])
    finite = np.abs(curv[np.isfinite(curv)])
    scale = float(np.max(finite, initial=0.0))  # (infinite at a fold: the gap there says so)
    if at.size:  # beside a kink the path's curvature is largest at the kink itself (near a branch's
        # fold, 1 / sqrt of the distance to it): the segments beside it take each side's limit at
        # their end by the kink, for their slope there (the kink sits at that sample to within an
        # interval), where the slope that gives them stays within the path's own between that
        # sample and the kink; a grid point up to an interval away read it 6.7 % low on the
        # four-tone profile at 1.02 times its troughs' radius on 327,680 samples, the miss halving
        # with the grid. Where it would not (a limit by the fold, 2.4e11 1/m on the sinusoid at
        # its troughs' radius, would have made a slope of 234,000), the segment keeps its slopes
        # and its miss is measured against the limit
        left, right, s_left, s_right = _kink_limits(texture, x[at], u[at], ahead[at] - x[at] - dx, dx, r)
        lims = np.abs(np.concatenate([left, right]))
        scale = max(scale, float(np.max(lims[np.isfinite(lims)], initial=0.0)))
        plain = np.ones(m, dtype=bool)
        plain[at] = False
        before, after = (at - 1) % m, (at + 1) % m
        ok = np.isfinite(left) & plain[before] & ((at >= 1) | periodic)
        ok_r = np.isfinite(right) & plain[after] & ((at + 1 < m) | periodic)
        before, left, s_left, after, right, s_right = before[ok], left[ok], s_left[ok], after[ok_r], right[ok_r], \
            s_right[ok_r]
        target[before, 1], target[after, 0] = left, right
        fixed = np.zeros((m, 2), dtype=bool)
        fixed[before, 1] = fixed[after, 0] = True
        n0, n1 = _curvature_ends(ends[:, 0], ends[:, 1], delta, target, fixed, dx)
        within = np.ones((m, 2), dtype=bool)  # (the new slope no farther from the sample's than the kink's)
        within[before, 1] = np.abs(n1[before] - slope[at[ok]]) <= np.abs(s_left - slope[at[ok]]) + 1e-12
        within[after, 0] = np.abs(n0[after] - slope[nxt[at[ok_r]]]) <= np.abs(s_right - slope[nxt[at[ok_r]]]) + 1e-12
        fixed &= within
        ends[:, 0], ends[:, 1] = _curvature_ends(ends[:, 0], ends[:, 1], delta, target, fixed, dx)
    e0, e1 = ends[:, 0], ends[:, 1]
    d2 = np.column_stack([(6 * delta - 4 * e0 - 2 * e1) / dx, (2 * e0 + 4 * e1 - 6 * delta) / dx])
    smooth = np.ones(m, dtype=bool)
    smooth[at] = False
    smooth &= held[:m] == held[nxt]  # (where the contact reaches the range's end the path's curvature
    # jumps to the pivot's circle's, within the interval: no cubic follows that, as at a kink)
    gap = np.max(np.abs(d2 - target), axis=1)[smooth]
    miss = float(np.max(gap)) / scale if gap.size and scale > 0 else 0.0
    # (and its most convex curvature against the path's, relative to that: D reads d_max / (R -
    # d_max) below it, eq. 18; a cubic's curvature is linear, so its sup is at its ends)
    convex = max(0.0, -float(np.min(curv[np.isfinite(curv)], initial=0.0)))
    bowed = 0.0
    if convex > 0:
        wrong = np.where(np.minimum(d2, target) < 0, np.abs(d2 - target), 0.0)[smooth]
        own = max(0.0, -float(np.min(d2[np.isfinite(d2)], initial=0.0)))
        bowed = max(abs(own / convex - 1.0), float(np.nanmax(wrong, initial=0.0)) / convex)
    kinks = np.column_stack([x[at] + 0.5 * dx, slope[nxt[at]] - slope[at]]) if at.size else np.zeros((0, 2))
    return hh, ends, kinks, (miss if math.isfinite(miss) else math.inf), contact, bowed


def _curvature_ends(s0, s1, mean, target, fixed, dx):
    """The end slopes (s0, s1) of cubic segments through their ends' heights (their mean slope
    ``mean``, interval dx, m) whose second derivative at an end where ``fixed`` (m, 2) is the
    ``target`` there (1/m), the other end keeping its slope; both ends fixed, both curvatures
    (its slope then free). From the Hermite segment's end curvatures, (6 mean - 4 s0 - 2 s1) / dx
    and (2 s0 + 4 s1 - 6 mean) / dx. Shapes (m,)."""
    k0, k1 = target[:, 0], target[:, 1]
    f0, f1 = fixed[:, 0], fixed[:, 1]
    both = f0 & f1
    n0 = np.where(both, mean - (2 * k0 + k1) * dx / 6, np.where(f0, (3 * mean - s1) / 2 - k0 * dx / 4, s0))
    n1 = np.where(both, mean + (k0 + 2 * k1) * dx / 6, np.where(f1, (3 * mean - s0) / 2 + k1 * dx / 4, s1))
    return n0, n1


def _seeded_contacts(texture, x, r, periodic, xs, ss):
    """Each grid point's best candidate contact s = x + u (m, shape (n,)) from a coarser grid's,
    abscissae xs and contacts ss (shape (k,), increasing), and (indices, contacts) of the points
    whose second candidate may be the higher: found in work proportional to the grid's points and
    the contacts' travel, not to the ball's width.

    The contact is nondecreasing in x (the ball's lift sqrt(r^2 - (s - x)^2) has increasing
    differences in (s, x): Topkis' monotonicity theorem), so the contact at x lies between the
    seeds' contacts at the coarse points either side (either side of the coarse point it falls
    on, where it falls on one: a coarser grid may have taken the lower of two near-tied branches
    beside a kink). That bracket is searched at the grid's own spacing dx (on the sampled range
    of a bounded profile and within the ball), with the point itself (the ball's lowest point
    never below the surface); its highest local maximum is the candidate, and its second where
    that is within dx^2 (max|h''| + 1/r) / 4 of the first (a peak is within dx / 2 of a sample,
    which reads it at most dx^2 (max|h''| + 1/r) / 8 low), for the caller's golden-section
    refinement within an interval of each."""
    dx = float(x[1] - x[0])
    if periodic:
        period = x.size * dx
        xe, se = np.r_[xs[-1] - period, xs, xs[0] + period], np.r_[ss[-1] - period, ss, ss[0] + period]
    else:
        xe, se = xs, ss
    j = np.clip(np.searchsorted(xe, x, side="right") - 1, 0, xe.size - 1)
    on = np.isclose(x, xe[j], rtol=0.0, atol=1e-9 * dx)  # (on a coarse point: the points either side)
    a = se[np.maximum(j - on, 0)] - dx
    b = se[np.minimum(j + 1, xe.size - 1)] + dx
    a, b = np.maximum(a, x - r), np.minimum(b, x + r)
    if not periodic:
        a, b = np.maximum(a, texture.domain[0]), np.minimum(b, texture.domain[1])
    b = np.maximum(a, b)
    count = np.ceil((b - a) / dx).astype(np.int64) + 2  # (the bracket's points, its ends included,
    # and the point itself: never below the surface there, h(x) + r, as the dilation's offset 0)
    start = np.r_[0, np.cumsum(count)[:-1]]
    owner = np.repeat(np.arange(x.size), count)
    step = np.arange(owner.size) - start[owner]
    last = step == count[owner] - 1
    s = np.where(last, x[owner], np.minimum(a[owner] + step * dx, b[owner]))
    v = texture.height(s) + np.sqrt(np.maximum(r * r - (s - x[owner]) ** 2, 0.0))
    # the local maxima along each bracket (its ends and the point itself count as peaks)
    inner = ~last & (step > 0) & (np.r_[step[1:], 0] > 0) & ~np.r_[last[1:], True]
    prev, nxt = np.r_[-np.inf, v[:-1]], np.r_[v[1:], -np.inf]
    peak = last | ~inner | ((v >= prev) & (v >= nxt))
    cand = np.flatnonzero(peak)
    order = cand[np.lexsort((-v[cand], owner[cand]))]  # (by point, then highest first)
    first = np.r_[True, owner[order][1:] != owner[order][:-1]]
    best = order[first]
    rank = np.arange(order.size) - np.repeat(np.flatnonzero(first), np.diff(np.r_[np.flatnonzero(first), order.size]))
    two = order[rank == 1]
    bound = dx * dx * (texture.max_curvature + 1.0 / r) / 4
    close = two[v[best[owner[two]]] - v[two] <= bound]
    return s[best], (owner[close], s[close])


def _path_curvature(texture, s, u, r):
    """The ball path's second derivative where its contact is s = x + u (m, any shape; u the
    contact's offset from the ball's centre): differentiating the contact condition h'(x + u) =
    u / sqrt(r^2 - u^2), h''(s) phi' / (phi' - h''(s)) with phi' = r^2 / (r^2 - u^2)^(3/2)
    (1/m); infinite where phi' <= h''(s) (a fold: no maximum there)."""
    dphi = r * r / np.maximum(r * r - u * u, 1e-300) ** 1.5
    hs = texture.curvature(s)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(dphi - hs > 0, hs * dphi / (dphi - hs), np.inf)


def _kink_limits(texture, x0, u0, u1, dx, r, steps=48):
    """The ball path's curvature either side of kinks (arrays of shape (k,): each interval's
    first point x0 (m), the contact offsets u0 at it and u1 at x0 + dx on the branch beyond the
    kink): each branch followed by Newton steps on the contact condition h'(x + u) = u / sqrt(r^2
    - u^2) from its end's contact, the kink bisected where the two branches' heights meet, and
    the path's curvature there on each branch, h''(s) phi' / (phi' - h''(s)), phi' = r^2 / (r^2
    - u^2)^(3/2), s = x + u. Returns (left, right, the left's slope, the right's slope): the
    curvatures NaN where a branch could not be followed."""
    lo, hi = x0.copy(), x0 + dx
    rim = r * (1 - 1e-12)

    def branch(x, u):  # Newton from u on the contact condition at x: (u, height, curvature)
        lost = np.zeros(u.shape, dtype=bool)  # (past the branch's fold: no maximum to follow)
        for _ in range(12):
            w = np.sqrt(np.maximum(r * r - u * u, 1e-300))
            f = texture.slope(x + u) - u / w
            fp = texture.curvature(x + u) - r * r / w**3
            lost |= ~(fp < 0)
            u = np.where(lost, u, np.clip(u - f / np.where(lost, -1.0, fp), -rim, rim))
        w = np.sqrt(np.maximum(r * r - u * u, 1e-300))
        ok = ~lost & (np.abs(texture.slope(x + u) - u / w) <= 1e-9 * (1 + np.abs(u / w)))
        return u, np.where(ok, texture.height(x + u) + w, np.nan), np.where(ok, _path_curvature(texture, x + u, u, r),
                                                                            np.nan)

    ua, ub = u0.copy(), u1.copy()
    for _ in range(steps):
        mid = 0.5 * (lo + hi)
        ma, ha, _ = branch(mid, ua)
        mb, hb, _ = branch(mid, ub)
        first = ~(hb > ha)  # (the first branch still the higher: the kink beyond mid)
        lo, ua = np.where(first, mid, lo), np.where(first, ma, ua)
        hi, ub = np.where(first, hi, mid), np.where(first, ub, mb)
    (ua, _, left), (ub, _, right) = branch(lo, ua), branch(hi, ub)
    return left, right, ua / np.sqrt(r * r - ua * ua), ub / np.sqrt(r * r - ub * ub)


PROFILE_CURVATURE_SLACK = 0.01
"""How far a felt profile's segments' curvature at its grid points may miss the ball path's own
there (and their largest the path's at a kink, where that is the path's largest), as a
fraction of the path's largest, before its grid is halved (chosen: q of B, C, G reads the
largest curvature; on `Sinusoid(0.2 mm, 2 mm)` at 0.8, 0.9, 0.95 times its troughs' radius
the default grid (7.8 um) read them -3.4, -19, -51 %; beside the kinks of the two-tone profile
at twice its troughs' radius, -9.6 and -12.6 % on 1,024 samples, where its path's curvature
is largest at the kink)."""

PROFILE_REFINE_SAMPLES = 1 << 19
"""The most samples a felt profile is refined to (chosen: 2,048 times the default grid of a
sinusoid, 4 nm over 2 mm, 16 MB of segments; the finer grids' contacts are followed from the
coarser ones', :func:`_seeded_contacts`, a few seconds a profile. Near the troughs' radius the
path's curvature spike, kappa / (1 - r kappa), is a few hundred nm wide: at 32,768 samples the
two-tone profile at 1.05 times its troughs' radius read q of C -9.2 %, at 524,288 -0.01 %)."""


BRIDGE_SAMPLES = 4096
"""Most points at which :func:`_bridges` samples the surface's curvature between two contacts
(chosen: 16 a shortest period, at least 16; a bracket is at most the ball's width)."""


def _bridges(texture, s0, s1, r):
    """Whether a ball of radius r (m) bridges the profile between contacts s0 < s1 (m, shape (k,)):
    whether r kappa > 1 somewhere between them, kappa = h'' / (1 + h'^2)^(3/2) the profile's
    curvature, sampled at 16 points a shortest period (at least 16, at most BRIDGE_SAMPLES a
    bracket). Shape (k,) bool."""
    if s0.size == 0:
        return np.zeros(0, dtype=bool)
    span = float(np.max(s1 - s0))
    m = int(min(max(16, math.ceil(16 * span / texture.shortest_period)), BRIDGE_SAMPLES))
    t = np.linspace(0.0, 1.0, m)
    out = np.zeros(s0.size, dtype=bool)
    rows = max(1, (1 << 20) // m)  # (about 8 MB of points at a time)
    for i in range(0, s0.size, rows):
        pts = s0[i:i + rows, None] + (s1 - s0)[i:i + rows, None] * t[None]
        kappa = texture.curvature(pts) / (1 + texture.slope(pts) ** 2) ** 1.5
        out[i:i + rows] = np.max(r * kappa, axis=1) > 1.0
    return out


def _kink_ends(s0, s1, mean):
    """The end slopes of intervals holding a kink (arrays of one shape: the exact slopes s0, s1 at
    the ends, the interval's mean slope): the cubic Hermite segment through both exact slopes
    overshoots them (by 40 % when the kink sits a sixth from one end), so one end keeps its exact
    slope and the other is moved within the three values, giving the quadratic whose slope runs
    linearly between them with the right mean; where neither fits (the kink at a sample itself)
    the interval is straight at its mean. Returns (s0', s1')."""
    lo = np.minimum(np.minimum(s0, s1), mean)
    hi = np.maximum(np.maximum(s0, s1), mean)
    a, b = 2 * mean - s1, 2 * mean - s0
    first = (lo <= a) & (a <= hi)
    second = ~first & (lo <= b) & (b <= hi)
    out0 = np.where(first, a, np.where(second, s0, mean))
    out1 = np.where(first, s1, np.where(second, b, mean))
    return out0, out1


def _resampled_axis(first, last, step, d, periodic):
    """The abscissae (m) of a sampled axis (its first and last samples, their step, m) resampled at
    spacing d (m): on a periodic axis n = max(4, floor(period / d)) steps that divide its period
    (last - first + step), none finer than d but where the period holds fewer than 4; else steps
    of d from the first sample, up to the last (at least 4 samples). Shape (n,)."""
    if periodic:
        span = last - first + step
        n = max(4, int(math.floor(span / d)))
        return first + np.arange(n) * (span / n)
    return first + np.arange(max(4, int(math.floor((last - first) / d)) + 1)) * d


def _profile_grid(texture, r, spacing, followed=False):
    """(x, heights, periodic, source) of the grid a profile is felt on at ``spacing`` (m; None:
    a sampled profile's own, an analytic one's default), refused past the dilation's work
    (:func:`haptex.probe._check_work`, naming its bounds) unless ``followed``: a refinement's
    grid, whose contacts are followed from the last grid's, no dilation made."""
    if isinstance(texture, SampledProfile):
        _check_ball_fits(texture, r)

        def axis_at(v):  # (the grid felt_by(r, spacing=v) resamples the profile on)
            return _resampled_axis(texture.x[0], texture.x[-1], texture.dx, v, texture.periodic)

        def grid_at(v):
            g = axis_at(v)
            return g.size, (float(g[1] - g[0]),)

        if spacing is None:
            if not followed:
                _check_work(texture.x.size, (float(texture.dx),), r, grid_at=grid_at, crop=not texture.periodic,
                            coarsest=_coarsest_spacing(texture)[0])
            return texture.x, texture.h, texture.periodic, texture.source or "profile"
        dx = _spacing(texture, r, spacing, 256, 32)  # resampled by its spline onto a coarser grid
        x = axis_at(dx)
        step = float(x[1] - x[0])
        if not followed:
            _check_work(x.size, (step,), r, grid_at=grid_at, spacing=dx, coarsest=_coarsest_spacing(texture)[0])
        return x, texture.height(x), texture.periodic, f"{texture.source or 'profile'} resampled at {_steps_text([step])}"
    period = texture.period
    if period is None:
        raise fail("texture", texture, "a periodic or sampled profile for a ball to roll on (sample it: "
                   "SampledProfile(x, texture.height(x)))")
    dx = _spacing(texture, r, spacing, 256, 32)
    def size_at(v):  # (the samples of the grid felt_by(r, spacing=v) makes)
        return int(math.ceil(period / v))

    n = size_at(dx)
    if n > MAX_PROBE_SAMPLES:
        raise fail("spacing", dx, f"at least {period / MAX_PROBE_SAMPLES:g} m ({MAX_PROBE_SAMPLES} samples a period)")

    def grid_at(v):
        k = size_at(v)
        return k, (period / k,)

    # (before sampling it; at the default spacing, which follows r, a smaller radius is no remedy)
    if not followed:
        _check_work(n, (period / n,), r, grid_at=grid_at, radius=spacing is not None, spacing=spacing,
                    coarsest=_coarsest_spacing(texture)[0])
    x = np.arange(n) * (period / n)
    return x, texture.height(x), True, f"{type(texture).__name__} sampled at {period / n * 1e6:.3g} um"
