"""Areal textures h(x, y) (metres) over the nominal plane z = 0: gratings and their sums,
band-limited noise, a profile extruded across the scan, and sampled height maps (measured,
generated, or greyscale images) with a C^2 bicubic spline.

A surface is a :class:`~haptex.textures.Texture` of dimension 2: the algorithms and the
analysis read it through ``height_at``, ``gradient`` and ``hessian`` on in-plane
positions of shape (..., 2) = [x, y] (m), the same calls through which they read a profile,
so a profile is the 1-D case and :class:`Extruded` reproduces its numbers exactly.
"""

from __future__ import annotations

import math
from functools import cached_property, partial

import numpy as np

from . import core as _core
from .core import _ext
from ._maximise import refine
from ._validation import (ParameterError, a_path, check_count, fail, finite, flag, nonnegative, numbers, positive,
                          random_seed, whole)
from .probe import (MAX_SAMPLES as MAX_PROBE_SAMPLES, _check_ball_fits, _check_work, _coarsest_spacing, _spacing,
                    _steps_text)
from .textures import (MAX_HARMONICS, SampledProfile, Texture, _band_limited_samples, _resampled_axis, _vector,
                       common_period)

__all__ = ["Surface", "SumOfGratings", "Grating", "BandLimitedNoise2D", "Extruded", "SampledSurface"]

MAX_GRID = 4_000_000
"""Most points of the dense grid on which a surface's sup ‖grad h‖, sup ||H|| and height
range are searched before refinement."""


def plane(xy, name: str = "xy") -> np.ndarray:
    """In-plane positions as float64 of shape (..., 2) = [x, y] (m), checked.

    Parameters
    ----------
    xy : array_like, shape (..., 2)
        Positions [x, y] (m).
    name : str, optional
        The parameter named in an error.

    Returns
    -------
    numpy.ndarray, shape (..., 2)

    Raises
    ------
    ParameterError
        If the last axis is not of length 2 or a coordinate is not finite.
    """
    arr = numbers(name, xy, "an array of shape (..., 2) of finite in-plane positions [x, y] in metres", copy=False)
    if arr.ndim == 0 or arr.shape[-1] != 2:
        raise ParameterError(f"{name} has shape {arr.shape}, which is not allowed: must be (..., 2) = [x, y] in metres")
    if not np.all(np.isfinite(arr)):
        raise fail(name, "a non-finite position", "finite coordinates in metres")
    return arr


class Surface(Texture):
    """Base class of areal textures h(x, y) (m).

    Subclasses provide ``height_at``, ``gradient`` and ``hessian`` on positions of shape
    (..., 2), and :attr:`shortest_period` (the shortest wavelength over all directions),
    :attr:`cell` (a periodic cell (L_x, L_y) in m, or None), :attr:`max_slope`
    (sup ‖grad h‖), :attr:`max_curvature` (sup of the Hessian's 2-norm) and
    :attr:`height_range`.
    """

    dimension = 2
    period = None  # a surface has a periodic cell (see cell), not a period along one axis

    def height(self, x):
        raise ParameterError(f"texture = {self!r} is a surface h(x, y): evaluate it with height_at([x, y])")

    slope = curvature = height

    def _felt(self, r: float, spacing: float | None) -> "SampledSurface":
        """A surface's felt texture (a ball of radius r > 0, m): the ball's centre path at each grid
        point, its contact found on the grid and refined on this surface itself, the path's
        gradient there the contact's (the envelope theorem), and the map the bicubic Hermite
        patches through those heights and gradients; a cell across which the contact jumps is
        the maximum of one patch per contact (:func:`_contact_map`). With no spacing given the
        map is made again on finer grids (REFINE: of the default spacing, or of a sampled map's
        interval, its spline resampled, the map's own grid first) while some cell beside a kink
        keeps its single patch or the map is steeper than the surface by more than STEEP_SLACK
        (its steepest slope sampled densely beside its kinks too, BRANCHED_SUP_POINTS), and
        finer still (REFINE_STEEP) while every grid made is steeper than the surface; the first
        grid without either is kept, else the one not steeper with the fewest such cells, else
        the least steep."""
        best = None
        refine = spacing is None
        sampled = isinstance(self, SampledSurface)
        if sampled:  # (its own grid first, then its spline resampled finer)
            base = min(float(self.x[1] - self.x[0]), float(self.y[1] - self.y[0]))
            extent = tuple(hi - lo for lo, hi in self.domain)
        else:
            base = _default_spacing(self, r) if refine else None
            extent = self.cell

        def fits(factor, cap=REFINE_SAMPLES):  # a grid of factor * base within cap samples over the cell
            sp = factor * base
            return math.ceil(extent[0] / sp) * math.ceil(extent[1] / sp) <= cap

        for k, factor in enumerate(REFINE + REFINE_STEEP if refine else (None,)):
            sp = spacing if not refine else None if sampled and k == 0 else factor * base
            if k >= len(REFINE):  # (finer still while every grid made is steeper than the surface)
                if not best[0][1] or not fits(factor, REFINE_STEEP_SAMPLES):
                    break
            elif k > 0 and not fits(factor):
                continue
            try:
                x, y, h, periodic, source = _surface_grid(self, r, sp)
                hf, grads, edges, kinks, branches = _contact_map(self, x, y, h, r, periodic)
            except ParameterError:
                if k == 0:
                    raise
                break  # (a finer grid past the dilation's work: the coarser one stands)
            out = SampledSurface(x, y, hf, periodic=periodic, gradients=grads,
                                 source=f"{source} felt by a ball of r = {r * 1e3:g} mm")
            out._edges = edges
            out._branches = branches
            out.kinks = kinks
            if not refine or (k == 0 and not (len(REFINE) > 1 and fits(REFINE[1]))):
                return self._smooth(out, r) if refine else out  # (no finer grid to make: nothing to compare it with)
            # (the path's slope is a contact's, never steeper than the surface: a map steeper
            # than that by more than STEEP_SLACK is a patch's overshoot, a grid to refine too)
            left, steep = _single_kink_cells(out), out.max_slope
            over = steep > self.max_slope * (1 + STEEP_SLACK)
            score = (over or left > 0, over, steep if over else 0.0, left, steep)
            if best is None or score < best[0]:
                best = (score, out)
            if not score[0]:
                break
        return self._smooth(best[1], r)

    def _smooth(self, felt, r):
        """``felt`` refined for its curvature where that applies, a periodic map: of a surface the
        ball cannot bridge by :func:`_curvature_refined`, of an analytic one it bridges by
        :func:`_bridged_refined` (not a sampled map's: on the tests' rough 64 x 64 map felt by a
        10 um ball, refined to 128 x 128 with 1,626 branched cells, two branched neighbours'
        highest patches parted by 2.9e-11 m between the five points an edge where their
        continuity is checked)."""
        if not felt.periodic:
            return felt
        if _may_bridge(self, r):
            return felt if isinstance(self, SampledSurface) else _bridged_refined(self, felt, r)
        return _curvature_refined(self, felt, r)

    def kernel_data(self) -> tuple[int, np.ndarray]:
        """(kind, coeffs) of the compiled kernels (:mod:`haptex.core`): a sum of gratings
        as ``SURFACE_GRATINGS`` with shape (4, n) (amplitudes m, k_x, k_y rad/m, phases
        rad), a height map as ``SURFACE_PATCHES`` (its bicubic patches), an extruded profile
        as its profile's data (h does not depend on y).

        Raises
        ------
        ParameterError
            For a surface type the compiled kernels do not know.
        """
        raise ParameterError(f"texture = {self!r} is not allowed here: the compiled simulator and renderer take "
                             "sums of gratings, height maps and extruded profiles")

    @property
    def cell(self) -> tuple[float, float] | None:  # pragma: no cover - abstract
        raise NotImplementedError

    @property
    def domain(self) -> tuple[tuple[float, float], tuple[float, float]] | None:
        """The in-plane region analysed by default, ((x0, x1), (y0, y1)) in m: one periodic
        cell, or None when the surface has none."""
        c = self.cell
        return None if c is None else ((0.0, float(c[0])), (0.0, float(c[1])))

    @property
    def peak_magnitude(self) -> float:
        """max |h| (m) over the surface."""
        lo, hi = self.height_range
        return max(abs(lo), abs(hi))

    # -- sups over a cell, by dense sampling and bounded refinement -----------------------
    def _grid_shape(self) -> list[int]:
        """Samples along x and y of :meth:`_grid`: 64 a shortest period, 64 to 4096 a side."""
        return [int(min(max(64 * (b - a) / self.shortest_period, 64), 4096)) for a, b in self.domain]

    def _grid(self):
        (x0, x1), (y0, y1) = self.domain
        n = self._grid_shape()
        check_count("texture", self, n[0] * n[1], MAX_GRID, "grid points over the periodic cell (a cell of at "
                    "most ~30 shortest periods a side)")
        xs = np.linspace(x0, x1, n[0], endpoint=False)
        ys = np.linspace(y0, y1, n[1], endpoint=False)
        X, Y = np.meshgrid(xs, ys, indexing="ij")
        return np.stack([X, Y], -1), ((x1 - x0) / n[0], (y1 - y0) / n[1])

    @_core.blas_held_to_one_thread
    def _sup(self, fun, where=None) -> float:
        """sup over the cell of fun(xy) >= 0, fun vectorised over (..., 2): the grid's largest,
        refined from its 8 largest samples by :func:`haptex._maximise.refine` within a grid
        step, in grid steps about each (so that the problem is well scaled); the points (2,) it
        was refined to appended to ``where`` (a list, or None). (BLAS held to one thread:
        L-BFGS-B's triangular solves woke OpenBLAS's workers, which then spun for 0.1 s beside
        whatever came next, a servo loop included.)"""
        pts, (dx, dy) = self._grid()
        vals = fun(pts)
        best = float(vals.max())
        flat = vals.ravel()
        scale = np.array([dx, dy])

        if flat.size > 8:  # the 8 largest, ties taken in the grid's order (argpartition's choice among
            t = np.partition(flat, -8)[-8]  # equal values depends on the CPU's SIMD selection)
            above = np.flatnonzero(flat > t)
            starts = np.r_[above, np.flatnonzero(flat == t)[:8 - above.size]]
        else:
            starts = range(flat.size)
        for idx in starts:
            start, norm = pts.reshape(-1, 2)[idx], max(best, 1e-300)

            def neg(u, start=start, norm=norm):  # (n, 2) steps about the sample
                return -fun(start + u * scale) / norm

            found, u = refine(neg, np.zeros(2), None, [(-1.0, 1.0)] * 2, ftol=1e-16, gtol=1e-13)
            best = max(best, found * norm)
            if where is not None:
                where.append(start + np.array(u) * scale)
        return best


_HESSIAN = np.array([3, 4, 4, 5])
"""Where h_xx, h_xy, h_yx, h_yy are in the C core's derivatives (h, h_x, h_y, h_xx, h_xy, h_yy):
a Hessian (..., 2, 2) in one gather (two nested stacks took 8 times as long)."""


def _symmetric_2x2_norm(a, b, c) -> np.ndarray:
    """The 2-norm (largest |eigenvalue|) of the symmetric 2 x 2 matrices [[a, b], [b, c]] (arrays
    of one shape), in closed form: |a + c| / 2 + sqrt(((a - c) / 2)^2 + b^2) (numpy's SVD per
    matrix took 3 s on a 640 x 480 map's 4.9 million grid points; this, 0.1 s). Same shape."""
    return 0.5 * np.abs(a + c) + np.hypot(0.5 * (a - c), b)


def _lowest_eigenvalue(H: np.ndarray) -> np.ndarray:
    """The lower eigenvalue (1/m) of symmetric 2 x 2 Hessians H, shape (..., 2, 2): shape (...),
    (a + c) / 2 - sqrt(((a - c) / 2)^2 + b^2); negative where the surface is convex."""
    return 0.5 * (H[..., 0, 0] + H[..., 1, 1]) - np.hypot(0.5 * (H[..., 0, 0] - H[..., 1, 1]), H[..., 0, 1])


def _hessian_norm(H: np.ndarray) -> np.ndarray:
    """:func:`_symmetric_2x2_norm` of Hessians H, shape (..., 2, 2): shape (...)."""
    return _symmetric_2x2_norm(H[..., 0, 0], H[..., 0, 1], H[..., 1, 1])


class SumOfGratings(Surface):
    """A sum of gratings h(x, y) = sum_k a_k sin(2 pi (x cos th_k + y sin th_k) / l_k + phi_k).

    Parameters
    ----------
    amplitudes : array_like, shape (n,)
        a_k >= 0 (m).
    periods : array_like, shape (n,)
        Wavelengths l_k > 0 (m), measured along each grating's direction.
    directions : array_like, shape (n,)
        th_k (rad): the direction of each wave vector from the x axis.
    phases : array_like, shape (n,), optional
        phi_k (rad), default 0.

    Raises
    ------
    ParameterError
        If the arrays are empty, of different lengths or not finite real numbers (a bool,
        text or a complex number is not one), an amplitude is negative or a period not > 0.

    Notes
    -----
    The areal form of Remark 2's sums: :attr:`max_slope` is sup ‖grad h‖ over a periodic
    cell when the gratings share one (each wave vector's components commensurate, ratio
    denominators <= 1000), else the rigorous bound sum_k 2 pi a_k / l_k
    (:attr:`max_slope_is_exact` says which).
    """

    def __init__(self, amplitudes, periods, directions, phases=None):
        a = _vector("amplitudes", amplitudes)
        lengths = _vector("periods", periods)
        th = _vector("directions", directions)
        ph = np.zeros_like(a) if phases is None else _vector("phases", phases)
        if not (a.shape == lengths.shape == th.shape == ph.shape):
            raise ParameterError(f"amplitudes, periods, directions and phases have lengths {a.size}, {lengths.size}, "
                                 f"{th.size}, {ph.size}, which is not allowed: they must have the same length")
        check_count("amplitudes", f"{a.size} gratings", a.size, MAX_HARMONICS, "gratings")
        for i, v in enumerate(a):
            nonnegative(f"amplitudes[{i}]", v, "m")
        for i, v in enumerate(lengths):
            positive(f"periods[{i}]", v, "m")
        self.amplitudes, self.periods, self.directions, self.phases = a, lengths, th, ph
        k = 2 * np.pi / lengths
        self._kvec = np.ascontiguousarray(np.stack([k * np.cos(th), k * np.sin(th)], -1))  # (n, 2), rad/m
        self._grad_w = a[:, None] * self._kvec  # (n, 2)
        self._hess_w = -(a[:, None, None] * self._kvec[:, :, None] * self._kvec[:, None, :]).reshape(-1, 4)

    def __repr__(self) -> str:
        if getattr(self, "_label", None):
            return self._label
        return (f"SumOfGratings(amplitudes={self.amplitudes.tolist()}, periods={self.periods.tolist()}, "
                f"directions={self.directions.tolist()}, phases={self.phases.tolist()})")

    def _series(self, xy, fun, weights):
        """sum_k weights_k fun(k_k . xy + phi_k) in chunks (temporaries below 32 MiB)."""
        xy = plane(xy)
        flat = xy.reshape(-1, 2)
        w = weights.reshape(self.amplitudes.size, -1)
        out = np.empty((flat.shape[0], w.shape[1]))
        step = max(1, (4 * 1024**2) // self.amplitudes.size)
        for i in range(0, flat.shape[0], step):
            out[i:i + step] = fun(flat[i:i + step] @ self._kvec.T + self.phases) @ w
        return out.reshape(xy.shape[:-1] + weights.shape[1:])

    def kernel_data(self) -> tuple[int, np.ndarray]:
        """(``SURFACE_GRATINGS``, [amplitudes, k_x, k_y, phases]) of shape (4, n).

        Returns
        -------
        tuple of (int, numpy.ndarray)
            ``SURFACE_GRATINGS`` and the coefficients, shape (4, n): amplitudes (m), k_x,
            k_y (rad/m), phases (rad).
        """
        return _ext.SURFACE_GRATINGS, np.ascontiguousarray(
            np.vstack([self.amplitudes, self._kvec[:, 0], self._kvec[:, 1], self.phases]))

    def height_at(self, xt):
        """The height h(x, y) = sum_k a_k sin(k_k . [x, y] + phi_k).

        Parameters
        ----------
        xt : array_like, shape (..., 2)
            In-plane positions [x, y] (m).

        Returns
        -------
        numpy.ndarray
            shape (...): h (m).
        """
        return self._series(xt, np.sin, self.amplitudes)

    def gradient(self, xt):
        """The gradient grad h = [h_x, h_y].

        Parameters
        ----------
        xt : array_like, shape (..., 2)
            In-plane positions [x, y] (m).

        Returns
        -------
        numpy.ndarray
            shape (..., 2): grad h (m/m).
        """
        return self._series(xt, np.cos, self._grad_w)

    def hessian(self, xt):
        """The Hessian [[h_xx, h_xy], [h_xy, h_yy]].

        Parameters
        ----------
        xt : array_like, shape (..., 2)
            In-plane positions [x, y] (m).

        Returns
        -------
        numpy.ndarray
            shape (..., 2, 2): the Hessian (1/m).
        """
        return self._series(xt, np.sin, self._hess_w).reshape(np.shape(xt)[:-1] + (2, 2))

    @property
    def shortest_period(self) -> float:
        """Shortest wavelength over all directions among the live gratings (m)."""
        live = self.periods[self.amplitudes > 0]
        return float((live if live.size else self.periods).min())

    @cached_property
    def cell(self) -> tuple[float, float] | None:
        """A periodic cell (L_x, L_y) (m): h(x + L_x, y) = h(x, y + L_y) = h(x, y); None
        when the wave vectors' components are not commensurate."""
        live = self.amplitudes > 0
        out = []
        for axis in (0, 1):
            comp = np.abs(self._kvec[live, axis])
            comp = comp[comp > 1e-12 * np.abs(self._kvec[live]).max(initial=1.0)]
            if comp.size == 0:  # invariant along this axis: any length is a period
                out.append(self.shortest_period)
                continue
            length = common_period(2 * np.pi / comp)
            if length is None:
                return None
            out.append(length)
        return out[0], out[1]

    @cached_property
    def max_slope_is_exact(self) -> bool:
        """True when :attr:`max_slope` is the computed sup rather than an upper bound."""
        return self.cell is not None

    @cached_property
    def felt_turn(self) -> float:
        """The angle (rad, in (-pi/4, pi/4]) by which :meth:`felt_by` turns its map's axes from
        the plane's: where every grating's wave vector lies along one of two perpendicular
        directions off the axes (the egg-crate's, at +-45 degrees: ``turn`` = pi/4) and the
        texture turned onto them is periodic on a lattice that holds the plane's cell, the
        felt map of a ball that cannot bridge it is made on axes along the gratings
        (:class:`~haptex.SampledSurface` with ``turn``), where its tensor patches follow the
        saddles' ridges along their sides; 0 otherwise (the map on the plane's axes). Measured
        on the egg-crate at 0.95 times its bowls' radius: q of D 58.5 on the plane's axes,
        1.0249 on the turned ones, for the ball path's 1.0248 (2026-11-28)."""
        live = self.amplitudes > 0
        if not live.any() or self.cell is None:
            return 0.0
        th = np.mod(self.directions[live], np.pi / 2)
        spread = np.mod(th - th[0] + np.pi / 4, np.pi / 2) - np.pi / 4
        if np.max(np.abs(spread)) > 1e-12:
            return 0.0
        turn = float(th[0] if th[0] <= np.pi / 4 else th[0] - np.pi / 2)
        if abs(turn) < 1e-12:
            return 0.0
        frame = self._turned_by(turn)
        if frame.cell is None:
            return 0.0
        c, s = math.cos(turn), math.sin(turn)
        k = np.abs(frame._kvec[live])
        along = [bool(np.any(k[:, a] > 1e-12 * k.max())) for a in (0, 1)]  # (else invariant along that axis)
        for vx, vy in ((self.cell[0], 0.0), (0.0, self.cell[1])):  # the plane's cell on the map's lattice
            for m, length, a in ((c * vx + s * vy, frame.cell[0], 0), (c * vy - s * vx, frame.cell[1], 1)):
                if along[a] and abs(m / length - round(m / length)) > 1e-9:
                    return 0.0
        return turn

    def _turned_by(self, turn: float) -> "SumOfGratings":
        """This texture on axes turned by ``turn`` (rad): h'(m) = h(R(turn) m)."""
        return SumOfGratings(self.amplitudes, self.periods, self.directions - turn, self.phases)

    def _felt(self, r: float, spacing: float | None) -> "SampledSurface":
        """Surface._felt's map, on axes turned to the gratings where :attr:`felt_turn` is not 0
        and the ball cannot bridge the surface (:func:`_may_bridge`; where it bridges, the map
        stays on the plane's axes: on the egg-crate at 1.05 times its bowls' radius the turned
        grids left cells beside the bowls' apexes unbranched from the first refinement on, 22 x
        22 and a 20 % curvature miss, where the plane's axes reach 304 a side and 3.5 %)."""
        turn = self.felt_turn
        if turn == 0.0 or _may_bridge(self, r):
            return super()._felt(r, spacing)
        out = _TurnedMap.of(self._turned_by(turn)._felt(r, spacing), turn, self.cell)
        if type(self) is not SumOfGratings and out.source.startswith("SumOfGratings "):  # (its own name)
            out.source = type(self).__name__ + out.source[len("SumOfGratings"):]
        return out

    @cached_property
    def max_slope(self) -> float:
        """M = sup ‖grad h‖ (m/m) over the plane (Remark 2 with the gradient's norm)."""
        if self.cell is None:
            return float(np.sum(self.amplitudes * 2 * np.pi / self.periods))
        return math.sqrt(self._sup(lambda p: np.sum(self.gradient(p) ** 2, axis=-1)))  # smooth at the sup

    @cached_property
    def max_curvature(self) -> float:
        """sup of the Hessian's 2-norm (1/m); the bound sum_k a_k k_k^2 without a cell."""
        if self.cell is None:
            return float(np.sum(self.amplitudes * (2 * np.pi / self.periods) ** 2))
        return self._sup(lambda p: _hessian_norm(self.hessian(p)))

    @cached_property
    def curvature_bound(self) -> float:
        """A rigorous C >= sup ||H||_2 (1/m): sum_k a_k ‖k_k‖^2, or, over a cell, the smaller of
        that and :attr:`max_curvature` plus its sampling error (||H|| moves at most
        sum_k a_k ‖k_k‖^3 per metre, and every point lies within half a grid cell's diagonal of
        a sample)."""
        k = np.hypot(self._kvec[:, 0], self._kvec[:, 1])
        total = float(np.sum(self.amplitudes * k ** 2))
        if self.cell is None:
            return total
        (x0, x1), (y0, y1) = self.domain
        n = self._grid_shape()
        r = 0.5 * math.hypot((x1 - x0) / n[0], (y1 - y0) / n[1])
        return min(total, self.max_curvature + float(np.sum(self.amplitudes * k ** 3)) * r)

    @cached_property
    def height_range(self) -> tuple[float, float]:
        """(min h, max h) (m); the bound (-sum a, sum a) without a cell; over a cell, the sampled
        extremes padded by their rigorous sampling error (:attr:`curvature_bound`)."""
        total = float(self.amplitudes.sum())
        if self.cell is None:
            return (-total, total)
        pts, (dx, dy) = self._grid()
        h = self.height_at(pts)
        pad = self.curvature_bound * (dx * dx + dy * dy) / 8  # sampling error of an extremum
        return (max(float(h.min()) - pad, -total), min(float(h.max()) + pad, total))

    def spectrum(self) -> tuple[np.ndarray, np.ndarray]:
        """Wave vectors / 2 pi, shape (n, 2) (1/m), and amplitudes a_k, shape (n,) (m).

        Returns
        -------
        tuple of numpy.ndarray
            Wave vectors / 2 pi (1/m), shape (n, 2), and amplitudes (m), shape (n,).
        """
        return self._kvec / (2 * np.pi), self.amplitudes.copy()

    @classmethod
    def egg_crate(cls, amplitude: float, period: float) -> SumOfGratings:
        """h = A sin(2 pi x / l) sin(2 pi y / l): the isotropic 'egg-crate' of the paper's
        A and l, written as the two gratings (A/2) [cos(k(x - y)) - cos(k(x + y))] of
        wavelength l / sqrt(2) at -45 and +45 degrees. Its sup ‖grad h‖ is 2 pi A / l (at
        x = 0, y = l/4), the same as the profile's.

        Parameters
        ----------
        amplitude : float
            A (m), >= 0.
        period : float
            l (m), > 0.

        Returns
        -------
        SumOfGratings

        Raises
        ------
        ParameterError
            If the amplitude is negative or the period not > 0.

        Examples
        --------
        >>> egg = hx.SumOfGratings.egg_crate(0.8e-3, 1e-3)
        >>> egg.dimension, egg.height_at([[0.25e-3, 0.25e-3]])
        (2, array([0.0008]))
        """
        a = nonnegative("amplitude", amplitude, "m")
        lp = positive("period", period, "m")
        out = cls([a / 2, a / 2], [lp / math.sqrt(2)] * 2, [-math.pi / 4, math.pi / 4], [math.pi / 2, -math.pi / 2])
        out._label = f"SumOfGratings.egg_crate(amplitude={a:g}, period={lp:g})"
        return out


class Grating(SumOfGratings):
    """One grating h = A sin(2 pi (x cos th + y sin th) / l + phi) (m).

    Parameters
    ----------
    amplitude : float
        A >= 0 (m).
    period : float
        Wavelength l > 0 (m) along the direction.
    direction : float, optional
        th (rad) of the wave vector from the x axis, default 0 (ridges along y).
    phase : float, optional
        phi (rad).

    Raises
    ------
    ParameterError
        For a negative amplitude, a non-positive period or non-finite values.
    """

    def __init__(self, amplitude, period, direction=0.0, phase=0.0):
        super().__init__([amplitude], [period], [direction], [phase])

    def __repr__(self) -> str:
        return (f"Grating(amplitude={self.amplitudes[0]:g}, period={self.periods[0]:g}, "
                f"direction={self.directions[0]:g}, phase={self.phases[0]:g})")

    @property
    def max_slope(self) -> float:  # type: ignore[override]
        """2 pi A / l, exact."""
        return float(2 * np.pi * self.amplitudes[0] / self.periods[0])

    max_slope_is_exact = True

    @property
    def max_curvature(self) -> float:  # type: ignore[override]
        """A (2 pi / l)^2, exact."""
        return float(self.amplitudes[0] * (2 * np.pi / self.periods[0]) ** 2)

    @property
    def height_range(self) -> tuple[float, float]:  # type: ignore[override]
        """(-A, A) (m), exact."""
        a = float(self.amplitudes[0])
        return (-a, a)


class BandLimitedNoise2D(SumOfGratings):
    """Isotropic band-limited noise h(x, y), periodic on a size x size cell (m).

    Every wave vector 2 pi (m, n) / size of the lattice (one of each +-pair) whose
    wavelength lies in [shortest_period, longest_period] gets the same amplitude a (a flat
    spectrum over the annulus) and an independent phase uniform in [0, 2 pi) from
    ``numpy.random.default_rng(seed)``; a = rms sqrt(2 / n), so the RMS height over the
    cell is exactly ``rms``.

    Parameters
    ----------
    rms : float
        RMS height (m), >= 0.
    shortest_period, longest_period : float
        Band limits (m), 0 < shortest <= longest <= size.
    size : float
        Side of the periodic cell (m).
    seed : int
        Seed of the phases.

    Raises
    ------
    ParameterError
        For out-of-range values, a band with no lattice wave vector, or more than
        ``MAX_HARMONICS`` of them.
    """

    def __init__(self, rms, shortest_period, longest_period, size, seed=0):
        rms = nonnegative("rms", rms, "m")
        lmin = positive("shortest_period", shortest_period, "m")
        lmax = positive("longest_period", longest_period, "m")
        side = positive("size", size, "m")
        if not lmin <= lmax <= side:
            raise fail("longest_period", lmax, f"in [shortest_period = {lmin:g}, size = {side:g}] m")
        rmax = side / lmin * (1 + 1e-9)
        check_count("shortest_period", lmin, math.pi * rmax * rmax / 2, MAX_HARMONICS,
                    "lattice wave vectors in the band (each evaluation of h costs one per grating)")
        r = math.floor(rmax)
        m, n = np.meshgrid(np.arange(0, r + 1), np.arange(-r, r + 1), indexing="ij")
        m, n = m.ravel(), n.ravel()
        half = (m > 0) | ((m == 0) & (n > 0))  # one of each +- pair
        radius = np.hypot(m, n)
        keep = half & (radius >= side / lmax * (1 - 1e-9)) & (radius <= rmax)
        m, n, radius = m[keep], n[keep], radius[keep]
        if m.size == 0:
            raise fail("shortest_period", lmin, f"a band that contains a wave vector of the 1/size = {1 / side:g} "
                       "1/m lattice")
        seed = random_seed("seed", seed)
        phases = np.random.default_rng(seed).uniform(0.0, 2 * np.pi, m.size)
        amp = rms * math.sqrt(2.0 / m.size)
        self.rms, self.size, self.seed = rms, side, int(seed)
        super().__init__(np.full(m.size, amp), side / radius, np.arctan2(n, m), phases)

    def __repr__(self) -> str:
        return (f"BandLimitedNoise2D(rms={self.rms:g}, shortest_period={self.shortest_period:g}, "
                f"size={self.size:g}, seed={self.seed})")

    @property
    def cell(self) -> tuple[float, float]:  # type: ignore[override]
        """(size, size): every wave vector is on the lattice 2 pi (m, n) / size."""
        return (self.size, self.size)


class Extruded(Surface):
    """A profile extruded across the scan: h(x, y) = h(x) (m).

    The 2-D paper is its y-invariant slice: every algorithm and analysis on
    ``Extruded(profile)`` in 3-D reproduces the profile's 2-D numbers, with zero force and
    Jacobian entries along y.

    Parameters
    ----------
    profile : Texture
        A height profile h(x) (dimension 1).

    Raises
    ------
    ParameterError
        If ``profile`` is not a profile.
    """

    def __init__(self, profile: Texture):
        if not isinstance(profile, Texture) or profile.dimension != 1:
            raise fail("profile", profile, "a haptex profile h(x) (e.g. haptex.Sinusoid(0.8e-3, 1e-3))")
        self.profile = profile

    def __repr__(self) -> str:
        return f"Extruded({self.profile!r})"

    def kernel_data(self) -> tuple[int, np.ndarray]:
        """The profile's (kind, coeffs): over [x, y, z] the kernels read h(x) and ignore y.

        Returns
        -------
        tuple of (int, numpy.ndarray)
            The profile's kind and coefficients.
        """
        return self.profile.kernel_data()

    def height_at(self, xt):
        """The profile's height at x, whatever y.

        Parameters
        ----------
        xt : array_like, shape (..., 2)
            In-plane positions [x, y] (m).

        Returns
        -------
        numpy.ndarray
            shape (...): h (m).
        """
        return self.profile.height(plane(xt)[..., 0])

    def gradient(self, xt):
        """[h'(x), 0].

        Parameters
        ----------
        xt : array_like, shape (..., 2)
            In-plane positions [x, y] (m).

        Returns
        -------
        numpy.ndarray
            shape (..., 2): grad h (m/m).
        """
        x = plane(xt)[..., 0]
        out = np.zeros(x.shape + (2,))
        out[..., 0] = self.profile.slope(x)
        return out

    def hessian(self, xt):
        """[[h''(x), 0], [0, 0]].

        Parameters
        ----------
        xt : array_like, shape (..., 2)
            In-plane positions [x, y] (m).

        Returns
        -------
        numpy.ndarray
            shape (..., 2, 2): the Hessian (1/m).
        """
        x = plane(xt)[..., 0]
        out = np.zeros(x.shape + (2, 2))
        out[..., 0, 0] = self.profile.curvature(x)
        return out

    @property
    def shortest_period(self) -> float:
        return self.profile.shortest_period

    @property
    def cell(self) -> tuple[float, float] | None:
        """(the profile's period, its shortest period): invariant along y."""
        period = self.profile.period
        return None if period is None else (float(period), self.profile.shortest_period)

    @property
    def domain(self):
        """((x0, x1), (0, the profile's shortest period)) in m: the profile's domain along x,
        one shortest period along y (invariant there), or None."""
        dom = self.profile.domain
        return None if dom is None else ((float(dom[0]), float(dom[1])), (0.0, self.profile.shortest_period))

    @property
    def max_slope(self) -> float:
        return self.profile.max_slope

    @property
    def max_slope_is_exact(self) -> bool:
        return bool(getattr(self.profile, "max_slope_is_exact", True))

    @property
    def max_curvature(self) -> float:
        return self.profile.max_curvature

    @property
    def height_range(self) -> tuple[float, float]:
        return self.profile.height_range


MAX_SAMPLES = 16_000_000
"""Most samples a height map may have (4000 x 4000): its spline's coefficients take as much
memory again."""


SURFACE_SAMPLES_PER_CUTOFF = 16
"""Samples per cut-off period a map keeps when band-limited (a profile keeps 32): the bicubic
spline through a band-limited map then errs by about (2 pi / 16)^2 / 12 = 1.3 % in curvature
at the cut-off, and the closest-point search of D and E, whose work grows with the patches
within reach of a deep probe, handles a quarter of the patches (chosen: a 1024 x 1024 map
of 1 um pixels kept all its 10^6 patches at 32, and one q of D took minutes)."""


def _increasing(name: str, arr: np.ndarray, what: str | None = None) -> np.ndarray:
    """``arr`` (m), its steps checked strictly positive (``name`` the parameter refused, ``what``
    the message's subject, default ``name``): the steps."""
    step = np.diff(arr)
    if not np.all(step > 0):
        i = int(np.argmax(~(step > 0))) + 1
        raise ParameterError(f"{name}[{i}] = {arr[i]:g} is not allowed: {what or name} must increase strictly")
    return step


def _four_samples(name: str, arr: np.ndarray) -> None:
    """Refuse an axis of fewer than 4 samples (a bicubic patch needs 4 x 4)."""
    if arr.size < 4:
        raise ParameterError(f"{name} has {arr.size} samples, which is not allowed: a height map needs at least "
                             "4 x 4 samples (a bicubic spline)")


def _grid_axis(name: str, values) -> tuple[np.ndarray, float]:
    """A uniform, strictly increasing sample axis (m) and its spacing."""
    arr = _vector(name, values)
    _four_samples(name, arr)
    step = _increasing(name, arr)
    d = (arr[-1] - arr[0]) / (arr.size - 1)
    if np.max(np.abs(step - d)) > 1e-6 * d:
        i = int(np.argmax(np.abs(step - d)))
        raise ParameterError(f"{name} is not allowed: its spacing is not uniform ({name}[{i + 1}] - {name}[{i}] = "
                             f"{step[i]:g} m against the mean {d:g} m); resample the map onto a regular grid")
    return arr, float(d)


def _graded_axes(x, y, knots, periodic, gradients):
    """A periodic Hermite map's graded axes: (x, y, (x knots, y knots)), each axis's knots
    strictly increasing, (n + 1,), the first n its samples (``SampledSurface``'s ``knots``)."""
    if gradients is None or not periodic:
        raise fail("knots", "given for a map without gradients or not periodic",
                   "knots with gradients=... and periodic=True (a periodic Hermite map on graded axes)")
    try:
        kx, ky = knots
    except (TypeError, ValueError):
        raise fail("knots", f"{knots!r}", "a pair (x knots, y knots) of increasing positions (m)") from None
    out = []
    for name, samples, k in (("x", x, kx), ("y", y, ky)):
        arr = _vector(name, samples)
        kk = _vector(f"knots[{len(out)}]", k)
        _four_samples(name, arr)
        if kk.size != arr.size + 1 or not np.array_equal(kk[:-1], arr):
            raise fail(f"knots[{len(out)}]", f"an axis of {kk.size} knots",
                       f"{arr.size + 1} knots whose first {arr.size} are {name}, the last the period's end")
        _increasing(f"knots[{len(out)}]", kk, "knots")
        out.append(kk)
    return out[0][:-1].copy(), out[1][:-1].copy(), (out[0], out[1])


PYRAMID_BASE = 1 << 18
"""A map's bounds pyramid starts from blocks of one patch up to this many patches, else from
blocks of 2^s patches a side that bring it there (about 14 MB at most)."""


def _block_reduce(b: np.ndarray, step: int) -> np.ndarray:
    """Bounds (..., 5) over blocks of step x step of the first two axes (the last blocks
    partial): min of min h, max of the others."""
    ix, iy = np.arange(0, b.shape[0], step), np.arange(0, b.shape[1], step)
    lo = np.minimum.reduceat(np.minimum.reduceat(b[..., :1], ix, axis=0), iy, axis=1)
    hi = np.maximum.reduceat(np.maximum.reduceat(b[..., 1:], ix, axis=0), iy, axis=1)
    return np.concatenate([lo, hi], axis=-1)


_NU = [(0, 0), (1, 0), (0, 1), (2, 0), (1, 1), (0, 2)]  # SampledSurface._derivatives' order
# d^p/ds^p s^a = _FALL[p][a] s^(a - p): the multipliers of a bicubic patch's coefficients
_FALL = [np.ones(4), np.arange(4.0), np.arange(4.0) * np.arange(-1.0, 3.0),
         np.arange(4.0) * np.arange(-1.0, 3.0) * np.arange(-2.0, 2.0)]


class SampledSurface(Surface):
    """A measured or generated height map h(x, y) on a regular grid, evaluated by a C^2
    bicubic spline (the tensor product of cubic interpolating splines).

    Parameters
    ----------
    x : array_like, shape (nx,)
        Column positions (m), uniform and strictly increasing, nx >= 4.
    y : array_like, shape (ny,)
        Row positions (m), uniform and strictly increasing, ny >= 4.
    h : array_like, shape (nx, ny)
        Heights (m), finite, ``h[i, j]`` at (x[i], y[j]).
    periodic : bool, optional
        Close the map into a periodic texture on the cell (nx dx, ny dy) with periodic
        splines; otherwise not-a-knot splines over the sampled rectangle, extended beyond
        it by the tangent plane of its edge (C^1 there).
    shortest_period : float, optional
        The shortest wavelength present (m); default the Nyquist period 2 max(dx, dy).
    source : str, optional
        Where the map came from (for reports).
    gradients : array_like, shape (nx, ny, 2), optional
        grad h (m/m) at each sample, when it is known exactly: the map is then the bicubic
        Hermite interpolant through heights and gradients (its twist d^2 h / dx dy from central
        differences of the gradients) instead of the C^2 spline: C^1 across the patch lines,
        C^2 within a patch. A felt map (:func:`haptex.probe.felt_by`) is one, with each
        kinked edge's slopes along it moved within the contacts' (then only C^0 there).
    knots : tuple of two array_like, optional
        For a periodic Hermite map (``gradients`` given) on graded axes: the cells' edges along
        x and along y (m), shapes (nx + 1,) and (ny + 1,), strictly increasing, the first nx
        (ny) of them ``x`` (``y``) and the last the period's end, so that the cells need not be
        uniform: fine where the map curves sharply, coarse elsewhere. The C core finds a point's
        cell by bisection of the knots (at most log2 n + 1 steps an axis). Transformations that
        need a regular grid (:meth:`spectrum`, :meth:`lowpass`, :meth:`band_limited`,
        :meth:`scaled`, :meth:`leveled`, :meth:`line`, the grid of
        :func:`haptex.probe.felt_by`, :func:`haptex.probe.reliability_cutoff`) act on the map
        sampled at as many points a side at its cells' mean widths (its own heights there).

    Attributes
    ----------
    kinks : numpy.ndarray, shape (k, 3)
        For a felt map, each grid edge across which the ball's contact jumps (the ball
        bridging a trough; none where r max_curvature <= 1, where it cannot bridge anything):
        its midpoint x, y (m) and the jump of the slope along it
        (dimensionless): the forces of B, C and G (eqs. 11, 14, 28: they read the slope) jump
        there; A's, D's, E's and F's do not (below a V-shaped crease the closest point is on the
        crease). Empty otherwise.
    curvature_miss : float or None
        For a periodic felt map refined for its curvature (of a surface the ball cannot bridge,
        or of an analytic one it bridges): how far its curvature misses the ball path's, as a
        fraction of the path's largest (its largest, and its Hessian at the cells' centres,
        against the path's there, at its nodes and at the kinks' one-sided limits). The
        refinement stops within ``CURVATURE_SLACK`` (1 %) or at its cap, keeping the grid that
        missed least; q of B, C and G (which read the curvature, eqs. 11, 14, 28) on the map is
        then within about this fraction of q on the ball's path. None where it was not measured
        (a map that ends at its edges, a sampled map the ball bridges, a first grid already past
        the cap, any other map). Where no uniform grid within the cap meets the slack, the map is
        made again on graded axes (``knots``: cells from about 1 um where the path's curvature
        comes within 2 % of its largest, ``haptex.surfaces.GRADED_HOT``, growing away from there
        to 3 times the last uniform grid's step) and kept where its largest curvature meets the
        slack (``peak_miss``): on the egg-crate at 0.95 times its bowls' radius 578 x 578
        samples, q of B, C and G +0.51 % where the uniform 760 x 760 read +3.29 %; on the tests'
        random map at 0.95 times 338 x 371, +0.72 % for +3.34 %. There the curvature between the
        finest cells, along the egg-crate saddles' diagonal ridges, is read short by up to 8.9 % of
        the largest (this miss), where the ridge is 93 % of it: the sup q reads is not there.
    peak_miss : float or None
        Where ``curvature_miss`` is measured: the part of it that the sup of the map's curvature,
        what q of B, C and G reads, can see: the miss of its largest, the cells' centres'
        2-norms beyond the path's largest, and short of the path's where that is within
        ``CURVATURE_SLACK`` of its largest, a fraction of the path's largest; at most
        ``curvature_miss`` (equal to it on a map the ball bridges). None where that is. Where
        it passes the slack the path's largest is climbed from its largest samples (nodes and
        cells' centres sample a spike narrower than the cells below its top), and the
        refinement's maps are ranked by it: on two gratings at 63 degrees at 0.98 times their
        tightest radius 3.4 % for q of C's -3.4 %, where the samples alone said 20.4 %; at 0.99
        times a graded map is kept that meets the slack (q of C within 1 %), where the samples
        kept a uniform one that said 15.3 % for -23.8 % (2026-11-29).
    convex_miss : float or None
        For a periodic felt map refined for its curvature of a surface the ball cannot bridge:
        how far its most convex curvature (the sup of its Hessian's lower eigenvalue where
        negative) misses the path's most convex at its nodes and cells' centres, as a fraction of
        that, and the lower eigenvalues at the centres where either is convex. q of D, d_max /
        (R - d_max) below the most convex point of radius R (eq. 18), is then off by about
        ``convex_miss`` (1 + q) (exactly so where the map's sup is that much more convex): on the
        egg-crate's map on the plane's axes at 0.88, 0.9 and 0.95 times its bowls' radius 1.4,
        3.0 and 176 %, q of D +3.07, +6.52 % and 58.5 for the path's 1.025 (the saddles, where
        the concave spike crosses the convex direction diagonally through the cells), where
        ``curvature_miss`` says 0.39, 0.65 and 8.9 %; the refinement reads it with the
        curvature's own. Its map is now on axes along its gratings (``turn``), where the
        saddles' ridges run along the cells' sides: 0.001 and 0.013 % at 0.9 and 0.95 times, q of
        D within 0.003 % (2026-11-29). q's note states this miss where it passes 1 %
        (:func:`haptex.characteristic_number`). None where ``curvature_miss`` is not measured or
        the ball bridges the surface.
    path_curvature : float or None
        Where ``curvature_miss`` is measured: the ball path's largest curvature (1/m) the
        refinement found (its samples, climbed where they pass the slack, on every map it made:
        the largest). A lower bound of the path's sup (every sample is a value of it): where the
        map's own largest (``max_curvature``) is below it, q of B, C and G on the path may be
        ``path_curvature / max_curvature`` times the map's or more (the note of
        :func:`haptex.characteristic_number` says so). None where the misses are not measured.
    turn : float
        The angle (rad) by which the map's axes are turned from the plane's: 0 but on a felt map
        of a sum of gratings whose wave vectors lie along two perpendicular directions off the
        plane's axes, made on axes along them (:attr:`haptex.SumOfGratings.felt_turn`, pi/4 on
        the egg-crate). ``x``, ``y``, ``knots`` and the patches are then on the map's axes (the C
        core's ``PATCH_TURN`` turns a point into them), while :attr:`cell`, :attr:`domain`,
        ``kinks``, :attr:`crease_ends`, :meth:`steepest_points` and every evaluation are on the
        plane's; :meth:`to_plane` turns the map's points. Its transformations act on its own
        axes and keep the turn; :meth:`line` refuses it.

    Raises
    ------
    ParameterError
        For a ``periodic`` that is not True or False, fewer than 4 x 4 samples, NaNs or
        infinities or entries that are not real numbers (a bool, text or a complex number),
        heights beyond +-1 km, a non-uniform or non-increasing axis, mismatched
        shapes, or more than
        ``MAX_SAMPLES`` samples; gradients of another shape or not finite; knots without
        gradients or periodic, or not increasing from x (y).

    Notes
    -----
    Transformations (:meth:`leveled`, :meth:`lowpass`, :meth:`scaled`, cropping) return a
    spline map of the new heights: a Hermite map's gradients are not carried over.
    """

    def __init__(self, x, y, h, periodic: bool = False, shortest_period: float | None = None, source: str = "",
                 gradients=None, knots=None):
        from scipy.interpolate import NdBSpline, make_interp_spline

        from ._validation import MAX_LENGTH

        periodic = flag("periodic", periodic)
        self._knots = None
        if knots is None:
            x, dx = _grid_axis("x", x)
            y, dy = _grid_axis("y", y)
        else:
            x, y, self._knots = _graded_axes(x, y, knots, periodic, gradients)
            dx, dy = (float(np.diff(k).max()) for k in self._knots)  # (the coarsest cells: Nyquist, leaves)
        h = numbers("h", h, "an array of heights in metres, shape (nx, ny)", copy=False)
        if h.shape != (x.size, y.size):
            raise ParameterError(f"h has shape {h.shape}, which is not allowed: must be (nx, ny) = ({x.size}, "
                                 f"{y.size}), h[i, j] at (x[i], y[j])")
        check_count("h", f"a {h.shape[0]} x {h.shape[1]} map", h.size, MAX_SAMPLES, "samples")
        bad = np.argwhere(~np.isfinite(h))
        if bad.size:
            i, j = (int(v) for v in bad[0])
            raise ParameterError(f"h[{i}, {j}] = {h[i, j]} is not allowed: a height map must be finite everywhere "
                                 f"({bad.shape[0]} non-finite samples; fill or crop them first)")
        if np.max(np.abs(h)) > MAX_LENGTH or max(abs(x[0]), abs(x[-1]), abs(y[0]), abs(y[-1])) > MAX_LENGTH:
            raise ParameterError(f"h = a map beyond +-{MAX_LENGTH:g} m is not allowed: samples must lie within "
                                 f"+-{MAX_LENGTH:g} m (check the unit)")
        self.x, self.y, self.h = x, y, np.ascontiguousarray(h)
        self.dx, self.dy = dx, dy
        self.periodic = periodic
        self.source = source
        self.kinks = np.zeros((0, 3))
        self.curvature_miss = self.peak_miss = self.convex_miss = self.path_curvature = None
        self._gradients = self._edges = self._branches = None
        if gradients is not None:
            allowed = f"shape ({x.size}, {y.size}, 2) of finite slopes (m/m), grad h at each sample"
            g = numbers("gradients", gradients, allowed, copy=False)
            if g.shape != h.shape + (2,) or not np.all(np.isfinite(g)):
                raise fail("gradients", f"an array of shape {np.shape(gradients)}", allowed)
            self._gradients = np.ascontiguousarray(g)
        if self._knots is not None:
            self._size = tuple(float(k[-1] - k[0]) for k in self._knots)
        else:
            self._size = (x.size * dx, y.size * dy) if self.periodic else ((x.size - 1) * dx, (y.size - 1) * dy)
        self._spline = None  # (a Hermite map is its patches alone: no spline of its heights is built)
        if self._gradients is None:
            if self.periodic:
                xe, ye = np.r_[x, x[-1] + dx], np.r_[y, y[-1] + dy]
                he = np.pad(h, ((0, 1), (0, 1)), mode="wrap")
                bx = make_interp_spline(xe, he, k=3, bc_type="periodic", axis=0)
                by = make_interp_spline(ye, bx.c, k=3, bc_type="periodic", axis=1)
            else:
                bx = make_interp_spline(x, h, k=3, axis=0)
                by = make_interp_spline(y, bx.c, k=3, axis=1)
            # make_interp_spline puts the interpolated axis first: by.c is (y coefficients, x coefficients)
            self._spline = NdBSpline((bx.t, by.t), np.ascontiguousarray(np.moveaxis(by.c, 0, 1)), 3)
        nyquist = 2 * max(dx, dy)
        self._shortest = nyquist if shortest_period is None else max(positive("shortest_period", shortest_period, "m"),
                                                                     nyquist)

    def __repr__(self) -> str:
        what = f", source={self.source!r}" if self.source else ""
        if self._knots is not None:
            return (f"SampledSurface({self.x.size}x{self.y.size} samples on graded axes, cells up to {self.dx:g} by "
                    f"{self.dy:g}, periodic={self.periodic}{what})")
        return (f"SampledSurface({self.x.size}x{self.y.size} samples, dx={self.dx:g}, dy={self.dy:g}, "
                f"periodic={self.periodic}{what})")

    # -- evaluation ------------------------------------------------------------------
    def _derivatives(self, xt) -> np.ndarray:
        """h, h_x, h_y, h_xx, h_xy, h_yy at in-plane positions (..., 2): shape (..., 6), by
        the C core's evaluation of the spline's bicubic patches (the patches are the spline,
        to round-off); by scipy's spline (:meth:`_spline_eval`, the C's oracle in the tests)
        where the patches would exceed the memory budget."""
        from . import core
        from ._validation import ParameterError

        try:
            self.patches()
        except ParameterError:
            if self._gradients is not None:  # (a Hermite map has no spline to fall back on)
                raise
            return np.stack([self._spline_eval(xt, nu) for nu in _NU], -1)
        return core.texture_derivatives(self, plane(xt))

    def _frame_kinks(self) -> np.ndarray:
        """:attr:`kinks` on the map's own axes (a turned map's are reported on the plane)."""
        return self.kinks

    turn = 0.0

    def to_plane(self, m) -> np.ndarray:
        """Points on the map's axes (``x``, ``y``) as the plane's: the same points, unless the map
        is turned (:attr:`turn`), where p = R(turn) m.

        Parameters
        ----------
        m : array_like, shape (..., 2)
            Points (m) on the map's axes.

        Returns
        -------
        numpy.ndarray, shape (..., 2)
            The same points on the plane's axes (m).
        """
        return np.array(m, dtype=float)

    def _spline_eval(self, xt, nu):
        """Derivative ``nu`` = (i, j) of the spline at in-plane positions (..., 2), by scipy."""
        p = plane(xt)
        start = np.array([self.x[0], self.y[0]])
        size = np.array(self._size)
        if self.periodic:
            p = start + np.mod(p - start, size)
            return self._spline(p.reshape(-1, 2), nu=nu).reshape(p.shape[:-1])
        c = np.clip(p, start, start + size)
        d = p - c  # nonzero along the axes where p lies beyond the map
        flat_c = c.reshape(-1, 2)

        def at(i, j):
            return self._spline(flat_c, nu=(i, j)).reshape(p.shape[:-1])

        out = at(*nu)
        if not np.any(d):
            return out
        dx, dy = d[..., 0], d[..., 1]
        # the tangent-plane extension F(p) = h(c) + grad h(c) . d, with c the nearest point of
        # the map (c_i = p_i along the axes where p is inside, d_i = 0 there). Differentiated
        # along p: a derivative along an axis where p is outside acts on d only; so with m such
        # derivatives, F's derivative is D(h)(c) + D(grad h)(c) . d for m = 0, D(h)(c) for
        # m = 1, and 0 for m = 2.
        outside = [dx != 0, dy != 0]
        m = sum(outside[a].astype(int) for a, times in enumerate(nu) for _ in range(times))
        m = np.broadcast_to(m, out.shape)
        extra = at(nu[0] + 1, nu[1]) * dx + at(nu[0], nu[1] + 1) * dy
        return np.where(m == 0, out + extra, np.where(m == 1, out, 0.0))

    def height_at(self, xt):
        """The spline's height h(x, y).

        Parameters
        ----------
        xt : array_like, shape (..., 2)
            In-plane positions [x, y] (m).

        Returns
        -------
        numpy.ndarray
            shape (...): h (m).
        """
        return self._derivatives(xt)[..., 0].copy()

    def gradient(self, xt):
        """The spline's gradient.

        Parameters
        ----------
        xt : array_like, shape (..., 2)
            In-plane positions [x, y] (m).

        Returns
        -------
        numpy.ndarray
            shape (..., 2): grad h (m/m).
        """
        return self._derivatives(xt)[..., 1:3].copy()

    def hessian(self, xt):
        """The spline's Hessian.

        Parameters
        ----------
        xt : array_like, shape (..., 2)
            In-plane positions [x, y] (m).

        Returns
        -------
        numpy.ndarray
            shape (..., 2, 2): the Hessian (1/m).
        """
        d = self._derivatives(xt)
        return np.take(d, _HESSIAN, axis=-1).reshape(d.shape[:-1] + (2, 2))

    def _jet(self, xt, hessian: bool = True):
        """:meth:`haptex.Texture._jet` from one evaluation of the patches (the three methods'
        values to the bit: each reads the same six derivatives)."""
        d = self._derivatives(xt)
        hess = np.take(d, _HESSIAN, axis=-1).reshape(d.shape[:-1] + (2, 2)) if hessian else None
        return d[..., 0].copy(), d[..., 1:3].copy(), hess

    def kernel_data(self) -> tuple[int, np.ndarray]:
        """(``SURFACE_PATCHES``, :meth:`patches`).

        Returns
        -------
        tuple of (int, numpy.ndarray)
            ``SURFACE_PATCHES`` and the patches, shape (1, 10 + 16 n_cells) (and more: see
            :meth:`patches`).
        """
        return _ext.SURFACE_PATCHES, self.patches()

    @property
    def knots(self) -> tuple[np.ndarray, np.ndarray] | None:
        """Each axis's knots on graded axes, or None on a uniform grid.

        Returns
        -------
        (kx, ky) : tuple of ndarray, shapes (nx + 1,) and (ny + 1,), or None
            The cells' edges (m), the last the period's end: the ``knots`` the map was made with,
            or those :func:`haptex.probe.felt_by` chose for a felt map refined on graded axes
            (fine cells where the ball's path curves fastest). Copies.
        """
        return None if self._knots is None else (self._knots[0].copy(), self._knots[1].copy())

    def _widths(self) -> tuple[np.ndarray, np.ndarray]:
        """The cells' widths along x and y (m), shapes (nx,) and (ny,) (cells, not samples)."""
        if self._knots is not None:
            return np.diff(self._knots[0]), np.diff(self._knots[1])
        nx = self.x.size if self.periodic else self.x.size - 1
        ny = self.y.size if self.periodic else self.y.size - 1
        return np.full(nx, self.dx), np.full(ny, self.dy)

    def _regular(self) -> SampledSurface:
        """This map on a regular grid: itself, or a map on graded axes sampled at as many points
        a side at its cells' mean widths (its heights there, the C core's evaluation; a spline
        map of them, with its shortest period), for what needs a regular grid. Cached."""
        if self._knots is None:
            return self
        cached = self.__dict__.get("_on_regular")
        if cached is None:
            x = self.x[0] + np.arange(self.x.size) * (self._size[0] / self.x.size)
            y = self.y[0] + np.arange(self.y.size) * (self._size[1] / self.y.size)
            X, Y = np.meshgrid(x, y, indexing="ij")
            cached = SampledSurface(x, y, self.height_at(np.stack([X, Y], -1)), periodic=True,
                                    shortest_period=self._shortest, source=self.source)
            self.__dict__["_on_regular"] = cached
        return cached

    def patches(self) -> np.ndarray:
        """The map as bicubic patches for the C core (``haptex.core._ext.SURFACE_PATCHES``):
        shape (1, 10 + 16 n_cells), the header PATCH_* and per cell the coefficients c[a, b] of
        s^a t^b in the cell's local coordinates s, t in [0, 1]: a spline map's from its values
        at 4 x 4 points of each cell (a bicubic is fixed by 16 values), a Hermite map's from its
        corners' heights, slopes and twists. A felt map whose contact jumps inside some cells
        (``PATCH_JOINS`` = ``JOINS_BRANCHED``) is followed by n_cells + 1 starts and its cells'
        extra patches (``hx_core.h``): the height there is the highest patch's. A map on graded
        axes (``knots``) ends with its nx + 1 and ny + 1 knots, their column in ``PATCH_AXES``
        (0 on uniform cells, ``PATCH_DX`` by ``PATCH_DY``), and each axis's bucket index, the C
        core's short cut to a point's cell (``hx_core.h``). Cached, read-only: the C core checks
        it once (``haptex.core._ext.checked``; a branched map's check reads every cell's start,
        0.4 ms on a 688 x 352 felt map) and not again on each evaluation; a map unpickled (a Dask
        worker's) makes the plain array it brought that table on its first use.

        Returns
        -------
        numpy.ndarray, shape (1, 10 + 16 n_cells) or (1, 10 + 17 n_cells + 1 + 16 n_extra)
            The header and each cell's 16 coefficients (m), then a branched map's starts and
            extra patches, then a graded map's knots (nx + ny + 2 more) and bucket indexes.

        Raises
        ------
        ParameterError
            If the patches would take more than the memory budget.
        """
        cached = self.__dict__.get("_patches")
        if cached is not None:
            if cached.flags.writeable:  # (unpickled, on a Dask worker: a plain copy, made the checked table again)
                cached = self.__dict__["_patches"] = _ext.checked(_ext.SURFACE_PATCHES, cached)
            return cached
        K = _ext
        from ._validation import check_budget

        nx = self.x.size if self.periodic else self.x.size - 1
        ny = self.y.size if self.periodic else self.y.size - 1
        extra = 0 if self._branches is None else self._branches[3].shape[0]  # (a branched cell's other patches)
        check_budget("h", f"a {self.x.size} x {self.y.size} map", 3 * 16 * 8 * (nx * ny + extra),
                     "bicubic patches for the closest-point search (D, E)")
        out = self._hermite_patches(nx, ny) if self._gradients is not None else self._spline_patches(nx, ny)
        head = np.zeros(K.PATCH_DATA)
        head[K.PATCH_X0], head[K.PATCH_Y0] = self.x[0], self.y[0]
        head[K.PATCH_DX], head[K.PATCH_DY] = (self.dx, self.dy) if self._knots is None else (
            self._size[0] / nx, self._size[1] / ny)  # (graded: the cells' mean widths)
        head[K.PATCH_NX], head[K.PATCH_NY] = nx, ny
        head[K.PATCH_PERIODIC] = 1.0 if self.periodic else 0.0
        head[K.PATCH_JOINS] = K.JOINS_SPLINE if self._gradients is None else K.JOINS_HERMITE
        head[K.PATCH_TURN] = self.turn
        tail = []
        if self._branches is not None:  # (a felt map's cells where the contact jumps: one patch a contact)
            cells, first, starts, extra = self._branches
            out.reshape(-1, 4, 4)[cells] = first
            head[K.PATCH_JOINS] = K.JOINS_BRANCHED
            tail = [starts.astype(np.float64), extra.ravel()]
        if self._knots is not None:  # (graded axes: their knots after all the rest, then their index, hx_core.h)
            head[K.PATCH_AXES] = K.PATCH_DATA + out.size + sum(t.size for t in tail)
            tail += list(self._knots) + [_knot_index(kn) for kn in self._knots]
        # (a read-only copy the C core checks once: a branched map's check reads every cell's start)
        arr = K.checked(K.SURFACE_PATCHES, np.concatenate([head, out.ravel(), *tail])[None, :])
        self.__dict__["_patches"] = arr
        return arr

    def _hermite_patches(self, nx, ny) -> np.ndarray:
        """A Hermite map's patches, shape (nx, ny, 4, 4): per cell the bicubic through its
        corners' heights, slopes along each edge (the edge's own where a kink moved them) and
        twists (the node's, none beside a kink), c = A F A^T with A the cubic Hermite basis's
        coefficients (:data:`_HERMITE`) and F the corners' data in the cell's units."""
        g = self._gradients
        wx, wy = self._widths()
        ex, ey, twist = (self._edges if self._edges is not None else
                         (*_node_edges(g, self.periodic), _twist(g, self.dx, self.dy, self.periodic, self._knots)))
        wx, wy = wx[:, None], wy[None, :]
        mx, my = self.x.size, self.y.size
        i = np.arange(nx)[:, None]
        j = np.arange(ny)[None, :]
        i1, j1 = (i + 1) % mx, (j + 1) % my
        F = np.empty((nx, ny, 4, 4))
        for a, ia in ((0, i), (1, i1)):
            for b, jb in ((0, j), (1, j1)):
                F[..., a, b] = self.h[ia, jb]
                F[..., 2 + a, b] = ex[i, jb, a] * wx  # the slope along x of the x-edge at row j + b
                F[..., a, 2 + b] = ey[ia, j, b] * wy  # the slope along y of the y-edge at column i + a
                F[..., 2 + a, 2 + b] = twist[ia, jb] * wx * wy
        return _HERMITE @ F @ _HERMITE.T

    def _spline_patches(self, nx, ny) -> np.ndarray:
        """The spline's patches, shape (nx, ny, 4, 4), from its values at 4 x 4 points a cell:
        the values D_x C D_y^T with C the spline's coefficients and D each axis's B-spline
        design matrix at the cell's points (scipy's ``BSpline.design_matrix``; four nonzero
        entries a row), so a map of n cells costs O(n), not n evaluations of the full tensor
        spline."""
        from scipy.interpolate import BSpline

        nodes = np.arange(4) / 3.0
        vand_inv = np.linalg.inv(nodes[:, None] ** np.arange(4)[None, :])  # values at s_k -> coefficients
        (tx, ty), coef = self._spline.t, self._spline.c
        px = (self.x[0] + (np.arange(nx)[:, None] + nodes[None, :]) * self.dx).ravel()
        py = (self.y[0] + (np.arange(ny)[:, None] + nodes[None, :]) * self.dy).ravel()
        # (extrapolate: the last cell's far points may round past the last knot)
        dy_ = BSpline.design_matrix(py, ty, 3, extrapolate=True)
        out = np.empty((nx, ny, 4, 4))
        step = max(1, 250_000 // ny)
        for i0 in range(0, nx, step):
            i1 = min(nx, i0 + step)
            dx_ = BSpline.design_matrix(px[4 * i0:4 * i1], tx, 3, extrapolate=True)
            vals = np.asarray((dy_ @ (dx_ @ coef).T).T)  # (4 (i1 - i0), 4 ny)
            # per cell vand_inv @ values @ vand_inv.T, as two products over all cells at once
            half = (vals.reshape(-1, 4) @ vand_inv.T).reshape(i1 - i0, 4, ny, 4)  # (cell x, s_k, cell y, b)
            out[i0:i1] = np.einsum("ak,ikjb->ijab", vand_inv, half, optimize=True)
        return out

    @cached_property
    def derivative_bounds(self) -> tuple[float, float, float]:
        """Rigorous bounds over the sampled rectangle (a periodic map: everywhere) of the
        spline's slope, curvature and third derivatives: the largest of
        :meth:`patch_bounds`' over the patches. S >= ‖grad h‖ (m/m), C >= ||H||_2 (1/m) and
        J >= the norm of the third-derivative tensor (1/m^2). The spline is C^2, so H is
        Lipschitz with constant J across patches: the closest-point search's Taylor bound
        (``_ext.G_JERK``) holds on any disc or square inside the map. A Hermite map's hold
        within each patch only (``_ext.PATCH_JOINS``: the search cuts its cells at the patch
        lines)."""
        b = self.patch_bounds()
        return float(b[..., 2].max()), float(b[..., 3].max()), float(b[..., 4].max())

    def patch_bounds(self) -> np.ndarray:
        """Rigorous bounds on each bicubic patch of :meth:`patches`, shape (nx, ny, 5): min h
        and max h (m; the least and largest of the patch's Bernstein coefficients, which
        bound a polynomial on its box, widened by 1e-13 of the coefficients' magnitude for
        rounding), sup ‖grad h‖ (m/m), sup ||H||_2 (1/m, the spectral radius of the entries'
        bounds, which bounds it by Perron-Frobenius) and the third-derivative tensor's norm
        (1/m^2; sup over unit u of ‖D^3 h[u, u, u]‖, bounded by Cauchy-Schwarz as
        sqrt(B_xxx^2 + 3 B_xxy^2 + 3 B_xyy^2 + B_yyy^2)), each derivative at most the sum of
        its terms' magnitudes on the patch (s, t in [0, 1]). Cached.

        Returns
        -------
        numpy.ndarray, shape (nx, ny, 5)
            Per patch: min h, max h (m), slope (m/m), curvature (1/m), third derivatives
            (1/m²).

        Raises
        ------
        ParameterError
            If the patches would take more than the memory budget.
        """
        cached = self.__dict__.get("_patch_bounds")
        if cached is not None:
            return cached
        main, starts, extra = self._patch_blocks()
        nx, ny = main.shape[:2]
        pat = main.reshape(-1, 4, 4)
        wx, wy = self._widths()
        dxs, dys = np.repeat(wx, ny), np.tile(wy, nx)  # (each cell's widths, row-major as the patches)
        if extra is not None:  # (a branched cell's bounds: its patches', merged below)
            own = np.repeat(np.arange(nx * ny), np.diff(starts).astype(np.int64))  # (each extra patch's cell)
            pat = np.concatenate([pat, extra])
            dxs, dys = np.concatenate([dxs, dxs[own]]), np.concatenate([dys, dys[own]])
        fall = _FALL  # the multipliers of ‖c[a, b]‖ in each derivative's bound
        bern = np.array([[math.comb(j, a) / math.comb(3, a) if a <= j else 0.0 for a in range(4)] for j in range(4)])
        out = np.empty((pat.shape[0], 5))
        for i0 in range(0, pat.shape[0], 1 << 16):
            raw = pat[i0:i0 + (1 << 16)]
            c = np.abs(raw)
            dx, dy = dxs[i0:i0 + raw.shape[0]], dys[i0:i0 + raw.shape[0]]

            def bound(p, q):
                return np.einsum("nab,a,b->n", c, fall[p], fall[q]) / (dx ** p * dy ** q)

            b = (bern @ raw @ bern.T).reshape(raw.shape[0], 16)  # Bernstein coefficients: h's range on the patch
            slack = 1e-13 * c.sum(axis=(1, 2))
            bx, by = bound(1, 0), bound(0, 1)
            bxx, bxy, byy = bound(2, 0), bound(1, 1), bound(0, 2)
            o = out[i0:i0 + raw.shape[0]]
            o[:, 0] = b.min(axis=1) - slack
            o[:, 1] = b.max(axis=1) + slack
            o[:, 2] = np.hypot(bx, by)
            o[:, 3] = 0.5 * (bxx + byy) + np.hypot(0.5 * (bxx - byy), bxy)
            o[:, 4] = np.sqrt(bound(3, 0) ** 2 + 3 * bound(2, 1) ** 2 + 3 * bound(1, 2) ** 2 + bound(0, 3) ** 2)
        if extra is not None:  # the largest of each bound over a cell's patches (min h: the least)
            more = out[nx * ny:]
            out = out[:nx * ny]
            np.minimum.at(out[:, 0], own, more[:, 0])
            for k in range(1, 5):
                np.maximum.at(out[:, k], own, more[:, k])
        out = out.reshape(nx, ny, 5)
        self.__dict__["_patch_bounds"] = out
        return out

    @property
    def crease_ends(self) -> np.ndarray:
        """Where a felt map's creases end: the centres (k, 2) (m) of the cells with a single
        kinked edge (a crease, a line of kinks where two branches of the ball's contact tie,
        that enters a cell and does not leave it; none on a map without kinks), but those at a
        corner of which another kinked edge ends, not the cell's own nor the neighbour's across
        its edge (the crease leaves through that grid node), or a grid edge whose ends' contacts
        lie more than CREASE_GAP intervals apart on either side of ground the ball cannot touch
        (the crease goes on there, its contacts parting by less than a kink's BRANCH_JUMP
        intervals: :func:`_ending`). At a crease's end
        its two branches merge at a fold and the ball's path curves without bound towards it (a
        cusp), so q of B, C and G (their Jacobians read the curvature, eqs. 11, 14, 28) on the
        ideal path is unbounded there; the map's own q, what is rendered, is finite.

        Returns
        -------
        numpy.ndarray, shape (k, 2)
            The cells' centres (x, y) (m).
        """
        my = self.y.size if self.periodic else self.y.size - 1
        ci, cj = np.divmod(_crease_end_cells(self), my)
        return np.column_stack([self.x[ci] + 0.5 * self.dx, self.y[cj] + 0.5 * self.dy]).reshape(-1, 2)

    @property
    def branched_cells(self) -> int:
        """How many cells of a felt map are branched (``JOINS_BRANCHED``): the highest of one
        patch per contact, where the ball rests on several sides of a bowl (0 for any other
        map).

        Returns
        -------
        int
            The number of branched cells.
        """
        return 0 if self._branches is None else int(self._branches[0].size)

    def _patch_blocks(self):
        """:meth:`patches` read back: the cells' patches (nx, ny, 4, 4) (cells, not samples),
        and a branched map's starts (n_cells + 1,) and extra patches (E, 4, 4) (None, None
        for any other)."""
        arr = self.patches()[0]
        K = _ext
        nx, ny = int(arr[K.PATCH_NX]), int(arr[K.PATCH_NY])
        end = K.PATCH_DATA + 16 * nx * ny
        main = arr[K.PATCH_DATA:end].reshape(nx, ny, 4, 4)
        if arr[K.PATCH_JOINS] != K.JOINS_BRANCHED:
            return main, None, None
        starts = arr[end:end + nx * ny + 1]
        stop = int(arr[K.PATCH_AXES]) or arr.size  # (a graded map's knots after them)
        return main, starts, arr[end + nx * ny + 1:stop].reshape(-1, 4, 4)

    def bounds_pyramid(self) -> np.ndarray:
        """:meth:`patch_bounds` gathered over square blocks of patches, coarser level by level
        (``haptex.core._ext.PY_*``, the C search's layout, ``hx_core.h``): a header (nx, ny
        patches, the base level's block of 2^s patches a side, the number of levels) then each
        level's blocks (min h, max h, sup ‖grad h‖, sup ||H||_2, jerk), blocks 2^(s + l) patches
        a side, from the finest. The base is one patch where the map has at most PYRAMID_BASE
        patches, else the smallest power of two that brings it there; levels stop once a side
        has at most two blocks. The closest-point search bounds a cell by the blocks that cover
        it instead of the whole map's bounds. Cached.

        Returns
        -------
        numpy.ndarray, shape (n,)
            The header (``PY_*``) and, level by level, five bounds a block: min h and max h
            (m), slope (m/m), curvature (1/m) and third derivatives (1/m²).
        """
        cached = self.__dict__.get("_pyramid")
        if cached is not None:
            return cached
        b = self.patch_bounds()
        nx, ny = b.shape[:2]
        shift = 0
        while -(-nx >> shift) * -(-ny >> shift) > PYRAMID_BASE:
            shift += 1
        parts, level, k = [], b, 0
        while True:
            step = 1 << (shift if k == 0 else 1)  # the base from the patches, then pairs of blocks
            if step > 1:
                level = _block_reduce(level, step)
            parts.append(level.reshape(-1))
            k += 1
            if level.shape[0] <= 2 and level.shape[1] <= 2:
                break
        head = np.zeros(_ext.PY_HEAD)
        head[_ext.PY_NX], head[_ext.PY_NY], head[_ext.PY_SHIFT], head[_ext.PY_LEVELS] = nx, ny, shift, k
        out = np.concatenate([head, *parts])
        self.__dict__["_pyramid"] = out
        return out

    @cached_property
    def edge_bounds(self) -> np.ndarray:
        """Bounds on the derivatives along each edge of a non-periodic map, for the
        closest-point search's Taylor bounds beyond it (``_ext.G_EDGE``): beyond an edge
        the map is extended by its tangent plane, h = H(t) + G(t) e (e the distance beyond,
        t along the edge; C^1 across the edge, C^2 beside it), whose slope, curvature and
        third derivatives grow with e at most as these bounds say. Shape (4, 7): the edges
        x = x0, x = x1, y = y0, y = y1; per edge sup ‖d^(p+q) h / dn^p dt^q‖ on it (n the
        normal's axis, t the edge's) for (p, q) = (1, 0), (0, 1), (1, 1), (0, 2), (1, 2), (0, 3),
        (1, 3), each the sum of its terms' magnitudes over every patch along the edge. Zeros
        for a periodic map (it has no edges)."""
        if self.periodic:
            return np.zeros((4, 7))
        pat, starts, extra = self._patch_blocks()
        a = np.arange(4.0)
        fall = _FALL
        pq = [(1, 0), (0, 1), (1, 1), (0, 2), (1, 2), (0, 3), (1, 3)]
        out = np.zeros((4, 7))
        # (patches along the edge, c[normal power, tangential power], edge at s = 0 or 1, dn, dt)
        nx, ny = pat.shape[:2]

        def along(i, j):  # the patches of the cells (i, j) along an edge, a branched cell's extras too
            c = pat[i, j]
            if extra is None:
                return c
            k = (np.broadcast_to(i, np.shape(c)[:1]) * ny + np.broadcast_to(j, np.shape(c)[:1])).astype(np.int64)
            more = [extra[int(starts[m]):int(starts[m + 1])] for m in k]
            return np.concatenate([c, *more])

        cols, rows = np.arange(ny), np.arange(nx)
        edges = [(along(0, cols), 0.0, self.dx, self.dy), (along(nx - 1, cols), 1.0, self.dx, self.dy),
                 (along(rows, 0).transpose(0, 2, 1), 0.0, self.dy, self.dx),
                 (along(rows, ny - 1).transpose(0, 2, 1), 1.0, self.dy, self.dx)]
        for k, (c, s_edge, dn, dt) in enumerate(edges):
            for m, (p, q) in enumerate(pq):
                # d^p/ds^p of s^a at the edge: fall_p(a) s^(a - p), s = 0 or 1
                at = fall[p] * (s_edge ** np.maximum(a - p, 0) if s_edge else (a == p))
                v = np.einsum("jab,a->jb", c, at)  # coefficients of t^b of the normal derivative
                out[k, m] = float(np.max(np.abs(v) @ fall[q])) / (dn ** p * dt ** q)
        return out

    # -- summary numbers -------------------------------------------------------------
    @property
    def shortest_period(self) -> float:
        return self._shortest

    @property
    def cell(self) -> tuple[float, float] | None:
        """(nx dx, ny dy) for a periodic map, else None."""
        return self._size if self.periodic else None

    @property
    def domain(self):
        """The sampled rectangle ((x0, x1), (y0, y1)) (m); one cell if periodic."""
        return ((float(self.x[0]), float(self.x[0] + self._size[0])),
                (float(self.y[0]), float(self.y[0] + self._size[1])))

    def _grid(self):
        """Points for the sups: four a sample interval (fewer if the map is large), but no more
        than needed for 16 a shortest period (at least one a sample): a map band-limited and
        resampled at 32 samples a period (what ``design`` analyses) needs no 128."""
        (x0, x1), (y0, y1) = self.domain
        need = math.ceil(16 * max(self.dx, self.dy) / self._shortest)
        per = max(1, min(4, need, int(math.sqrt(MAX_GRID / (self.x.size * self.y.size)))))
        if self._knots is not None:  # (graded axes: per points in each cell, its steps the coarsest)
            xs, ys = ((k[:-1, None] + np.diff(k)[:, None] * (np.arange(per) / per)).ravel() for k in self._knots)
            X, Y = np.meshgrid(xs, ys, indexing="ij")
            return np.stack([X, Y], -1), (self.dx / per, self.dy / per)
        n = [self.x.size * per, self.y.size * per]
        xs = np.linspace(x0, x1, n[0], endpoint=self.periodic is False)
        ys = np.linspace(y0, y1, n[1], endpoint=self.periodic is False)
        X, Y = np.meshgrid(xs, ys, indexing="ij")
        pts, steps = np.stack([X, Y], -1), (xs[1] - xs[0], ys[1] - ys[0])
        cells = _kink_cells(self)
        if self._branches is not None:
            cells = np.union1d(cells, self._branches[0])
        if cells.size == 0:
            return pts, steps
        # a felt map's cells beside its kinks: a branched one the highest of several patches,
        # whose slope jumps along their creases, a steep patch the highest in a sliver beside one
        # that four points an interval step over (and the refinement, which climbs a smooth
        # function, cannot reach); a single one bridging the kink, strongly curved
        k = max(2, min(BRANCHED_SUP_POINTS, int(math.sqrt(MAX_GRID / 4 / cells.size))))
        s = (np.arange(k) + 0.5) / k
        ci, cj = np.divmod(cells, self.y.size if self.periodic else self.y.size - 1)
        X = np.broadcast_to((self.x[ci][:, None] + s * self.dx)[:, :, None], (cells.size, k, k))
        Y = np.broadcast_to((self.y[cj][:, None] + s * self.dy)[:, None, :], (cells.size, k, k))
        return np.concatenate([pts.reshape(-1, 2), np.stack([X, Y], -1).reshape(-1, 2)]), steps

    max_slope_is_exact = True

    @cached_property
    def max_slope(self) -> float:
        """M = sup ‖grad h‖ of the spline over the map (m/m): a dense grid (4 points a
        sample interval; on a felt map, ``haptex.surfaces.BRANCHED_SUP_POINTS`` a side in each
        cell beside its kinks too) refined by bounded quasi-Newton steps."""
        return math.sqrt(self._sup(lambda p: np.sum(self.gradient(p) ** 2, axis=-1),
                                   self.__dict__.setdefault("_steepest", [])))

    @cached_property
    def max_curvature(self) -> float:
        """sup of the Hessian's 2-norm over the map (1/m), found like :attr:`max_slope`."""
        return self._sup(lambda p: _hessian_norm(self.hessian(p)), self.__dict__.setdefault("_steepest", []))

    def steepest_points(self) -> np.ndarray:
        """The points (k, 2) (m, k <= 16) where the map's slope and curvature are largest: those
        :attr:`max_slope`'s and :attr:`max_curvature`'s searches refined from their grids' 8
        largest samples (four a sample interval, and more in the cells beside a felt map's
        kinks). :func:`haptex.characteristic_number` starts its refinement from them too: a map
        finer than its plane grid (256 cells a side at most) may peak within a sample, where B's,
        C's and G's Jacobians read the curvature (eqs. 11, 14, 28).

        Returns
        -------
        numpy.ndarray, shape (k, 2)
            The points (x, y) (m), k at most 16 (8 for each sup; fewer on a map of few samples).
        """
        self.max_slope, self.max_curvature  # (their searches record the points)
        return np.array(self.__dict__.get("_steepest", []), dtype=float).reshape(-1, 2)

    @cached_property
    def height_range(self) -> tuple[float, float]:
        """(min h, max h) (m): the grid's extremes widened by the sampling error
        sup ||H|| (dx^2 + dy^2) / 8; a Hermite map's (whose slopes may jump across its patch
        lines) the patches' Bernstein bounds (:meth:`patch_bounds`)."""
        if self._gradients is not None:
            b = self.patch_bounds()
            return (float(b[..., 0].min()), float(b[..., 1].max()))
        pts, (dx, dy) = self._grid()
        hh = self.height_at(pts)
        pad = self.max_curvature * (dx * dx + dy * dy) / 8
        return (float(hh.min()) - pad, float(hh.max()) + pad)

    def spectrum(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Amplitude spectrum of the samples: spatial frequencies f_x (shape (nx,)), f_y
        (shape (ny // 2 + 1,)) in 1/m, and amplitudes (m), shape (nx, ny // 2 + 1), scaled
        so that a grating of amplitude a on the grid shows a (numpy's rfft2).

        Returns
        -------
        tuple of numpy.ndarray
            f_x (1/m), shape (nx,); f_y (1/m), shape (ny // 2 + 1,); amplitudes (m), shape
            (nx, ny // 2 + 1).
        """
        if self._knots is not None:
            return self._regular().spectrum()
        H = np.fft.rfft2(self.h) / self.h.size
        amp = np.abs(H) * 2
        amp[0, 0] /= 2
        return np.fft.fftfreq(self.x.size, self.dx), np.fft.rfftfreq(self.y.size, self.dy), amp

    # -- transformations ---------------------------------------------------------------
    def _new(self, h, x=None, y=None, shortest=None) -> SampledSurface:
        return SampledSurface(self.x if x is None else x, self.y if y is None else y, h, self.periodic,
                              self._shortest if shortest is None else shortest, self.source)

    def leveled(self) -> SampledSurface:
        """The map minus its least-squares plane a + b x + c y (removes tilt and offset).

        Returns
        -------
        SampledSurface
            The levelled map (m), on the same grid.
        """
        if self._knots is not None:
            return self._regular().leveled()
        X, Y = np.meshgrid(self.x - self.x[0], self.y - self.y[0], indexing="ij")
        basis = np.stack([np.ones(X.size), X.ravel(), Y.ravel()], -1)
        coef, *_ = np.linalg.lstsq(basis, self.h.ravel(), rcond=None)
        return self._new(self.h - (basis @ coef).reshape(self.h.shape))

    def lowpass(self, shortest_period: float) -> SampledSurface:
        """Band-limit the map to wavelengths >= ``shortest_period`` (m) in every direction.

        Periodic maps: the 2-D FFT components with ‖f‖ > 1 / shortest_period are removed
        (an isotropic cut). Others: a zero-phase 4th-order Butterworth filter along x and
        then along y (scipy.signal.sosfiltfilt), cut-off 1 / shortest_period on each axis.

        Parameters
        ----------
        shortest_period : float
            The cut-off wavelength (m).

        Returns
        -------
        SampledSurface

        Raises
        ------
        ParameterError
            If the cut-off is not above the Nyquist period 2 max(dx, dy), or is longer than the
            map's shorter side (as :meth:`haptex.textures.SampledProfile.lowpass` refuses one
            longer than the scan).
        """
        if self._knots is not None:
            return self._regular().lowpass(shortest_period)
        lc = positive("shortest_period", shortest_period, "m")
        nyq = 2 * max(self.dx, self.dy)
        side = float(min(self.x[-1] - self.x[0], self.y[-1] - self.y[0]))
        if not nyq < lc <= side:
            raise fail("shortest_period", lc, f"longer than the Nyquist period 2 max(dx, dy) = {nyq:g} m and at most "
                       f"the map's shorter side, {side:g} m (a longer cut-off leaves no period of the map)")
        if self.periodic:
            H = np.fft.rfft2(self.h)
            fx = np.fft.fftfreq(self.x.size, self.dx)[:, None]
            fy = np.fft.rfftfreq(self.y.size, self.dy)[None, :]
            H[np.hypot(fx, fy) > 1.0 / lc] = 0.0
            hf = np.fft.irfft2(H, self.h.shape)
        else:
            from scipy.signal import butter

            from .textures import zero_phase_lowpass

            hf = self.h
            for axis, step in ((0, self.dx), (1, self.dy)):
                hf = zero_phase_lowpass(butter(4, (1.0 / lc) / (0.5 / step), output="sos"), hf, axis)
        return self._new(hf, shortest=lc)

    def band_limited(self, shortest_period: float,
                     samples_per_period: int = SURFACE_SAMPLES_PER_CUTOFF) -> SampledSurface:
        """What a device renders of this map: band-limited to wavelengths >= ``shortest_period``
        (:meth:`lowpass`) and resampled along x and y to at least ``samples_per_period``
        samples per shortest period (default 16, half a profile's: see
        ``SURFACE_SAMPLES_PER_CUTOFF``); see :meth:`SampledProfile.band_limited`.

        Parameters
        ----------
        shortest_period : float
            The cut-off wavelength (m).
        samples_per_period : int, optional
            Samples per shortest period along x and y, >= 4.

        Returns
        -------
        SampledSurface

        Raises
        ------
        ParameterError
            For a non-positive period or fewer than 4 samples per period, or a period
            :meth:`lowpass` refuses.
        """
        if self._knots is not None:
            return self._regular().band_limited(shortest_period, samples_per_period)
        surf, h, (sx, sy) = _band_limited_samples(self, shortest_period, samples_per_period, (self.dx, self.dy))
        if h is None:
            return surf
        return SampledSurface(self.x[0] + sx * np.arange(h.shape[0]), self.y[0] + sy * np.arange(h.shape[1]), h,
                              self.periodic, surf._shortest, self.source)

    def scaled(self, length_factor: float = 1.0, height_factor: float = 1.0) -> SampledSurface:
        """Stretch the map: x and y by ``length_factor``, h by ``height_factor``.

        Parameters
        ----------
        length_factor : float, optional
            Factor on x and y, > 0.
        height_factor : float, optional
            Factor on the heights, finite.

        Returns
        -------
        SampledSurface

        Raises
        ------
        ParameterError
            For a length factor not > 0 or a height factor not finite, or either so large that
            the scaled samples would lie beyond +-MAX_LENGTH (1000 m; the largest it takes is
            said).
        """
        if self._knots is not None:
            return self._regular().scaled(length_factor, height_factor)
        from ._validation import scale_factors

        lf, hf = scale_factors(length_factor, height_factor, float(max(np.abs(self.x).max(), np.abs(self.y).max())),
                               float(np.abs(self.h).max()))
        return self._new(self.h * hf, self.x * lf, self.y * lf, self._shortest * lf)

    def line(self, y: float | None = None, row: int | None = None):
        """One line of the map along x, as a profile.

        Parameters
        ----------
        y : float, optional
            Position of the line (m): the spline evaluated at (x_i, y) for every column
            x_i; within the rows of a map that is not periodic (any y on a periodic one, which
            its period wraps).
        row : int, optional
            Index j of a row of samples: h[:, j] as they are. Give exactly one of the two.

        Returns
        -------
        SampledProfile
            On the map's x samples, periodic if the map is.

        Raises
        ------
        ParameterError
            If neither or both are given, the row is out of range, or y is not finite or, on a
            map that is not periodic, beyond its rows.
        """
        if self._knots is not None:
            return self._regular().line(y, row)
        if (y is None) == (row is None):
            raise ParameterError(f"y = {y!r}, row = {row!r} is not allowed: give exactly one of the two")
        if row is not None:
            j = whole("row", row, 0, self.y.size - 1)
            h, where = self.h[:, j], f"row {j}"
        else:
            yv = finite("y", y, "m")
            lo, hi = float(self.y[0]), float(self.y[-1])
            if not (self.periodic or lo <= yv <= hi):
                raise fail("y", y, f"a position within the map's rows, {lo:g} to {hi:g} m (beyond them it has no "
                           "measured heights)")
            h = self.height_at(np.stack([self.x, np.full(self.x.size, yv)], -1))
            where = f"y = {yv:g} m"
        return SampledProfile(self.x, h, periodic=self.periodic, source=f"{self.source}, {where}".lstrip(", "))

    @classmethod
    def from_file(cls, path, *, spacing=None, x_unit=None, height_unit=None, variable=None, periodic: bool = False,
                  fill_undefined: bool = False, crop=None) -> SampledSurface:
        """Load a measured areal height map: every format SurfaceTopography reads (X3P, SDF,
        Gwyddion, Zygo, Wyko, Digital Surf, Keyence, Olympus, Sensofar, NPY, ...) with its
        stated physical size and unit, and MATLAB matrices (rows along y, as an image).

        Parameters
        ----------
        path : str or Path
        spacing : float or str, optional
            Pixel size, the same along x and y ("1um" or metres); required when the file
            states no physical size; never guessed.
        x_unit, height_unit : str, optional
            Units of the positions and heights when the file does not state them.
        variable : str, optional
            A .mat variable, an instrument file's channel (its name, or its index where two
            share a name) or a text table's heights' column (its name or index); default its
            only variable, or the instrument's height channel.
        periodic : bool, optional
            See :class:`SampledSurface`.
        fill_undefined : bool, optional
            Fill undefined (NaN) heights by SurfaceTopography's harmonic interpolation;
            by default such a map is refused, naming how many and where.
        crop : "auto" or (float, float, float, float), optional
            The part of the map kept, before any filling: ``"auto"``, the largest axis-aligned
            rectangle without undefined points (the maximal-rectangle algorithm on the mask), or
            ``(x0, x1, y0, y1)`` in metres (bounds given by hand must hold no undefined point
            unless ``fill_undefined``).

        Returns
        -------
        SampledSurface
            ``h[i, j]`` at (x_i, y_j), x along the instrument's first axis.

        Raises
        ------
        ParameterError
            As :meth:`SampledProfile.from_file`; a line scan is refused (read it with
            ``SampledProfile.from_file``), and so is a map over ``MAX_SAMPLES`` samples.
        """
        from ._loaders import read_topography

        r = read_topography(path, spacing=spacing, x_unit=x_unit, height_unit=height_unit, variable=variable,
                            fill_undefined=fill_undefined, crop=crop)
        if not r.areal:
            raise ParameterError(f"{path}: holds a line scan ({r.x.size} samples), not an areal map: read it with "
                                 "SampledProfile.from_file, or extrude it with Extruded(...)")
        return cls(r.x, r.y, r.h, periodic=periodic, source=r.source)

    @classmethod
    def from_image(cls, path, pixel_size, height_range, periodic: bool = False) -> SampledSurface:
        """A greyscale height map from an image (the bump maps CHAI3D and H3D users have).

        Parameters
        ----------
        path : str or Path
            An image Pillow reads (PNG, TIFF, JPEG, ...); colour is converted to luminance.
            8- and 16-bit greys keep their depth.
        pixel_size : float
            Size of a pixel (m), > 0; required (an image does not state it).
        height_range : (float, float)
            Heights (m) of black and of white: grey g in [0, 1] maps to
            black + g (white - black); required (an image does not state it).
        periodic : bool, optional
            Tile the image (a seamless texture).

        Returns
        -------
        SampledSurface
            Column i at x = i pixel_size, row j at y = j pixel_size (the image's top row
            at y = 0).

        Raises
        ------
        ParameterError
            If the file cannot be read as an image, the pixel size or height range is
            missing or invalid, or the image is smaller than 4 x 4 pixels.
        """
        from PIL import Image, UnidentifiedImageError

        if pixel_size is None:
            raise ParameterError("pixel_size = None is not allowed: an image does not state its pixel size; give it "
                                 "in metres (e.g. 10e-6; in the explorer, the image's pixel size box, e.g. 10um)")
        if height_range is None:
            raise ParameterError("height_range = None is not allowed: an image does not state its heights; give "
                                 "(black, white) in metres (e.g. (0, 50e-6))")
        step = positive("pixel_size", pixel_size, "m")
        try:
            black, white = (float(v) for v in height_range)
        except (TypeError, ValueError):
            raise fail("height_range", height_range, "a pair (black, white) of heights in metres") from None
        if not (math.isfinite(black) and math.isfinite(white)) or black == white:
            raise fail("height_range", height_range, "two different finite heights (black, white) in metres")
        p = a_path("path", path, "an image file's path")
        if not p.is_file():
            raise ParameterError(f"path = {str(path)!r} is not allowed: {'a directory' if p.is_dir() else 'no such file'}")
        try:
            with Image.open(p) as im:
                check_count("path", str(path), im.width * im.height, MAX_SAMPLES, "pixels")
                if im.mode in ("I;16", "I;16B", "I;16L", "I"):
                    grey = np.asarray(im, dtype=np.float64) / (65535.0 if im.mode.startswith("I;16") else
                                                                max(float(np.max(np.asarray(im))), 1.0))
                else:
                    grey = np.asarray(im.convert("L"), dtype=np.float64) / 255.0
        except (UnidentifiedImageError, OSError) as exc:
            raise ParameterError(f"path = {str(path)!r} is not allowed: not an image Pillow can read ({exc})") from None
        h = black + grey.T * (white - black)  # rows are y, columns x: h[i, j] at (x_i, y_j)
        x = step * np.arange(h.shape[0])
        y = step * np.arange(h.shape[1])
        return cls(x, y, h, periodic=periodic, source=str(path))


class _TurnedMap(SampledSurface):
    """A periodic felt map on axes turned by ``turn`` (rad) from the plane's: its samples, cells,
    knots and patches are on the map's own axes (``x``, ``y`` along them), its surface is
    h(p) = h_m(R(turn)^T p) on the plane (the C core's ``PATCH_TURN``, which turns a point into
    the map's frame, its gradient and Hessian back, and the closest-point search's probe), and
    what it reports about places (:attr:`cell`, :attr:`domain`, :attr:`kinks`,
    :attr:`crease_ends`, :meth:`steepest_points`) is on the plane. Made by
    ``SumOfGratings.felt_by`` where the gratings' wave vectors lie along two perpendicular
    directions off the plane's axes (the egg-crate's, at +-45 degrees): a tensor patch follows a
    ridge along its side, not across its diagonal. Transformations act on the map in its frame
    and keep the turn."""

    _CACHES = ("_on_regular", "_patches", "_closest_cache", "_surface_search", "_steepest", "_frame")

    @classmethod
    def of(cls, frame: SampledSurface, turn: float, cell) -> "_TurnedMap":
        """``frame`` (a periodic map on the map's axes) turned by ``turn`` (rad), periodic on the
        plane's ``cell`` (L_x, L_y) (m)."""
        out = cls.__new__(cls)
        out.__dict__.update({k: v for k, v in frame.__dict__.items() if k not in cls._CACHES})
        out.turn, out._cell = float(turn), (float(cell[0]), float(cell[1]))
        out._frame = frame
        out.kinks = frame.kinks.copy()
        out.kinks[:, :2] = out.to_plane(frame.kinks[:, :2])
        if "_steepest" in frame.__dict__:
            out.__dict__["_steepest"] = list(out.to_plane(np.asarray(frame.__dict__["_steepest"]).reshape(-1, 2)))
        return out

    def to_plane(self, m) -> np.ndarray:
        """Points on the map's axes as the plane's: p = R(turn) m.

        Parameters
        ----------
        m : array_like, shape (..., 2)
            Points (m) on the map's axes (``x``, ``y``).

        Returns
        -------
        numpy.ndarray, shape (..., 2)
            The same points on the plane's axes (m).
        """
        c, s = math.cos(self.turn), math.sin(self.turn)
        m = np.asarray(m, dtype=float)
        return np.stack([c * m[..., 0] - s * m[..., 1], s * m[..., 0] + c * m[..., 1]], -1)

    def __repr__(self) -> str:
        return super().__repr__()[:-1] + f", on axes turned {math.degrees(self.turn):g} deg)"

    def _derivatives(self, xt) -> np.ndarray:
        self.patches()  # (no spline fallback: its axes are the map's; ParameterError past the budget)
        return _core.texture_derivatives(self, plane(xt))

    def _frame_kinks(self) -> np.ndarray:
        return self._frame.kinks

    @property
    def cell(self) -> tuple[float, float]:
        """The plane's periodic cell (L_x, L_y) (m), the texture's it was felt on."""
        return self._cell

    @property
    def domain(self):
        """One cell of the plane, ((0, L_x), (0, L_y)) (m)."""
        return Surface.domain.fget(self)

    def _grid(self):
        pts, steps = super()._grid()
        return self.to_plane(pts), steps

    @property
    def crease_ends(self) -> np.ndarray:
        return self.to_plane(self._frame.crease_ends).reshape(-1, 2)

    def _turned(self, out: SampledSurface) -> "_TurnedMap":
        return _TurnedMap.of(out, self.turn, tuple(self._cell[a] * out._size[a] / self._size[a] for a in (0, 1)))

    def spectrum(self):
        """The map's amplitude spectrum on its own axes (:meth:`SampledSurface.spectrum`): f_x,
        f_y along the map's axes, turned ``turn`` from the plane's."""
        return self._frame.spectrum()

    def leveled(self) -> "_TurnedMap":
        return self._turned(self._frame.leveled())

    def lowpass(self, shortest_period: float) -> "_TurnedMap":
        return self._turned(self._frame.lowpass(shortest_period))

    def band_limited(self, shortest_period: float, samples_per_period: int = SURFACE_SAMPLES_PER_CUTOFF) -> "_TurnedMap":
        return self._turned(self._frame.band_limited(shortest_period, samples_per_period))

    def scaled(self, length_factor: float = 1.0, height_factor: float = 1.0) -> "_TurnedMap":
        return self._turned(self._frame.scaled(length_factor, height_factor))

    def line(self, y: float | None = None, row: int | None = None):
        raise ParameterError(f"texture = {self!r} is not allowed for line(): its rows run along axes turned "
                             f"{math.degrees(self.turn):g} deg from x; take a line of the texture it was felt on, "
                             "or evaluate height_at along the line you want")

    def _felt(self, r: float, spacing: float | None) -> "_TurnedMap":
        return self._turned(self._frame._felt(r, spacing))


def load_texture(path, *, spacing=None, x_unit=None, height_unit=None, variable=None, periodic: bool = False,
                 fill_undefined: bool = False, crop=None) -> SampledProfile | SampledSurface:
    """A measured texture from any file haptex reads, as the file holds it: a line scan
    becomes a :class:`~haptex.textures.SampledProfile`, an areal map a
    :class:`SampledSurface` (what ``--texture FILE`` does at the command line).

    Parameters
    ----------
    path : str or os.PathLike
        The file (every format of :meth:`SampledSurface.from_file` and of
        :meth:`~haptex.textures.SampledProfile.from_file`).
    spacing : float or str, optional
        Sample or pixel size ("1um" or metres), for a file that states none; never guessed.
    x_unit : str, optional
        Unit of the positions, for a file that does not state it.
    height_unit : str, optional
        Unit of the heights, for a file that does not state it.
    variable : str, optional
        A .mat variable, an instrument file's channel (its name, or its index where two
        share a name, as a trace and a retrace 'Height'), or the heights' column of a text
        table of four or more named columns (its name or index, the positions from
        ``spacing``); default its only variable, or the instrument's height channel.
    periodic : bool, optional
        Close the texture periodically.
    fill_undefined : bool, optional
        Fill undefined heights by interpolation instead of refusing them.
    crop : "auto" or tuple of float, optional
        ``"auto"``, ``(x0, x1)`` for a line scan or ``(x0, x1, y0, y1)`` for a map, in
        metres (``--crop`` at the command line).

    Returns
    -------
    SampledProfile or SampledSurface

    Raises
    ------
    ParameterError
        As :meth:`SampledSurface.from_file`: a ``path`` that is not a path (a str or
        os.PathLike, PEP 519), a file that cannot be read, a unit or size it does not state
        and that is not given, undefined heights not filled, a bad crop.
    """
    from ._loaders import read_topography

    r = read_topography(path, spacing=spacing, x_unit=x_unit, height_unit=height_unit, variable=variable,
                        fill_undefined=fill_undefined, crop=crop)
    out = (SampledSurface(r.x, r.y, r.h, periodic=periodic, source=r.source) if r.areal
           else SampledProfile(r.x, r.h, periodic=periodic, source=r.source))
    out.instrument_tip = r.instrument_tip
    return out


def _node_edges(g, periodic):
    """Each grid edge's slopes along it at its two ends, from the nodes' gradients g (nx, ny, 2):
    x-edges (i to i + 1 at row j) shape (mx, ny, 2), y-edges (j to j + 1 at column i) shape
    (nx, my, 2); m = n periodic, n - 1 otherwise."""
    gx, gy = g[..., 0], g[..., 1]
    if periodic:
        return (np.stack([gx, np.roll(gx, -1, axis=0)], -1), np.stack([gy, np.roll(gy, -1, axis=1)], -1))
    return np.stack([gx[:-1], gx[1:]], -1), np.stack([gy[:, :-1], gy[:, 1:]], -1)


def _knot_index(kn):
    """A graded axis's bucket index for the C core (``hx_core.h``, after the knots): [B, then the
    cell holding each of B equal buckets' starts], B the axis's length over its narrowest cell
    (rounded up), at most 16 n, so that a bucket holds at most one knot where it can (a point's
    cell then one bisection step from its bucket's), shape (B + 1,)."""
    n = kn.size - 1
    r = kn - kn[0]
    nb = int(min(np.ceil(r[-1] / np.min(np.diff(kn))), 16 * n))
    starts = r[-1] * np.arange(nb) / nb
    cells = np.clip(np.searchsorted(r, starts, side="right") - 1, 0, n - 1)
    return np.r_[float(nb), cells.astype(np.float64)]


def _twist(g, dx, dy, periodic, knots=None):
    """d^2 h / dx dy at the nodes: the mean of the central differences of h_x along y and of h_y
    along x (one-sided at a map's edges; on graded axes, ``knots``, the three-point difference
    exact for quadratics), shape (nx, ny)."""
    if knots is not None:
        return 0.5 * (_periodic_difference(g[..., 0], knots[1], 1) + _periodic_difference(g[..., 1], knots[0], 0))
    if periodic:
        hxy = (np.roll(g[..., 0], -1, axis=1) - np.roll(g[..., 0], 1, axis=1)) / (2 * dy)
        hyx = (np.roll(g[..., 1], -1, axis=0) - np.roll(g[..., 1], 1, axis=0)) / (2 * dx)
    else:
        hxy = np.gradient(g[..., 0], dy, axis=1)
        hyx = np.gradient(g[..., 1], dx, axis=0)
    return 0.5 * (hxy + hyx)


def _periodic_difference(f, knots, axis):
    """df/du at the nodes of a periodic axis of n + 1 knots (the last the period's end), along
    ``axis`` of f: (h-^2 f+ - h+^2 f- + (h+^2 - h-^2) f) / (h- h+ (h- + h+)), h- and h+ the
    steps before and after (the derivative of the quadratic through the three nodes)."""
    step = np.diff(knots)
    hp, hm = step, np.roll(step, 1)
    shape = [1] * f.ndim
    shape[axis] = -1
    hp, hm = hp.reshape(shape), hm.reshape(shape)
    fp, fm = np.roll(f, -1, axis=axis), np.roll(f, 1, axis=axis)
    return (hm * hm * fp - hp * hp * fm + (hp * hp - hm * hm) * f) / (hm * hp * (hm + hp))


BRANCH_JUMP = 3
"""A felt map's edge is kinked, and a cell branched, where two of its ends' or corners'
contacts lie more than this many sample intervals apart (chosen: the grid's arg-max and its
refinement move a contact by at most about one interval between neighbours on one side of a
trough)."""

CREASE_GAP = 0.5
"""Where a felt map's line of kinked edges stops, its crease goes on (:func:`_ending`) across the
grid edges whose ends' contacts lie more than this many intervals apart either side of ground the
ball cannot touch (chosen: on the egg-crate at 1.01 times its bowls' radius, whose creases run
bowl to saddle to bowl and end nowhere, their two contacts 20 um apart at least by brute force,
the branches part by 0.8 to 2.4 of the 25 um grid's intervals near the bowls, under BRANCH_JUMP's
3, and the map named 20 ends)."""

CREASE_WALK = 64
"""Cells a crease is followed through past its last kink (:func:`_ending`); past them its end is
named at that kink's cell (chosen: a crease's weak tail spans a few intervals where its branches
merge; on a rough map, where contacts part everywhere, the walk would not stop)."""

CONTACT_NEWTON_STEPS = 8
"""Safeguarded Newton steps refining each grid point's contact on an areal texture (chosen: from
the grid's arg-max, within one interval of the true contact, the error squares each step)."""

CONTINUATION_STEPS = 8
"""Steps a sample interval in which a felt map's branch whose contact left its box when followed
in one step is followed again by continuation (:func:`_continued_contacts`; chosen: on the
egg-crate's bowls felt by a ball of 1.1 times their radius, 44 % of the branches followed to a
464 x 464 grid's corners left their box, and their tangent planes put there made patches whose
curvature read 11.5 times the path's; followed in 8 steps an interval the map's largest
curvature is within 0.3 % of the path's and q of C within 0.28 %; each corner followed in
8 steps an interval of its source's larger offset). A branch so continued is kept
at a corner only where its curvature there is within the twist's bound, 2 M / interval (at 1.007
times the radius, continued branches nearer their folds branched 72 cells of a 32 x 32 map whose
patches stood 0.63 % steeper than the surface)."""


BRANCHED_SUP_POINTS = 32
"""Points a side of each cell of a felt map beside its kinks (branched or not) at which its sups
(:attr:`SampledSurface.max_slope`, :attr:`~SampledSurface.max_curvature`) are sampled too, fewer
where those cells would take more than a quarter of ``MAX_GRID`` points (chosen: on the 4 mm
egg-crate sampled 60 x 60, periodic, felt by a 1.2 mm ball, four points an interval read the
map's steepest slope as 0.3152 where a sliver beside a crease reaches 0.3236, found at 16
points a side; on a 1024 x 1024 rough map felt by a 20 um ball, 3,164 branched cells, the sup
takes 1.1 s)."""


REFINE = (1.0, 0.8, 0.65, 0.5, 0.4)
"""Spacings, relative to the default (an analytic surface's) or to the map's interval (a sampled
map's, its spline resampled; its own grid first), at which a felt map is made again while some
cell beside a kink keeps its single patch (its branches could not be made there) or the map is
steeper than the surface by more than STEEP_SLACK (a path's slope is a contact's): the first
with neither is kept, else the one not steeper with the fewest such cells, else the least steep
(chosen: on the egg-crate's bowls from 1.0 to 1.3 times their radius whether a cell branches
depends on where the grid's points fall, e.g. at 1.2 rho 58 points a period did and 51 and 100
did not; at 31 radii, 1.0 to 1.3 rho a hundredth apart, every one within 1 % of the
brute-force path, the farthest 1.12 rho, +0.59 %; at most 5 constructions (and REFINE_STEEP's),
0.1-3 s there. On the egg-crate sampled 61 x 61 over 4 mm, ending there, felt by 1.02, 1.05,
1.07 mm balls, its own grid read +4.60, +5.37, +9.68 %, the grids chosen +0.02, +0.03, +0.00 %;
a grid that branched nothing there read up to +27 %, steeper than the surface, and is not
chosen)."""


REFINE_STEEP = (0.3, 0.25)
"""Spacings, relative as REFINE's, at which a felt map is made again after REFINE's while every
grid made so far is steeper than the surface by more than STEEP_SLACK (an overshoot, q too
large), within REFINE_STEEP_SAMPLES (chosen: the tests' 64 x 64 rough map, 1 um samples, felt by
balls of 0.85, 0.88, 0.9 um, just below its tightest trough's radius 0.91 um, read +4.28, +2.79,
+6.55 % steeper than the surface on its own grid, +2.8 to +16 % on REFINE's, +0.00 % at 0.25 of
its interval; tried for every map that leaves single cells too, it took 13-31 s on that map and
27 s on a 128 x 128 one for no gain)."""

REFINE_STEEP_SAMPLES = 256 * 256
"""The largest grid (samples over the cell, or over a sampled map) REFINE_STEEP's are made on
(chosen: 0.25 of the 64 x 64 map's interval; 1-2 s a construction there)."""

REFINE_SAMPLES = 128 * 128
"""The largest grid (samples over the cell, or over a sampled map) a refined felt map is made on;
a map that cannot be refined within it keeps its own grid, unrefined (chosen: the egg-crate's
bowls need 66 x 66; a rough surface felt on a 400 x 400 grid took 200 s once)."""


FELT_SAMPLES = (16, 16)
"""A felt map's default grid step: the smaller of a 16th of the texture's shortest period and a
16th of the ball's radius (chosen)."""


def _default_spacing(texture, r, spacing=None):
    """``spacing`` (m) checked, or the felt map's default (:data:`FELT_SAMPLES`)."""
    return _spacing(texture, r, spacing, *FELT_SAMPLES)


def _kink_cells(felt) -> np.ndarray:
    """The flat indices (i * cells a row + j) of a felt map's cells beside its kinks: the two
    cells sharing each kinked edge (on a map that ends at its edges, those on it)."""
    return np.unique(_kinked_edge_cells(felt))


def _kinked_edges(felt):
    """A felt map's kinked edges: their first nodes' indices i, j (k,) and whether each runs
    along x (k,) bool (from (i, j) to (i + 1, j); else to (i, j + 1)); on a periodic map the
    indices wrapped, the nodes' (nx, ny) and the cells' alike."""
    kinks = felt._frame_kinks()
    if kinks is None or len(kinks) == 0:
        return np.zeros(0, dtype=int), np.zeros(0, dtype=int), np.zeros(0, dtype=bool)
    dx, dy = float(felt.x[1] - felt.x[0]), float(felt.y[1] - felt.y[0])
    k = kinks[:, :2]
    i = np.floor((k[:, 0] - felt.x[0]) / dx + 1e-9).astype(int)
    j = np.floor((k[:, 1] - felt.y[0]) / dy + 1e-9).astype(int)
    along_x = np.abs((k[:, 0] - felt.x[0]) / dx - i - 0.5) < 1e-6  # (a kink at an x edge's middle)
    if felt.periodic:
        i, j = i % felt.x.size, j % felt.y.size
    return i, j, along_x


def _edge_cells(felt, i, j, along_x) -> np.ndarray:
    """The flat indices (2, k) of the two cells either side of kinked edges (:func:`_kinked_edges`):
    an x edge's above and below it, a y edge's right and left; wrapped on a periodic map, -1 off a
    bounded one."""
    mx, my = (felt.x.size, felt.y.size) if felt.periodic else (felt.x.size - 1, felt.y.size - 1)
    ci = np.stack([i, np.where(along_x, i, i - 1)])
    cj = np.stack([j, np.where(along_x, j - 1, j)])
    if felt.periodic:
        return (ci % mx) * my + cj % my
    on = (ci >= 0) & (ci < mx) & (cj >= 0) & (cj < my)
    return np.where(on, ci * my + cj, -1)


def _kinked_edge_cells(felt) -> np.ndarray:
    """The flat indices of the cells on either side of each kinked edge of a felt map, once an
    edge (a cell as often as it has kinked edges; on a map that ends at its edges, the cells on
    it)."""
    cell = _edge_cells(felt, *_kinked_edges(felt))
    return cell[cell >= 0]


def _shortfall(path_curvature, max_curvature):
    """How many times a felt map's largest curvature ``max_curvature`` (1/m) the path's largest
    found ``path_curvature`` (1/m, a lower bound of its sup) is, where the map's is short of it;
    else None."""
    if path_curvature is None or not 0.0 < max_curvature < path_curvature:
        return None
    return path_curvature / max_curvature


def _crease_end_cells(felt) -> np.ndarray:
    """The flat indices of a felt map's cells where a crease ends (:attr:`SampledSurface.crease_ends`):
    a cell with a single kinked edge, unless a corner of it is an end of another kinked edge that
    is neither its own nor one of the cell's across that edge (a crease passing through a grid
    node, from the cell's side to a diagonal neighbour: on the egg-crate just above its bowls'
    radius, whose creases run along the diagonals through nodes to where they meet, such cells
    were named ends, 2026-12-01)."""
    i, j, ax = _kinked_edges(felt)
    if i.size == 0:
        return np.zeros(0, dtype=np.int64)
    my = felt.y.size if felt.periodic else felt.y.size - 1
    nx, ny = felt.x.size, felt.y.size
    cell = _edge_cells(felt, i, j, ax)  # (2, k): each edge's two cells, -1 off the map
    flat, count = np.unique(cell[cell >= 0], return_counts=True)
    single = flat[count == 1]
    if single.size == 0:
        return single
    ei, ej = np.where(ax, i + 1, i), np.where(ax, j, j + 1)  # (each edge's second node)
    if felt.periodic:
        ei, ej = ei % nx, ej % ny
    at = {}  # node (flat) -> the edges ending there
    for k, node in enumerate(np.concatenate([i * ny + j, ei * ny + ej]).tolist()):
        at.setdefault(node, []).append(k % i.size)
    lone = set(single.tolist())
    edge_of = {c: k for k, pair in enumerate(cell.T.tolist()) for c in pair if c in lone}  # (its one kinked edge)
    ends = []
    for c in single.tolist():
        k = edge_of[c]
        mine = set(int(v) for v in cell[:, k] if v >= 0)
        a, b = divmod(c, my)
        corners = [((a + da) % nx) * ny + (b + db) % ny for da in (0, 1) for db in (0, 1)]
        through = any(not (mine & set(int(v) for v in cell[:, e] if v >= 0))
                      for n in corners for e in at.get(n, ()) if e != k)
        if not through:
            ends.append(c)
    return _ending(felt, np.array(ends, dtype=np.int64), cell, edge_of, i, j, ax)


def _ending(felt, ends, cell, edge_of, i, j, ax):
    """Where the creases that stop at the cells ``ends`` (flat indices; ``cell`` (2, k) and
    ``edge_of`` as in :func:`_crease_end_cells`, i, j, ax the kinked edges, :func:`_kinked_edges`)
    end: each is followed from its cell along the grid edges whose ends' contacts (from the nodes'
    gradients, :func:`_contact_offsets`) lie more than CREASE_GAP intervals apart either side of
    ground the ball cannot touch (:func:`_kinked` with that gap, in any direction): the crease goes on
    there, its contacts parting by less than a kink's BRANCH_JUMP intervals (near the troughs'
    radius, or where two grid points' contacts sit on a chord at an angle to the direction the
    ball bridges). Each step looks at the edges at the corners of the cells reached, but those of
    cells reached before (the crease's own, behind it). Where it meets a kinked edge the crease
    goes on and ends nowhere there; where no such edge is left, it ends in the last cell reached
    (the crease's extreme, an interval or a few past its last kink); past CREASE_WALK cells, at
    its last kink's cell, as before. On a map with no record of what it was felt on and by,
    ``ends`` as given. Returns the flat indices (k,) of the cells."""
    texture, r = getattr(felt, "_felt_from", None), getattr(felt, "_felt_radius", None)
    if ends.size == 0 or texture is None or r is None or felt._gradients is None:
        return ends
    nx, ny, periodic = felt.x.size, felt.y.size, felt.periodic
    my = ny if periodic else ny - 1
    u = _contact_offsets(felt._gradients.reshape(-1, 2), r).reshape(nx, ny, 2)
    dx, dy = felt.dx, felt.dy
    wrap = (lambda a, b: (a % nx, b % ny)) if periodic else (lambda a, b: (a, b))
    kinked = {(int(a), int(b), bool(c)) for a, b, c in zip(*wrap(i, j), ax)}
    weak = {}  # (edge) -> whether the crease goes on across it

    def gone_on(edges):  # which edges (first node i, j, along x) the crease crosses weakly
        todo = [e for e in edges if e not in weak]
        if todo:
            ei, ej, ex = (np.array(v) for v in zip(*todo))
            fi, fj = np.where(ex, ei + 1, ei), np.where(ex, ej, ej + 1)
            s0 = np.column_stack([felt.x[0] + ei * dx, felt.y[0] + ej * dy]) + u[ei % nx, ej % ny]
            s1 = np.column_stack([felt.x[0] + fi * dx, felt.y[0] + fj * dy]) + u[fi % nx, fj % ny]
            on = _kinked(texture, s0, s1 - s0, dx, dy, r, CREASE_GAP, any_direction=True)
            weak.update(zip(todo, on.tolist()))
        return [weak[e] for e in edges]

    def around(c):  # the edges at cell c's corners: (edge, its two cells)
        a, b = divmod(c, my)
        out = {}
        for na, nb in ((a, b), (a + 1, b), (a, b + 1), (a + 1, b + 1)):
            for ea, eb, along in ((na, nb, True), (na - 1, nb, True), (na, nb, False), (na, nb - 1, False)):
                if not periodic and not (0 <= ea and 0 <= eb and ea + along < nx and eb + (not along) < ny):
                    continue
                e = (*(int(v) for v in wrap(ea, eb)), along)
                out[e] = [int(v) for v in _edge_cells(felt, np.array([e[0]]), np.array([e[1]]), np.array([along]))[:, 0]
                          if v >= 0]
        return out

    found = []
    for c in ends.tolist():
        seen = set(int(v) for v in cell[:, edge_of[c]] if v >= 0)  # (the cell and the one across its kink)
        queue, last, joined = [c], c, False
        while queue and len(seen) <= CREASE_WALK:
            cur = last = queue.pop(0)
            near = {e: two for e, two in around(cur).items() if set(two) & seen <= {cur}}
            if any(e in kinked for e in near):
                joined = True
                break
            edges = list(near)
            for e, on in zip(edges, gone_on(edges)):
                for v in near[e] if on else ():
                    if v not in seen:
                        seen.add(v)
                        queue.append(v)
        if joined:
            continue
        found.append(c if len(seen) > CREASE_WALK else last)
    return np.unique(np.array(found, dtype=np.int64))


def _single_kink_cells(felt):
    """How many cells beside a felt map's kinks are not branched."""
    cells = _kink_cells(felt)
    if felt._branches is None:
        return int(cells.size)
    return int(np.count_nonzero(~np.isin(cells, felt._branches[0])))


def _on_rim(q, x, y):
    """Which in-plane points q (..., 2) lie on the rim of the sampled rectangle x by y (to 1e-6 of
    an interval)."""
    tol = 1e-6 * min(float(x[1] - x[0]), float(y[1] - y[0]))
    return ((q[..., 0] <= x[0] + tol) | (q[..., 0] >= x[-1] - tol) | (q[..., 1] <= y[0] + tol)
            | (q[..., 1] >= y[-1] - tol))


def _path_gradient(texture, P, u, r, rim):
    """The gradient (..., 2) of the ball's centre path at points P (..., 2) whose contacts are at
    offsets u (..., 2): the envelope theorem on c(p) = max over q of H(q) + sqrt(r^2 - |q - p|^2),
    the set of q (the disc, and a bounded map's sampled rectangle) not moving with p, gives
    grad c = u / sqrt(r^2 - |u|^2); at a contact inside the rectangle that is grad H there (the
    contact's own slope, which is evaluated), where ``rim`` (..., bool; None on a periodic map)
    says it lies on its rim only the formula holds."""
    grads = texture.gradient(P + u)
    if rim is not None and rim.any():
        ur = u[rim]
        grads[rim] = ur / np.sqrt(np.maximum(r * r - np.einsum("ij,ij->i", ur, ur), 1e-300))[:, None]
    return grads


def _contact_hessians(texture, Q, u, r):
    """At contact points Q (n, 2) with offsets u (n, 2) from the ball's centre (radius r, m): the
    surface's Hessian A (n, 2, 2) there, the sphere's B = I / s + u u^T / s^3 (n, 2, 2) (the
    derivative of u / s, s = sqrt(r^2 - |u|^2)) and s (n,): the contact condition grad h(Q) = u / s
    differentiated."""
    from . import core

    deriv = texture._derivatives if isinstance(texture, SampledSurface) else partial(core.texture_derivatives, texture)
    d = deriv(Q)
    s = np.sqrt(np.maximum(r * r - np.einsum("ij,ij->i", u, u), 1e-300))
    A = np.take(d, _HESSIAN, axis=-1).reshape(-1, 2, 2)
    B = np.eye(2) / s[:, None, None] + u[:, :, None] * u[:, None, :] / (s**3)[:, None, None]
    return A, B, s


def _path_hessian(texture, P, u, r, sound=1e-3):
    """The Hessian (n, 2, 2) of the ball's centre path at points P (n, 2) whose contacts inside
    the surface are at offsets u (n, 2): the implicit function theorem on grad H(p + u) = u / s
    (s = sqrt(r^2 - |u|^2)) gives -A (A - B)^-1 B, A the surface's Hessian at the contact and
    B = I / s + u u^T / s^3 the sphere's; NaN where |det(A - B)| is at most ``sound`` / s^2
    (near r = the surface's radius of curvature the contact is degenerate, A ~ B, and the
    path's curvature unbounded)."""
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):  # (NaN where it has none)
        A, B, s = _contact_hessians(texture, P + u, u, r)
        M = A - B
        det = M[:, 0, 0] * M[:, 1, 1] - M[:, 0, 1] ** 2
        inv = np.stack([np.stack([M[:, 1, 1], -M[:, 0, 1]], -1), np.stack([-M[:, 0, 1], M[:, 0, 0]], -1)], -2)
        ok = np.abs(det) > sound / s**2
        inv /= np.where(ok, det, 1.0)[:, None, None]
        return np.where(ok[:, None, None], -(A @ inv @ B), np.nan)


def _path_twist(texture, P, u, r):
    """The cross derivative d2c/dxdy (n,) of the ball's centre path at points P (n, 2) whose
    contacts inside the surface are at offsets u (n, 2): :func:`_path_hessian`'s, NaN where
    det(A - B) is under 1e-3 / s^2."""
    return _path_hessian(texture, P, u, r)[:, 0, 1]


def _refine_contacts(texture, P, u, lo, hi, r, rim, tol):
    """Safeguarded Newton ascent of g(u) = H(P + u) + sqrt(r^2 - |u|^2) from offsets u (n, 2)
    within the boxes [lo, hi] (n, 2) and the disc |u| <= rim, by the C core
    (``hx_contact_ascent``, hx_felt.c; each point its own ascent, on the core's threads): at most
    CONTACT_NEWTON_STEPS steps, each from one evaluation of H, grad H and its Hessian at the
    contact, the ascent's Hessian shifted to negative definite where it is not; a step is kept
    only where it raises g (inside the box and the disc), halved while longer than ``tol`` (m;
    Newton's error then ~ tol^2 times the curvature's ratio), and a point stops once its kept
    step is shorter than ``tol``. A coordinate at its bound whose ascent points out of the box
    is held there and the other stepped by its own curvature (projected Newton: on a map's rim
    the full step, clipped, stalled 1e-3 of an interval short). Returns u (n, 2) and g there
    (n,). The texture's patches are built first (ParameterError past the memory budget)."""
    kind, coeffs = texture.kernel_data()
    coeffs = np.ascontiguousarray(coeffs, dtype=np.float64)  # (a map's checked table is kept as it is)
    u = np.array(u, dtype=np.float64, order="C")  # (a copy: refined in place)
    P, lo, hi = (np.ascontiguousarray(np.broadcast_to(a, u.shape), dtype=np.float64) for a in (P, lo, hi))
    g = np.empty(u.shape[0])
    _core.in_slices(lambda a, b: _ext.contact_ascent(kind, coeffs, P[a:b], u[a:b], lo[a:b], hi[a:b], g[a:b], float(r),
                                                     float(rim), float(tol), CONTACT_NEWTON_STEPS),
                    u.shape[0], least=256)
    return u, g


def _continued_contacts(texture, Ps, us, P, r, rim, reach, steps, tol):
    """The contacts of branches followed by continuation: each ball position moved from Ps (n, 2)
    to P (n, 2) in ``steps`` equal steps, its contact from offset us (n, 2) carried along by the
    implicit-function predictor du = (B - A)^-1 A dP (A the surface's Hessian at the contact, B =
    I / s + u u^T / s^3 the sphere's: the derivative of grad h(p + u) = u / s) and corrected by
    :func:`_refine_contacts` (to ``tol``, m) within ``reach`` (2,) m of the prediction. A branch
    ends (its fold: A - B no longer negative definite, or the correction at its box's wall, or
    the contact off the disc) and is not followed further. Returns (u (n, 2), g (n,) the
    ascent's maximum, -inf where it ended, alive (n,) bool)."""
    u, g = us.copy(), np.full(us.shape[0], -np.inf)
    alive = np.ones(us.shape[0], dtype=bool)
    dP = (P - Ps) / steps
    for k in range(1, steps + 1):
        idx = np.nonzero(alive)[0]
        if idx.size == 0:
            break
        ua = u[idx]
        A, B, _ = _contact_hessians(texture, Ps[idx] + (k - 1) * dP[idx] + ua, ua, r)
        M = B - A  # (positive definite on a branch: the ascent's Hessian A - B negative there)
        det = M[:, 0, 0] * M[:, 1, 1] - M[:, 0, 1] ** 2
        ok = (M[:, 0, 0] > 0) & (det > 0)
        with np.errstate(divide="ignore", invalid="ignore"):
            du = np.linalg.solve(np.where(ok[:, None, None], M, np.eye(2)), (A @ dP[idx][..., None]))[..., 0]
        du = np.clip(du, -reach, reach)
        pred = ua + du
        Pk = Ps[idx] + k * dP[idx]
        lo, hi = pred - reach, pred + reach
        v, gv = _refine_contacts(texture, Pk, pred, lo, hi, r, rim, tol)
        wall = np.any((v <= lo + 1e-6 * reach) | (v >= hi - 1e-6 * reach), axis=1)
        inside = np.einsum("ij,ij->i", v, v) < (rim * (1 - 1e-6)) ** 2
        live = ok & ~wall & inside
        u[idx], g[idx] = v, gv
        alive[idx[~live]] = False
    return u, np.where(alive, g, -np.inf), alive


def _contact_map(texture, x, y, h, r, periodic):
    """The ball's centre path on the grid (x, y) over a surface: heights c - r (nx, ny), the
    path's gradients (nx, ny, 2), the edges' slopes (:func:`_node_edges`' layout, each kinked
    edge's moved by :func:`haptex.textures._kink_ends`, for a cell beside it that is not
    branched) with the nodes' twists (:func:`_twist`'s, none beside a kink), the kinks (k, 3):
    x, y (m) and the slope jump along the edge, and the branched cells (:func:`_branch_patches`).

    c(p) = max over |u| <= r of [H(p + u) + sqrt(r^2 - |u|^2)], H the texture's own height:
    the maximum over the grid's offsets first (each grid point's arg-max contact), then refined
    on H by safeguarded Newton steps within one interval of it (never below the grid's own
    maximum); the gradient is grad H at the contact (the envelope theorem: the path's normal is
    the contact's), u / sqrt(r^2 - |u|^2) where the contact is on a bounded map's rim
    (:func:`_path_gradient`). A kinked edge joins neighbouring points whose contacts lie more than
    BRANCH_JUMP intervals apart (the ball bridging a trough), as on a profile; the cells beside
    it are branched. Where a branch followed to a grid point stands higher than the contact the
    point's own search found (two rim contacts the grid's arg-max could not tell apart), that is
    the point's contact, and the edges and branches are made once more (what was followed at or
    from other points kept, :func:`_forget`)."""
    dx, dy = float(x[1] - x[0]), float(y[1] - y[0])
    from .probe import _grid_contacts

    nx, ny = h.shape
    best, (ua, ub) = _grid_contacts(h, (dx, dy), r, periodic)
    X, Y = np.meshgrid(x, y, indexing="ij")
    P = np.stack([X, Y], -1)
    if periodic:
        u0 = np.stack([ua * dx, ub * dy], -1)
        lo, hi = u0 - [dx, dy], u0 + [dx, dy]
    else:  # the contact stays on the sampled rectangle (beyond it the padding repeats its edges)
        ia = np.clip(np.arange(nx)[:, None] + ua, 0, nx - 1)
        ib = np.clip(np.arange(ny)[None, :] + ub, 0, ny - 1)
        u0 = np.stack([x[ia] - X, y[ib] - Y], -1)
        lo = np.maximum(u0 - [dx, dy], np.stack([x[0] - X, y[0] - Y], -1))
        hi = np.minimum(u0 + [dx, dy], np.stack([x[-1] - X, y[-1] - Y], -1))
    rim = r * (1 - 1e-9)
    u, gu = _refine_contacts(texture, P.reshape(-1, 2), u0.reshape(-1, 2), lo.reshape(-1, 2), hi.reshape(-1, 2),
                             r, rim, 1e-6 * min(dx, dy))
    u, gu = u.reshape(u0.shape), gu.reshape(h.shape)
    keep = best > gu  # never below the grid's own maximum
    u = np.where(keep[..., None], u0, u)
    c = np.where(keep, best, gu) - r
    return _contact_paths(texture, x, y, P, u, c, r, rim, periodic)


def _contact_paths(texture, x, y, P, u, c, r, rim, periodic, own_twists=False, fold=False):
    """:func:`_contact_edges` from the contacts u (nx, ny, 2) and heights c (nx, ny), made once
    more where a branch followed to a grid point stands higher than its contact (that is then its
    contact, u and c updated in place; what was followed at or from other points kept,
    :func:`_forget`). Returns (c, gradients, (ex, ey, twist), kinks, branches)."""
    cache = {}  # (the branches followed, kept for the second pass where their points did not move)
    for _again in range(2):  # (once more where a branch found a grid point's higher contact)
        out = _contact_edges(texture, x, y, P, u, c, r, rim, periodic, cache, own_twists, fold)
        if out[-1] is None:
            break
        node, ub, val = out[-1]
        u.reshape(-1, 2)[node] = ub
        c.ravel()[node] = val
        _forget(cache, node, c.shape)
    return out[:-1]


CURVATURE_SLACK = 0.01
"""How far a felt map's curvature may miss the ball path's own, as a fraction of the path's
largest, before its grid is halved, on a periodic map the ball cannot bridge: its largest
(:attr:`SampledSurface.max_curvature`, the Hermite patches') against the path's largest at its
nodes and cells' centres, and its Hessian at each cell's centre against the path's there
and its most convex curvature against the path's, relative to that (chosen as a profile's
``PROFILE_CURVATURE_SLACK``: q of B, C and G reads the largest curvature, kappa / (1 - r kappa)
at a trough, a spike a few um wide in the ball's position near the troughs' radius; the
egg-crate's bowls at 0.8, 0.9, 0.95 times their radius read q of C +3.8, -19, -64 % on REFINE's
grids. Comparing the largest alone stopped where it agreed by chance while the patches between
the nodes did not: at 0.82 and 0.93 times on 39 and 136 samples a side, their Hessians at the
cells' centres 6 and 23 % of the largest apart. D reads d_max / (R - d_max) below the most
convex point, radius R: at 0.5 and 0.8 times +2.2 and +2.1 % without the convex comparison,
+0.31 and +0.51 % with it, on 128 and 640 samples a side)."""

CURVATURE_REFINE_SAMPLES = 768 * 768
"""The most samples (over the cell) a felt map is refined to for its curvature (chosen: q of C on
the egg-crate's bowls at 0.85 and 0.88 times their radius read +1.15 and +1.71 % with the cap at
512 x 512 and +0.32, +0.67 % at 640 x 640; at 0.9 times +1.10 % on 576 a side (doubled grids, the
next past 640), and with the grids of :func:`_refined_sizes` +0.65 % on 768, the tests' random
map (AREAL_CASES) at 0.9 times its tightest radius +0.69 % on 768 (+1.87 % on 448), 7-9 s a
construction, 610 MB at most for the process. Nearer the radius the spike is narrower than any
grid within the cap resolves: at 0.95 times the egg-crate's +3.29 % on 760 a side (+2.1 % on
1,280, 21-24 s and 1.4 GB), the random map's +3.22 % on 768 (+3.83 % on 640, +2.89 % on 848: not
monotone))."""

REFINE_AIM = 0.8
"""The fraction of CURVATURE_SLACK a felt map's next grid aims its curvature's miss at (chosen: a
bicubic Hermite patch's one-sided curvature at a node misses the path's by h^2 / 12 times its
fourth derivative (Taylor), so the next grid is sqrt(miss / (REFINE_AIM CURVATURE_SLACK)) times
finer along each axis the path curves along; measured on the egg-crate at 0.9 times its bowls'
radius: +1.10 % on 576 a side, so +0.89 % predicted on 640, +0.91 % read)."""

REFINE_GROWTH = (1.2, 4.0)
"""The least and most a felt map's next grid is finer than the last along an axis it is refined
along (chosen: a step the h^2 law's scatter cannot undo at least, at most what one reading of
that law is trusted for; the doubling it replaces is within)."""

FELT_STEEP_TOLERANCE = 1e-6
"""How much (relative) steeper than the surface a felt map refined for its curvature may be before
a finer grid is made (a path's slope is a contact's, the surface's there: the path's steepest is
at most the surface's, equal to it where the ball cannot bridge; the Hermite patches between the
nodes overshoot it by the interpolation's error, chosen: the egg-crate's bowls at 0.5 times their
radius read 8.5e-6 below the surface's on 64 a side, 3.3e-6 above on 80, 4.7e-7 below on 144,
kept)."""


def _refined_sizes(sizes, bends, miss):
    """The next grid's samples (nx, ny) after a periodic felt map of ``sizes`` samples whose
    curvature missed the path's by ``miss`` (a fraction of its largest): along the axes where
    ``bends`` (the path curves along them) sqrt(miss / (REFINE_AIM CURVATURE_SLACK)) times finer
    (the h^2 law of a Hermite patch's curvature), within REFINE_GROWTH, in multiples of 8 (a
    symmetric texture's troughs at a quarter of its cell stay on nodes); where that passes
    CURVATURE_REFINE_SAMPLES the largest grid within it, those axes shrunk alike. None where no
    grid within the cap is REFINE_GROWTH's least finer."""
    lo, hi = REFINE_GROWTH
    f = min(max(math.sqrt(miss / (REFINE_AIM * CURVATURE_SLACK)), lo), hi)
    want = [n * f if b else float(n) for n, b in zip(sizes, bends)]
    over = want[0] * want[1] / CURVATURE_REFINE_SAMPLES
    if over > 1:
        shrink = over ** (-0.5 if all(bends) else -1.0)
        out = [8 * math.floor(v * shrink / 8) if b else n for v, n, b in zip(want, sizes, bends)]
    else:
        out = [8 * math.ceil(v / 8) if b else n for v, n, b in zip(want, sizes, bends)]
    if any(b and m < lo * n for m, n, b in zip(out, sizes, bends)):
        return None
    return tuple(int(v) for v in out)


def _contact_offsets(g, r):
    """The contact offsets u (n, 2) of a ball of radius r (m) whose path has gradients g (n, 2):
    the contact condition grad h(p + u) = u / sqrt(r^2 - |u|^2) = g inverted, r g / sqrt(1 +
    |g|^2)."""
    return r * g / np.sqrt(1 + np.einsum("ij,ij->i", g, g))[:, None]


def _smooth_contacts(texture, felt, P, r, tol):
    """The contact offsets (n, 2) of the points P (n, 2) on a surface the ball of radius r (m)
    cannot bridge, and the ascent's maximum there (n,): from the offset r g / sqrt(1 + |g|^2)
    that the felt map's gradient g gives (the contact condition's inverse), refined on the
    surface by :func:`_refine_contacts` (the disc its only bound: one contact, the ascent
    concave), up to four times over (each call ends once every step is under ``tol``, m; the next
    is not made once a call moved no contact by more than that)."""
    u = _contact_offsets(felt.gradient(P), r)
    box = np.full_like(u, r)
    for _ in range(4):
        last = u
        u, gu = _refine_contacts(texture, P, u, -box, box, r, r * (1 - 1e-9), tol)
        if not np.any(np.abs(u - last) > tol):  # (still: a call from here would step as that one ended)
            break
    return u, gu


def _finer_grid(cur, nx, ny):
    """The grid of nx x ny points over a periodic map ``cur``'s cell, from its origin: (x (nx,),
    y (ny,), the points (nx, ny, 2), dx, dy), in m."""
    dx, dy = cur.dx * cur.x.size / nx, cur.dy * cur.y.size / ny
    x, y = cur.x[0] + np.arange(nx) * dx, cur.y[0] + np.arange(ny) * dy
    X, Y = np.meshgrid(x, y, indexing="ij")
    return x, y, np.stack([X, Y], -1), dx, dy


def _curvature_refined(texture, felt, r):
    """A periodic felt map of a surface the ball of radius r (m) cannot bridge
    (:func:`_may_bridge` false: one contact everywhere, found by Newton steps from any start, the
    ascent's Hessian A - B negative there), made again on finer grids (:func:`_refined_sizes`:
    as much finer as the last miss says, by the h^2 law) while its curvature misses the path's
    (:func:`_path_hessian`) by more than CURVATURE_SLACK of the path's largest, within
    CURVATURE_REFINE_SAMPLES: its largest (``max_curvature``, the
    patches') against the path's largest at its nodes and cells' centres, and its Hessian at
    each cell's centre against the path's there (the 2-norm of the difference); and, relative
    to the path's most convex curvature (its lower eigenvalue's least), the map's most convex
    against it and the lower eigenvalues at the centres (D reads the convex radius: the patches
    overshoot beside a spike, convex where the path is not). The nodes'
    contacts are r g / sqrt(1 + |g|^2) from their gradients g, the centres' and each finer
    grid's start from the last map's gradients and are refined on the surface itself
    (:func:`_smooth_contacts`: no dilation), its twists the path's own. The first grid within the
    slack and not steeper than the surface (FELT_STEEP_TOLERANCE) is kept, else the one that
    ranks first (:func:`_felt_rank`, on its misses as it states them, :func:`_climbed`, every
    map's against the largest path top found on any, :func:`_against_top`), with
    ``felt``'s shortest period (its analyses' grids: more samples of one path, not a shorter
    wavelength); a map with no finer grid within the cap is returned as it is. Where the kept
    uniform grid still misses the path's curvature by more than the slack, a map on graded axes
    is made about where the path's curvature is hottest on the last grid
    (:func:`_graded_refined`) and kept where it ranks before it."""
    if _refined_sizes((felt.x.size, felt.y.size), (True, True), 0.0) is None:
        return felt  # (no finer grid within the cap: nothing to compare it with)
    seen = []
    cur, u = felt, _contact_offsets(felt._gradients.reshape(-1, 2), r)
    while True:
        m = _felt_misses(texture, cur, u, r)
        seen.append(_stated(_climbed(texture, m, r)))  # (ranked by what it states; refined by what it samples)
        sizes = None if (m["miss"] <= CURVATURE_SLACK and not m["steep"]) or not any(m["bends"]) else _refined_sizes(
            (cur.x.size, cur.y.size), m["bends"], m["miss"])
        if sizes is None:  # (no axis to refine: a path whose Hessians are all NaN would loop here)
            break
        nx, ny = sizes
        x, y, P, dx, dy = _finer_grid(cur, nx, ny)
        P = P.reshape(-1, 2)
        u, gu = _smooth_contacts(texture, cur, P, r, 1e-6 * min(dx, dy))
        cur = _felt_on(texture, P, u, gu, r, x, y, (dx, dy), felt,
                       f"{felt.source}, refined to {nx} x {ny} for its curvature")
    seen = _against_top(seen)
    best = min(seen, key=_felt_rank)  # (the first of equals)
    if best["curved"] > CURVATURE_SLACK:  # (not met on a uniform grid within the cap: graded axes,
        graded = _graded_refined(texture, felt, m, r)  # from the finest grid's contacts)
        if graded:
            told = _against_top(seen + graded)
            best = min(told[:len(seen)], key=_felt_rank)
            graded = min(told[len(seen):], key=lambda t: (t["steep"], t["peak"]))
            if _felt_rank(graded) < _felt_rank(best):
                best = graded
    out = best["map"]
    out.curvature_miss, out.peak_miss = float(best["curved"]), float(best["peak"])
    out.path_curvature = float(best["truth"]) if math.isfinite(best["truth"]) and best["truth"] > 0 else None
    out.convex_miss = float(best["bowed"])
    return out


def _felt_on(texture, P, u, gu, r, x, y, axes, felt, source):
    """The periodic felt map (Hermite) on the nodes P (n, 2) = the grid x, y from their
    contacts u (n, 2) and the ascent's maxima gu (n,), ``axes`` its steps (dx, dy) or its graded
    axes' knots: heights gu - r, the path's gradients and own twists (where not finite, the
    gradients' differences), with ``felt``'s shortest period (more samples of one path, not a
    shorter wavelength)."""
    nx, ny = x.size, y.size
    knots = axes if np.ndim(axes[0]) else None
    grads = _path_gradient(texture, P, u, r, None).reshape(nx, ny, 2)
    twist = _path_twist(texture, P, u, r).reshape(nx, ny)
    steps = (None, None) if knots is not None else axes
    twist = np.where(np.isfinite(twist), twist, _twist(grads, *steps, True, knots))
    out = SampledSurface(x, y, gu.reshape(nx, ny) - r, periodic=True, gradients=grads,
                         shortest_period=felt.shortest_period, source=source, knots=knots)
    out._edges = (*_node_edges(grads, True), twist)
    return out


def _felt_misses(texture, cur, u, r):
    """How far the periodic felt map ``cur`` misses the ball path's curvature, its nodes'
    contacts u (n, 2): a dict of ``curved`` (its largest, ``max_curvature``, against the path's
    largest at its nodes and cells' centres, and its Hessian at each cell's centre against the
    path's there, the 2-norm of the difference, relative to the path's largest), ``peak`` (the
    part of that which the sup reads, q of B, C and G: its largest's miss, the centres' 2-norms
    past the path's largest, and short of the path's where that is within CURVATURE_SLACK of its
    largest), ``bowed`` (its most convex curvature, the sup of its lower eigenvalue where negative,
    against the path's most convex, and the lower eigenvalues at the centres where either is
    convex, relative to the path's most convex: what D reads), ``miss`` (the larger, and the
    lower eigenvalues everywhere), ``steep`` (steeper than the surface by more than
    FELT_STEEP_TOLERANCE), ``bends`` (per axis, whether the path curves along it), the path's
    largest curvature ``truth`` (1/m), its nodes' Hessians ``hs`` (n, 2, 2), ``map``, and what
    the misses are made of (:func:`_stated_misses`, :func:`_path_top`): the path's curvature
    ``norms`` (n + k,) at the nodes and the cells' centres, their contact points ``touches``
    (n + k, 2) in the same order, the map's ``nm`` and the path's ``nc`` (k,) at the centres,
    and ``apart``."""
    X, Y = np.meshgrid(cur.x, cur.y, indexing="ij")
    P = np.stack([X, Y], -1).reshape(-1, 2)
    hs = _path_hessian(texture, P, u, r, sound=0.0)
    wx, wy = cur._widths()
    Pc = P + 0.5 * np.stack(np.meshgrid(wx, wy, indexing="ij"), -1).reshape(-1, 2)  # (the cells' centres)
    uc, _ = _smooth_contacts(texture, cur, Pc, r, 1e-6 * min(wx.min(), wy.min()))
    hc = _path_hessian(texture, Pc, uc, r, sound=0.0)
    both = np.concatenate([hs, hc])
    norms = _hessian_norm(both)
    truth = float(np.nanmax(norms)) if np.isfinite(both).any() else math.inf
    hm = cur.hessian(Pc)
    nm, nc = _hessian_norm(hm), norms[len(hs):]
    apart = float(np.nanmax(_hessian_norm(hm - hc), initial=0.0))
    curved, peak = _stated_misses(cur, nm, nc, apart, truth)
    miss = curved  # (the curvature's own: what B, C and G read, the map's curvature_miss)
    # (and its most convex curvature against the path's, relative to that: D's focal points;
    # the map's convex_miss is the part D reads, its sup and the centres where either is convex)
    convex, bowed = max(0.0, -float(np.nanmin(_lowest_eigenvalue(both)))), 0.0
    if convex > 0:
        own = cur._sup(lambda p: np.maximum(0.0, -_lowest_eigenvalue(cur.hessian(p))))
        lm, lc = _lowest_eigenvalue(hm), _lowest_eigenvalue(hc)
        wrong = np.abs(lm - lc)
        either = np.minimum(lm, lc) < 0
        bowed = max(abs(own / convex - 1.0), float(np.nanmax(wrong[either], initial=0.0)) / convex)
        miss = max(miss, bowed, float(np.nanmax(wrong)) / convex)
    # (a path's slope is a contact's: a grid steeper than the surface is not kept while one is not)
    steep = bool(cur.max_slope > texture.max_slope * (1 + FELT_STEEP_TOLERANCE))
    # (refined along an axis the path curves along: a grating's map not across its lines)
    bends = [bool(np.nanmax(np.abs(both[:, a, a]) + np.abs(both[:, a, 1 - a])) > CURVATURE_SLACK * truth)
             for a in (0, 1)]
    return {"map": cur, "steep": steep, "miss": miss, "curved": curved, "peak": peak, "bowed": bowed,
            "bends": bends, "truth": truth, "hs": hs, "norms": norms, "touches": np.concatenate([P + u, Pc + uc]),
            "nm": nm, "nc": nc, "apart": apart}


def _stated_misses(cur, nm, nc, apart, truth):
    """A felt map's misses of the path's curvature against the path's largest ``truth`` (1/m),
    as fractions of it: (``curved``: its largest's miss and ``apart``, the largest 2-norm of its
    Hessian's difference from the path's at its cells' centres; ``peak``, the part the sup reads:
    its largest's miss, the centres' 2-norms nm (k,) past ``truth``, and their shortfall from the
    path's nc (k,) where that comes within CURVATURE_SLACK of ``truth``, weighted from 0 there to 1
    at ``truth``); 0 where ``truth`` is not positive. :func:`_felt_misses`' against its samples'
    largest, :func:`_with_path_top`'s against the climbed. (The weight, chosen, keeps ``peak``
    continuous in ``truth``: counted whole from the slack's edge, a centre 7.4 % short where the
    path is 1 % below its top made a graded map of two gratings at 63 deg at 0.99 times their
    tightest radius state 8.4 % or 0.67 % as the climbed top moved by 0.06 %, 2026-11-29; its
    largest +0.45 % from the path's.)"""
    if not truth > 0:
        return 0.0, 0.0
    largest = abs(cur.max_curvature / truth - 1.0)
    near = np.clip((nc / truth - (1 - CURVATURE_SLACK)) / CURVATURE_SLACK, 0.0, 1.0)
    return (max(largest, apart / truth),
            max(largest, float(np.nanmax(nm - truth, initial=0.0)) / truth,
                float(np.nanmax(np.nan_to_num(near * (nc - nm), nan=0.0), initial=0.0)) / truth))


PATH_TOP_STARTS = 4
"""How many of a felt map's largest samples of its path's curvature (nodes and cells' centres)
:func:`_path_top` climbs from (chosen, with PATH_TOP_REACH)."""

PATH_TOP_REACH = 4
"""How many cells either way :func:`_path_top` climbs from each sample (chosen, measured
2026-11-29 on two gratings at 63 deg at 0.99 times their tightest radius, the path's largest
curvature 157,912 1/m, the 832 x 416 map's samples' largest 142,184: climbed within 1 and 4 cells
of its 4 largest samples 156,150 and 157,753, -1.1 and -0.10 %: the spike's ridge rises along
it past a cell from where the samples sit on its flanks)."""


def _path_top(texture, m, r, starts=None):
    """The ball path's largest curvature (1/m) near a felt map's samples of it (:func:`_felt_misses`'
    dict ``m``): its samples' largest, climbed from the PATH_TOP_STARTS largest by
    :func:`haptex._maximise.refine` (L-BFGS-B) over their contact points, within PATH_TOP_REACH
    cells' widths of each. Where the ball cannot bridge the surface (the only maps this is made
    for, :func:`_curvature_refined`'s) it rests on every point q of it, its centre over
    p = q - u, u = r g / sqrt(1 + |g|^2) (g the surface's gradient at q, :func:`_contact_offsets`),
    and the path's Hessian there is :func:`_path_hessian`'s at that contact: a smooth function of
    q, evaluated in closed form (no contact searched), whose sup over q is the path's over p.
    Where the spike is narrower than the cells the samples see its sides only; any point's value
    bounds the sup from below, so the climbed is the nearer. ``starts``: the samples to climb
    from (indices into ``m``'s), the PATH_TOP_STARTS largest by default. Returns (the largest,
    and each start's climbed (value, contact point (2,) (m)) in turn, none where no sample
    curves)."""
    cur, norms = m["map"], np.nan_to_num(m["norms"], nan=0.0, posinf=0.0, neginf=0.0)
    pts = m["touches"]  # (norms' contact points)
    nx, ny = cur.x.size, cur.y.size
    wx, wy = cur._widths()
    best = float(norms.max())
    if not best > 0:
        return best, []
    climbed = []

    def curvature(q):  # (n, 2) contact points -> the path's curvature over them (n,)
        return np.nan_to_num(_hessian_norm(_resting(texture, q, r)[1]), nan=0.0)

    for k in np.argsort(norms, kind="stable")[-PATH_TOP_STARTS:] if starts is None else starts:
        i, j = divmod(int(k) % (nx * ny), ny)
        start, scale = pts[k], np.array([wx[i], wy[j]])

        def neg(v, start=start, scale=scale):  # (n, 2) steps about the sample's contact, in its cell's widths
            return -curvature(start + v * scale) / best

        found, v = refine(neg, np.zeros(2), None, [(-PATH_TOP_REACH, PATH_TOP_REACH)] * 2, ftol=1e-16, gtol=1e-13)
        climbed.append((found * best, start + np.asarray(v) * scale))
        best = max(best, found * best)
    return best, climbed


def _climbed(texture, m, r):
    """:func:`_felt_misses`' dict ``m`` as a map states it: where its largest curvature's miss
    passes CURVATURE_SLACK, against the path's largest climbed (:func:`_with_path_top`); else
    ``m``. The maps are ranked by it (:func:`_felt_rank`), refined by ``m``'s samples."""
    return _with_path_top(texture, m, r) if m["peak"] > CURVATURE_SLACK else m


def _with_path_top(texture, m, r):
    """:func:`_felt_misses`' dict ``m`` with the path's largest curvature climbed (:func:`_path_top`)
    and the misses that read it, ``truth``, ``curved`` and ``peak``, made again against it."""
    return _with_truth(m, _path_top(texture, m, r)[0])


def _with_truth(m, top):
    """:func:`_felt_misses`' dict ``m`` with the misses that read the path's largest curvature,
    ``truth``, ``curved`` and ``peak``, made again against ``top`` (1/m) where that is larger."""
    if not top > m["truth"]:
        return m
    curved, peak = _stated_misses(m["map"], m["nm"], m["nc"], m["apart"], top)
    return {**m, "truth": top, "curved": curved, "peak": peak}


def _stated(m):
    """:func:`_felt_misses`' dict ``m`` without what only its making and climbing read (the
    path's Hessians at its nodes, its curvatures and contact points there and at the cells'
    centres): what ranks the map and states its misses again (:func:`_with_truth`), kept for
    every map a refinement makes."""
    return {k: v for k, v in m.items() if k not in ("hs", "norms", "touches")}


def _against_top(told):
    """Felt maps' :func:`_felt_misses` dicts (each as it states its misses, :func:`_climbed`) all
    stated against the largest of their paths' largest curvatures: the maps are of one path,
    and each one's sampled or climbed largest bounds its sup from below (on two gratings at 63
    deg at 0.995 times their tightest radius a graded map, climbed from its own samples to
    0.18 % under its largest, stated 0.15 % where its largest was 2.0 % short of the path's
    climbed from another's, and q of C read -1.8 %, 2026-11-29)."""
    tops = [t["truth"] for t in told if math.isfinite(t["truth"])]
    return [_with_truth(t, max(tops)) for t in told] if tops else told


def _felt_rank(m):
    """How a felt map ranks among its refinements (:func:`_felt_misses`' dict as the map states
    it, :func:`_climbed`; the least is kept): not steeper than the surface first, then the one
    whose largest curvature meets CURVATURE_SLACK (``peak``: q of B, C and G), then its most
    convex (``bowed``: D's), then, of those whose largest misses the slack, the least ``peak``,
    then the least curvature miss and the least miss (chosen: graded
    axes resolve the spikes where the largest curvature is but not a spike that runs along a
    diagonal, as the egg-crate's saddles' do, where the convex curvature D reads is the small
    difference of its large entries; and at 0.99 times the egg-crate's radius, where no grid
    meets either, the least miss alone kept the first 32 x 32 grid, its largest curvature 89 %
    short, for its convex miss 5.3 against the 768 grid's 28, whose largest is 14 % short; and
    on two gratings at 63 deg at 0.995 times their tightest radius, where no map meets either,
    the least curvature miss kept a uniform 832 x 416 map whose largest is 48 % short, q of C
    with it, for its ``curved`` 0.480 against a graded 784 x 402 map's 0.491, whose largest is
    2.0 % short, 2026-11-29)."""
    over = m["peak"] > CURVATURE_SLACK
    return (m["steep"], over, m["bowed"] > CURVATURE_SLACK, m["peak"] if over else 0.0, m["curved"], m["miss"])


GRADED_BASE = 3
"""A felt map on graded axes (:func:`_graded_refined`) has cells up to this many times the last
uniform grid's step (chosen, measured 2026-11-28 with GRADED_HOT and GRADED_GROWTH as they are:
the egg-crate at 0.95 times its bowls' radius on 672, 578, 535 samples a side with 2, 3, 4 times
the 760 grid's 2.6 um, its largest curvature +0.49, +0.51, +0.45 % from the path's; the tests'
random map at 0.95 times its tightest radius on 447 x 473, 338 x 371, 286 x 320, +0.72, +0.75,
+0.73 %: the finest cells hold the largest, the coarse ones the rest)."""

GRADED_GROWTH = 1.2
"""How much wider each cell of a graded axis may be than the one before it, away from the path's
hottest curvature: its cells' width grows by GRADED_GROWTH - 1 times the distance from it
(chosen, measured as GRADED_BASE: 1.1, 1.2, 1.3 read the egg-crate's largest curvature +0.66,
+0.51, +0.57 % on 628, 578, 562 a side, the random map's +0.76, +0.75, +0.72 % on 356 x 385,
338 x 371, 332 x 365)."""

GRADED_HOT = 2 * CURVATURE_SLACK
"""A graded axis's finest cells cover where the path's curvature at the uniform map's nodes (and
at balls resting on the surface there, :func:`_hot_intervals`) is within this fraction of its
largest, a node either side (chosen, measured as GRADED_BASE: 1, 2,
5 % read the egg-crate's largest curvature +0.47, +0.51, +0.55 % on 507, 578, 741 a side, the
random map's +0.74, +0.75, +0.75 % on 321 x 343, 338 x 371, 399 x 450; the egg-crate's saddles'
diagonal ridges, within 2 % of the largest for about 90 um along, hold the sup where only the
points were graded: +1.92 % then, with finest cells of 0.12 to 0.48 um; on the plane's axes,
before the egg-crate's map was turned along its gratings). Across the spike only
(:func:`_hot_intervals`: along each axis as the largest curvature's direction says; it was along
both axes over the whole of where the curvature is hot, 697 x 697 at 0.99 times on the turned
egg-crate, 357 x 357 now)."""

GRADED_BROAD = 0.5
"""Where the path is most convex over more than this fraction of an axis's nodes, a graded
axis is not made finer there (:func:`_hot_intervals`; chosen: the random map at 0.95 times its
tightest radius is most convex over 9 and 15 % of its axes, where cells of its uniform grid's
step keep q of D to +0.001 % (its convex miss 2.1 % without them); the egg-crate's crests and
saddles over all of them, where such cells made a grid past the cap)."""

GRADED_TRIES = 4
"""How many graded maps :func:`_graded_refined` makes at most, each with finer cells than the
last's (GRADED_STEP), within CURVATURE_REFINE_SAMPLES (chosen, measured 2026-11-29 on the
egg-crate on axes along its gratings, whose path's curvature spike at its bowls is about 50 (1 -
r / rho) um wide across each trough's line: at 0.99 times their radius rho the third map, 357 x
357 with cells from 60 nm, meets the slack (q of C +0.85 %); at 0.995 the fourth, 450 x 450
(+0.89 %); at 0.999 none, the third, 424 x 424 with cells from 15 nm, kept (+1.76 %, its
peak_miss 1.75 %), the fourth and a fifth (with six tries) missing more (4.1 and 6.0 %, cells
of 9 and 6 nm)). Since 2026-11-30 the axes are also fine about the path's climbed tops
(:func:`_top_intervals`, GRADED_TOP_CELLS): the first graded map meets the slack at 0.99, 0.995
and 0.999 times, 359, 374 and 448 a side with cells from 46, 9.5 and 1.0 nm, q of C +0.62, +0.73
and +0.38 %."""

GRADED_SAMPLES = 1024 * 1024
"""The most nodes a felt map on graded axes may have (:func:`_graded_refined`; a uniform map's
CURVATURE_REFINE_SAMPLES. Chosen, measured 2026-11-29 on two gratings at 63 deg, whose
tightest trough's ridge runs at an angle to both axes, so that a graded axis is fine wherever
the ridge crosses it: at 0.995 times their tightest radius the fourth graded map, 946 x 848,
meets CURVATURE_SLACK, q of C +0.98 %, 40 s a felt map and 1.45 GB peak resident; within 768 x
768 the third, 762 x 638, was kept, +1.77 %, 28 s and 1.0 GB. Where the graded maps are
smaller, as the egg-crate's and the random map's, nothing changes.)"""

GRADED_STEP = (0.5, 0.85)
"""The least and most a graded map's finest cells are of the last's when it missed the slack:
the h^2 law's step towards REFINE_AIM of CURVATURE_SLACK, within these (chosen: halving, as
before 2026-11-29, took the egg-crate's map at 0.95 times its bowls' radius, on axes along its
gratings, from 539 x 540 nodes and a 1.04 % miss past CURVATURE_REFINE_SAMPLES)."""


def _resting(texture, q, r):
    """Balls of radius r (m) resting on the surface ``texture`` at contact points q (n, 2) (m),
    where it cannot be bridged: their contacts' offsets u (n, 2) (:func:`_contact_offsets`, the
    centres over q - u) and the path's Hessians (n, 2, 2) (1/m) at those centres, in closed form
    (:func:`_path_hessian`; NaN where it is unsound), no contact searched."""
    u = _contact_offsets(texture.gradient(q), r)
    return u, _path_hessian(texture, q - u, u, r, sound=0.0)


def _across(h):
    """|e_x|, |e_y| (k, 2) of the direction e of the largest |eigenvalue| of each symmetric
    Hessian h (k, 2, 2) (the direction a spike is narrow across); 1 along both axes where the
    other eigenvalue comes within GRADED_HOT of it (an umbilic spike)."""
    w, v = np.linalg.eigh(h)  # (columns the directions)
    size = np.abs(w)
    lead = np.abs(v[np.arange(len(v)), :, np.argmax(size, axis=1)])
    return np.where((size.min(axis=1) >= (1 - GRADED_HOT) * size.max(axis=1))[:, None], 1.0, lead)


def _hot_intervals(texture, m, cur, r):
    """Per axis, the intervals (a, b, f, fixed) (a, b in m) where a graded axis's cells are
    fine, f their width in the finest cells' (``fixed`` False) or in the uniform grid's steps
    (True), from the path's curvature at the uniform felt map ``cur``'s nodes (:func:`_felt_misses`'
    dict ``m``'s ``hs``) and at the centres of balls of radius r (m) resting on the ``texture``
    at those nodes. Where its 2-norm comes within GRADED_HOT of the largest of both (the spikes
    B, C and G's q reads), at a node or at the node nearest such a centre, cells up to f times
    the finest, f = 1 / |e_a|, e the direction of the largest curvature there, across which the
    contact, and with it the spike, runs 1 / (1 - r kappa) times as fast as the ball (f = 1
    along both axes where the other principal curvature comes within GRADED_HOT of it, an
    umbilic spike; no interval along an axis the spike runs along, as the turned egg-crate's do
    from its bowls along its troughs' lines); each such node's interval spans a node either
    side. (The centres p = q - u over contact points q, u :func:`_contact_offsets`, the path's
    Hessian there :func:`_path_hessian`'s: the spike, 1 / (1 - r kappa) times wider in the
    contact than in the ball's position, is sampled all along its ridge by the contacts where
    the nodes, on a ridge at an angle to the axes, fall on its flanks by turns: on two gratings
    at 63 deg at 0.985 times their tightest radius the fine band had gaps where the path is
    within 1 % of its top, and the graded maps' centres there read it 6 to 20 % short; with the
    contacts' band q of C -3.4, +2.8, +0.45, -2.0 % at 0.98, 0.985, 0.99, 0.995 times became
    +0.91, +0.72, +0.84, +1.78 %, measured 2026-11-29 with GRADED_SAMPLES.) And ``fixed``
    where the path's convex curvature (the lower eigenvalue's negative) at the nodes comes
    within GRADED_HOT of its most convex (D's radius), a node either side, unless that spans
    more than GRADED_BROAD of an axis (a broad maximum, as the egg-crate's crests and saddles
    make): cells f uniform steps wide, as the h^2 law says the crest needs for CURVATURE_SLACK
    (REFINE_AIM of it; h^2 / 12 times the most convex curvature's second difference along the
    axis where it is hot, the patches' miss), from 1 to GRADED_BASE (they were 1 step before
    2026-11-29's last session: on two gratings at 63 deg the uniform grid's step, 1.85 um for
    the troughs' spike, over 1 mm of each 2 mm axis along a crest; the h^2 law says 3, and the
    graded maps at 0.98 to 0.995 times the tightest radius shrank from 875 x 475 - 1,127 x 778
    to 510 x 338 - 762 x 638 nodes a try, q of C +0.69 to +0.98 %; the random map at 0.95 times
    290 x 281 for 347 x 363, q of C +0.68 % for +0.46 %, of D +0.004 %)."""
    nx, ny = cur.x.size, cur.y.size
    hs = np.nan_to_num(m["hs"], nan=0.0, posinf=0.0, neginf=0.0)
    f = _hessian_norm(hs)
    top = f.max()
    across = _across(hs).reshape(nx, ny, 2)
    hot = np.zeros((nx, ny), bool)
    if top > 0:  # (the ridge's hot part as its contacts see it, the uniform map's nodes as contact points)
        Q = np.stack(np.meshgrid(cur.x, cur.y, indexing="ij"), -1).reshape(-1, 2)
        u, hq = _resting(texture, Q, r)
        hq = np.nan_to_num(hq, nan=0.0, posinf=0.0, neginf=0.0)
        fq = _hessian_norm(hq)
        top = max(top, float(fq.max()))
        on = fq >= (1 - GRADED_HOT) * top
        P = Q[on] - u[on]  # (their balls' centres, at the nearest nodes)
        i = np.round((P[:, 0] - cur.x[0]) / cur.dx).astype(int) % nx
        j = np.round((P[:, 1] - cur.y[0]) / cur.dy).astype(int) % ny
        hot = (f >= (1 - GRADED_HOT) * top).reshape(nx, ny)
        hot[i, j] = True
        np.maximum.at(across, (i, j), _across(hq[on]))
    bow = -_lowest_eigenvalue(hs).reshape(nx, ny)  # (convex where positive)
    convex = None
    if bow.max() > 0:
        convex = bow >= (1 - GRADED_HOT) * bow.max()
        if max(np.mean(np.any(convex, axis=1)), np.mean(np.any(convex, axis=0))) > GRADED_BROAD:
            convex = None
    out = [[], []]
    for axis, (step, start) in enumerate(((cur.dx, cur.x[0]), (cur.dy, cur.y[0]))):
        need = np.max(np.where(hot, across[..., axis], 0.0), axis=1 - axis)  # (per index along the axis)
        for i in np.nonzero(need > 0)[0]:
            out[axis].append((start + (i - 1) * step, start + (i + 1) * step, 1.0 / need[i], False))
        if convex is not None:
            on = np.any(convex, axis=1 - axis)
            on = on | np.roll(on, 1) | np.roll(on, -1)
            idx = np.nonzero(on)[0]
            runs = np.split(idx, np.nonzero(np.diff(idx) > 1)[0] + 1) if idx.size else []
            # (the h^2 law: a patch's curvature misses by h^2 / 12 times the curvature's second
            # derivative, here the most convex eigenvalue's second difference along the axis)
            bend = np.abs(np.roll(bow, 1, axis) - 2 * bow + np.roll(bow, -1, axis)) / step**2
            fourth = float(np.max(bend[convex], initial=0.0))
            wide = GRADED_BASE if fourth == 0 else float(np.clip(
                math.sqrt(12 * REFINE_AIM * CURVATURE_SLACK * bow.max() / fourth) / step, 1.0, GRADED_BASE))
            out[axis] += [(start + run[0] * step, start + run[-1] * step, wide, True) for run in runs]
    return out


GRADED_TOP_CELLS = 10
"""A graded axis's cells about the path's climbed top (:func:`_top_intervals`) are the spike's
half-width there along the axis divided by this (chosen: the patches' curvature is linear
across a cell, so the map's largest sits at a node within half a cell of the top, where a
spike K / (1 + (d / w)^2) has fallen by (h / 2w)^2, 0.25 % at w / 10, and their curvature at
the nodes misses by about h^2 K'' / 12, 0.2 % more; measured 2026-11-30 on the egg-crate at
0.999 times its bowls' radius, the spike at a saddle 10 nm wide: see GRADED_TRIES)."""

GRADED_TOP_ANGLE = 1e-3
"""The most (rad) the direction across which the path's curvature spikes at its top may turn
from an axis for :func:`_top_intervals` to grade the axes about it (chosen: a band of
GRADED_TOP_REACH half-widths holds the spike's ridge, along which it stays within 1 % of its top
for about 2.6 um on the egg-crate at 0.999 times its bowls' radius, where the ridge is 10 nm
wide, only while the ridge turns from the axis by less than 30 nm / 2.6 um, about 10 mrad: a
tenth of that allowed; on two gratings at 63 deg, whose ridge runs at an angle
to both axes, such bands made q of C at 0.9975 times their tightest radius +3.1 % where the map
stated 8.3 %, 2026-11-30: none made there)."""

GRADED_TOP_STARTS = 16
"""How many of a uniform felt map's samples of the path's curvature within GRADED_HOT of their
largest, PATH_TOP_REACH cells apart, :func:`_top_intervals` climbs from (chosen: the egg-crate's
spikes top at its bowls and at both saddles of each turned cell, at one value)."""

GRADED_TOP_REACH = 3
"""How many of the spike's half-widths either side of the path's climbed top a graded axis's
cells are GRADED_TOP_CELLS times finer than it (:func:`_top_intervals`; chosen: at 3 half-widths
the spike has fallen to a tenth of its top, below what q reads)."""


def _top_intervals(texture, m, r):
    """Per axis, the intervals (a, b, w) (m) about the ball path's largest curvature, climbed
    (:func:`_path_top`) from the uniform felt map of :func:`_felt_misses`' dict ``m``, in which a
    graded axis's cells are w wide: the spike's half-width along the axis through the top (the
    least offset, on a ladder halving from the map's step to 1e-12 m, either way, where the
    path's curvature, at contacts refined on the surface, :func:`_smooth_contacts`, has fallen
    to half the top's) over GRADED_TOP_CELLS, within GRADED_TOP_REACH half-widths either side;
    none along an axis where it does not fall to half within a step (the hot intervals'
    cells, :func:`_hot_intervals`, are fine enough there), nor where the path does not curve,
    nor about a top whose spike runs across neither axis (GRADED_TOP_ANGLE). The tops: climbed
    from the samples within GRADED_HOT of the largest, PATH_TOP_REACH cells apart (at most
    GRADED_TOP_STARTS), each kept within GRADED_HOT of the highest.
    Near the troughs' radius the spike is narrower than the hot intervals' finest cells: on the
    egg-crate at 0.999 times its bowls' radius 10 nm wide at its saddles, cells of 15 to 31 nm
    read the map's largest curvature +1.75 %, of 9 to 21 nm +4.1 % (2026-11-30)."""
    cur, out = m["map"], [[], []]
    norms = np.nan_to_num(m["norms"], nan=0.0, posinf=0.0, neginf=0.0)
    nx, ny = cur.x.size, cur.y.size
    # (the climbs' starts: the samples within GRADED_HOT of the largest, the largest first, each
    # more than PATH_TOP_REACH cells from every one before it, at most GRADED_TOP_STARTS)
    starts, taken, hot = [], [], (1 - GRADED_HOT) * norms.max()
    for k in np.argsort(norms, kind="stable")[::-1]:
        if norms[k] < hot or len(starts) == GRADED_TOP_STARTS:
            break
        ij = np.array(divmod(int(k) % (nx * ny), ny))
        d = np.abs(np.array(taken) - ij) if taken else np.zeros((0, 2))
        d = np.minimum(d, np.array([nx, ny]) - d)  # (periodic)
        if not np.any(np.all(d <= PATH_TOP_REACH, axis=1)):
            starts.append(int(k))
            taken.append(ij)
    top, climbed = _path_top(texture, m, r, starts)
    if not top > 0:
        return out
    for value, q in climbed:
        if value < (1 - GRADED_HOT) * top:
            continue
        u, hq = _resting(texture, np.asarray(q)[None], r)
        p = np.asarray(q) - u[0]  # (the ball's centre over the top's contact)
        if _across(np.nan_to_num(hq))[0].max() < math.cos(GRADED_TOP_ANGLE):
            continue  # (a spike across neither axis: a band about its top would not hold its ridge)
        for axis, (step, start, period) in enumerate(((cur.dx, cur.x[0], cur._size[0]),
                                                       (cur.dy, cur.y[0], cur._size[1]))):
            ladder = step * 0.5 ** np.arange(int(math.ceil(math.log2(step / 1e-12))) + 1)
            e = np.zeros(2)
            e[axis] = 1.0
            P = p + np.concatenate([ladder, -ladder])[:, None] * e
            uc, _ = _smooth_contacts(texture, cur, P, r, 1e-3 * float(ladder[-1]))
            k = np.nan_to_num(_hessian_norm(_path_hessian(texture, P, uc, r, sound=0.0)), nan=np.inf)
            low = np.concatenate([ladder, ladder])[k <= 0.5 * value]
            if low.size == 0:
                continue
            w = float(low.min())
            at = start + float(np.mod(p[axis] - start, period))
            out[axis].append((at - GRADED_TOP_REACH * w, at + GRADED_TOP_REACH * w, w / GRADED_TOP_CELLS))
    return out


def _graded_axis(intervals, start, period, widest):
    """Knots (n + 1,) of a periodic axis from ``start`` over ``period`` (m): cells no wider than
    w within each of ``intervals`` (a, b, w) (m, taken modulo the period), away from them as wide
    as w + (GRADED_GROWTH - 1) times the distance, up to ``widest``; the last cell ends at the
    period's end (merged into the one before where it would be less than a third of it)."""
    spans = np.array([(a - start, b - start, w) for a, b, w in intervals], float).reshape(-1, 3)
    lo = np.concatenate([spans[:, 0] + shift for shift in (-period, 0.0, period)])
    hi = np.concatenate([spans[:, 1] + shift for shift in (-period, 0.0, period)])
    ws = np.tile(spans[:, 2], 3)

    def width(x):
        return float(min(widest, np.min(ws + (GRADED_GROWTH - 1) * np.maximum(np.maximum(lo - x, 0.0), x - hi),
                                        initial=math.inf)))

    knots, x = [0.0], 0.0
    while True:
        w = width(x)
        w = min(w, width(x + w))  # (not past the start of finer cells)
        if x + w >= period - 1e-3 * w:
            if period - x < w / 3 and len(knots) > 1:
                knots.pop()
            break
        x += w
        knots.append(x)
    return start + np.r_[knots, period]


def _graded_refined(texture, felt, m, r):
    """A periodic felt map on axes graded about where the path's curvature is hottest
    (:func:`_hot_intervals` on the uniform map of :func:`_felt_misses`' dict ``m``), for a
    surface the ball cannot bridge: cells up to GRADED_BASE times the uniform grid's step, there
    as much finer than it as its miss says (the h^2 law: to REFINE_AIM CURVATURE_SLACK / 2), and
    about the path's climbed tops a tenth of the spike's half-width (:func:`_top_intervals`); the
    former made finer up to GRADED_TRIES times (GRADED_STEP) while the largest curvature's miss
    (``peak``) passes CURVATURE_SLACK, within GRADED_SAMPLES nodes; its nodes' contacts from the uniform
    map's gradients refined on the surface (:func:`_smooth_contacts`), its heights, gradients
    and twists the path's own (:func:`_felt_on`). The :func:`_felt_misses` dicts of the maps
    made, as each states its misses (:func:`_climbed`); none where no graded grid is within the
    cap."""
    cur = m["map"]
    shrink = min(0.5, math.sqrt(0.5 * REFINE_AIM * CURVATURE_SLACK / max(m["curved"], 1e-300)))
    hot = _hot_intervals(texture, m, cur, r)
    if not hot[0] or not hot[1]:
        return []
    tops = _top_intervals(texture, m, r)
    made = []
    for _ in range(GRADED_TRIES):
        kx, ky = (_graded_axis([(a, b, step * f if fixed else min(shrink * step * f, GRADED_BASE * step))
                                for a, b, f, fixed in spans] + top, start, period, GRADED_BASE * step)
                  for spans, top, start, period, step in ((hot[0], tops[0], cur.x[0], cur._size[0], cur.dx),
                                                          (hot[1], tops[1], cur.y[0], cur._size[1], cur.dy)))
        if (kx.size - 1) * (ky.size - 1) > GRADED_SAMPLES:
            break
        x, y = kx[:-1], ky[:-1]
        X, Y = np.meshgrid(x, y, indexing="ij")
        P = np.stack([X, Y], -1).reshape(-1, 2)
        u, gu = _smooth_contacts(texture, cur, P, r, 1e-6 * shrink * min(cur.dx, cur.dy))
        out = _felt_on(texture, P, u, gu, r, x, y, (kx, ky), felt,
                       f"{felt.source}, refined to {x.size} x {y.size} on axes graded about its curvature's peaks")
        g = _felt_misses(texture, out, u, r)
        made.append(_stated(_climbed(texture, g, r)))
        if g["peak"] <= CURVATURE_SLACK:
            break
        # (finer by the h^2 law towards REFINE_AIM of the slack, at least GRADED_STEP[0] and at
        # most GRADED_STEP[1] of the last: a miss just past the slack needs a little, not half)
        shrink *= min(GRADED_STEP[1], max(GRADED_STEP[0], math.sqrt(REFINE_AIM * CURVATURE_SLACK / g["peak"])))
    return made


def _branch_limits(texture, P0, P1, u0, u1, r, steps=40):
    """The ball path's Hessians (k, 2, 2) either side of the kinks on k grid edges from P0 to P1
    (k, 2), the contacts' offsets u0 at P0 and u1 at P1 (k, 2) on the two branches: each branch
    followed by :func:`_refine_contacts` within half the two contacts' distance of its last
    contact (so that it cannot reach the other's), the kink bisected where the two branches'
    heights meet (a branch that ends, its contact at its box's wall, is past its fold: the kink
    lies before it), and :func:`_path_hessian` on each branch there; NaN where the two do not
    meet there (within the surface's steepest slope times the bracket, a branch lost on the way).
    The areal form of the profile's :func:`haptex.textures._kink_limits`."""
    lo, hi, ua, ub = P0.copy(), P1.copy(), u0.copy(), u1.copy()
    rim = r * (1 - 1e-9)
    span = np.maximum(0.5 * np.abs((P1 + u1) - (P0 + u0)), 1e-3 * np.linalg.norm(P1 - P0, axis=1)[:, None])
    tol = 1e-9 * float(np.min(span))

    def follow(P, u):
        v, g = _refine_contacts(texture, P, u, u - span, u + span, r, rim, tol)
        wall = np.any((v <= u - span + 1e-6 * span) | (v >= u + span - 1e-6 * span), axis=1)
        return v, np.where(wall, -np.inf, g)

    for _ in range(steps):
        mid = 0.5 * (lo + hi)
        va, fa = follow(mid, ua)
        vb, fb = follow(mid, ub)
        first = fa >= fb  # (the first branch still the higher: the kink beyond mid)
        lo, ua = np.where(first[:, None], mid, lo), np.where(first[:, None], va, ua)
        hi, ub = np.where(first[:, None], hi, mid), np.where(first[:, None], ub, vb)
    ga = texture.height_at(lo + ua) + np.sqrt(np.maximum(r * r - np.einsum("ij,ij->i", ua, ua), 0.0))
    gb = texture.height_at(hi + ub) + np.sqrt(np.maximum(r * r - np.einsum("ij,ij->i", ub, ub), 0.0))
    met = np.abs(ga - gb) <= texture.max_slope * np.linalg.norm(hi - lo, axis=1) + 1e-9 * r
    left, right = _path_hessian(texture, lo, ua, r, sound=0.0), _path_hessian(texture, hi, ub, r, sound=0.0)
    return np.where(met[:, None, None], left, np.nan), np.where(met[:, None, None], right, np.nan)


def _bridged_miss(texture, felt, r):
    """How far a periodic felt map of a surface the ball bridges misses its path's curvature, as a
    fraction of the path's largest (nodes', non-jump cells' centres' and the kinks' one-sided
    limits, :func:`_branch_limits`): its largest (``max_curvature``) against that, and its Hessian
    at each centre of a cell across which the contact does not jump against the path's there.
    Returns (miss, the path's Hessian's largest |entries| along x and y rows (2,), its largest)."""
    nx, ny = felt.x.size, felt.y.size
    dx, dy = felt.dx, felt.dy
    X, Y = np.meshgrid(felt.x, felt.y, indexing="ij")
    P = np.stack([X, Y], -1)
    u = _contact_offsets(felt._gradients.reshape(-1, 2), r).reshape(nx, ny, 2)
    found = [_path_hessian(texture, P.reshape(-1, 2), u.reshape(-1, 2), r, sound=0.0)]
    still = ~_jump_cells(u, dx, dy, True, texture, r, (felt.x[0], felt.y[0]))
    Pc = P[still] + 0.5 * np.array([dx, dy])
    uc, _ = _smooth_contacts(texture, felt, Pc, r, 1e-6 * min(dx, dy))
    hc = _path_hessian(texture, Pc, uc, r, sound=0.0)
    found.append(hc)
    for axis, unit in ((0, np.array([dx, 0.0])), (1, np.array([0.0, dy]))):
        nxt = np.roll(u, -1, axis=axis)
        jump = _kinked(texture, P + u, nxt - u + unit, dx, dy, r)
        if jump.any():
            P0 = P[jump]
            left, right = _branch_limits(texture, P0, P0 + unit, u[jump], nxt[jump], r)
            found += [left, right]
    both = np.concatenate(found)
    norms = _hessian_norm(both)
    truth = float(np.nanmax(norms)) if np.isfinite(norms).any() else math.inf
    if not (truth > 0) or not math.isfinite(truth):
        return 0.0, np.zeros(2), truth
    apart = _hessian_norm(felt.hessian(Pc) - hc) if Pc.size else np.zeros(1)
    miss = max(abs(felt.max_curvature / truth - 1.0), float(np.nanmax(apart, initial=0.0)) / truth)
    rows = np.array([np.nanmax(np.abs(both[:, a, a]) + np.abs(both[:, a, 1 - a])) for a in (0, 1)])
    return miss, rows, truth


def _bridged_contacts(texture, coarse, P, r):
    """The contacts (n, 2) and the path's heights c (n,) at points P (n, 2) on a periodic surface
    the ball bridges, from a felt map ``coarse`` on a coarser grid: each point's contact refined
    (:func:`_refine_contacts`) from the offset its coarse gradient gives (r g / sqrt(1 + |g|^2));
    in a coarse cell across which the contact jumps, from the contacts of that cell's 4 x 4
    block of grid points too (each within BRANCH_JUMP coarse intervals), the highest kept: the
    path is the highest of the branches there (:func:`_branch_patches`' sources)."""
    nx, ny = coarse.x.size, coarse.y.size
    dx, dy = coarse.dx, coarse.dy
    rim = r * (1 - 1e-9)
    tol = 1e-6 * min(dx, dy)
    u, c = _smooth_contacts(texture, coarse, P, r, tol)
    uc = _contact_offsets(coarse._gradients.reshape(-1, 2), r).reshape(nx, ny, 2)
    jumps = _jump_cells(uc, dx, dy, True, texture, r, (coarse.x[0], coarse.y[0]))
    i = np.floor((P[:, 0] - coarse.x[0]) / dx + 1e-9).astype(np.int64) % nx
    j = np.floor((P[:, 1] - coarse.y[0]) / dy + 1e-9).astype(np.int64) % ny
    k = np.nonzero(jumps[i, j])[0]
    span = BRANCH_JUMP * np.array([dx, dy])
    for a in (-1, 0, 1, 2):
        for b in (-1, 0, 1, 2):
            if k.size == 0:
                break
            si, sj = (i[k] + a) % nx, (j[k] + b) % ny
            # (the source's contact point, as an offset from each point: the cell's corner
            # (i, j) sits at P - the point's place in the cell)
            corner = np.column_stack([coarse.x[i[k]], coarse.y[j[k]]])
            start = uc[si, sj] + corner + np.array([a * dx, b * dy]) - P[k]
            v, g = _refine_contacts(texture, P[k], start, start - span, start + span, r, rim, tol)
            up = g > c[k]
            u[k[up]], c[k[up]] = v[up], g[up]
    return u, c - r


def _bridged_refined(texture, felt, r):
    """A periodic felt map of an analytic surface the ball bridges (:func:`_may_bridge`), made again on grids
    halved from ``felt``'s (along the axes its path curves along) while its curvature misses the
    path's by more than CURVATURE_SLACK of the path's largest (:func:`_bridged_miss`: its largest
    against the path's largest at the nodes, the centres of the cells across which the contact
    does not jump and the kinks' one-sided limits, where near the troughs' radius the path's
    curvature is largest; and its Hessian at those centres against the path's), within
    CURVATURE_REFINE_SAMPLES. Each finer grid's contacts start from the last map's
    (:func:`_bridged_contacts`: no dilation), its edges, kinks and branched cells made as the
    first's (:func:`_contact_edges`); where the first finer grid misses by more than the slack,
    it is made again with the hidden branches' corners from their neighbours' Taylor polynomials
    (:func:`_branch_patches`' ``fold``), the one that misses less going on and its way alone on
    the finer grids (two gratings at 1.2 times their tightest radius: 676 % on 86 x 44 the first
    way, 11 % the second, then 2.2, 1.8 and 1.05 % on 172 x 88, 344 x 176 and 688 x 352, where
    the first way, made on each, read 270, 60 and 56.5 %; the egg-crate's bowls at 1.1 times
    their radius 13.7 % on 58 x 58 the first way, 121 % the second, which also left 116 and 232
    a side unbranched or too steep, where the first went on to 0.70 % on 464 x 464; 2026-11-30);
    a grid that leaves a cell beside a kink unbranched or is steeper than the surface
    (STEEP_SLACK) every way made ends the refinement. The first grid within the slack is kept,
    else the one that missed least, with ``felt``'s shortest period."""
    if 2 * felt.x.size * felt.y.size > CURVATURE_REFINE_SAMPLES or felt._gradients is None:
        return felt
    best = None
    cur = felt
    bound = texture.max_slope * (1 + STEEP_SLACK)
    miss, rows, truth = _bridged_miss(texture, cur, r)
    ways = (False, True)  # (without and with _branch_patches' fold)
    tops = [truth]  # (each map's samples of the path's largest curvature: the largest bounds its sup from below)

    def kept():
        out = best[1]
        out.curvature_miss = out.peak_miss = float(best[0])
        top = max((t for t in tops if math.isfinite(t)), default=0.0)
        out.path_curvature = float(top) if top > 0 else None
        return out

    while True:
        if best is None or miss < best[0]:
            best = (miss, cur)
        bends = [bool(v > CURVATURE_SLACK * truth) for v in rows]
        nx, ny = (n * (2 if b else 1) for n, b in zip((cur.x.size, cur.y.size), bends))
        if miss <= CURVATURE_SLACK or not any(bends) or nx * ny > CURVATURE_REFINE_SAMPLES:
            return kept()
        x, y, P, dx, dy = _finer_grid(cur, nx, ny)
        u0, c0 = _bridged_contacts(texture, cur, P.reshape(-1, 2), r)
        tried, made = [], 0
        for fold in ways:
            if tried and tried[0][0] <= CURVATURE_SLACK:
                break
            made += 1
            u, c = u0.reshape(nx, ny, 2).copy(), c0.reshape(nx, ny).copy()
            hf, grads, edges, kinks, branches = _contact_paths(texture, x, y, P, u, c, r, r * (1 - 1e-9), True,
                                                                own_twists=True, fold=fold)
            finer = SampledSurface(x, y, hf, periodic=True, gradients=grads,
                                   shortest_period=felt.shortest_period,  # (more samples of one path)
                                   source=f"{felt.source}, refined to {nx} x {ny} for its curvature")
            finer._edges, finer._branches, finer.kinks = edges, branches, kinks
            if _single_kink_cells(finer) == 0 and finer.max_slope <= bound:
                tried.append((*_bridged_miss(texture, finer, r), finer, fold))
        tops.extend(t[2] for t in tried)
        if not tried:
            return kept()  # (a grid that cannot be branched, or overshoots: the coarser stand)
        miss, rows, truth, cur, folded = min(tried, key=lambda t: t[0])
        if made == 2:  # (the way that did better alone on the finer grids)
            ways = (folded,)


def _may_bridge(texture, r) -> bool:
    """Whether a ball of radius r (m) can bridge the surface anywhere: between two contacts the
    ball's vertical section through them is a circle of radius at most r, tangent from above at
    both, so the surface's section must curve more somewhere, its second derivative there above
    1 / r; none can where r times the sup of the Hessian's 2-norm (``max_curvature``, a dense
    grid's refined by quasi-Newton steps as the profile's bridging test samples its curvature;
    the egg-crate's rigorous ``curvature_bound`` is 14 % above it) is at most 1, and the ball
    touches the surface everywhere (its path the offset surface, smooth)."""
    return not (r * float(texture.max_curvature) <= 1.0)


def _forget(cache, node, shape):
    """Drop from :func:`_branch_patches`' cache what was followed at or from the grid points
    ``node`` (flat indices), whose contacts have changed."""
    known = cache.get("known")
    if known is None:
        return
    nx, ny = shape
    W = 2 * BRANCH_REACH + 1
    g = known["key"] // (W * W)
    sa = (known["key"] // W) % W - BRANCH_REACH
    sb = known["key"] % W - BRANCH_REACH
    src = ((g // ny + sa) % nx) * ny + (g % ny + sb) % ny
    stay = ~(np.isin(g, node) | np.isin(src, node))
    for name in known:
        known[name] = known[name][stay]
    for k in np.asarray(node).tolist():
        cache["reps"].pop(int(k), None)


def _contact_edges(texture, x, y, P, u, c, r, rim, periodic, cache=None, own_twists=False, fold=False):
    """The rest of :func:`_contact_map` from the contacts u (nx, ny, 2) and the path's heights
    c (nx, ny): (c, gradients, (ex, ey, twist), kinks, branches, better), ``better`` the grid
    points (flat indices, offsets, heights) where a branch stands higher than c, or None. With
    ``own_twists`` a node beside a kink takes its own contact's twist (:func:`_path_twist`, within
    2 M / interval), else none (on a rough map felt by a 3 um ball its own made the map 0.07 %
    steeper than the surface; :func:`_bridged_refined`'s grids take it, checked against the
    path's curvature and the surface's slope). ``fold``: :func:`_branch_patches`'."""
    dx, dy = float(x[1] - x[0]), float(y[1] - y[0])
    on_rim = None if periodic else _on_rim(P + u, x, y)
    grads = _path_gradient(texture, P, u, r, on_rim)
    bridges = _may_bridge(texture, r)
    # the edges: kinked where the contact jumps by more than three intervals across a section
    # the ball can bridge
    step_x, step_y = np.array([dx, 0.0]), np.array([0.0, dy])
    ex, ey = _node_edges(grads, periodic)
    flat = np.zeros(c.shape, dtype=bool)
    kinks = []
    cells = None
    from .textures import _kink_ends

    for axis, edges, d, unit in ((0, ex, dx, step_x), (1, ey, dy, step_y)):
        nxt = np.roll(u, -1, axis=axis) if periodic else (u[1:] if axis == 0 else u[:, 1:])
        here = u if periodic else (u[:-1] if axis == 0 else u[:, :-1])
        # (else the contact only runs fast: the path is smooth)
        jump = (_kinked(texture, (P if periodic else (P[:-1] if axis == 0 else P[:, :-1])) + here,
                        nxt - here + unit, dx, dy, r) if bridges else np.zeros(here.shape[:2], dtype=bool))
        # (and where the ball passes from resting on a bounded map's rim to resting inside it: the
        # path is C^1 there but its curvature jumps, and the cubic through both exact slopes
        # overshot them by up to 5.5 % on a 4 mm map felt by a 0.1 mm ball; not a kink)
        # Not beside a cell across which the contact jumps: such a cell may be branched, its
        # patches through the contacts' own slopes, and its neighbour's edge must be the same
        # cubic (moved there, every branched cell beside it parted from its unbranched
        # neighbours, and the continuity check unbranched the whole of its cluster: the 4 mm
        # egg-crate map felt by 1.1-1.3 mm balls read +15 to +34 % steep)
        soft = np.zeros_like(jump)
        if on_rim is not None:
            rh = on_rim[:-1] if axis == 0 else on_rim[:, :-1]
            rn = on_rim[1:] if axis == 0 else on_rim[:, 1:]
            soft = (rh != rn) & ~jump
            if soft.any():
                if cells is None:
                    cells = _jump_cells(u, dx, dy, periodic, texture, r, (x[0], y[0]))
                beside = np.zeros(soft.shape, dtype=bool)  # (edges of axis 0 border cells (i, j - 1) and (i, j))
                if axis == 0:
                    beside[:, :-1] |= cells
                    beside[:, 1:] |= cells
                else:
                    beside[:-1, :] |= cells
                    beside[1:, :] |= cells
                soft &= ~beside
        if not (jump.any() or soft.any()):
            continue
        hn = np.roll(c, -1, axis=axis) if periodic else (c[1:] if axis == 0 else c[:, 1:])
        hh = c if periodic else (c[:-1] if axis == 0 else c[:, :-1])
        mean = (hn - hh) / d
        moved = jump | soft
        jump_ = edges[..., 1][jump] - edges[..., 0][jump]  # (the kinks' slope jumps, as the contacts give them)
        # (a cell beside a kink that is not branched keeps its edges' slopes within the contacts')
        edges[..., 0][moved], edges[..., 1][moved] = _kink_ends(edges[..., 0][moved], edges[..., 1][moved],
                                                                mean[moved])  # (views: set in place)
        ii, jj = np.nonzero(moved)
        flat[ii, jj] = True
        flat[(ii + (axis == 0)) % c.shape[0], (jj + (axis == 1)) % c.shape[1]] = True
        ii, jj = np.nonzero(jump)
        mid = np.column_stack([x[ii] + 0.5 * dx * (axis == 0), y[jj] + 0.5 * dy * (axis == 1)])
        kinks.append(np.column_stack([mid, jump_]))
    twist = _twist(grads, dx, dy, periodic)
    # (beside a kink the central differences straddle the jump: none there, or with
    # ``own_twists`` the node's own contact's, :func:`_path_twist`, where it gives one)
    if flat.any():
        inner = flat if on_rim is None else flat & ~on_rim
        twist[flat] = 0.0
        if own_twists and inner.any():
            with np.errstate(divide="ignore", invalid="ignore"):
                own = _path_twist(texture, P[inner], u[inner], r)
            # (within what a cubic can follow, as a branch's: no slope changes by more than
            # 2 M across a cell)
            fits = np.isfinite(own) & (np.abs(own) <= 2.0 * texture.max_slope / min(dx, dy))
            twist[inner] = np.where(fits, own, 0.0)
    branches, better = (_branch_patches(texture, x, y, u, grads, twist, r, rim, periodic, c, ex, ey, cache,
                                        fold=fold) if bridges else (None, None))
    return c, grads, (ex, ey, twist), (np.concatenate(kinks) if kinks else np.zeros((0, 3))), branches, better


BRANCH_REACH = 6
"""A branch is followed to a corner from the contact of a grid point at most this many
intervals away along each axis (chosen: a cell's own 4 x 4 block and what its neighbours pass
it, see :func:`_branch_patches`; at 4, on the egg-crate's bowls felt by a ball of 1.09 times
their radius, the contacts 4.4-5.5 intervals from their grid points, the branches passed between
neighbours fell out of reach and 144 of 170 cells failed the edge check on 0.8 of the default
grid; at 6, with the twist bounded in :func:`_branch_patches`, none)."""

STEEP_SLACK = 1e-2
"""A branched cell's patch may be this much (relative) steeper than the surface where it is the
highest, the Hermite interpolation's own error near the surface's steepest slope (chosen: on
the egg-crate's bowls at 1.6 times their radius a branch through four contacts reaches 1.006
times it, where the single patch the cell would fall back on, and its neighbours with it, reads
1.3 times); steeper, the cell keeps its single patch."""

BRANCH_CELLS = 20_000
"""At most this many cells of a felt map are tried for branching (chosen: about 5 s on this
project's machine, 0.26 ms a cell on a rough map); a map with more (a rough map felt by a ball
of a few samples, where contacts jump between asperities everywhere) keeps its single patches."""

BRANCH_ROUNDS = 6
"""Rounds in which neighbouring branched cells whose highest patches part along a shared edge
pass each other their branches (chosen; measured: two suffice on the egg-crate's bowls)."""

BRANCH_GROWTH = 4
"""Times the candidate cells of a felt map's branching are grown by the cells beside them that
are no candidates (their corners' contacts close) but whose single patch a branched candidate
does not meet along their shared edge (a crease crossing it), the branching then made again;
only while every candidate can be branched (chosen; measured: on the rough map of the tests, 64
x 64 samples of 1 um felt by 10 and 12 um balls, two growths, by 24 and 2 cells, then 5 and 2
after a grid point took a higher branch; on a 128 x 128 one at 10 um, by 78, 9 and 1 cells)."""


def _jump_cells(u, dx, dy, periodic, texture=None, r=None, origin=(0.0, 0.0)):
    """The cells (mx, my) across which the contact jumps: two of their corners' contacts (offsets u
    (nx, ny, 2) from their grid points) more than BRANCH_JUMP intervals apart (:func:`_far_apart`)
    and, given the surface ``texture`` and the ball's radius r (m), able to bridge the surface
    between them (:func:`_section_bridges`; the grid's first point at ``origin``, m): elsewhere
    the contact only runs fast across the cell and the path is smooth there. The candidates of
    :func:`_branch_patches`."""
    nx, ny = u.shape[:2]
    mx, my = (nx, ny) if periodic else (nx - 1, ny - 1)
    i = np.arange(mx)[:, None]
    j = np.arange(my)[None, :]
    rel = [u[(i + a) % nx, (j + b) % ny] + np.array([a * dx, b * dy]) for a, b in ((0, 0), (1, 0), (0, 1), (1, 1))]
    jumps = np.zeros((mx, my), dtype=bool)
    for k in range(4):
        for k2 in range(k + 1, 4):
            far = _far_apart(rel[k] - rel[k2], dx, dy) & ~jumps
            if texture is not None and far.any():
                ci, cj = np.nonzero(far)
                corner = np.column_stack([origin[0] + ci * dx, origin[1] + cj * dy])
                far[ci, cj] = _section_bridges(texture, corner + rel[k][ci, cj], corner + rel[k2][ci, cj], r)
            jumps |= far
    return jumps


def _section_bridges(texture, s0, s1, r, any_direction=False):
    """Whether a ball of radius r (m) can bridge the surface between contacts s0 and s1 (k, 2) (m):
    the ball's vertical section through both is a circle of radius at most r tangent from above at
    each, so the surface's section along the segment must curve more than it somewhere, r kappa >
    1 with kappa = h_ee / (1 + h_e^2)^(3/2) (e the segment's direction), sampled as the profile's
    :func:`haptex.textures._bridges` (16 points a shortest period, at least 16, at most
    BRIDGE_SAMPLES a segment); elsewhere the contact only runs fast between them (near the
    troughs' radius 1 / (1 - r kappa) times as fast as the ball) and the path is smooth there.
    With ``any_direction``, whether the segment crosses ground the ball cannot touch, r kappa > 1
    along some direction e there (SECTION_DIRECTIONS of them): two contacts of neighbouring grid
    points, not of one ball, either side of it (their chord at an angle to the direction it is
    bridged along). Shape (k,) bool."""
    from . import core
    from .textures import BRIDGE_SAMPLES

    d = s1 - s0
    length = np.linalg.norm(d, axis=1)
    out = np.zeros(s0.shape[0], dtype=bool)
    if out.size == 0:
        return out
    m = int(min(max(16, math.ceil(16 * float(length.max()) / texture.shortest_period)), BRIDGE_SAMPLES))
    e = d / np.maximum(length, 1e-300)[:, None]
    t = np.linspace(0.0, 1.0, m)
    deriv = texture._derivatives if isinstance(texture, SampledSurface) else partial(core.texture_derivatives, texture)
    rows = max(1, (1 << 18) // (m * (SECTION_DIRECTIONS if any_direction else 1)))
    for i in range(0, out.size, rows):
        pts = s0[i:i + rows, None] + d[i:i + rows, None] * t[None, :, None]
        q = deriv(pts.reshape(-1, 2)).reshape(pts.shape[0], m, 6)
        if any_direction:
            ee = _SECTION_E[None, None]  # (1, 1, directions, 2)
            q = q[..., None, :]
        else:
            ee = e[i:i + rows, None]
        slope = q[..., 1] * ee[..., 0] + q[..., 2] * ee[..., 1]
        bend = q[..., 3] * ee[..., 0] ** 2 + 2 * q[..., 4] * ee[..., 0] * ee[..., 1] + q[..., 5] * ee[..., 1] ** 2
        kr = r * bend / (1 + slope**2) ** 1.5
        out[i:i + rows] = np.max(kr.reshape(kr.shape[0], -1), axis=1) > 1.0
    return out


SECTION_DIRECTIONS = 32
"""Directions, over half a turn, in which :func:`_section_bridges` looks for a section the ball
bridges with ``any_direction`` (chosen: on level ground a section's curvature is k1 cos^2 t + k2
sin^2 t at an angle t to the most curved direction, k1, within 0.24 % of k1 - k2 of it at half the
5.6 deg between two directions)."""

_SECTION_E = np.stack([np.cos(np.pi * np.arange(SECTION_DIRECTIONS) / SECTION_DIRECTIONS),
                       np.sin(np.pi * np.arange(SECTION_DIRECTIONS) / SECTION_DIRECTIONS)], -1)


def _kinked(texture, s0, d, dx, dy, r, apart=BRANCH_JUMP, any_direction=False):
    """Whether the grid edges whose ends' contacts are at s0 and s0 + d (..., 2) (m) are kinked:
    the contacts more than ``apart`` intervals apart (BRANCH_JUMP; :func:`_far_apart`) and the
    surface between them one the ball of radius r (m) can bridge (:func:`_section_bridges`, with
    ``any_direction`` as there: CREASE_GAP and True for a crease that goes on past its kinks,
    :func:`_ending`). Shape (...)."""
    jump = _far_apart(d, dx, dy, apart)
    if jump.any():
        jump[jump] = _section_bridges(texture, s0[jump], s0[jump] + d[jump], r, any_direction)
    return jump


def _far_apart(d, dx, dy, apart=BRANCH_JUMP):
    """Whether two contacts d (..., 2) apart (m) lie more than ``apart`` (BRANCH_JUMP) intervals
    apart, each axis in its own interval (dx, dy; a map refined along one axis only has cells
    longer than they are wide, across which a contact that moves with the ball moves by more than
    BRANCH_JUMP of the shorter interval). Shape (...)."""
    return (d[..., 0] / dx) ** 2 + (d[..., 1] / dy) ** 2 > apart**2


_FOLD_NEIGHBOURS = ((-1, 0), (1, 0), (0, -1), (0, 1), (-1, -1), (1, -1), (-1, 1), (1, 1))
"""The grid neighbours a corner's data come from with ``fold``, in the order tried (a fixed
order, so that the data are a function of the corner and the branch)."""


def _branch_patches(texture, x, y, u, grads, twist, r, rim, periodic, c, ex, ey, cache=None, grown=None,
                    growth=BRANCH_GROWTH, fold=False):
    """The branched cells of a felt map (``JOINS_BRANCHED``): where two corners' contacts lie more
    than BRANCH_JUMP intervals apart, the ball's path is the maximum of smooth branches, one a
    contact (the contact followed continuously as the ball moves). A cell's branches start from the
    contacts of the grid points of its 4 x 4 block (near a bowl's apex a point inside the cell may
    rest on a side none of its corners rests on; one of the contacts within half an interval of
    each other); each is followed to the cell's four corners, one computation per (corner, source
    grid point) so that every cell meeting at a grid point reads the same: the point's own contact
    where it is the source (the path's value there exactly), else the Newton refinement from the
    source's contact, kept where it ends inside its box (or on a bounded map's rim) and the disc
    (on a periodic map, one that left its box is followed again by continuation,
    :func:`_continued_contacts`, CONTINUATION_STEPS steps an interval, and kept where it reaches
    the corner before its fold with its curvature within the twist's bound; else the ball there
    cannot rest on it: the branch's tangent plane at the grid neighbour one step toward the
    source, along its larger offset first, where it is there, else the source's;
    its slopes a contact's; where that plane stands above the path there, the path's own height and
    gradient); one contact reached from several sources is one set of data (the first's, or the
    point's own). A branch is the cubic Hermite patch through its corners' heights, gradients (the
    contacts', by the envelope theorem) and twists (the contact's own, :func:`_path_twist`, where
    it gives one; else the node's where the corner is the source, else the cell's mean cross
    difference); it is kept where it is a corner's own or the highest at one of 5 x 5 points of the
    cell (of those within a tolerance of the highest there, the one there at most corners, a
    corner's own first), one of those alike (there at the same corners, with the same heights at
    all four). Two branched neighbours whose highest patches part along their shared edge pass each
    other their kept branches (BRANCH_ROUNDS rounds); a cell is branched at the end where it keeps
    at most ``_ext.MAX_BRANCHES``, none steeper where it is the highest than the surface
    (STEEP_SLACK), no cell of its cluster (its edge neighbours', and theirs) fails that, and its
    edges meet its neighbours' (:func:`_discontinuous`). The candidates are the cells the contact
    jumps across, and ``grown`` ((mx, my) bool, or None) those a previous try added: a cell beside
    them whose single patch a branched one does not meet is added and the whole made again, at most
    ``growth`` times (BRANCH_GROWTH) and while every candidate can be branched. Not tried past
    BRANCH_CELLS candidate cells. With ``fold`` (a periodic map), a corner where the branch is
    hidden (another contact higher there) or not there (past its fold) takes instead the
    second-order Taylor polynomial of the path at its first grid neighbour whose own contact the
    branch is (_FOLD_NEIGHBOURS): near its fold a hidden branch curves without bound, and a cubic
    through it misreads the visible side beside the kink; where no neighbour gives one, as
    without. Returns (None where no cell is branched, else (cells (m,) flat
    indices, first (m, 4, 4) each cell's first branch, starts (n_cells + 1,), extra (E, 4, 4) the
    others); and the grid points where a branch stands higher than c: (flat indices, offsets (k,
    2), heights (k,)), or None)."""
    dx, dy = float(x[1] - x[0]), float(y[1] - y[0])
    nx, ny = u.shape[:2]
    mx, my = (nx, ny) if periodic else (nx - 1, ny - 1)
    corner_at = ((0, 0), (1, 0), (0, 1), (1, 1))
    candidates = _jump_cells(u, dx, dy, periodic, texture, r, (x[0], y[0]))
    if grown is not None:
        candidates |= grown
    bi, bj = np.nonzero(candidates)
    if bi.size == 0 or bi.size > BRANCH_CELLS:
        return None, None
    m = bi.size
    W = 2 * BRANCH_REACH + 1
    tol = 1e-8 * min(dx, dy)  # (the refinement leaves a contact's height within ~1e-13 of a 0.1 mm cell)
    cache = {} if cache is None else cache  # (a caller's: what follow() found, for its next call)
    known = cache.setdefault("known", {"key": np.zeros(0, dtype=np.int64), "at": np.zeros(0, dtype=bool),
                                       "val": np.zeros(0), "G": np.zeros((0, 2)), "U": np.zeros((0, 2)),
                                       "T": np.zeros(0)})

    def follow(ni, nj, sa, sb):  # the branch of the contact of grid point (ni + sa, nj + sb) at (ni, nj)
        si, sj = (ni + sa) % nx, (nj + sb) % ny
        step = np.column_stack([sa * dx, sb * dy])  # from the corner to its source
        own_k = (sa == 0) & (sb == 0)
        p0 = np.column_stack([x[ni], y[nj]])
        u0 = u[si, sj] + step
        span = np.maximum(np.maximum(np.abs(sa), np.abs(sb)), 1)[:, None] * np.where(own_k, 1.0, BRANCH_JUMP)[:, None]
        lo, hi = u0 - span * [dx, dy], u0 + span * [dx, dy]
        if not periodic:  # (the contact stays on the sampled rectangle)
            map_lo = np.column_stack([x[0] - p0[:, 0], y[0] - p0[:, 1]])
            map_hi = np.column_stack([x[-1] - p0[:, 0], y[-1] - p0[:, 1]])
            lo, hi = np.maximum(lo, map_lo), np.minimum(hi, map_hi)
            u0 = np.clip(u0, lo, hi)
        ub, gb = _refine_contacts(texture, p0, u0, lo, hi, r, rim, 1e-6 * min(dx, dy))
        edge = 1e-6 * min(dx, dy)
        # inside its box, or on the map's own edge (the ball resting on the sampled rectangle's
        # rim: a contact as much as an inner one)
        at_lo, at_hi = ub <= lo + edge, ub >= hi - edge
        on_map_rim = None
        wall = at_lo | at_hi
        if not periodic:
            wall = (at_lo & (lo > map_lo + edge)) | (at_hi & (hi < map_hi - edge))
            on_map_rim = np.any((at_lo & ~(lo > map_lo + edge)) | (at_hi & ~(hi < map_hi - edge)), axis=1)
        inside = ~np.any(wall, axis=1) & (np.einsum("ij,ij->i", ub, ub) < (rim * (1 - 1e-6)) ** 2)
        # a branch whose contact ran past its box may still be there: near its fold the contact
        # runs 1 / (1 - r kappa) times as fast as the ball; followed again by continuation,
        # CONTINUATION_STEPS steps an interval (on a periodic map: a bounded one's rim contacts
        # are no ascent's stationary points)
        redo = np.nonzero(~own_k & np.any(wall, axis=1))[0] if periodic else np.zeros(0, dtype=np.int64)
        reach = np.maximum(np.abs(sa[redo]), np.abs(sb[redo]))  # (intervals to the source, the larger)
        for m in np.unique(reach):
            grp = redo[reach == m]
            uc, gc, ok = _continued_contacts(texture, p0[grp] + step[grp], u[si[grp], sj[grp]], p0[grp], r, rim,
                                             np.array([dx, dy]), CONTINUATION_STEPS * int(m), 1e-6 * min(dx, dy))
            # (kept where a cubic can follow it: near its fold the branch's curvature grows
            # without bound, and a patch through it overshoots; the twist's bound below)
            curv = _hessian_norm(_path_hessian(texture, p0[grp[ok]], uc[ok], r, sound=0.0))
            ok[ok] = curv <= 2.0 * bound / min(dx, dy)
            done = grp[ok]
            ub[done], gb[done], inside[done], at_lo[done], at_hi[done] = uc[ok], gc[ok], True, False, False
        at = own_k | inside
        # (the source's tangent plane where the branch is not there, never above the path's own
        # height there: the branches' highest is the path at every grid point)
        gs = grads[si, sj]
        val = np.where(at, gb - r, np.minimum(c[si, sj] - np.einsum("ij,ij->i", gs, step), c[ni, nj]))
        G = np.where(at[:, None], _path_gradient(texture, p0, ub, r, on_map_rim), gs)
        # one contact, one set of data: a branch that ends on the grid point's own contact is
        # the path there (the node's height and gradient, as the unbranched patches read them),
        # and copies of another contact reached from different sources are the first's (each
        # stops within the refinement's tolerance of it, and the cells that keep different
        # copies must still meet along their edges)
        snap = at & (np.linalg.norm(ub - u[ni, nj], axis=1) < same)
        val[snap], G[snap], ub[snap] = c[ni[snap], nj[snap]], grads[ni[snap], nj[snap]], u[ni[snap], nj[snap]]
        for k in np.nonzero(at & ~snap)[0]:
            alike = reps.setdefault(int(ni[k] * ny + nj[k]), [])
            for ru, rv, rg in alike:
                if abs(ru[0] - ub[k, 0]) < same and abs(ru[1] - ub[k, 1]) < same:
                    val[k], G[k] = rv, rg
                    break
            else:
                alike.append((ub[k].copy(), float(val[k]), G[k].copy()))
        T = np.full(at.size, np.nan)  # the branch's own twist where the contact is inside the map
        inner = at & ~np.any(at_lo | at_hi, axis=1)
        if inner.any():
            T[inner] = _path_twist(texture, p0[inner], ub[inner], r)
        return at, val, G, ub, T

    reps = cache.setdefault("reps", {})  # grid point -> the contacts followed there but its own
    same = 1e-4 * min(dx, dy)  # (two contacts closer than that are one, followed to within 1e-6)

    def corner_data(ni, nj, sa, sb):  # follow(), each (grid point, source) computed once
        keys = ((ni * ny + nj) * W + sa + BRANCH_REACH) * W + sb + BRANCH_REACH
        uk, first, inv = np.unique(keys, return_index=True, return_inverse=True)
        pos = np.minimum(np.searchsorted(known["key"], uk), max(known["key"].size - 1, 0))  # (the keys sorted)
        new = (known["key"][pos] != uk) if known["key"].size else np.ones(uk.size, dtype=bool)
        if new.any():
            f = first[new]
            at, val, G, U, T = follow(ni[f], nj[f], sa[f], sb[f])
            order = np.argsort(np.concatenate([known["key"], uk[new]]), kind="stable")
            known["key"] = np.concatenate([known["key"], uk[new]])[order]
            known["at"] = np.concatenate([known["at"], at])[order]
            known["val"] = np.concatenate([known["val"], val])[order]
            known["G"] = np.concatenate([known["G"], G])[order]
            known["U"] = np.concatenate([known["U"], U])[order]
            known["T"] = np.concatenate([known["T"], T])[order]
        idx = np.searchsorted(known["key"], uk)[inv]
        return known["at"][idx], known["val"][idx], known["G"][idx], known["T"][idx]

    node_hess, node_known = np.empty((nx * ny, 2, 2)), np.zeros(nx * ny, dtype=bool)

    def node_hessian(flat):  # the path's Hessian at grid points (flat indices) on their own contacts
        new = np.unique(flat[~node_known[flat]])
        if new.size:
            gi, gj = np.divmod(new, ny)
            node_hess[new] = _path_hessian(texture, np.column_stack([x[gi], y[gj]]), u[gi, gj], r, sound=0.0)
            node_known[new] = True
        return node_hess[flat]

    def from_neighbour(ni, nj, sa, sb, own, at, val, G, T):
        # with ``fold``, a branch the path hides at the corner (another contact higher there) or
        # that is not there (past its fold): the second-order Taylor polynomial of the path at
        # the first grid neighbour (_FOLD_NEIGHBOURS) whose own contact the branch is, not the
        # branch's data at the corner nor a tangent plane. Past the kink the hidden branch runs
        # toward its fold, its curvature growing without bound, and a cubic through a corner
        # near the fold, or through a plane past it, misreads the visible side beside the kink
        # (two gratings at 1.2 times their tightest radius: 12,100 1/m beside the crease for the
        # path's 7,800). A function of the corner and the branch alone (the neighbour's own
        # data), so that copies of one branch from different sources agree; kept where it stays
        # below the path at the corner and no steeper there than the surface. Returns (where it
        # set the data, val, G, T)
        done = np.zeros(ni.size, dtype=bool)
        if not periodic or not fold:
            return done, val, G, T
        val, G, T = val.copy(), G.copy(), T.copy()
        htol = 1e-9 * min(dx, dy)
        left = np.nonzero(~own & (~at | (val < c[ni, nj] - htol)))[0]
        for di, dj in _FOLD_NEIGHBOURS:
            reach = (np.abs(sa[left] - di) <= BRANCH_REACH) & (np.abs(sb[left] - dj) <= BRANCH_REACH)
            w = left[reach]
            if w.size == 0:
                continue
            gi, gj = (ni[w] + di) % nx, (nj[w] + dj) % ny
            there, v, _, _ = corner_data(gi, gj, sa[w] - di, sb[w] - dj)
            mine = there & (v == c[gi, gj])  # (the branch is that point's own contact: its height exactly)
            w, gi, gj = w[mine], gi[mine], gj[mine]
            if w.size == 0:
                continue
            H = node_hessian(gi * ny + gj)
            d = np.column_stack([np.full(w.size, -di * dx), np.full(w.size, -dj * dy)])
            Hd = np.einsum("kij,kj->ki", H, d)
            g = grads[gi, gj] + Hd
            v = c[gi, gj] + np.einsum("ij,ij->i", grads[gi, gj], d) + 0.5 * np.einsum("ij,ij->i", d, Hd)
            ok = (v < c[ni[w], nj[w]] - htol) & (np.einsum("ij,ij->i", g, g) <= bound**2)  # (NaN: not kept)
            w, v, g, H = w[ok], v[ok], g[ok], H[ok]
            val[w], G[w], T[w] = v, g, H[:, 0, 1]
            done[w] = True
            left = np.setdiff1d(left, w)
        return done, val, G, T

    def toward_source(ni, nj, sa, sb, at, val, G):
        # where the branch of source (ni + sa, nj + sb) is not at grid point (ni, nj): its tangent
        # plane at the grid neighbour one step toward the source (along the source's larger
        # offset first, then the other) where it is there, never above the path at (ni, nj)
        # (where it would be, the path's own height and gradient there); a function of (grid
        # point, source) alone, so every cell meeting there reads the same
        miss = np.nonzero(~at)[0]
        val, G = val.copy(), G.copy()
        sx, sy = np.sign(sa[miss]).astype(np.int64), np.sign(sb[miss]).astype(np.int64)
        xs = np.abs(sa[miss]) >= np.abs(sb[miss])
        left = np.ones(miss.size, dtype=bool)
        for di, dj in ((np.where(xs, sx, 0), np.where(xs, 0, sy)), (np.where(xs, 0, sx), np.where(xs, sy, 0))):
            gi, gj = ni[miss] + di, nj[miss] + dj
            ok = left & ((di != 0) | (dj != 0))
            if not periodic:
                ok &= (gi >= 0) & (gi < nx) & (gj >= 0) & (gj < ny)
            if not ok.any():
                continue
            there, v, g, _ = corner_data(gi[ok] % nx, gj[ok] % ny, sa[miss][ok] - di[ok], sb[miss][ok] - dj[ok])
            w = np.nonzero(ok)[0][there]
            k = miss[w]
            v, g = v[there], g[there]
            plane = v - g[:, 0] * di[w] * dx - g[:, 1] * dj[w] * dy
            # (a plane above the path there is no branch's, the path being their highest: the
            # path's own height and gradient, so that the patch meets it there, not crosses it;
            # the bounded egg-crate map at its bowls' radius read +1.35 %, then -0.04 %)
            above = plane > c[ni[k], nj[k]]
            val[k] = np.where(above, c[ni[k], nj[k]], plane)
            G[k] = np.where(above[:, None], grads[ni[k], nj[k]], g)
            left[w] = False
        return val, G

    # the sources: (cell row, offset from its origin), from the 4 x 4 block (the corners first)
    # each whose contact lies more than half an interval from every one before it (a contact
    # that close is the same one, followed from a neighbour)
    block = sorted(((a, b) for a in (-1, 0, 1, 2) for b in (-1, 0, 1, 2)), key=lambda o: (o not in corner_at, o))
    q = np.stack([u[(bi + a) % nx, (bj + b) % ny] + np.array([a * dx, b * dy]) for a, b in block], 1)  # (m, 16, 2)
    pick = np.zeros((m, len(block)), dtype=bool)
    pick[:, 0] = True
    for k in range(1, len(block)):
        d2 = np.sum((q[:, :k] - q[:, k:k + 1]) ** 2, axis=2)
        pick[:, k] = ~np.any(pick[:, :k] & (d2 <= (0.5 * min(dx, dy)) ** 2), axis=1)
    src_m, kb = np.nonzero(pick)
    src_a = np.array([o[0] for o in block])[kb]
    src_b = np.array([o[1] for o in block])[kb]
    row = np.full(mx * my, -1, dtype=np.int64)
    row[bi * my + bj] = np.arange(m)
    sides = _SIDES
    bound = texture.max_slope  # (the path's slope is a contact's: never the surface's max)

    def branch_patches(pm, pa, pb):  # the patches of the pairs (cell, source offset), with their data
        n = pm.size
        ca, cb = np.tile([0, 1, 0, 1], n), np.tile([0, 0, 1, 1], n)
        ni, nj = (np.repeat(bi[pm], 4) + ca) % nx, (np.repeat(bj[pm], 4) + cb) % ny
        sa, sb = np.repeat(pa, 4) - ca, np.repeat(pb, 4) - cb
        at, val, G, T = corner_data(ni, nj, sa, sb)
        own = (sa == 0) & (sb == 0)
        done, val, G, T = from_neighbour(ni, nj, sa, sb, own, at, val, G, T)
        val, G = toward_source(ni, nj, sa, sb, at | done, val, G)
        there, val, G, T = at.reshape(n, 4), val.reshape(n, 4), G.reshape(n, 4, 2), T.reshape(n, 4)
        own = own.reshape(n, 4)
        # the corners' Hermite data in the cell's units, as _hermite_patches'
        mean_twist = 0.5 * ((G[:, 2, 0] - G[:, 0, 0] + G[:, 3, 0] - G[:, 1, 0]) / (2 * dy)
                            + (G[:, 1, 1] - G[:, 0, 1] + G[:, 3, 1] - G[:, 2, 1]) / (2 * dx))
        mean_twist[~there.all(axis=1)] = 0.0  # (a plane has none)
        F = np.zeros((n, 4, 4))
        for k, (a, b) in enumerate(corner_at):
            node_twist = twist[(bi[pm] + a) % nx, (bj[pm] + b) % ny]
            F[:, a, b] = val[:, k]
            F[:, 2 + a, b] = G[:, k, 0] * dx
            F[:, a, 2 + b] = G[:, k, 1] * dy
            # the branch's own twist where its contact gives one (the node's is a central
            # difference, none beside a kink; the mean cross difference an O(d) estimate that
            # put the apex of a bowl 1.2 % steep at 1.5 rho), where a cubic can follow it: the
            # path's slope is a contact's, within the surface's steepest M either way, so across
            # a cell none of its derivatives changes by more than 2 M. A twist beyond that is a
            # branch's near its focal point (the bowls' radius), where the implicit function
            # theorem's blows up: at 1.09 rho, 3.2e5 1/m, a slope change of 22 over a 69 µm cell
            # where M = 0.31, and its patch stood 10 times steeper than the surface
            tk = np.where(np.abs(T[:, k]) <= 2.0 * bound / min(dx, dy), T[:, k], np.nan)
            tw = np.where(np.isfinite(tk), tk, np.where(own[:, k], node_twist, mean_twist))
            F[:, 2 + a, 2 + b] = tw * dx * dy
        pats = _HERMITE @ F @ _HERMITE.T
        return pats, there, own, val, (_POWERS.T @ pats @ _POWERS).reshape(n, 25), _patch_slopes(pats, dx, dy)

    def usable(pm, pa, pb):  # sources within reach (and on the map)
        ok = (np.abs(pa) <= BRANCH_REACH - 1) & (np.abs(pb) <= BRANCH_REACH - 1)
        if not periodic:
            ok &= (bi[pm] + pa >= 0) & (bi[pm] + pa < nx) & (bj[pm] + pb >= 0) & (bj[pm] + pb < ny)
        return ok

    ok = usable(src_m, src_a, src_b)
    src_m, src_a, src_b = src_m[ok], src_a[ok], src_b[ok]
    pats, there, own, val, V, slopes = branch_patches(src_m, src_a, src_b)
    # the clusters of candidate cells (edge neighbours): a cell that cannot be branched keeps its
    # single patch, which parts from its branched neighbours along the kinks between them, and
    # so on across its cluster; a cluster with one such cell is not branched (and costs no more)
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    links = []
    for _, (oi, oj), _, _ in sides:
        ni, nj = bi + oi, bj + oj
        other = row[(ni % mx) * my + nj % my]
        inside = other >= 0 if periodic else (other >= 0) & (ni >= 0) & (ni < mx) & (nj >= 0) & (nj < my)
        links.append((np.nonzero(inside)[0], other[inside]))
    la = np.concatenate([lk[0] for lk in links])
    lb = np.concatenate([lk[1] for lk in links])
    _, cluster = connected_components(coo_matrix((np.ones(la.size), (la, lb)), shape=(m, m)), directed=False)
    alive = np.ones(m, dtype=bool)
    for _round in range(BRANCH_ROUNDS):
        R = src_m.size
        # kept: a corner's own, or the highest at one of 5 x 5 points; one of those alike, the
        # same heights at all four corners (copies of one contact reached from different
        # sources agree where it is there but may differ where it is not, each filled from its
        # own source: a cell that kept one where its neighbour kept the other parted from it)
        top = np.full((m, 25), -np.inf)
        np.maximum.at(top, src_m, V)
        high = V >= top[src_m] - tol
        _, first_alike = np.unique(np.column_stack([src_m, np.round(val / (100 * tol)), there]), axis=0,
                                   return_index=True)
        distinct = np.zeros(R, dtype=bool)
        distinct[first_alike] = True
        eligible = there.any(axis=1) & distinct
        # the highest at a point is one patch: of those within tol of it, the one there at most
        # corners, a corner's own first, then the first (on rough maps one contact at three
        # corners and others at the fourth tie at most points, and keeping every one took
        # cells to 13-17 branches, past MAX_BRANCHES, unbranching their clusters)
        order = np.lexsort((np.arange(R), ~own.any(axis=1), -there.sum(axis=1), src_m))
        rank = np.empty(R, dtype=np.int64)
        rank[order] = np.arange(R)
        ranked = np.where(high & eligible[:, None], rank[:, None], R)
        first = np.full((m, 25), R, dtype=np.int64)
        np.minimum.at(first, src_m, ranked)
        keep = (own.any(axis=1) | np.any(ranked == first[src_m], axis=1)) & eligible
        # a cell none of whose kept patches is steeper, where it is the highest, than the surface
        steep = np.any(high & (slopes > bound * (1 + STEEP_SLACK)), axis=1)
        bad = np.zeros(m, dtype=bool)
        np.logical_or.at(bad, src_m, keep & steep)
        bad |= np.bincount(src_m[keep], minlength=m) > _ext.MAX_BRANCHES
        alive &= ~np.isin(cluster, cluster[bad])
        keep &= alive[src_m]
        # branched neighbours whose highest patches part along a shared edge pass each other
        # their kept branches
        env = _edge_envelopes(V.reshape(R, 5, 5), src_m, keep, m)
        live = np.isfinite(env[:, 0, 0])
        give = []
        kept = np.nonzero(keep)[0]
        for k, (_, (oi, oj), theirs, _) in enumerate(sides):
            ni, nj = bi + oi, bj + oj
            inside = np.ones(m, dtype=bool) if periodic else (ni >= 0) & (ni < mx) & (nj >= 0) & (nj < my)
            other = row[(ni % mx) * my + nj % my]
            pair = live & inside & (other >= 0)
            pair[pair] &= live[other[pair]]
            part = np.zeros(m, dtype=bool)
            part[pair] = np.any(np.abs(env[pair, k] - env[other[pair], theirs]) > tol, axis=1)
            g = kept[part[src_m[kept]]]  # (a parted cell's kept sources to its neighbour, moved to its origin)
            give.append(np.column_stack([other[src_m[g]], src_a[g] - oi, src_b[g] - oj]))
        give = np.concatenate(give)
        if give.size == 0 or _round == BRANCH_ROUNDS - 1:
            break
        w2 = 2 * BRANCH_REACH + 3

        def code(mm, aa, bb):
            return (mm * w2 + aa + BRANCH_REACH + 1) * w2 + bb + BRANCH_REACH + 1

        fresh = np.unique(give[~np.isin(code(*give.T), code(src_m, src_a, src_b))], axis=0)
        fresh = fresh[usable(*fresh.T)]
        if fresh.size == 0:
            break
        more = branch_patches(*fresh.T)
        src_m = np.concatenate([src_m, fresh[:, 0]])
        src_a = np.concatenate([src_a, fresh[:, 1]])
        src_b = np.concatenate([src_b, fresh[:, 2]])
        pats, there, own, val, V, slopes = (np.concatenate([old_, new_]) for old_, new_ in
                                            zip((pats, there, own, val, V, slopes), more))
    if growth > 0 and alive.all():  # (cells beside the candidates that a branched one parts from:
        # candidates too; not where a cluster cannot be branched anyway: on a 128 x 128 rough map
        # felt by a 3 um ball, 205 of 2,175 candidates alive, 8 growths took 35 s, for 8 cells)
        outside = _discontinuous(V.reshape(R, 5, 5), src_m, keep, bi, bj, (mx, my), c, ex, ey, (dx, dy), periodic,
                                 strangers=True)
        if outside.size and m + outside.size <= BRANCH_CELLS:
            grown = candidates.copy()
            grown.ravel()[outside] = True
            return _branch_patches(texture, x, y, u, grads, twist, r, rim, periodic, c, ex, ey, cache, grown,
                                   growth - 1, fold)
    # a grid point where a branch followed from elsewhere stands higher than the contact its own
    # search found (the grid's arg-max took the lower of two maxima it could not tell apart):
    # the path is that branch there, for the caller to take
    up = known["at"] & (known["val"] > c.ravel()[known["key"] // (W * W)] + tol)
    better = None
    if up.any():
        node = known["key"][up] // (W * W)
        order = np.lexsort((-known["val"][up], node))
        first = np.r_[True, node[order][1:] != node[order][:-1]]
        better = node[order][first], known["U"][up][order][first], known["val"][up][order][first]
    keep &= ~_discontinuous(V.reshape(R, 5, 5), src_m, keep, bi, bj, (mx, my), c, ex, ey, (dx, dy), periodic)[src_m]
    # per cell: a corner's own first, then the most points where it is the highest
    sel = np.lexsort((-high.sum(axis=1), ~own.any(axis=1), src_m))
    sel = sel[keep[sel]]
    if sel.size == 0:
        return None, better
    cell_of_sel = src_m[sel]
    is_first = np.r_[True, cell_of_sel[1:] != cell_of_sel[:-1]]
    cells = bi * my + bj
    starts = np.zeros(mx * my + 1, dtype=np.int64)
    np.add.at(starts, cells[cell_of_sel[~is_first]] + 1, 1)
    return (cells[cell_of_sel[is_first]], pats[sel[is_first]], np.cumsum(starts), pats[sel[~is_first]]), better


def _edge_envelopes(V, cell, live, m):
    """Each of m cells' height along its four edges (``_SIDES``' order) at the five points: the
    highest of its live patches there, from their values V (R, 5, 5) at 5 x 5 points (patches of
    cells ``cell`` (R,), those where ``live`` (R,)); -inf for a cell with none. Shape (m, 4, 5)."""
    env = np.full((m, 4, 5), -np.inf)
    cl = cell[live]
    if cl.size == 0:
        return env
    order = np.argsort(cl, kind="stable")  # (each cell's patches together: a reduction per run)
    cl, Vl = cl[order], V[live][order]
    start = np.flatnonzero(np.r_[True, cl[1:] != cl[:-1]])
    for k, (pts, _, _, _) in enumerate(_SIDES):
        env[cl[start], k] = np.maximum.reduceat(Vl[pts], start, axis=0)
    return env


def _discontinuous(V, rm, keep, bi, bj, cells_shape, c, ex, ey, steps, periodic, strangers=False):
    """The branched cells (rows of bi, bj) to leave unbranched so that the felt map stays
    continuous: a branched cell's height along each of its edges (the highest of its kept
    patches, V (R, 5, 5) at 5 x 5 points, R patches of cells rm) must be its neighbour's there,
    at the five points: the neighbour's own highest if it is branched too, else the cubic
    Hermite edge through the nodes' heights c and the edges' slopes ex, ey (kinked ones as
    moved). Leaving a cell unbranched may part it from a branched neighbour: repeated until
    none is (the set only shrinks). Returns (m,) bool; with ``strangers``, instead, the flat
    indices (i * my + j) of the cells, none of bi, bj, that a branched cell parts from."""
    mx, my = cells_shape
    dx, dy = steps
    m = bi.size
    basis = (_POWERS.T @ _HERMITE).T  # (value at 0, value at 1, slope at 0, slope at 1) at the points
    nx, ny = c.shape

    def hermite(i, j, axis):  # the edge from node (i, j) along axis, at the five points
        i1, j1 = (i + (axis == 0)) % nx, (j + (axis == 1)) % ny
        e = ex[i % ex.shape[0], j % ex.shape[1]] if axis == 0 else ey[i % ey.shape[0], j % ey.shape[1]]
        d = dx if axis == 0 else dy
        return (c[i % nx, j % ny][:, None] * basis[0] + c[i1, j1][:, None] * basis[1]
                + d * (e[:, 0][:, None] * basis[2] + e[:, 1][:, None] * basis[3]))

    sides = _SIDES
    branched = np.zeros(m, dtype=bool)
    np.logical_or.at(branched, rm[keep], True)
    row = np.full(mx * my, -1, dtype=np.int64)
    row[bi * my + bj] = np.arange(m)
    tol = 1e-8 * min(dx, dy)  # (the refinement leaves a contact's height within ~1e-13 of a 0.1 mm cell)
    single = [hermite(bi + ai, bj + aj, axis) for _, _, _, (ai, aj, axis) in sides]  # (an unbranched neighbour's)
    while True:
        env = _edge_envelopes(V, rm, keep & branched[rm], m)
        off = np.zeros(m, dtype=bool)
        outside = []  # (with strangers: the first check's unbranched non-candidates, then done)
        for k, (_, (oi, oj), theirs, _) in enumerate(sides):
            ni, nj = bi + oi, bj + oj
            inside = np.ones(m, dtype=bool) if periodic else (ni >= 0) & (ni < mx) & (nj >= 0) & (nj < my)
            other = row[(ni % mx) * my + nj % my]
            ref = single[k].copy()
            both = (other >= 0) & branched[np.maximum(other, 0)]
            ref[both] = env[other[both], theirs]
            parts = branched & inside & np.any(np.abs(env[:, k] - ref) > tol, axis=1)
            off |= parts
            if strangers:
                outside.append((ni[parts & (other < 0)] % mx) * my + nj[parts & (other < 0)] % my)
        if strangers:
            return np.unique(np.concatenate(outside))
        if not off.any():
            return ~branched
        branched &= ~off


_SIDES = [((slice(None), slice(None), 0), (0, -1), 1, (0, 0, 0)), ((slice(None), slice(None), 4), (0, 1), 0, (0, 1, 0)),
          ((slice(None), 0, slice(None)), (-1, 0), 3, (0, 0, 1)), ((slice(None), 4, slice(None)), (1, 0), 2, (1, 0, 1))]
"""Each edge of a cell: its points in a patch's 5 x 5 values, the neighbour across it, that
neighbour's edge (bottom 0, top 1, left 2, right 3), the edge's first node and its axis."""

_HERMITE = np.array([[1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [-3.0, 3.0, -2.0, -1.0], [2.0, -2.0, 1.0, 1.0]])
"""The cubic Hermite basis's coefficients: columns value at 0, value at 1, slope at 0, slope at
1; rows powers of s (a patch is _HERMITE F _HERMITE^T, F its corners' data in cell units)."""

_SAMPLES = np.linspace(0.0, 1.0, 5)
_POWERS = _SAMPLES ** np.arange(4)[:, None]  # (power a, point): s^a at 5 points of [0, 1]
_SLOPES = np.arange(4)[:, None] * _SAMPLES ** np.maximum(np.arange(4) - 1, 0)[:, None]  # a s^(a - 1)


def _patch_slopes(pats, dx, dy):
    """The gradient's norm (m/m) of each bicubic patch (R, 4, 4) (cell dx by dy) at 5 x 5 points
    of its cell, shape (R, 25)."""
    gx = (_SLOPES.T @ pats @ _POWERS) / dx
    gy = (_POWERS.T @ pats @ _SLOPES) / dy
    return np.hypot(gx, gy).reshape(pats.shape[0], 25)


def _surface_grid(texture, r, spacing):
    if isinstance(texture, SampledSurface):
        texture = texture._regular()  # (a map on graded axes: sampled at its cells' mean widths)
        x, y = texture.x, texture.y
        _check_ball_fits(texture, r)

        def axes_at(v):  # (the grid felt_by(r, spacing=v) resamples the map on)
            return [_resampled_axis(axis[0], axis[-1], axis[1] - axis[0], v, texture.periodic) for axis in (x, y)]

        def grid_at(v):  # (as its check below counts it)
            gx, gy = axes_at(v)
            return gx.size * gy.size, (v, v)

        if spacing is None:  # (the map's own grid: a smaller radius, a part of it, or a coarser grid)
            _check_work(x.size * y.size, (float(x[1] - x[0]), float(y[1] - y[0])), r, grid_at=grid_at,
                        crop=not texture.periodic, coarsest=_coarsest_spacing(texture)[0])
            return x, y, texture.h, texture.periodic, texture.source or "map"
        d = _default_spacing(texture, r, spacing)  # resampled by its spline onto a coarser grid
        grids = axes_at(d)
        if grids[0].size * grids[1].size > MAX_PROBE_SAMPLES:
            raise fail("spacing", d, f"a spacing giving at most {MAX_PROBE_SAMPLES} samples over the map")
        _check_work(grids[0].size * grids[1].size, (d, d), r, grid_at=grid_at, spacing=d,
                    coarsest=_coarsest_spacing(texture)[0])
        X, Y = np.meshgrid(*grids, indexing="ij")
        h = texture.height_at(np.stack([X, Y], axis=-1))
        step = _steps_text([float(g[1] - g[0]) for g in grids])  # (d, or a periodic map's dividing its cell)
        return grids[0], grids[1], h, texture.periodic, f"{texture.source or 'map'} resampled at {step}"
    cell = getattr(texture, "cell", None)
    if cell is None:
        raise fail("texture", texture, "a surface with a periodic cell, or a height map, for a ball to roll on")
    d = _default_spacing(texture, r, spacing)

    def sizes_at(v):  # (the samples a side of the grid felt_by(r, spacing=v) makes)
        return [int(math.ceil(c / v)) for c in cell]

    nx, ny = sizes_at(d)
    if nx * ny > MAX_PROBE_SAMPLES:
        raise fail("spacing", d, f"a spacing giving at most {MAX_PROBE_SAMPLES} samples over the cell "
                   f"({cell[0] * 1e3:g} x {cell[1] * 1e3:g} mm)")
    x, y = np.arange(nx) * (cell[0] / nx), np.arange(ny) * (cell[1] / ny)
    steps = (cell[0] / nx, cell[1] / ny)

    def grid_at(v):
        mx, my = sizes_at(v)
        return mx * my, (cell[0] / mx, cell[1] / my)

    # (before sampling it; at the default spacing, which follows r, a smaller radius is no remedy)
    _check_work(nx * ny, steps, r, grid_at=grid_at, radius=spacing is not None, spacing=spacing,
                coarsest=_coarsest_spacing(texture)[0])
    X, Y = np.meshgrid(x, y, indexing="ij")
    h = texture.height_at(np.stack([X, Y], axis=-1))
    return x, y, h, True, f"{type(texture).__name__} sampled at {cell[0] / nx * 1e6:.3g} um"
