"""Passivity and what a device can render: the condition of Corollary 1 (eq. 1), the
largest passive stiffness and the rendering limits of Section II-B."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .._validation import ParameterError, fail, numbers, positive
from ..algorithms import Algorithm, checked_algorithm
from ..textures import Texture, checked_texture
from .characteristic import CharacteristicNumber, characteristic_number
from ..catalogue import checked_device


# ------------------------------------------------------------------------------------
# devices: the six texture-rendering limits and the passivity condition
# ------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Limit:
    """One inequality of Section II-B: ``lhs < rhs`` must hold.

    Parameters
    ----------
    name : str
    formula : str
        As evaluated (with the paper's printed form where it differs).
    lhs, rhs : float
        Both sides, in the units of ``unit``.
    unit : str
    passed : bool
    """

    name: str
    formula: str
    lhs: float
    rhs: float
    unit: str
    passed: bool


SAMPLES_PER_PERIOD = 5
"""alpha = beta = gamma of Section II-B, the samples a rendered period needs (the paper:
"typically 5 to 10"): chosen, the paper's lowest, the default wherever ``samples_per_period``
is taken (:func:`rendering_cutoff`, :func:`texture_limits`, :func:`haptex.design`,
:func:`haptex.rendered_texture`)."""


def texture_limits(texture: Texture, device, speed: float, stiffness: float,
                   samples_per_period=SAMPLES_PER_PERIOD) -> list[Limit]:
    """The six necessary conditions of Section II-B for rendering a texture on a device.

    With l the texture's shortest period, M its Lipschitz bound (Remark 2: 2 pi A / l for
    a sinusoid), A_F = kappa_0 max|h| the force amplitude the texture produces at
    stiffness kappa_0, and alpha = beta = gamma = ``samples_per_period``:

    1. scanning velocity       alpha v T / l < 1
    2. low-speed reconstruction beta delta / l < 1
    3. high-speed reconstruction alpha delta / l < 1 (as printed)
    4. force reconstruction    gamma b < A_F (printed "gamma b / l < A", whose sides
       have different units; the force amplitude must span gamma force quanta)
    5. gain                    kappa_0 M < K_max (printed 2 pi A / l < A_0 with A the
       force amplitude: the force gradient 2 pi A_F / l = kappa_0 M), with K_max the
       device's largest stiffness (its ``max_stiffness``, else sigma_0(B) / (2T))
    6. structural              v / l < F_0

    Limit 4 counts as met for a flat texture (A_F = 0: no force to reconstruct, on any device).
    Limits 1-3 and 6 bound the shortest period from below; they count as met at equality,
    so that a texture band-limited to exactly :func:`rendering_cutoff`'s l_c passes them
    (its filter has already attenuated l_c itself).

    Parameters
    ----------
    texture : Texture
    device : Device
    speed : float
        Scanning velocity v (m/s), > 0.
    stiffness : float
        kappa_0 (N/m) the texture is rendered with.
    samples_per_period : float or (float, float, float), optional
        alpha, beta, gamma ("typically 5 to 10"), default :data:`SAMPLES_PER_PERIOD` (5); each
        from 2 (Nyquist's) to 1e6 (chosen).

    Returns
    -------
    list of Limit
        In the paper's order.

    Raises
    ------
    ParameterError
        For a non-positive speed or stiffness, or a sample count not from 2 to 1e6 (or three
        such).
    """
    texture = checked_texture(texture)
    device = checked_device(device)
    v = positive("speed", speed, "m/s")
    k0 = positive("stiffness", stiffness, "N/m")
    alpha, beta, gamma = _samples_per_period(samples_per_period)
    ell = float(texture.shortest_period)
    M = float(texture.max_slope)
    force_amp = k0 * float(texture.peak_magnitude)
    b = device.force_resolution
    kmax = device.max_stiffness
    bound = _period_bounds(device, v, alpha, beta)
    out = [Limit(name, formula, bound[name] / ell, 1.0, "1", bound[name] / ell <= 1)
           for name, formula in PERIOD_LIMITS[:3]]
    out += [
        Limit("force reconstruction", "gamma b < A_F (printed: gamma b / l < A)", gamma * b, force_amp, "N",
              gamma * b < force_amp or force_amp == 0.0),  # (a flat texture: nothing to reconstruct)
        Limit("gain", "kappa_0 M < K_max (printed: 2 pi A / l < A_0)", k0 * M, kmax, "N/m", k0 * M < kmax),
        Limit("device structural", "v / l < F_0", v / ell, device.first_resonance, "Hz",
              v / ell <= device.first_resonance),
    ]
    return out


PERIOD_LIMITS = (("scanning velocity", "alpha v T / l < 1"), ("low-speed reconstruction", "beta delta / l < 1"),
                 ("high-speed reconstruction", "alpha delta / l < 1"), ("device structural", "v / l < F_0"))
"""The four limits of Section II-B that bound the texture's shortest period l from below."""


def _samples_per_period(samples_per_period) -> tuple[float, float, float]:
    allowed = ("a number of samples a period from 2 (Nyquist's) to 1e6, or three such (alpha, beta, gamma); the "
               "paper's are 5 to 10")
    spp = numbers("samples_per_period", samples_per_period, allowed)
    try:
        spp = np.broadcast_to(spp, (3,))
    except ValueError:  # (neither one nor three)
        raise fail("samples_per_period", samples_per_period, allowed) from None
    for name, val in zip(("alpha", "beta", "gamma"), spp):
        if not 2.0 <= val <= 1e6:  # (NaN too)
            raise fail(f"samples_per_period ({name})", float(val), allowed)
    return tuple(float(v_) for v_ in spp)


def _period_bounds(device, v: float, alpha: float, beta: float) -> dict[str, float]:
    """The shortest period (m) each of the four period limits allows: l > alpha v T,
    beta delta, alpha delta, v / F_0."""
    T, delta = device.period, device.position_resolution
    return {"scanning velocity": alpha * v * T, "low-speed reconstruction": beta * delta,
            "high-speed reconstruction": alpha * delta, "device structural": v / device.first_resonance}


@dataclass(frozen=True)
class Cutoff:
    """Result of :func:`rendering_cutoff`.

    Parameters
    ----------
    period : float
        l_c (m): the shortest period the device renders faithfully at the speed.
    set_by : tuple of str
        The limit(s) attaining l_c (their names as in :func:`texture_limits`).
    bounds : dict
        Each of the four period limits' bound on l (m).
    """

    period: float
    set_by: tuple[str, ...]
    bounds: dict

    @classmethod
    def from_bounds(cls, bounds: dict) -> Cutoff:
        """The cut-off of named bounds on the period: the largest, and the names attaining it.

        Parameters
        ----------
        bounds : dict of str to float
            Each limit's bound on the shortest rendered period (m), as in ``bounds``.

        Returns
        -------
        Cutoff
        """
        lc = max(bounds.values())
        return cls(lc, tuple(name for name, b in bounds.items() if b >= lc * (1 - 1e-12)), dict(bounds))


def rendering_cutoff(device, speed: float, samples_per_period=SAMPLES_PER_PERIOD) -> Cutoff:
    """The shortest texture period a device can render at a scanning speed: the largest of
    the bounds the four period limits of Section II-B (scanning velocity, low- and
    high-speed reconstruction, device structural) put on the shortest period l,

        l_c = max(alpha v T, beta delta, alpha delta, v / F_0).

    A texture band-limited to periods >= l_c passes those four limits (with equality at
    l_c); the force-reconstruction and gain limits depend on amplitude and stiffness and
    are checked on the band-limited texture by :func:`texture_limits`.

    Parameters
    ----------
    device : Device
        Its ``period`` T (s), ``position_resolution`` delta (m), ``first_resonance`` F_0 (Hz).
    speed : float
        Scanning velocity v (m/s), > 0.
    samples_per_period : float or (float, float, float), optional
        alpha, beta, gamma (default :data:`SAMPLES_PER_PERIOD`, 5).

    Returns
    -------
    Cutoff

    Raises
    ------
    ParameterError
        For a non-positive speed or sample count.
    """
    device = checked_device(device)
    v = positive("speed", speed, "m/s")
    alpha, beta, _ = _samples_per_period(samples_per_period)
    return Cutoff.from_bounds(_period_bounds(device, v, alpha, beta))


@dataclass(frozen=True)
class PassivityCondition:
    """Result of :func:`passivity_condition` (Corollary 1, eq. 1).

    Parameters
    ----------
    holds : bool
        sup ||J||_2 <= sigma_0(B) / (2T) over the rendering region.
    sup_jacobian_norm : float
        kappa_0 q (N/m); inf when q is unbounded.
    limit : float
        sigma_0(B) / (2T) (N/m).
    margin : float
        limit / sup_jacobian_norm (> 1 when the condition holds with room to spare).
    characteristic_number : CharacteristicNumber
    """

    holds: bool
    sup_jacobian_norm: float
    limit: float
    margin: float
    characteristic_number: CharacteristicNumber


def passivity_condition(algorithm: Algorithm, device, max_penetration: float = 1e-3, x_range=None) -> PassivityCondition:
    """Corollary 1: is ||J_f||_2 <= sigma_0(B) / (2T) everywhere in the rendering region?

    Parameters
    ----------
    algorithm : Algorithm
    device : Device
        Its inside damping matrix B and sampling period T are used; of the algorithm's
        dimension (a 3-DOF device, B 3x3, over a surface).
    max_penetration : float, optional
        Depth of the rendering region (m).
    x_range : (float, float), optional
        Abscissa range (m); the texture's domain by default.

    Returns
    -------
    PassivityCondition

    Notes
    -----
    A sufficient condition (eq. 1), derived from Theorem 1 of Miller, Colgate & Freeman
    [18]; the simulator shows how conservative it is for a given device.
    """
    algorithm = checked_algorithm(algorithm)
    device = checked_device(device)
    _same_dimension(algorithm, device)
    q = characteristic_number(algorithm, max_penetration=max_penetration, x_range=x_range)
    sup = algorithm.stiffness * q.value
    lim = device.passivity_limit
    margin = lim / sup if sup > 0 else math.inf
    return PassivityCondition(bool(sup <= lim), float(sup), float(lim), float(margin), q)


def max_passive_stiffness(algorithm: Algorithm, device, max_penetration: float = 1e-3, x_range=None) -> float:
    """Largest nominal stiffness kappa_0 (N/m) that satisfies Corollary 1: sigma_0(B) / (2 T q).

    q is computed numerically for the algorithm's texture (it does not depend on
    kappa_0); 0 when q is unbounded (algorithm D below peaks sharper than the region's
    depth: use ``characteristic_number(...).paper_form_value`` for eq. 18's 1).

    Parameters
    ----------
    algorithm : Algorithm
    device : Device
    max_penetration : float, optional
        Depth of the rendering region (m).
    x_range : (float, float), optional
        Abscissa range (m).

    Returns
    -------
    float
        sigma_0(B) / (2 T q) (N/m); 0 when q is unbounded.
    """
    algorithm = checked_algorithm(algorithm)
    device = checked_device(device)
    _same_dimension(algorithm, device)
    q = characteristic_number(algorithm, max_penetration=max_penetration, x_range=x_range).value
    return 0.0 if math.isinf(q) else float(device.passivity_limit / q)


def _same_dimension(algorithm: Algorithm, device) -> None:
    """Corollary 1 compares the field's n x n Jacobian with the device's n x n damping."""
    if device.dimension != algorithm.dimension:
        what = "a surface h(x, y) needs a 3-DOF device" if algorithm.dimension == 3 else "a profile needs a planar device"
        raise ParameterError(f"device = {device.name!r} with dimension = {device.dimension} is not allowed for "
                             f"{algorithm!r}: {what} (Device(..., dimension={algorithm.dimension}))")
