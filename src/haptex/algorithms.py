"""The smooth wall W and the texture algorithms A–G of Campion & Hayward as force fields.

Every algorithm is an object with a vectorised ``force(p)`` (N) and ``jacobian(p)`` (N/m)
over probe positions ``p = [x, z]`` (m) of shape (..., 2), built with
:func:`algorithm`. Forces push the probe out of the wall. z < 0 is below the nominal
surface. Sign convention for the paper's penetration: d < 0 inside (Table I); the
:meth:`Algorithm.penetration` method returns the *depth* -d >= 0 instead.

Algorithm F (friction with memory) lives in :mod:`haptex.friction` and is added to the
same registry when it exists.
"""

from __future__ import annotations

import numpy as np

from ._validation import ParameterError, fail, optional_positive, positions, positive
from .closest import closest_point
from .textures import Flat, Texture

__all__ = ["Algorithm", "algorithm", "ALGORITHMS"]


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
    """

    letter: str = "?"
    name: str = ""
    penetration_kind: str = "vertical"
    is_gradient: bool = False
    has_memory: bool = False
    reference: str = ""

    def __init__(self, texture: Texture, stiffness: float, max_penetration: float | None = None):
        self.texture = texture
        self.stiffness = positive("stiffness", stiffness, "N/m")
        self.max_penetration = optional_positive("max_penetration", max_penetration, "m")

    def __repr__(self) -> str:
        extra = "" if self.max_penetration is None else f", max_penetration={self.max_penetration:g}"
        return f"algorithm({self.letter!r}, {self.texture!r}, stiffness={self.stiffness:g}{extra})"

    # -- public vectorised API ----------------------------------------------------------
    def force(self, p) -> np.ndarray:
        """Force f(p) that the algorithm commands.

        Parameters
        ----------
        p : array_like, shape (..., 2)
            Probe positions [x, z] (m).

        Returns
        -------
        ndarray, shape (..., 2)
            Force [f_x, f_z] (N); zero outside the wall.

        Raises
        ------
        ParameterError
            If ``p`` has the wrong shape or a non-finite coordinate.
        """
        arr = positions(p)
        f, _ = self._evaluate(arr[..., 0], arr[..., 1], jacobian=False)
        return f

    def jacobian(self, p) -> np.ndarray:
        """Analytic Jacobian J = df/dp.

        Parameters
        ----------
        p : array_like, shape (..., 2)
            Probe positions [x, z] (m).

        Returns
        -------
        ndarray, shape (..., 2, 2)
            ``J[..., i, j] = d f_i / d p_j`` (N/m) with index 0 = x and 1 = z; zero
            outside the wall.

        Raises
        ------
        ParameterError
            If ``p`` has the wrong shape or a non-finite coordinate.
        """
        arr = positions(p)
        _, j = self._evaluate(arr[..., 0], arr[..., 1], jacobian=True)
        return j

    def force_and_jacobian(self, p) -> tuple[np.ndarray, np.ndarray]:
        """Both :meth:`force` (shape (..., 2), N) and :meth:`jacobian` (shape (..., 2, 2), N/m)."""
        arr = positions(p)
        return self._evaluate(arr[..., 0], arr[..., 1], jacobian=True)

    def penetration(self, p) -> np.ndarray:
        """Penetration depth as this algorithm measures it (m), >= 0, shape (...).

        ``h(p^x) - p^z`` for A, B, C; the distance to the textured surface for D, E;
        ``-p^z`` for W, F, G (Table I); 0 outside the wall.

        Raises
        ------
        ParameterError
            If ``p`` has the wrong shape or a non-finite coordinate.
        """
        arr = positions(p)
        x, z = arr[..., 0], arr[..., 1]
        if self.penetration_kind == "nominal":
            return np.maximum(-z, 0.0)
        if self.penetration_kind == "vertical":
            return np.maximum(self.texture.height(x) - z, 0.0)
        return closest_point(self.texture, arr).distance

    def inside(self, p) -> np.ndarray:
        """True where the probe is inside the wall (penetration > 0), shape (...)."""
        return self.penetration(p) > 0

    def potential(self, p) -> np.ndarray:
        """Stored elastic energy V(p) >= 0 (J) with f = -grad V, where the field is a gradient.

        The paper writes the potential with the opposite sign, U = -V (eqs. 13, 16), so
        that f = grad U.

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


def _zeros(x, jacobian):
    f = np.zeros(x.shape + (2,))
    j = np.zeros(x.shape + (2, 2)) if jacobian else None
    return f, j


class SmoothWall(Algorithm):
    """W — the smooth virtual wall, eq. 30: f = [0, -kappa_0 p^z] for p^z < 0.

    Its Jacobian is diag(0, -kappa_0), so its characteristic number is 1.
    """

    letter = "W"
    name = "smooth wall"
    penetration_kind = "nominal"
    is_gradient = True
    reference = "eq. 30"

    def __init__(self, texture: Texture | None, stiffness: float):
        if texture is not None and not isinstance(texture, Flat):
            raise ParameterError(
                f"texture = {texture!r} is not allowed for algorithm W: the smooth wall has no texture (pass None)"
            )
        super().__init__(Flat(), stiffness)

    def _evaluate(self, x, z, jacobian):
        k = self.stiffness
        f, j = _zeros(x, jacobian)
        inside = z < 0
        f[..., 1] = np.where(inside, -k * z, 0.0)
        if jacobian:
            j[..., 1, 1] = np.where(inside, -k, 0.0)
        return f, j

    def potential(self, p):
        """Stored energy V = kappa_0 (p^z)^2 / 2 inside, 0 outside (J), shape (...)."""
        z = positions(p)[..., 1]
        return np.where(z < 0, 0.5 * self.stiffness * z**2, 0.0)


class _Vertical(Algorithm):
    """Shared evaluation for A, B, C: d = p^z - h(p^x) (Table I)."""

    penetration_kind = "vertical"

    def _evaluate(self, x, z, jacobian):
        h = self.texture.height(x)
        s = self.texture.slope(x)
        c = self.texture.curvature(x) if jacobian else None
        d = z - h
        inside = d < 0
        f, j = _zeros(x, jacobian)
        self._fill(np.where(inside, d, 0.0), s, c, f, j)
        f[~inside] = 0.0
        if jacobian:
            j[~inside] = 0.0
        return f, j


class GroovedVertical(_Vertical):
    """A — grooved boundary, force normal to the nominal surface (Choi & Tan [19]).

    Eq. 6: f = [0, -kappa_0 d^z] with d^z = p^z - h(p^x) < 0 inside. Jacobian eq. 7:
    -kappa_0 [[0, 0], [-h', 1]].
    """

    letter = "A"
    name = "grooved boundary, force normal to surface"
    reference = "eq. 6, 7; Choi & Tan (2004) [19]"

    def __init__(self, texture, stiffness):
        super().__init__(texture, stiffness)

    def _fill(self, d, s, c, f, j):
        k = self.stiffness
        f[..., 1] = -k * d
        if j is not None:
            j[..., 1, 0] = k * s
            j[..., 1, 1] = -k


class GroovedNormal(_Vertical):
    """B — grooved boundary, force normal to the groove (Choi & Tan [19]).

    Eq. 11: f = -kappa_0 d^z n(p^x), n = [-h', 1] / sqrt(1 + h'^2). The Jacobian is
    derived here by the chain rule (the paper gives none): with s = h', c = h'',
    g = (1 + s^2)^(-1/2),

        J = kappa_0 [[-s^2 g + d c g^3,  s g], [s g + d s c g^3,  -g]].

    With ``max_penetration`` the lateral component uses max(d, -d_max^z) (Remark 3).
    """

    letter = "B"
    name = "grooved boundary, force normal to groove"
    reference = "eq. 11, 12; Choi & Tan (2004) [19]"

    def _fill(self, d, s, c, f, j):
        k = self.stiffness
        g = 1.0 / np.sqrt(1.0 + s * s)
        dl, follows = self._clamped(d)
        f[..., 0] = k * dl * s * g
        f[..., 1] = -k * d * g
        if j is not None:
            g3 = g**3
            j[..., 0, 0] = k * (np.where(follows, -s * s * g, 0.0) + dl * c * g3)
            j[..., 0, 1] = k * np.where(follows, s * g, 0.0)
            j[..., 1, 0] = k * (s * g + d * s * c * g3)
            j[..., 1, 1] = -k * g


class ChangeOfHeight(_Vertical):
    """C — change of height (Minsky [16], Robles-De-La-Torre & Hayward [11]).

    Eq. 14: f = -kappa_0 [-d^z h', d^z], the gradient of U_C = -kappa_0 (d^z)^2 / 2
    (eq. 13). Jacobian eq. 15: -kappa_0 [[h'^2 - d^z h'', -h'], [-h', 1]].

    With ``max_penetration`` the lateral component uses max(d, -d_max^z) (Remark 3); the
    field is then no longer a gradient below that depth.
    """

    letter = "C"
    name = "change of height"
    reference = "eq. 13–15; Minsky (1995) [16]"

    @property
    def is_gradient(self) -> bool:  # type: ignore[override]
        return self.max_penetration is None

    def _fill(self, d, s, c, f, j):
        k = self.stiffness
        dl, follows = self._clamped(d)
        f[..., 0] = k * dl * s
        f[..., 1] = -k * d
        if j is not None:
            j[..., 0, 0] = k * (np.where(follows, -s * s, 0.0) + dl * c)
            j[..., 0, 1] = k * np.where(follows, s, 0.0)
            j[..., 1, 0] = k * s
            j[..., 1, 1] = -k

    def potential(self, p):
        """Stored energy V = kappa_0 (d^z)^2 / 2 inside, 0 outside (J), shape (...).

        Raises
        ------
        TypeError
            If ``max_penetration`` is set (the clamped field is not a gradient).
        """
        if not self.is_gradient:
            return super().potential(p)
        arr = positions(p)
        d = arr[..., 1] - self.texture.height(arr[..., 0])
        return np.where(d < 0, 0.5 * self.stiffness * d**2, 0.0)


class _Distance(Algorithm):
    """Shared evaluation for D and E: the closest point p_h on z = h(x)."""

    penetration_kind = "distance"

    def _evaluate(self, x, z, jacobian):
        f, j = _zeros(x, jacobian)
        h = self.texture.height(x)
        inside = z < h
        if not np.any(inside):
            return f, j
        px, pz = x[inside], z[inside]
        cp = closest_point(self.texture, np.stack([px, pz], axis=-1))
        fi, ji = self._inside(px, pz, cp.x, cp.z, cp.distance, jacobian)
        f[inside] = fi
        if jacobian:
            j[inside] = ji
        return f, j


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
    """

    letter = "D"
    name = "god-object, variant 1 (gradient of the minimum distance)"
    is_gradient = True
    reference = "eq. 16–18, 32–44; Zilles & Salisbury (1995) [28]"

    def __init__(self, texture, stiffness):
        super().__init__(texture, stiffness)

    def jacobian(self, p, form: str = "exact") -> np.ndarray:
        """Jacobian of D (N/m), shape (..., 2, 2).

        Parameters
        ----------
        p : array_like, shape (..., 2)
            Probe positions [x, z] (m).
        form : {"exact", "paper"}
            ``"exact"``: the derivative of -kappa_0 (p - p_h) including the boundary's
            curvature. ``"paper"``: eq. 18 (flat-boundary linearisation, ||J|| = kappa_0).

        Raises
        ------
        ParameterError
            If ``form`` is not one of the two, or ``p`` is malformed.
        """
        if form == "exact":
            return super().jacobian(p)
        if form != "paper":
            raise fail("form", form, 'one of "exact", "paper"')
        arr = positions(p)
        x, z = arr[..., 0], arr[..., 1]
        j = np.zeros(x.shape + (2, 2))
        inside = z < self.texture.height(x)
        if np.any(inside):
            cp = closest_point(self.texture, arr[inside])
            s = self.texture.slope(cp.x)
            k = -self.stiffness / (1 + s * s)
            j[inside] = k[:, None, None] * np.stack(
                [np.stack([s * s, -s], -1), np.stack([-s, np.ones_like(s)], -1)], -2
            )
        return j

    def _inside(self, px, pz, tx, tz, dist, jacobian):
        k = self.stiffness
        f = -k * np.stack([px - tx, pz - tz], axis=-1)
        if not jacobian:
            return f, None
        s = self.texture.slope(tx)
        c = self.texture.curvature(tx)
        den = 1.0 + s * s + (tz - pz) * c
        with np.errstate(divide="ignore", invalid="ignore"):
            inv = 1.0 / den
        j = np.empty(px.shape + (2, 2))
        j[:, 0, 0] = -k * (1.0 - inv)
        j[:, 0, 1] = k * s * inv
        j[:, 1, 0] = k * s * inv
        j[:, 1, 1] = -k * (1.0 - s * s * inv)
        return f, j

    def potential(self, p):
        """Stored energy V = kappa_0 (d^min)^2 / 2 inside, 0 outside (J), shape (...)."""
        d = self.penetration(p)
        return 0.5 * self.stiffness * d**2


class GodObjectVertical(_Distance):
    """E — variant 2 of the god-object method: force normal to the nominal surface.

    Eq. 19 prints f = [0, -kappa_0 d^min]; since d^min is a distance (>= 0) that sign
    would pull the probe into the wall. We use the physical sign, f = [0, +kappa_0 d^min]
    inside, and accordingly the Jacobian is the negative of the printed eq. 20:

        J = (kappa_0 / d^min) [[0, 0], [p^x - p_h^x, p^z - p_h^z]],

    whose 2-norm is kappa_0 wherever the closest point is unique (eq. 21).
    """

    letter = "E"
    name = "god-object, variant 2 (force normal to nominal surface)"
    reference = "eq. 19–21 (sign corrected); after Zilles & Salisbury (1995) [28]"

    def __init__(self, texture, stiffness):
        super().__init__(texture, stiffness)

    def _inside(self, px, pz, tx, tz, dist, jacobian):
        k = self.stiffness
        f = np.zeros(px.shape + (2,))
        f[:, 1] = k * dist
        if not jacobian:
            return f, None
        j = np.zeros(px.shape + (2, 2))
        safe = dist > 0
        j[safe, 1, 0] = k * (px - tx)[safe] / dist[safe]
        j[safe, 1, 1] = k * (pz - tz)[safe] / dist[safe]
        return f, j


class ForceShading(Algorithm):
    """G — force shading (Morgenbesser & Srinivasan [29]) on a flat wall.

    Eq. 28: f = -kappa_0 p^z n(p^x), n = [-h', 1] / sqrt(1 + h'^2), for p^z < 0.
    Jacobian by the chain rule (the paper gives none): with s = h', c = h'',
    g = (1 + s^2)^(-1/2),

        J = kappa_0 [[p^z c g^3,  s g], [p^z s c g^3,  -g]].

    With ``max_penetration`` the lateral component uses max(p^z, -d_max^z) (Remark 3).
    """

    letter = "G"
    name = "force shading"
    penetration_kind = "nominal"
    reference = "eq. 28, 29; Morgenbesser & Srinivasan (1996) [29]"

    def _evaluate(self, x, z, jacobian):
        k = self.stiffness
        s = self.texture.slope(x)
        g = 1.0 / np.sqrt(1.0 + s * s)
        inside = z < 0
        d = np.where(inside, z, 0.0)
        dl, follows = self._clamped(d)
        f, j = _zeros(x, jacobian)
        f[..., 0] = k * dl * s * g
        f[..., 1] = -k * d * g
        if jacobian:
            c = self.texture.curvature(x)
            g3 = g**3
            j[..., 0, 0] = k * dl * c * g3
            j[..., 0, 1] = k * np.where(follows, s * g, 0.0)
            j[..., 1, 0] = k * d * s * c * g3
            j[..., 1, 1] = -k * g
            j[~inside] = 0.0
        return f, j


ALGORITHMS: dict[str, type[Algorithm]] = {
    "W": SmoothWall,
    "A": GroovedVertical,
    "B": GroovedNormal,
    "C": ChangeOfHeight,
    "D": GodObjectGradient,
    "E": GodObjectVertical,
    "G": ForceShading,
}
"""Registry of algorithm classes by the paper's letter (Table I)."""


def algorithm(letter: str, texture: Texture | None = None, stiffness: float = 2000.0, **params) -> Algorithm:
    """Build the force field of one of the paper's algorithms.

    Parameters
    ----------
    letter : str
        ``"W"`` (smooth wall, eq. 30) or one of ``"A"``–``"G"`` (Table I); case-insensitive.
    texture : Texture, optional
        Height profile h (m). Required for A–G; must be ``None`` for W.
    stiffness : float
        Nominal stiffness kappa_0 > 0 (N/m); default 2000 N/m, the paper's Section V-A.
    **params
        Algorithm-specific parameters: ``max_penetration`` (d^z_max, m) for B, C and G
        (Remark 3); F's friction parameters (see :mod:`haptex.friction`).

    Returns
    -------
    Algorithm

    Raises
    ------
    ParameterError
        If the letter is unknown, a texture is missing (or given to W), a parameter is
        not accepted by that algorithm, or a value is out of range.
    """
    key = str(letter).strip().upper()
    if key not in ALGORITHMS:
        allowed = ", ".join(sorted(ALGORITHMS, key=lambda c: (c != "W", c)))
        raise fail("letter", letter, f"one of {allowed}")
    cls = ALGORITHMS[key]
    if key != "W" and texture is None:
        raise ParameterError(f"texture = None is not allowed for algorithm {key}: pass a Texture")
    if texture is not None and not isinstance(texture, Texture):
        raise fail("texture", texture, "a haptex Texture (e.g. haptex.Sinusoid(0.8e-3, 1e-3))")
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
    if key in ("B", "C", "G"):
        return "it accepts max_penetration"
    if key == "F":
        return "see haptex.friction"
    return "it accepts no extra parameter"
