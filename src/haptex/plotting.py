"""Figures (matplotlib only here; computing modules never import matplotlib)."""

from __future__ import annotations

from pathlib import Path

import numpy as np


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def plot_simulation(result, path, title: str = "") -> Path:
    """Position, force and energy of a simulation, as in the paper's Figs. 5–7.

    Parameters
    ----------
    result : SimulationResult
        From :func:`haptex.simulate`.
    path : str or Path
        PNG file to write.
    title : str, optional
        Figure title.

    Returns
    -------
    Path
        The file written.
    """
    plt = _pyplot()
    fig, axes = plt.subplots(3, 1, figsize=(8, 8), sharex=True)
    t = result.time
    axes[0].plot(t, result.position[:, 0] * 1e3, label="x")
    axes[0].plot(t, result.position[:, 1] * 1e3, label="z")
    axes[0].set_ylabel("position (mm)")
    axes[0].legend(loc="upper right")
    axes[1].plot(t, result.force[:, 0], label="f_x")
    axes[1].plot(t, result.force[:, 1], label="f_z")
    axes[1].set_ylabel("force command (N)")
    axes[1].legend(loc="upper right")
    axes[2].plot(t, result.energy_x * 1e3, label="E_x = -Σ f_x Δx")
    axes[2].plot(t, result.energy_z * 1e3, label="E_z = -Σ f_z Δz")
    axes[2].set_ylabel("energy absorbed (mJ)")
    axes[2].set_xlabel("time (s)")
    axes[2].legend(loc="lower left")
    for ax in axes:
        ax.grid(True, alpha=0.3)
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    out = Path(path)
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return out


def finite_or_nan(values) -> np.ndarray:
    """Array of floats with non-finite entries as NaN (for plotting)."""
    arr = np.asarray(values, dtype=np.float64)
    return np.where(np.isfinite(arr), arr, np.nan)
