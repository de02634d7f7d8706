"""The smooth wall W and the texture algorithms A–G of Campion & Hayward as force fields.

Every algorithm is an object with a vectorised ``force(p)`` (N) and ``jacobian(p)`` (N/m)
over probe positions ``p = [x, z]`` (m) of shape (..., 2), built with
:func:`algorithm`. Forces push the probe out of the wall. z < 0 is below the nominal
surface. Sign convention for the paper's penetration: d < 0 inside (Table I); the
:meth:`Algorithm.penetration` method returns the *depth* -d >= 0 instead.

Algorithm F (friction with memory) keeps its presliding state in :mod:`haptex.friction`.
"""

from __future__ import annotations

import numpy as np

import warnings


from .core import _ext
from ._validation import (ParameterError, fail, finite, in_range, nonnegative, not_an_algorithm, optional_positive,
                          numbers, positions, positive)
from .closest import closest_point, search_data
from .friction import PreslidingState, smooth_table, step
from .textures import Flat, Texture, checked_texture

__all__ = ["Algorithm", "algorithm", "ALGORITHMS"]


# ------------------------------------------------------------------------------------
# where a segment's force has kinks: the boundary, a clamp depth, the closest point's jumps
# (used by F's contact pieces here and by haptex.analysis.work's path integrals)
# ------------------------------------------------------------------------------------
def _signed_depths(alg: Algorithm, pts: np.ndarray) -> list[np.ndarray]:
    """Functions whose sign changes mark kinks of the force along a path: the boundary
    and, with max_penetration, the clamp depth."""
    if hasattr(alg, "signed_depth"):  # an object: measured along its base's normal
        return [alg.signed_depth(pts)]
    z = pts[..., -1]
    if alg.penetration_kind == "nominal":
        d = z
    else:
        d = z - alg.texture.height_at(pts[..., :-1])
    out = [d]
    dm = getattr(alg, "max_penetration", None)
    if dm is not None:
        out.append(d + dm)
    return out


def _breakpoints(alg: Algorithm, a: np.ndarray, b: np.ndarray) -> list[float]:
    """Parameters u in (0, 1) where the segment a->b crosses the boundary or a clamp depth."""
    length = float(np.linalg.norm(b - a))
    tex = alg.texture
    scale = tex.shortest_period if not isinstance(tex, Flat) else length
    n = int(min(max(64, 64 * length / scale), 20000))
    u = np.linspace(0.0, 1.0, n + 1)
    pts = a + u[:, None] * (b - a)
    out: list[float] = []
    from scipy import optimize

    for k, vals in enumerate(_signed_depths(alg, pts)):
        sgn = np.sign(vals)
        out.extend(float(u[i]) for i in np.nonzero(sgn[1:-1] == 0)[0] + 1)  # a sample on the kink
        for i in np.nonzero(sgn[:-1] * sgn[1:] < 0)[0]:
            fn = lambda uu, k=k: float(_signed_depths(alg, (a + uu * (b - a))[None, :])[k][0])  # noqa: E731
            out.append(optimize.brentq(fn, u[i], u[i + 1], xtol=1e-16, rtol=1e-15))
    if hasattr(alg, "kinks"):  # an object: where the base's coordinates change piece (a mesh's facets)
        out.extend(alg.kinks(a, b, u, pts))
    if alg.penetration_kind == "distance":
        from .surfaces import Extruded

        if isinstance(tex, Extruded):  # the profile's search, on the segment seen in the x-z plane
            keep = [0, 2]
            out.extend(_closest_point_jumps(tex.profile, a[keep], b[keep], u, pts[:, keep], length / n))
        else:
            out.extend(_closest_point_jumps(tex, a, b, u, pts, length / n))
    return sorted(out)


def _closest_point_jumps(tex: Texture, a, b, u, pts, spacing) -> list[float]:
    """Parameters where the closest boundary point jumps along the segment a->b (the
    probe crosses the medial axis, Remark 6), located by bisection to round-off (all
    brackets bisected together, one vectorised closest-point call per halving). A jump moves
    the closest point by more than 1e-9 of the shortest period across its bisected bracket:
    near a centre of curvature the closest point runs 1 / (1 - d kappa) times as fast as the
    probe, and with 1e-12 that motion in a bracket of round-off width passed for a jump, each
    splitting its bracket again (2,801 cuts on one 1 mm segment below a band-limited trough,
    none of them a jump); a smaller jump is a non-smooth point inside a quadrature piece,
    which :func:`haptex.analysis.path_work`'s halving closes in on."""
    cp = closest_point(tex, pts)
    inside = cp.distance > 0

    def foot(c):  # the closest points' in-plane coordinates, shape (n, k)
        return np.stack([c.x] if c.y is None else [c.x, c.y], axis=-1)

    t_all = foot(cp)
    dt = np.linalg.norm(np.diff(t_all, axis=0), axis=-1)
    out = _tie_changes(tex, a, b, u, cp.tie)
    idx = np.nonzero((dt > 2 * spacing) & inside[:-1] & inside[1:])[0]
    per_u = 2 * spacing / (u[1] - u[0])  # the closest point's smooth motion allowed per unit of u
    slack = 1e-9 * tex.shortest_period
    lo, hi = u[idx].copy(), u[idx + 1].copy()
    t_lo, t_hi = t_all[idx].copy(), t_all[idx + 1].copy()

    def gap(p, q):
        return np.linalg.norm(p - q, axis=-1)

    for _ in range(8):  # a bracket may hold several jumps (a thin branch of the medial axis)
        if lo.size == 0:
            break
        lo0, hi0, t_lo0, t_hi0 = lo.copy(), hi.copy(), t_lo.copy(), t_hi.copy()
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            live = (lo < mid) & (mid < hi)
            if not live.any():
                break
            t_mid = foot(closest_point(tex, a + mid[:, None] * (b - a)))
            left = gap(t_mid, t_lo) >= gap(t_hi, t_mid)
            hi = np.where(live & left, mid, hi)
            t_hi = np.where((live & left)[:, None], t_mid, t_hi)
            lo = np.where(live & ~left, mid, lo)
            t_lo = np.where((live & ~left)[:, None], t_mid, t_lo)
        jump = gap(t_hi, t_lo) > per_u * (hi - lo) + slack
        out += (0.5 * (lo + hi))[jump].tolist()
        # what is left on either side of the jump found: another jump if the closest point
        # moved more there than smooth motion allows
        left_more = jump & (gap(t_lo, t_lo0) > per_u * (lo - lo0) + slack)
        right_more = jump & (gap(t_hi0, t_hi) > per_u * (hi0 - hi) + slack)
        lo, hi = np.r_[lo0[left_more], hi[right_more]], np.r_[lo[left_more], hi0[right_more]]
        t_lo, t_hi = (np.concatenate([t_lo0[left_more], t_hi[right_more]]),
                      np.concatenate([t_lo[left_more], t_hi0[right_more]]))
    return out


def _tie_changes(tex: Texture, a, b, u, tie) -> list[float]:
    """Parameters where the segment enters or leaves the medial axis (a centre of
    curvature: the force is continuous there but not smooth), by bisection."""
    idx = np.nonzero(tie[:-1] != tie[1:])[0]
    if idx.size == 0:
        return []
    lo, hi = u[idx].copy(), u[idx + 1].copy()
    lo_tie = tie[idx].copy()
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        live = (lo < mid) & (mid < hi)
        if not live.any():
            break
        same = closest_point(tex, a + mid[:, None] * (b - a)).tie == lo_tie
        lo = np.where(live & same, mid, lo)
        hi = np.where(live & ~same, mid, hi)
    # the flag flips where the two minima are closer than the search can tell apart, a
    # little off the centre of curvature itself: solve p(u) = (t, h) + (1 + h'^2) (-h', 1) / h''
    # for (t, u) from there (Newton), and keep the exact crossing when it is close by
    if tex.dimension == 2:  # over a surface the bisected parameter itself
        return (0.5 * (lo + hi)).tolist()
    out = []
    for u0 in 0.5 * (lo + hi):
        t0 = float(closest_point(tex, (a + u0 * (b - a))[None, :]).x[0])
        out.append(_focal_crossing(tex, a, b, t0, float(u0)))
    return out


def _focal_crossing(tex: Texture, a, b, t0: float, u0: float) -> float:
    """Parameter u where the segment a->b crosses the centre of curvature of the boundary
    near abscissa t0 (Newton on (t, u)); u0 if Newton does not converge nearby."""
    d = b - a
    t, u = t0, u0
    for _ in range(30):
        h, s, c = (float(f(np.array(t))) for f in (tex.height, tex.slope, tex.curvature))
        if c == 0.0:
            return u0
        q = 1.0 + s * s
        third = (float(tex.curvature(np.array(t + 1e-9 * tex.shortest_period))) - c) / (1e-9 * tex.shortest_period)
        res = np.array([t - s * q / c - (a[0] + u * d[0]), h + q / c - (a[1] + u * d[1])])
        # d/dt of the centre: x: 1 - (c q + 2 s^2 c) / c^2 + s q c' / c^2 ; z: s + 2 s c / c - q c' / c^2
        jx = 1.0 - (q + 2 * s * s) + s * q * third / (c * c)
        jz = s + 2 * s - q * third / (c * c)
        jac = np.array([[jx, -d[0]], [jz, -d[1]]])
        try:
            step = np.linalg.solve(jac, -res)
        except np.linalg.LinAlgError:
            return u0
        t += step[0]
        u += step[1]
        if abs(step[1]) <= 1e-15 and abs(step[0]) <= 1e-15 * tex.shortest_period:
            break
    ok = np.isfinite(u) and abs(u - u0) <= 1e-3 and abs(t - t0) <= 0.05 * tex.shortest_period
    return float(u) if ok else u0


class Algorithm:
    """Base class of the memoryless force fields W, A–E and G.

    Attributes
    ----------
    letter : str
        The paper's letter (Table I); ``"W"`` for the smooth wall of eq. 30.
    name : str
        The paper's descriptive name (section headings of Section IV).
    stiffness : float
        Nominal wall stiffness kappa_0 (N/m).
    texture : Texture
        The height profile h (m); :class:`~haptex.textures.Flat` for W.
    penetration_kind : {"vertical", "distance", "nominal"}
        How the algorithm measures penetration (Table I): d = p^z - h(p^x) ("vertical":
        A, B, C), the minimum distance to the textured surface ("distance": D, E), or the
        distance to the nominal surface d = p^z ("nominal": W, F, G).
    is_gradient : bool
        True when the field is by construction the gradient of a potential (W, C, D).
        This is a statement of the construction; conservativity is *measured* by
        :func:`haptex.analysis.conservativity`.
    has_memory : bool
        False for every algorithm but F.
    parameters : tuple of str
        The keyword parameters :func:`algorithm` takes for this letter besides the texture and
        the stiffness (``max_penetration``, d^z_max of Remark 3, for B, C, F and G; F's friction
        and presliding; W's virtual damper): the one place the CLI, the explorer, the sweeps and
        objects learn which letter takes what.
    textured : bool
        False for W only (the smooth wall takes no texture).
    reads_slope : bool
        True where the force reads the texture's slope (B, C and G: eqs. 11, 14, 28), so that its
        Jacobian reads the curvature h'' and the force jumps where the texture's slope does (a
        felt texture's kinks); False for W, A, D, E and F.

    Parameters
    ----------
    texture : Texture
        The height profile or surface h (m).
    stiffness : float
        Nominal wall stiffness kappa_0 (N/m), > 0.
    max_penetration : float, optional
        d^z_max of Remark 3 (m), > 0: the depth at which the lateral force stops growing;
        default none.

    Raises
    ------
    ParameterError
        For a stiffness not > 0, a max_penetration not > 0, or a surface where the algorithm
        takes profiles only.
    """

    letter: str = "?"
    parameters: tuple[str, ...] = ()
    textured: bool = True
    name: str = ""
    penetration_kind: str = "vertical"
    is_gradient: bool = False
    has_memory: bool = False
    reads_slope: bool = False
    reference: str = ""

    surfaces = True
    """Whether the algorithm is defined over surfaces h(x, y) yet (else profiles only)."""

    def __init__(self, texture: Texture, stiffness: float, max_penetration: float | None = None):
        texture = checked_texture(texture)
        if texture.dimension != 1 and not self.surfaces:
            raise ParameterError(f"texture = {texture!r} is not allowed for algorithm {self.letter} yet: its 3-D "
                                 "form (a surface h(x, y)) is not implemented; W, A, B, C and G take surfaces")
        self.texture = texture
        self.stiffness = positive("stiffness", stiffness, "N/m")
        self.max_penetration = optional_positive("max_penetration", max_penetration, "m")

    @property
    def dimension(self) -> int:
        """Coordinates of a probe position: 2 ([x, z]) over a profile, 3 ([x, y, z]) over a
        surface."""
        return self.texture.dimension + 1

    def _positions(self, p) -> np.ndarray:
        return positions(p, dim=self.dimension)

    def __repr__(self) -> str:
        extra = "" if self.max_penetration is None else f", max_penetration={self.max_penetration:g}"
        return f"algorithm({self.letter!r}, {self.texture!r}, stiffness={self.stiffness:g}{extra})"

    # -- public vectorised API ----------------------------------------------------------
    def force(self, p) -> np.ndarray:
        """Force f(p) that the algorithm commands.

        Parameters
        ----------
        p : array_like, shape (..., 2) or (..., 3)
            Probe positions [x, z] over a profile, [x, y, z] over a surface (m).

        Returns
        -------
        ndarray, shape (..., 2) or (..., 3)
            Force [f_x, f_z] or [f_x, f_y, f_z] (N); zero outside the wall.

        Raises
        ------
        ParameterError
            If ``p`` has the wrong shape (a profile given 3-D positions or a surface 2-D
            ones) or a non-finite coordinate.
        """
        arr = self._positions(p)
        f, _ = self._evaluate(arr[..., :-1], arr[..., -1], jacobian=False)
        return f

    def jacobian(self, p) -> np.ndarray:
        """Analytic Jacobian J = df/dp.

        Parameters
        ----------
        p : array_like, shape (..., 2) or (..., 3)
            Probe positions [x, z] over a profile, [x, y, z] over a surface (m).

        Returns
        -------
        ndarray, shape (..., 2, 2) or (..., 3, 3)
            ``J[..., i, j] = d f_i / d p_j`` (N/m), indices in the order of ``p`` (the last
            is z); zero outside the wall.

        Raises
        ------
        ParameterError
            If ``p`` has the wrong shape or a non-finite coordinate.
        """
        arr = self._positions(p)
        _, j = self._evaluate(arr[..., :-1], arr[..., -1], jacobian=True)
        return j

    def force_and_jacobian(self, p) -> tuple[np.ndarray, np.ndarray]:
        """Both :meth:`force` (shape (..., n), N) and :meth:`jacobian` (shape (..., n, n), N/m),
        n = :attr:`dimension`.

        Parameters
        ----------
        p : array_like, shape (..., 2) or (..., 3)
            Probe positions [x, z] over a profile, [x, y, z] over a surface (m).

        Returns
        -------
        (numpy.ndarray, numpy.ndarray)
            The force, shape (..., n) (N), and the Jacobian, shape (..., n, n) (N/m).
        """
        arr = self._positions(p)
        return self._evaluate(arr[..., :-1], arr[..., -1], jacobian=True)

    def penetration(self, p) -> np.ndarray:
        """Penetration depth as this algorithm measures it (m), >= 0, shape (...).

        ``h(p^x) - p^z`` for A, B, C (h(p^x, p^y) - p^z over a surface); the distance to
        the textured surface for D, E; ``-p^z`` for W, F, G (Table I); 0 outside the wall.

        Parameters
        ----------
        p : array_like, shape (..., 2) or (..., 3)
            Probe positions [x, z] over a profile, [x, y, z] over a surface (m).

        Returns
        -------
        numpy.ndarray
            Shape (...): the depth (m), >= 0.

        Raises
        ------
        ParameterError
            If ``p`` has the wrong shape or a non-finite coordinate.
        """
        arr = self._positions(p)
        z = arr[..., -1]
        if self.penetration_kind == "nominal":
            return np.maximum(-z, 0.0)
        if self.penetration_kind == "vertical":
            return np.maximum(self.texture.height_at(arr[..., :-1]) - z, 0.0)
        return closest_point(self.texture, arr).distance

    def inside(self, p) -> np.ndarray:
        """True where the probe is inside the wall (penetration > 0), shape (...).

        Parameters
        ----------
        p : array_like, shape (..., 2) or (..., 3)
            Probe positions [x, z] over a profile, [x, y, z] over a surface (m).

        Returns
        -------
        numpy.ndarray
            Shape (...), bool.
        """
        return self.penetration(p) > 0

    def kernel_spec(self) -> tuple[int, np.ndarray, int, np.ndarray, np.ndarray]:
        """What the C core reads for this algorithm (:mod:`haptex.core`: its fields, the
        renderer's tick, the simulator's loops; positions [x, z] over a profile, [x, y, z]
        over a surface).

        Returns
        -------
        (code, params, kind, coeffs, aux)
            Algorithm code, parameter vector float64[6] (kappa_0 N/m, d^z_max m or -1,
            mu, d^x_max m, modulation scale 1/m, z_stick m or -1), the texture's (kind, coeffs)
            (:meth:`haptex.Texture.kernel_data`), and ``aux``: the closest-point search data
            for D and E (:func:`haptex.closest.search_data` over a profile or an extruded
            profile, the constants of :func:`haptex.closest.surface_search_data` over a sum
            of gratings or a height map), the smooth presliding table for F
            (:func:`haptex.friction.smooth_table`), else zeros(1).
        """
        kind, coeffs = self.texture.kernel_data()
        return (_CODES[self.letter], self.kernel_params(), kind, np.require(coeffs, np.float64, ["C"]),
                np.require(self._aux(), np.float64, ["C"]))

    def kernel_params(self) -> np.ndarray:
        """The algorithm's parameter vector float64[6] of the C core (``hx_model.prm``, the
        slots ``P_*`` of :mod:`haptex.core._ext`; see :meth:`kernel_spec`), for a profile or a
        surface.

        Returns
        -------
        numpy.ndarray, shape (6,)
            float64 parameters in the C core's slots ``P_*`` (SI units: stiffness N/m,
            lengths m).
        """
        prm = np.zeros(_ext.N_PARAMS)
        prm[_ext.P_K0] = self.stiffness
        prm[_ext.P_DZMAX] = -1.0 if self.max_penetration is None else self.max_penetration
        prm[_ext.P_ZSTICK] = -1.0
        self._fill_kernel_params(prm)
        return prm

    def _fill_kernel_params(self, prm) -> None:
        """Hook for algorithm-specific kernel parameters (F)."""

    def _aux(self) -> np.ndarray:
        """The kernel's auxiliary array (see :meth:`kernel_spec`)."""
        return np.zeros(1)

    def spring_energy(self, p) -> np.ndarray:
        """Energy stored in the virtual spring, kappa_0 d^2 / 2 (J), shape (...), with d the
        algorithm's own penetration (:meth:`penetration`, Table I).

        It is what a probe at p gets back on leaving the wall along the penetration
        direction, so E - V (the energy a run absorbed minus what is still stored) is the
        energy gained or lost for good, the quantity on which Section V-C's energy jumps
        are judged. It equals :meth:`potential` where the field is a gradient (W, D; C
        without a clamp); for A, B, E, F, G it is the spring's stretch energy, not a
        potential of the field (those fields have none).

        Parameters
        ----------
        p : array_like, shape (..., 2) or (..., 3)
            Probe positions [x, z] over a profile, [x, y, z] over a surface (m).

        Returns
        -------
        numpy.ndarray
            Shape (...): the energy (J).

        Raises
        ------
        ParameterError
            If ``p`` has the wrong shape or a non-finite coordinate.
        """
        return 0.5 * self.stiffness * self.penetration(p) ** 2

    def potential(self, p) -> np.ndarray:
        """Stored elastic energy V(p) >= 0 (J) with f = -grad V, where the field is a gradient.

        The paper writes the potential with the opposite sign, U = -V (eqs. 13, 16), so
        that f = grad U.

        Parameters
        ----------
        p : array_like, shape (..., 2) or (..., 3)
            Probe positions [x, z] over a profile, [x, y, z] over a surface (m).

        Returns
        -------
        numpy.ndarray
            Shape (...): V (J).

        Raises
        ------
        TypeError
            If the algorithm's field is not a gradient (A, B, E, G; C with
            ``max_penetration``).
        """
        raise TypeError(f"algorithm {self.letter} is not a gradient field: it has no potential")

    # -- implementation -----------------------------------------------------------------
    def _evaluate(self, x, z, jacobian: bool):  # pragma: no cover - abstract
        raise NotImplementedError

    def _clamped(self, d):
        """Depth used in the lateral component (Remark 3): max(d, -d_max^z), and the mask
        where it follows d (so its derivative is that of d)."""
        if self.max_penetration is None:
            return d, np.ones_like(d, dtype=bool)
        return np.maximum(d, -self.max_penetration), d > -self.max_penetration


def _zeros(xt, jacobian):
    """Zero forces (..., n) and Jacobians (..., n, n) for in-plane positions xt of shape
    (..., n - 1)."""
    n = xt.shape[-1] + 1
    f = np.zeros(xt.shape[:-1] + (n,))
    j = np.zeros(xt.shape[:-1] + (n, n)) if jacobian else None
    return f, j


def _outer(a, b):
    """a b^T over the last axis: shape (..., k, k)."""
    return a[..., :, None] * b[..., None, :]


def _matvec(m, v):
    """m v over the last axes: (..., k, k) x (..., k) -> (..., k)."""
    if v.shape[-1] == 1:  # a profile: a product of numbers (no reduction to pay for)
        return m[..., 0] * v
    return np.sum(m * v[..., None, :], axis=-1)


def _unit_scale(s):
    """g = (1 + ‖s‖^2)^(-1/2) for gradients s of shape (..., k): shape (...)."""
    sq = s[..., 0] * s[..., 0] if s.shape[-1] == 1 else np.sum(s * s, axis=-1)
    return 1.0 / np.sqrt(1.0 + sq)


def _matmul(a, b):
    """a b over the last two axes: (..., k, k) x (..., k, k)."""
    return a * b if a.shape[-1] == 1 else a @ b


def _normal_projector(s, g):
    """P = I - g^2 s s^T with g = (1 + ‖s‖^2)^(-1/2), shape (..., k, k): the derivative of the
    unit normal's in-plane part, d(g s)/dx = g P H. Written without cancellation (for
    k = 2, P = g^2 [[1 + s_y^2, -s_x s_y], [-s_x s_y, 1 + s_x^2]]; for k = 1, P = g^2)."""
    g2 = g * g
    if s.shape[-1] == 1:
        return g2[..., None, None]
    sx, sy = s[..., 0], s[..., 1]
    p = np.empty(s.shape + (2,))
    p[..., 0, 0] = 1.0 + sy * sy
    p[..., 1, 1] = 1.0 + sx * sx
    p[..., 0, 1] = p[..., 1, 0] = -sx * sy
    return g2[..., None, None] * p


class SmoothWall(Algorithm):
    """W — the smooth virtual wall, eq. 30: f = [0, -kappa_0 p^z] for p^z < 0.

    Its Jacobian is diag(0, -kappa_0), so its characteristic number is 1. Over a surface
    (texture ``Flat(dimension=2)``, positions [x, y, z]) f = [0, 0, -kappa_0 p^z] and
    J = diag(0, 0, -kappa_0).

    With ``damping`` B > 0 it is the classic sampled spring–damper virtual wall of Colgate
    & Schenkel ("Passivity of a class of sampled-data systems: application to haptic
    interfaces", J. Robotic Systems 14(1), 1997): inside the wall the command is
    f^z_k = -kappa_0 p^z_k - B (p^z_k - p^z_{k-1}) / T, the velocity being the backward
    difference of the sensed positions over the servo period T (``period``). Colgate and
    Schenkel show this wall, on a device with physical damping b, is passive iff
    b > kappa_0 T / 2 + |B|. The damper is linear (it may pull while the probe leaves
    fast), as in their analysis. It acts in the compiled servo loop (simulator,
    renderer); the static field (:meth:`force`, :meth:`jacobian` and the analysis) is the
    spring alone.

    Parameters
    ----------
    texture : None or Flat
        None (a planar wall), or ``Flat(dimension=2)`` for positions [x, y, z].
    stiffness : float
        kappa_0 (N/m).
    damping : float, optional
        Virtual damping B (N s/m), default 0; negative values are allowed (they model a
        controller that injects energy, the other half of Colgate & Schenkel's condition).
    period : float, optional
        Servo period T (s) of the backward difference; required when ``damping`` != 0 and
        checked against the device's period by the simulator.

    Raises
    ------
    ParameterError
        For a texture, a non-finite damping, or a damping without a period.
    """

    letter = "W"
    name = "smooth wall"
    parameters = ("damping", "period")
    textured = False
    penetration_kind = "nominal"
    is_gradient = True
    reference = "eq. 30"

    def __init__(self, texture: Texture | None, stiffness: float, damping: float = 0.0, period: float | None = None):
        if texture is not None and not isinstance(texture, Flat):
            raise ParameterError(
                f"texture = {texture!r} is not allowed for algorithm W: the smooth wall has no texture (pass None, "
                "or Flat(dimension=2) for positions [x, y, z])"
            )
        super().__init__(texture if texture is not None else Flat(), stiffness)
        self.damping = finite("damping", damping, "N s/m")
        self.period = optional_positive("period", period, "s")
        if self.damping != 0.0 and self.period is None:
            raise ParameterError(f"period = None is not allowed with damping = {self.damping:g} N s/m: the "
                                 "virtual damper's backward-difference velocity needs the servo period T (s)")

    def __repr__(self) -> str:
        if self.damping == 0.0:
            return super().__repr__()
        return (f"algorithm('W', None, stiffness={self.stiffness:g}, damping={self.damping:g}, "
                f"period={self.period:g})")

    def _fill_kernel_params(self, prm) -> None:
        prm[_ext.P_MU] = self.damping  # W's slots: virtual damping B and servo period T
        prm[_ext.P_DXMAX] = 1.0 if self.period is None else self.period

    def _evaluate(self, xt, z, jacobian):
        k = self.stiffness
        f, j = _zeros(xt, jacobian)
        inside = z < 0
        f[..., -1] = np.where(inside, -k * z, 0.0)
        if jacobian:
            j[..., -1, -1] = np.where(inside, -k, 0.0)
        return f, j

    def potential(self, p):
        """Stored energy V = kappa_0 (p^z)^2 / 2 inside, 0 outside (J), shape (...).

        Parameters
        ----------
        p : array_like, shape (..., 2) or (..., 3)
            Probe positions (m).

        Returns
        -------
        numpy.ndarray
            Shape (...): V (J).
        """
        z = self._positions(p)[..., -1]
        return np.where(z < 0, 0.5 * self.stiffness * z**2, 0.0)


class _Vertical(Algorithm):
    """Shared evaluation for A, B, C: d = p^z - h(p^x) (Table I), over a profile or a
    surface: the formulas below are written with the in-plane gradient s = grad h and
    Hessian H of h, which for a profile are h' and h''."""

    penetration_kind = "vertical"

    def _evaluate(self, xt, z, jacobian):
        tex = self.texture
        h, s, hess = tex._jet(xt, jacobian)
        d = z - h
        inside = d < 0
        f, j = _zeros(xt, jacobian)
        self._fill(np.where(inside, d, 0.0), s, hess, f, j)
        f[~inside] = 0.0
        if jacobian:
            j[~inside] = 0.0
        return f, j


class GroovedVertical(_Vertical):
    """A — grooved boundary, force normal to the nominal surface (Choi & Tan [19]).

    Eq. 6: f = [0, -kappa_0 d^z] with d^z = p^z - h(p^x) < 0 inside. Jacobian eq. 7:
    -kappa_0 [[0, 0], [-h', 1]].

    Over a surface (3-D): f = [0, 0, -kappa_0 d^z], d^z = p^z - h(p^x, p^y); the
    Jacobian's last row is kappa_0 [h_x, h_y, -1], the others zero, so
    q_A = sqrt(1 + sup ‖grad h‖^2) (Remark 2 with the gradient's norm).

    Parameters
    ----------
    texture : Texture
        The height profile or surface h (m).
    stiffness : float
        Nominal wall stiffness kappa_0 (N/m), > 0.

    Raises
    ------
    ParameterError
        For a stiffness not > 0, a max_penetration not > 0, or a surface where the algorithm
        takes profiles only.
    """

    letter = "A"
    name = "grooved boundary, force normal to surface"
    reference = "eq. 6, 7; Choi & Tan (2004) [19]"

    def __init__(self, texture, stiffness):
        super().__init__(texture, stiffness)

    def _fill(self, d, s, hess, f, j):
        k = self.stiffness
        f[..., -1] = -k * d
        if j is not None:
            j[..., -1, :-1] = k * s
            j[..., -1, -1] = -k


class GroovedNormal(_Vertical):
    """B — grooved boundary, force normal to the groove (Choi & Tan [19]).

    Eq. 11: f = -kappa_0 d^z n(p^x), n = [-h', 1] / sqrt(1 + h'^2). The Jacobian is
    derived here by the chain rule (the paper gives none): with s = h', c = h'',
    g = (1 + s^2)^(-1/2),

        J = kappa_0 [[-s^2 g + d c g^3,  s g], [s g + d s c g^3,  -g]].

    Over a surface (3-D) n is the textured normal (-grad h, 1) / sqrt(1 + ‖grad h‖^2); with
    s = grad h, H its Hessian, g = (1 + ‖s‖^2)^(-1/2) and P = I - g^2 s s^T, the in-plane
    block is kappa_0 (-g s s^T + d g P H), the in-plane column kappa_0 g s, the last row
    kappa_0 [g s + d g^3 H s, -g].

    With ``max_penetration`` the lateral component uses max(d, -d_max^z) (Remark 3).

    Parameters
    ----------
    texture : Texture
        The height profile or surface h (m).
    stiffness : float
        Nominal wall stiffness kappa_0 (N/m), > 0.
    max_penetration : float, optional
        d^z_max of Remark 3 (m), > 0: the depth at which the lateral force stops growing;
        default none.

    Raises
    ------
    ParameterError
        For a stiffness not > 0, a max_penetration not > 0, or a surface where the algorithm
        takes profiles only.
    """

    letter = "B"
    reads_slope = True
    name = "grooved boundary, force normal to groove"
    parameters = ("max_penetration",)
    reference = "eq. 11, 12; Choi & Tan (2004) [19]"

    def _fill(self, d, s, hess, f, j):
        k = self.stiffness
        g = _unit_scale(s)
        dl, follows = self._clamped(d)
        np.multiply((k * dl * g)[..., None], s, out=f[..., :-1])
        f[..., -1] = -k * d * g
        if j is not None:
            g3 = g**3
            lat = np.where(follows, g, 0.0)
            j[..., :-1, :-1] = k * (-lat[..., None, None] * _outer(s, s)
                                    + (dl * g)[..., None, None] * _matmul(_normal_projector(s, g), hess))
            j[..., :-1, -1] = (k * lat)[..., None] * s
            j[..., -1, :-1] = k * (g[..., None] * s + (d * g3)[..., None] * _matvec(hess, s))
            j[..., -1, -1] = -k * g


class ChangeOfHeight(_Vertical):
    """C — change of height (Minsky [16], Robles-De-La-Torre & Hayward [11]).

    Eq. 14: f = -kappa_0 [-d^z h', d^z], the gradient of U_C = -kappa_0 (d^z)^2 / 2
    (eq. 13). Jacobian eq. 15: -kappa_0 [[h'^2 - d^z h'', -h'], [-h', 1]].

    Over a surface (3-D) the same potential gives f = (kappa_0 d h_x, kappa_0 d h_y,
    -kappa_0 d) and J = -kappa_0 [[s s^T - d H, -s], [-s^T, 1]] with s = grad h, H its
    Hessian.

    With ``max_penetration`` the lateral component uses max(d, -d_max^z) (Remark 3); the
    field is then no longer a gradient below that depth.

    Parameters
    ----------
    texture : Texture
        The height profile or surface h (m).
    stiffness : float
        Nominal wall stiffness kappa_0 (N/m), > 0.
    max_penetration : float, optional
        d^z_max of Remark 3 (m), > 0: the depth at which the lateral force stops growing;
        default none.

    Raises
    ------
    ParameterError
        For a stiffness not > 0, a max_penetration not > 0, or a surface where the algorithm
        takes profiles only.
    """

    letter = "C"
    reads_slope = True
    name = "change of height"
    parameters = ("max_penetration",)
    reference = "eq. 13–15; Minsky (1995) [16]"

    @property
    def is_gradient(self) -> bool:  # type: ignore[override]
        """True without ``max_penetration``: C is then the gradient of kappa_0 (d^z)^2 / 2."""
        return self.max_penetration is None

    def _fill(self, d, s, hess, f, j):
        k = self.stiffness
        dl, follows = self._clamped(d)
        np.multiply((k * dl)[..., None], s, out=f[..., :-1])
        f[..., -1] = -k * d
        if j is not None:
            lat = np.where(follows, 1.0, 0.0)
            j[..., :-1, :-1] = k * (-lat[..., None, None] * _outer(s, s) + dl[..., None, None] * hess)
            j[..., :-1, -1] = (k * lat)[..., None] * s
            j[..., -1, :-1] = k * s
            j[..., -1, -1] = -k

    def potential(self, p):
        """Stored energy V = kappa_0 (d^z)^2 / 2 inside, 0 outside (J), shape (...).

        Parameters
        ----------
        p : array_like, shape (..., 2) or (..., 3)
            Probe positions (m).

        Returns
        -------
        numpy.ndarray
            Shape (...): V (J).

        Raises
        ------
        TypeError
            If ``max_penetration`` is set (the clamped field is not a gradient).
        """
        if not self.is_gradient:
            return super().potential(p)
        arr = self._positions(p)
        d = arr[..., -1] - self.texture.height_at(arr[..., :-1])
        return np.where(d < 0, 0.5 * self.stiffness * d**2, 0.0)


class _Distance(Algorithm):
    """Shared evaluation for D and E: the closest point p_h on z = h(x) (or z = h(x, y))."""

    penetration_kind = "distance"

    def __init__(self, texture, stiffness):
        super().__init__(texture, stiffness)
        if texture.dimension == 2:
            from .surfaces import Extruded, SampledSurface, SumOfGratings

            if not isinstance(texture, Extruded | SampledSurface | SumOfGratings):
                raise ParameterError(f"texture = {texture!r} is not allowed for algorithm {self.letter}: the closest "
                                     "point is searched on profiles, sums of gratings, height maps and extruded "
                                     "profiles")

    def _aux(self) -> np.ndarray:
        from .surfaces import Extruded

        tex = self.texture
        if tex.dimension == 1:
            return search_data(tex)
        if isinstance(tex, Extruded):
            return search_data(tex.profile)
        from .closest import surface_search_data

        return surface_search_data(tex)[2]

    def _evaluate(self, xt, z, jacobian):
        f, j = _zeros(xt, jacobian)
        inside = z < self.texture.height_at(xt)
        if not np.any(inside):
            return f, j
        p = np.concatenate([xt[inside], z[inside][:, None]], axis=-1)
        cp = closest_point(self.texture, p)
        fi, ji = self._inside(p, cp, jacobian)
        f[inside] = fi
        if jacobian:
            j[inside] = ji
        return f, j

    def jacobian_at_closest(self, p, cp) -> np.ndarray:
        """The Jacobian (N/m), shape (n, k + 1, k + 1), at probe positions inside the wall whose
        closest points are already known (the analysis finds them to decide where the foot
        is unique, and need not search again).

        Parameters
        ----------
        p : ndarray, shape (n, k + 1)
            Probe positions below the boundary (m).
        cp : ClosestPoint
            :func:`haptex.closest_point` of exactly these positions.
        """
        return self._inside(np.asarray(p, dtype=np.float64), cp, True)[1]

    def _surface_frame(self, cp):
        """grad h, shape (n, k), and its Hessian, shape (n, k, k), at the closest points."""
        tex = self.texture
        t = np.stack([cp.x] if cp.y is None else [cp.x, cp.y], axis=-1)
        return tex._jet(t)[1:]


class GodObjectGradient(_Distance):
    """D — variant 1 of the god-object method (Zilles & Salisbury [28]).

    Eq. 17: f = -kappa_0 (p - p_h) inside, the gradient of U_D (eq. 16), where p_h is
    the closest point of the textured boundary.

    The Jacobian is the exact derivative of p - p_h, which includes the boundary's
    curvature: with t = p_h^x, s = h'(t), c = h''(t) and
    D = 1 + s^2 + (h(t) - p^z) c,

        J = -kappa_0 (I - [[1, s], [s, s^2]] / D).

    The paper's eq. 18 is the flat-boundary linearisation (c = 0, D = 1 + s^2); it is
    available as ``jacobian(p, form="paper")``. Below a peak (c < 0), D tends to 0 at the
    centre of curvature, where ||J|| grows without bound; deeper, the closest point jumps
    from one flank to the other (Remark 6) and the force is discontinuous.

    Over a surface (3-D) p_h = (t, h(t)) minimises |p - p_h| over the plane t = (x, y)
    (a 2-D search, :func:`haptex.closest_point`); with s = grad h(t), H its Hessian,
    V = [I; s^T] and G = I + s s^T + (h(t) - p^z) H (the shape operator's part),
    dp_h/dp = V G^-1 V^T and J = -kappa_0 (I - V G^-1 V^T), which for a profile is the
    formula above; eq. 18's form is -kappa_0 n n^T, n the unit normal at p_h.

    Parameters
    ----------
    texture : Texture
        The height profile or surface h (m).
    stiffness : float
        Nominal wall stiffness kappa_0 (N/m), > 0.

    Raises
    ------
    ParameterError
        For a stiffness not > 0, a max_penetration not > 0, or a surface where the algorithm
        takes profiles only.
    """

    letter = "D"
    name = "god-object, variant 1 (gradient of the minimum distance)"
    is_gradient = True
    reference = "eq. 16–18, 32–44; Zilles & Salisbury (1995) [28]"

    def __init__(self, texture, stiffness):
        super().__init__(texture, stiffness)

    def jacobian(self, p, form: str = "exact") -> np.ndarray:
        """Jacobian of D (N/m), shape (..., 2, 2) or (..., 3, 3).

        Parameters
        ----------
        p : array_like, shape (..., 2) or (..., 3)
            Probe positions [x, z] or [x, y, z] (m).
        form : {"exact", "paper"}
            ``"exact"``: the derivative of -kappa_0 (p - p_h) including the boundary's
            curvature. ``"paper"``: eq. 18 (flat-boundary linearisation, ||J|| = kappa_0).

        Returns
        -------
        numpy.ndarray, shape (..., 2, 2) or (..., 3, 3)
            dF/dp (N/m) at each position.

        Raises
        ------
        ParameterError
            If ``form`` is not one of the two, or ``p`` is malformed.
        """
        if form == "exact":
            return super().jacobian(p)
        if form != "paper":
            raise fail("form", form, 'one of "exact", "paper"')
        arr = self._positions(p)
        xt, z = arr[..., :-1], arr[..., -1]
        n = arr.shape[-1]
        j = np.zeros(z.shape + (n, n))
        inside = z < self.texture.height_at(xt)
        if np.any(inside):
            cp = closest_point(self.texture, arr[inside])
            s, _ = self._surface_frame(cp)
            normal = np.concatenate([-s, np.ones(s.shape[:-1] + (1,))], -1)
            normal /= np.linalg.norm(normal, axis=-1, keepdims=True)
            j[inside] = -self.stiffness * _outer(normal, normal)
        return j

    def _inside(self, p, cp, jacobian):
        k = self.stiffness
        f = -k * (p - cp.point)
        if not jacobian:
            return f, None
        s, hess = self._surface_frame(cp)
        n, kk = s.shape
        e = (cp.z - p[:, -1])[:, None, None]
        G = np.eye(kk) + _outer(s, s) + e * hess
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            if kk == 1:
                Ginv = 1.0 / G
            else:
                det = G[:, 0, 0] * G[:, 1, 1] - G[:, 0, 1] * G[:, 1, 0]
                adj = np.stack([np.stack([G[:, 1, 1], -G[:, 0, 1]], -1), np.stack([-G[:, 1, 0], G[:, 0, 0]], -1)], -2)
                Ginv = adj / det[:, None, None]
        V = np.concatenate([np.broadcast_to(np.eye(kk), (n, kk, kk)), s[:, None, :]], axis=1)  # (n, k+1, k)
        with np.errstate(invalid="ignore", over="ignore"):
            dph = V @ Ginv @ np.swapaxes(V, -1, -2)  # d p_h / d p, (n, k+1, k+1)
        j = -k * (np.eye(kk + 1) - dph)
        return f, j

    def potential(self, p):
        """Stored energy V = kappa_0 (d^min)^2 / 2 inside, 0 outside (J), shape (...).

        Parameters
        ----------
        p : array_like, shape (..., 2) or (..., 3)
            Probe positions (m).

        Returns
        -------
        numpy.ndarray
            Shape (...): V (J).
        """
        d = self.penetration(p)
        return 0.5 * self.stiffness * d**2


class GodObjectVertical(_Distance):
    """E — variant 2 of the god-object method: force normal to the nominal surface.

    Eq. 19 prints f = [0, -kappa_0 d^min]; since d^min is a distance (>= 0) that sign
    would pull the probe into the wall. We use the physical sign, f = [0, +kappa_0 d^min]
    inside, and accordingly the Jacobian is the negative of the printed eq. 20:

        J = (kappa_0 / d^min) [[0, 0], [p^x - p_h^x, p^z - p_h^z]],

    whose 2-norm is kappa_0 wherever the closest point is unique (eq. 21). Over a surface
    (3-D) f = [0, 0, kappa_0 d^min] and J's last row is kappa_0 (p - p_h)^T / d^min (the
    distance's gradient), of norm kappa_0.

    Parameters
    ----------
    texture : Texture
        The height profile or surface h (m).
    stiffness : float
        Nominal wall stiffness kappa_0 (N/m), > 0.

    Raises
    ------
    ParameterError
        For a stiffness not > 0, a max_penetration not > 0, or a surface where the algorithm
        takes profiles only.
    """

    letter = "E"
    name = "god-object, variant 2 (force normal to nominal surface)"
    reference = "eq. 19–21 (sign corrected); after Zilles & Salisbury (1995) [28]"

    def __init__(self, texture, stiffness):
        super().__init__(texture, stiffness)

    def _inside(self, p, cp, jacobian):
        k = self.stiffness
        dist = cp.distance
        f = np.zeros(p.shape)
        f[:, -1] = k * dist
        if not jacobian:
            return f, None
        j = np.zeros(p.shape + (p.shape[-1],))
        safe = dist > 0
        j[safe, -1, :] = k * (p - cp.point)[safe] / dist[safe, None]
        return f, j


class ForceShading(Algorithm):
    """G — force shading (Morgenbesser & Srinivasan [29]) on a flat wall.

    Eq. 28: f = -kappa_0 p^z n(p^x), n = [-h', 1] / sqrt(1 + h'^2), for p^z < 0.
    Jacobian by the chain rule (the paper gives none): with s = h', c = h'',
    g = (1 + s^2)^(-1/2),

        J = kappa_0 [[p^z c g^3,  s g], [p^z s c g^3,  -g]].

    Over a surface (3-D) n is the textured normal (-grad h, 1) / sqrt(1 + ‖grad h‖^2):
    f = -kappa_0 p^z n, J's in-plane block kappa_0 p^z g P H, in-plane column kappa_0 g s,
    last row kappa_0 [p^z g^3 H s, -g] (s = grad h, H its Hessian, g and P as for B).

    With ``max_penetration`` the lateral component uses max(p^z, -d_max^z) (Remark 3).

    Parameters
    ----------
    texture : Texture
        The height profile or surface h (m).
    stiffness : float
        Nominal wall stiffness kappa_0 (N/m), > 0.
    max_penetration : float, optional
        d^z_max of Remark 3 (m), > 0: the depth at which the lateral force stops growing;
        default none.

    Raises
    ------
    ParameterError
        For a stiffness not > 0, a max_penetration not > 0, or a surface where the algorithm
        takes profiles only.
    """

    letter = "G"
    reads_slope = True
    name = "force shading"
    parameters = ("max_penetration",)
    penetration_kind = "nominal"
    reference = "eq. 28, 29; Morgenbesser & Srinivasan (1996) [29]"

    def _evaluate(self, xt, z, jacobian):
        k = self.stiffness
        _, s, hess = self.texture._jet(xt, jacobian)
        g = _unit_scale(s)
        inside = z < 0
        d = np.where(inside, z, 0.0)
        dl, follows = self._clamped(d)
        f, j = _zeros(xt, jacobian)
        np.multiply((k * dl * g)[..., None], s, out=f[..., :-1])
        f[..., -1] = -k * d * g
        if jacobian:
            g3 = g**3
            j[..., :-1, :-1] = (k * dl * g)[..., None, None] * _matmul(_normal_projector(s, g), hess)
            j[..., :-1, -1] = (k * np.where(follows, g, 0.0))[..., None] * s
            j[..., -1, :-1] = (k * d * g3)[..., None] * _matvec(hess, s)
            j[..., -1, -1] = -k * g
            j[~inside] = 0.0
        return f, j


class FrictionModulated(Algorithm):
    """F — flat wall with lateral friction modulated by the texture (the paper's own).

    Eq. 22, with the dissipative sign: for p^z < 0,

        f_x = -mu kappa_0 |p^z| [1 - h~(p^x)] d^x / d^x_max,     f_z = -kappa_0 p^z,

    where d^x is the presliding deflection of the Hayward–Armstrong model
    (:mod:`haptex.friction`, eq. 24), so the lateral force opposes the deflection and
    reaches mu kappa_0 |p^z| [1 - h~] (Amontons–Coulomb) in slip. The printed eq. 22
    reads -kappa_0 mu [1 - h] (d^x / d^x_max) p^z, which with p^z < 0 pushes *along*
    the deflection and would make sliding generative; Section IV-F-4 says sliding is
    dissipative, so haptex uses the sign that makes it so.

    Reading of the paper's dimensionless h: for F the paper assumes 0 <= h <= 1 and its
    experiments use "A = 0.8". haptex normalises the texture to peak magnitude 1 and
    scales it by ``modulation_depth`` (0 <= depth <= 1): h~ = depth h / max|h|, so the
    modulation 1 - h~ lies in [1 - depth, 1 + depth] within [0, 2]. The default
    depth 0.8 is the paper's A = 0.8. A texture of zero amplitude gives h~ = 0.

    With ``max_penetration`` (d^z_max, Remark 3 and Section IV-F-3) the lateral term uses
    min(|p^z|, d^z_max).

    Over a surface (3-D) the presliding is isotropic in the tangent plane: the deflection
    d = p_t - w is a 2-D vector with |d| <= d^x_max, the adhesion point w moving only when
    |d| reaches d^x_max (the sharp model, eq. 24, as a play operator in the plane: w is
    dragged along d), and f_t = -mu kappa_0 |p^z| [1 - h~(p^x, p^y)] d / d^x_max, f_z =
    -kappa_0 p^z. In stick dd/dp_t = I; in slip dd/dp_t = I - u u^T, u = d / |d| (motion
    along d is slip, across it turns d). The smooth variant follows the 1-D flow along d and
    is elastic across it (:func:`haptex.friction.step_plane`).

    The field has memory: evaluate it statically with an explicit deflection
    (``force(p, deflection)``, ``jacobian(p, deflection, phase)``, eqs. 23, 25, 26), or
    along a path with :func:`haptex.path_work`, which steps the friction state.

    Parameters
    ----------
    texture : Texture
        The height profile or surface h (m).
    stiffness : float
        Nominal wall stiffness kappa_0 (N/m), > 0.
    friction : float, optional
        Coulomb friction coefficient mu, >= 0 (default 0.8).
    presliding : float, optional
        Presliding deflection d^x_max (m), > 0 (default 1 mm).
    modulation_depth : float, optional
        Depth of the texture's modulation of the friction, in [0, 1] (default 0.8).
    max_penetration : float, optional
        d^z_max of Remark 3 (m), > 0: the depth at which the lateral force stops growing;
        default none.
    stick_deflection : float, optional
        The smooth presliding model's elastic range z_stick (m), below ``presliding``;
        default none (the sharp model).

    Raises
    ------
    ParameterError
        For a stiffness not > 0, a max_penetration not > 0, or a surface where the algorithm
        takes profiles only.
    """

    letter = "F"
    name = "flat wall with modulated lateral friction"
    parameters = ("friction", "presliding", "modulation_depth", "max_penetration", "stick_deflection")
    penetration_kind = "nominal"
    has_memory = True
    reference = "eq. 22–27, 31; Hayward & Armstrong (2000) [32]"

    def __init__(self, texture, stiffness, friction=0.8, presliding=1e-3, modulation_depth=0.8,
                 max_penetration=None, stick_deflection=None):
        super().__init__(texture, stiffness, max_penetration)
        self.friction = nonnegative("friction", friction)
        self.presliding = positive("presliding", presliding, "m")
        self.modulation_depth = in_range("modulation_depth", modulation_depth, 0.0, 1.0)
        # validates stick_deflection against presliding
        self.stick_deflection = PreslidingState(0.0, self.presliding, stick_deflection).stick_deflection
        peak = float(texture.peak_magnitude)
        if not np.isfinite(peak):
            raise fail("texture", texture, "a texture with finite heights")
        self._scale = self.modulation_depth / peak if peak > 0 else 0.0
        if not (np.isfinite(self._scale) and np.isfinite(self._scale * float(texture.max_slope))):
            # a subnormal peak (1e-320 m) overflows h~ = h / max|h| and ended in "non-finite
            # position [nan, nan]" (issue 33): name the texture's height instead
            raise fail("texture", texture, f"a texture whose peak height F can normalise (h~ = h / max|h| overflows at "
                       f"{peak:g} m), or a flat one")

    def __repr__(self) -> str:
        extra = "" if self.max_penetration is None else f", max_penetration={self.max_penetration:g}"
        if self.stick_deflection is not None:
            extra += f", stick_deflection={self.stick_deflection:g}"
        return (f"algorithm('F', {self.texture!r}, stiffness={self.stiffness:g}, friction={self.friction:g}, "
                f"presliding={self.presliding:g}, modulation_depth={self.modulation_depth:g}{extra})")

    # -- modulation --------------------------------------------------------------------
    def modulation(self, x) -> np.ndarray:
        """Modulation 1 - h~ (dimensionless) of the friction.

        Parameters
        ----------
        x : array_like
            Abscissae of any shape (m) over a profile; in-plane positions of shape (..., 2)
            (m) over a surface.

        Returns
        -------
        numpy.ndarray
            The modulation, shape (...).
        """
        x = numbers("x", x, "abscissae (m), or in-plane positions [x, y] (m) over a surface", copy=False)
        if self.texture.dimension == 1:
            return 1.0 - self._scale * self.texture.height(x)
        return 1.0 - self._scale * self.texture.height_at(x)

    @property
    def modulation_max_slope(self) -> float:
        """sup |grad h~| (1/m): depth M / max|h|, with M the texture's Lipschitz bound."""
        return self._scale * self.texture.max_slope

    def _aux(self) -> np.ndarray:
        if self.stick_deflection is None:
            return np.zeros(1)
        return smooth_table(self.presliding, self.stick_deflection)

    def _fill_kernel_params(self, prm) -> None:
        prm[_ext.P_MU] = self.friction
        prm[_ext.P_DXMAX] = self.presliding
        prm[_ext.P_SCALE] = self._scale
        prm[_ext.P_ZSTICK] = -1.0 if self.stick_deflection is None else self.stick_deflection

    def initial_state(self, x: float) -> PreslidingState:
        """Friction state of a fresh contact: zero deflection.

        Parameters
        ----------
        x : float
            The abscissa of the contact (m).

        Returns
        -------
        PreslidingState
        """
        return PreslidingState.at(x, self.presliding, self.stick_deflection)

    # -- static evaluation ---------------------------------------------------------------
    def _deflection(self, deflection, shape):
        """Deflections broadcast to ``shape`` (profiles) or ``shape + (2,)`` (surfaces),
        each within the presliding range."""
        k = self.texture.dimension
        d = numbers("deflection", deflection, "deflections (m)", copy=False)
        if k == 2 and d.ndim == 0:
            d = np.array([float(d), 0.0])  # a scalar over a surface: a deflection along x
        try:
            d = np.broadcast_to(d, shape + ((2,) if k == 2 else ()))
        except ValueError:
            raise fail("deflection", f"an array of shape {np.shape(deflection)}",
                       f"broadcastable to {shape + ((2,) if k == 2 else ())} (a 2-vector per position over a surface)")\
                from None
        size = np.abs(d) if k == 1 else np.linalg.norm(d, axis=-1)
        ok = np.isfinite(size) & (size <= self.presliding * (1 + 1e-12))
        if not np.all(ok):
            bad = (d if k == 1 else size)[~ok].ravel()[0]
            raise fail("deflection", float(bad), f"a finite deflection of magnitude <= {self.presliding:g} m")
        return d

    def force(self, p, deflection=0.0) -> np.ndarray:
        """Force of F at positions p for a given presliding deflection (eq. 22).

        Parameters
        ----------
        p : array_like, shape (..., 2) or (..., 3)
            Probe positions [x, z] over a profile, [x, y, z] over a surface (m).
        deflection : float or array_like
            Presliding deflection d^x (m), |d^x| <= d^x_max: broadcastable to (...) over a
            profile, to (..., 2) over a surface (a scalar there means along x).

        Returns
        -------
        ndarray, shape (..., 2) or (..., 3)
            Force (N); zero outside the wall (p^z >= 0).

        Raises
        ------
        ParameterError
            If ``p`` is malformed or a deflection is outside the presliding range.
        """
        arr = self._positions(p)
        xt, z = arr[..., :-1], arr[..., -1]
        d = self._deflection(deflection, z.shape)
        f, _ = self._static(xt, z, d, None)
        return f

    def jacobian(self, p, deflection=0.0, phase: str = "stick") -> np.ndarray:
        """Jacobian of F (eq. 23) for a given deflection and friction phase.

        Parameters
        ----------
        p : array_like, shape (..., 2) or (..., 3)
            Probe positions (m).
        deflection : float or array_like
            Presliding deflection (m), as for :meth:`force`.
        phase : {"stick", "slip"}
            Over a profile dd^x/dp^x = 1 in stick and 0 in slip (eq. 24); over a surface
            dd/dp_t = I in stick and I - u u^T in slip, u = d / |d| (0 at d = 0).

        Returns
        -------
        ndarray, shape (..., 2, 2) or (..., 3, 3)
            With m = 1 - h~, z_c = min(|p^z|, d^z_max), D = dd/dp_t:
            J_tt = -mu kappa_0 z_c (m D - d grad h~^T) / d_max,
            J_tz = mu kappa_0 m d / d_max where |p^z| < d^z_max (else 0),
            J_zt = 0, J_zz = -kappa_0 (N/m).

        Raises
        ------
        ParameterError
            If ``phase`` is not "stick" or "slip", or another argument is malformed.
        """
        if phase not in ("stick", "slip"):
            raise fail("phase", phase, 'one of "stick", "slip"')
        arr = self._positions(p)
        xt, z = arr[..., :-1], arr[..., -1]
        d = self._deflection(deflection, z.shape)
        dv = d[..., None] if self.texture.dimension == 1 else d
        eye = np.broadcast_to(np.eye(dv.shape[-1]), dv.shape + (dv.shape[-1],))
        if phase == "stick":
            D = eye
        else:
            size = np.linalg.norm(dv, axis=-1)
            u = np.divide(dv, size[..., None], out=np.zeros_like(dv), where=size[..., None] > 0)
            D = np.where((size > 0)[..., None, None], eye - _outer(u, u), 0.0)
        _, j = self._static(xt, z, d, D)
        return j

    def _static(self, xt, z, d, D):
        """Force and (with D = dd/dp_t, shape (..., k, k)) Jacobian for deflections d
        ((...) over a profile, (..., 2) over a surface)."""
        k0, mu, dm = self.stiffness, self.friction, self.presliding
        dv = d[..., None] if self.texture.dimension == 1 else d
        inside = z < 0
        depth = np.where(inside, -z, 0.0)
        follows = np.ones_like(inside)
        if self.max_penetration is not None:
            follows = depth < self.max_penetration
            depth = np.minimum(depth, self.max_penetration)
        if D is None:
            hgt, grad = self.texture.height_at(xt), None
        else:
            hgt, grad, _ = self.texture._jet(xt, False)
        m = 1.0 - self._scale * hgt
        f, j = _zeros(xt, D is not None)
        f[..., :-1] = (-mu * k0 * depth * m / dm)[..., None] * dv
        f[..., -1] = np.where(inside, -k0 * z, 0.0)
        if j is not None:
            grad_mod = self._scale * grad  # grad h~ = -grad m
            j[..., :-1, :-1] = (-mu * k0 * depth / dm)[..., None, None] * (m[..., None, None] * D - _outer(dv, grad_mod))
            j[..., :-1, -1] = np.where(inside & follows, mu * k0 * m / dm, 0.0)[..., None] * dv
            j[..., -1, -1] = np.where(inside, -k0, 0.0)
        return f, j

    def _evaluate(self, xt, z, jacobian):
        d = np.zeros(z.shape + ((2,) if self.texture.dimension == 2 else ()))
        eye = np.broadcast_to(np.eye(xt.shape[-1]), z.shape + (xt.shape[-1],) * 2)
        return self._static(xt, z, d, eye if jacobian else None)

    # -- along a path ----------------------------------------------------------------------
    def path_work(self, pts: np.ndarray, rtol: float = 1e-10) -> float:
        """Work (J) along a polyline of shape (N, 2) (over a surface (N, 3): see
        :meth:`_path_work_plane`), stepping the friction state.

        Contact starts with zero deflection where the path enters the wall and the state
        is reset where it leaves. With the sharp model the deflection is piecewise
        affine along each segment, so each stick and slip piece is integrated by
        adaptive quadrature; the smooth variant is stepped on 4000 sub-steps a piece and
        integrated by the trapezoidal rule.

        Parameters
        ----------
        pts : array_like, shape (N, 2) or (N, 3)
            The polyline's vertices (m).
        rtol : float, optional
            Relative tolerance of the adaptive quadrature (sharp model).

        Returns
        -------
        float
            The work the field does on the probe along the path (J).
        """
        if self.texture.dimension == 2:
            return self._path_work_plane(pts)
        total = 0.0
        state = None  # None: out of contact
        for piece in self._contact_pieces(pts):
            if piece is None:
                state = None
                continue
            a, delta, u0, u1 = piece
            if state is None:
                state = self.initial_state(float(a[0] + u0 * delta[0]))
            work, state = self._piece_work(a, delta, u0, u1, state, rtol)
            total += work
        return total

    def _contact_pieces(self, pts: np.ndarray):
        """The smooth pieces of a polyline, in order: (a, delta, u0, u1) for the piece
        a + u delta, u in [u0, u1], inside the wall, None for a piece outside it (where the
        friction state resets). Segments are cut where they cross z = 0 or d^z_max."""
        for a, b in zip(pts[:-1], pts[1:]):
            delta = b - a
            if not np.any(delta):
                continue
            cuts = [0.0, *_breakpoints(self, a, b), 1.0]
            for u0, u1 in zip(cuts[:-1], cuts[1:]):
                if u1 <= u0:
                    continue
                if (a + 0.5 * (u0 + u1) * delta)[-1] >= 0.0:
                    yield None
                else:
                    yield a, delta, u0, u1

    def _path_work_plane(self, pts: np.ndarray, steps: int = 4000) -> float:
        """Work (J) along a polyline in space over a surface: each piece in contact
        (:meth:`_contact_pieces`) is cut into ``steps`` equal sub-steps, the deflection
        stepped by :func:`haptex.friction.step_plane` (exact for straight strokes from rest,
        first order in the sub-step otherwise) and the work summed by the trapezoidal rule."""
        from .friction import _step_plane

        table = None if self.stick_deflection is None else self._aux()
        total = 0.0
        d = None  # deflection; None out of contact
        for piece in self._contact_pieces(pts):
            if piece is None:
                d = None
                continue
            a, delta, u0, u1 = piece
            us = np.linspace(u0, u1, steps + 1)
            p = a + us[:, None] * delta
            ds = np.empty((us.size, 2))
            d = np.zeros(2) if d is None else d
            ds[0] = d
            for i in range(1, us.size):
                d = _step_plane(d, p[i, :-1] - p[i - 1, :-1], self.presliding, self.stick_deflection, table)
                ds[i] = d
            vals = self.force(p, ds) @ delta
            total += float(np.trapezoid(vals, us))
        return total

    def _piece_work(self, a, delta, u0, u1, state, rtol):
        from scipy import integrate

        def fz_work(u, d):
            return float(self.force((a + u * delta)[None, :], d)[0] @ delta)

        scale = self.stiffness * float(delta @ delta)
        if self.stick_deflection is not None or delta[0] == 0.0:
            if delta[0] == 0.0:
                d = state.deflection
                val = integrate.quad(lambda u: fz_work(u, d), u0, u1, epsabs=1e-15 * scale, epsrel=rtol, limit=200)[0]
                return val, state
            us = np.linspace(u0, u1, 4001)
            ds = np.empty_like(us)
            for i, u in enumerate(us):  # the state stepped in order; the forces at once below
                d, state = step(state, float(a[0] + u * delta[0])) if i else (state.deflection, state)
                ds[i] = d
            vals = self.force(a + us[:, None] * delta, ds) @ delta
            return float(np.trapezoid(vals, us)), state
        direction = 1.0 if delta[0] > 0 else -1.0
        dm = self.presliding
        w = state.adhesion
        # stick until x(u) - w reaches direction * d_max
        u_slip = (w + direction * dm - a[0]) / delta[0]
        pieces = []
        if u_slip > u0:
            pieces.append((u0, min(u1, u_slip), "stick"))
        if u_slip < u1:
            pieces.append((max(u0, u_slip), u1, "slip"))
        total = 0.0
        for p0, p1, kind in pieces:
            if kind == "stick":
                fn = lambda u: fz_work(u, a[0] + u * delta[0] - w)  # noqa: E731
            else:
                fn = lambda u: fz_work(u, direction * dm)  # noqa: E731
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", integrate.IntegrationWarning)
                total += integrate.quad(fn, p0, p1, epsabs=1e-15 * scale, epsrel=rtol, limit=200)[0]
        _, state = step(state, float(a[0] + u1 * delta[0]))
        return total, state



ALGORITHMS: dict[str, type[Algorithm]] = {
    "W": SmoothWall,
    "A": GroovedVertical,
    "B": GroovedNormal,
    "C": ChangeOfHeight,
    "D": GodObjectGradient,
    "E": GodObjectVertical,
    "F": FrictionModulated,
    "G": ForceShading,
}
"""Registry of algorithm classes by the paper's letter (Table I), in the paper's order: the one
place the letters are known (the CLI, design, tables, the atlas and export read it)."""

_CODES = {letter: getattr(_ext, f"ALG_{letter}") for letter in ALGORITHMS}
"""Each letter's code in the C core (``hx_core.h``, ``HX_ALG_*``)."""


def checked_algorithm(algorithm, *, proxy: bool = False):
    """``algorithm`` as given where it is one of haptex's algorithms, else a refusal that says
    what renders a texture: the first check of every public function that takes an algorithm.

    Parameters
    ----------
    algorithm : Algorithm or GodObject
        An :class:`Algorithm` (:func:`algorithm`, on the plane or an object); with ``proxy``, a
        :class:`haptex.proxy.GodObject` too.
    proxy : bool, optional
        Whether the caller also takes a god-object (the renderer, the simulator, the export).

    Returns
    -------
    Algorithm or GodObject
        ``algorithm`` itself.

    Raises
    ------
    ParameterError
        For anything else, naming it and the call that makes an algorithm of a texture
        (``haptex.algorithm('A', texture, 2000.0)``): a texture's force field, and with it eq. 5's
        q and every analysis of the paper, is an algorithm's (Table I), not the texture's.
    """
    if isinstance(algorithm, Algorithm) or (proxy and callable(getattr(algorithm, "kernel_spec", None))):
        return algorithm  # (a god-object by its tick's arrays: the proxy module imports this one)
    raise not_an_algorithm(algorithm, proxy)


def algorithm(letter: str, texture: Texture | None = None, stiffness: float = 2000.0, **params) -> Algorithm:
    """Build the force field of one of the paper's algorithms.

    Parameters
    ----------
    letter : str
        ``"W"`` (smooth wall, eq. 30) or one of ``"A"``–``"G"`` (Table I); case-insensitive.
    texture : Texture, optional
        Height profile h(x) or surface h(x, y) (m). Required for A–G; ``None`` (or
        ``Flat(dimension=2)`` for 3-D positions) for W. Over a surface every algorithm
        takes positions [x, y, z].
    stiffness : float
        Nominal stiffness kappa_0 > 0 (N/m); default 2000 N/m, the paper's Section V-A.
    **params
        Algorithm-specific parameters: ``max_penetration`` (d^z_max, m) for B, C, F and G
        (Remark 3); for F also ``friction`` (mu >= 0, default 0.8), ``presliding``
        (d^x_max > 0, m, default 1 mm), ``modulation_depth`` (in [0, 1], default 0.8) and
        ``stick_deflection`` (z_stick, m, smooth stick-to-slip variant; default None);
        for W ``damping`` (a virtual damper B, N s/m) and ``period`` (its servo period T, s).

    Returns
    -------
    Algorithm

    Raises
    ------
    ParameterError
        If the letter is unknown, a texture is missing (or given to W), a parameter is
        not accepted by that algorithm, or a value is out of range.

    Examples
    --------
    The paper's algorithm A over its sinusoid (A = 0.8 mm, l = 1 mm) at 2 kN/m, the probe
    0.2 mm below the nominal surface:

    >>> alg = hx.algorithm("A", hx.Sinusoid(0.8e-3, 1e-3), 2000.0)
    >>> alg.force([[0.0, -0.2e-3]])
    array([[0. , 0.4]])
    >>> alg.jacobian([[0.0, -0.2e-3]]).shape
    (1, 2, 2)
    """
    key = str(letter).strip().upper()
    if key not in ALGORITHMS:
        allowed = ", ".join(sorted(ALGORITHMS, key=lambda c: (c != "W", c)))
        raise fail("letter", letter, f"one of {allowed}")
    cls = ALGORITHMS[key]
    if cls.textured and texture is None:
        raise ParameterError(f"texture = None is not allowed for algorithm {key}: pass a Texture")
    if texture is not None:
        texture = checked_texture(texture)
    try:
        return cls(texture, stiffness, **params)
    except TypeError as exc:
        if "unexpected keyword" not in str(exc):
            raise
        bad = sorted(params)
        raise ParameterError(
            f"parameters {bad} are not allowed for algorithm {key} ({cls.name}); "
            f"{_accepted(key)}"
        ) from None


def _accepted(key: str) -> str:
    names = ALGORITHMS[key].parameters
    return f"it accepts {', '.join(names)}" if names else "it accepts no extra parameter"


def taking(name: str) -> list[str]:
    """The letters whose algorithm takes a keyword parameter, from the registry.

    Parameters
    ----------
    name : str
        A keyword parameter of :func:`algorithm`, e.g. ``"max_penetration"`` (d^z_max of
        Remark 3).

    Returns
    -------
    list of str
        The letters whose :attr:`Algorithm.parameters` hold ``name``, in the paper's order
        (Table I, W first); empty for a name no letter takes.
    """
    return [letter for letter, cls in ALGORITHMS.items() if name in cls.parameters]
