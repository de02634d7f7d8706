"""The energy a vibration supplies at a device's port, and the servo rate it needs."""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from .._validation import ParameterError, _fmt, fail, positive
from .models import ArmaModel
from ..catalogue import checked_device

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
        from .._validation import nonnegative

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
    device = checked_device(device)
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
