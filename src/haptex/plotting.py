"""Figures (matplotlib only here; computing modules never import matplotlib)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ._validation import a_path


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _finish(plt, fig, path, title: str = "", dpi: int = 200, title_size=None) -> Path:
    """Title, lay out, write the figure and free it; returns the path written. A PNG path
    also gets its vector twin (same name, .svg) beside it."""
    if title:
        fig.suptitle(title.replace("kappa_0", "\u03ba\u2080"), fontsize=title_size)
    fig.tight_layout()
    out = a_path("path", path, "an image file's path")
    fig.savefig(out, dpi=dpi)
    if out.suffix.lower() == ".png":
        fig.savefig(out.with_suffix(".svg"))
    plt.close(fig)
    return out


def plot_simulation(result, path, title: str = "") -> Path:
    """Position, force and energy per axis of a simulation (2-D or 3-D), as in the paper's
    Figs. 5–7.

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
    axes_names = "xz" if result.dimension == 2 else "xyz"
    for i, a in enumerate(axes_names):
        axes[0].plot(t, result.position[:, i] * 1e3, label=a)
    axes[0].set_ylabel("position (mm)")
    axes[0].legend(loc="upper right")
    for i, a in enumerate(axes_names):
        axes[1].plot(t, result.force[:, i], label=f"f_{a}")
    axes[1].set_ylabel("force command (N)")
    axes[1].legend(loc="upper right")
    for i, a in enumerate(axes_names):
        axes[2].plot(t, result.energy_per_axis[:, i] * 1e3, label=f"E_{a} = -Σ f_{a} Δ{a}")
    axes[2].set_ylabel("energy absorbed (mJ)")
    axes[2].set_xlabel("time (s)")
    axes[2].legend(loc="lower left")
    for ax in axes:
        ax.grid(True, alpha=0.3)
    return _finish(plt, fig, path, title)


def plot_force_field(alg, path, n: int = 23, max_penetration: float = 1e-3, vmax: float | None = None,
                     x_range=None) -> Path:
    """Force field of one algorithm over one texture period, in the spirit of Fig. 2.

    Arrows show the force direction (length scaled by magnitude^0.5 for legibility),
    colour its magnitude (N); the solid line is the textured surface z = h(x), the grey
    line the nominal surface z = 0. For F the field is shown in full slip to the right
    (d^x = +d^x_max).

    Parameters
    ----------
    alg : Algorithm
    path : str or Path
        PNG file to write.
    n : int
        Arrows per axis.
    max_penetration : float
        Depth shown below the lowest valley (m).
    vmax : float, optional
        Top of the colour scale (N), shared by panels that are compared; larger forces
        take the top colour (the colour bar says so). Default: this panel's largest force.
    x_range : (float, float), optional
        Abscissa window (m); default one texture period from 0 (1 mm for an aperiodic
        texture).

    Returns
    -------
    pathlib.Path
        The figure written.
    """
    from .analysis import field_map

    plt = _pyplot()
    tex = alg.texture
    m = field_map(alg, x_range, n=n, max_penetration=max_penetration)
    x0, x1 = m.x[0], m.x[-1]
    X, Z = np.meshgrid(m.x, m.z)
    F = m.force
    mag = np.hypot(F[..., 0], F[..., 1])
    scale = np.where(mag > 0, np.sqrt(mag / max(mag.max(), 1e-300)) / np.maximum(mag, 1e-300), 0.0)
    fig, ax = plt.subplots(figsize=(5.2, 4.2))
    q = ax.quiver(X * 1e3, Z * 1e3, F[..., 0] * scale, F[..., 1] * scale, mag, cmap="viridis", angles="xy",
                  pivot="tail", width=0.004)
    _surface(ax, tex, x0, x1)
    ax.set_title(f"{alg.letter}: {alg.name}", fontsize=9)
    top = float(mag.max()) if vmax is None else float(vmax)
    q.set_clim(0.0, top)
    fig.colorbar(q, ax=ax, label="|f| (N)", extend="max" if mag.max() > top else "neither")
    ax.legend(loc="lower right", fontsize=7)
    return _finish(plt, fig, path)


def _surface(ax, tex, x0, x1) -> None:
    """The textured surface (black) and the nominal surface z = 0 (grey), axes in mm."""
    xs = np.linspace(x0, x1, 800)
    ax.plot(xs * 1e3, tex.height(xs) * 1e3, "k-", lw=1.5, label="textured surface")
    ax.axhline(0.0, color="0.6", lw=2, zorder=0, label="nominal surface")
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("z (mm)")


def plot_q_map(alg, path, q, max_penetration: float = 1e-3, x_range=None, n: int = 121) -> Path:
    """Map of ||J(p)||_2 / kappa_0 over the rendering region (penetration in (0, d_max],
    as the algorithm measures it), with the sup q marked.

    Parameters
    ----------
    alg : Algorithm
        A memoryless algorithm (F's map depends on its presliding state and is not drawn).
    path : str or Path
        PNG file to write (and its SVG twin).
    q : CharacteristicNumber
        From :func:`haptex.characteristic_number` on the same region; its location is
        marked and its value printed.
    max_penetration : float
        Depth of the region below the lowest valley (m).
    x_range : (float, float), optional
        Abscissa window (m), as in :func:`plot_force_field`.
    n : int
        Grid points per axis.

    Returns
    -------
    pathlib.Path
        The figure written.
    """
    from .analysis import field_map

    plt = _pyplot()
    tex = alg.texture
    lo, hi = tex.height_range
    m = field_map(alg, x_range, (lo - max_penetration, max(hi, 0.0)), n=n, max_penetration=max_penetration)
    x0, x1 = m.x[0], m.x[-1]
    X, Z = np.meshgrid(m.x, m.z)
    norm = m.gain  # NaN outside the region q is the sup over
    fig, ax = plt.subplots(figsize=(5.2, 4.2))
    finite = norm[np.isfinite(norm)]
    top = float(np.percentile(finite, 99.5)) if finite.size else 1.0
    mesh = ax.pcolormesh(X * 1e3, Z * 1e3, norm, cmap="magma", shading="auto", vmin=0.0, vmax=max(top, 1.0))
    fig.colorbar(mesh, ax=ax, label="\u2016J\u2016\u2082 / \u03ba\u2080", extend="max")
    _surface(ax, tex, x0, x1)
    label = "q unbounded" if q.unbounded else f"q = {q.value:.4g}"
    ax.plot(q.where[0] * 1e3, q.where[1] * 1e3, "c*", ms=12, mec="k", label=label)
    ax.set_title(f"{alg.letter}: {alg.name}, {label}", fontsize=9)
    ax.legend(loc="lower right", fontsize=7)
    return _finish(plt, fig, path)


def plot_loop_energies(rows, path) -> Path:
    """Bar chart of Fig. 3 loop energies: computed by quadrature beside the closed forms.

    Parameters
    ----------
    rows : list of dict
        Table II rows (``algorithm``, ``loop_energy``, ``loop_energy_closed_form``).
    path : str or Path

    Returns
    -------
    pathlib.Path
        The figure written.
    """
    plt = _pyplot()
    letters = [r["algorithm"] for r in rows]
    ours = [r["loop_energy"] * 1e3 for r in rows]
    closed = [np.nan if r["loop_energy_closed_form"] is None else r["loop_energy_closed_form"] * 1e3 for r in rows]
    xs = np.arange(len(letters))
    fig, ax = plt.subplots(figsize=(7, 3.6))
    ax.bar(xs - 0.2, ours, 0.4, label="haptex (quadrature)")
    ax.bar(xs + 0.2, closed, 0.4, label="closed form (eqs. 10, 12, 27, 29)")
    ax.set_xticks(xs, letters)
    ax.set_ylabel("loop energy ΔE (mJ)")
    ax.axhline(0, color="k", lw=0.8)
    ax.legend(fontsize=8)
    ax.grid(True, axis="y", alpha=0.3)
    return _finish(plt, fig, path)


def plot_runs(runs, path, quantity: str = "position", title: str = "") -> Path:
    """Time series of several runs, one panel each (Figs. 5, 6, 7).

    Parameters
    ----------
    runs : list of Run
        From :mod:`haptex.experiments`.
    path : str or Path
    quantity : {"position", "energy"}
        ``"position"``: p^z (mm) over time with E_x + E_z on a second axis;
        ``"energy"``: E_x and E_z (mJ) over time.
    title : str

    Returns
    -------
    pathlib.Path
        The figure written.
    """
    plt = _pyplot()
    fig, axes = plt.subplots(len(runs), 1, figsize=(7.5, 1.9 * len(runs) + 0.6), sharex=False, squeeze=False)
    for ax, run in zip(axes[:, 0], runs):
        r = run.result
        if quantity == "position":
            ax.plot(r.time, r.position[:, 1] * 1e3, lw=0.8, color="C0")
            ax.set_ylabel("z (mm)", color="C0")
            ax2 = ax.twinx()
            ax2.plot(r.time, (r.energy_x + r.energy_z) * 1e3, lw=0.8, color="C3")
            ax2.set_ylabel("E (mJ)", color="C3")
        else:
            ax.plot(r.time, r.energy_x * 1e3, lw=1.0, label="E_x")
            ax.plot(r.time, r.energy_z * 1e3, lw=1.0, label="E_z")
            ax.set_ylabel("energy (mJ)")
            ax.axhline(0, color="k", lw=0.5)
            ax.legend(loc="lower left", fontsize=7)
        osc = (" — oscillating" if r.oscillating else " — no limit cycle") if quantity == "position" else ""
        ax.set_title(f"{run.label}{osc}", fontsize=9)
        ax.grid(True, alpha=0.3)
    axes[-1, 0].set_xlabel("time (s)")
    return _finish(plt, fig, path, title, title_size=10)


def plot_trajectories(runs, surface_x, surface_h, path, title: str = "", setpoint=None) -> Path:
    """Handle trajectories over a textured surface (Fig. 7's enlarged bump), drawn to scale.

    Parameters
    ----------
    runs : list of Run
    surface_x, surface_h : ndarray
        The surface profile to draw (m).
    path : str or Path
    title : str
    setpoint : ndarray, shape (n, 2), optional
        The hand's set-point path (m), drawn dashed.

    Returns
    -------
    pathlib.Path
        The figure written.
    """
    plt = _pyplot()
    fig, axes = plt.subplots(len(runs), 2, figsize=(10, 2.2 * len(runs) + 0.6), squeeze=False)
    for (ax, ax2), run in zip(axes, runs):
        r = run.result
        ax.plot(surface_x * 1e3, surface_h * 1e3, "k-", lw=1.2, label="surface")
        if setpoint is not None:
            ax.plot(setpoint[:, 0] * 1e3, setpoint[:, 1] * 1e3, "--", color="0.5", lw=0.8, label="hand set-point")
        ax.plot(r.position[:, 0] * 1e3, r.position[:, 1] * 1e3, lw=0.7, label="handle")
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_ylabel("z (mm)")
        ax.set_title(f"{run.label}: trajectory", fontsize=9)
        ax2.plot(r.time, (r.energy_x + r.energy_z) * 1e3, lw=0.8, color="C3")
        ax2.set_ylabel("E_x + E_z (mJ)")
        ax2.set_title(f"{run.label}: energy absorbed by the environment", fontsize=9)
        for a in (ax, ax2):
            a.grid(True, alpha=0.3)
    axes[-1, 0].set_xlabel("x (mm)")
    axes[-1, 1].set_xlabel("time (s)")
    axes[0, 0].legend(fontsize=7, loc="lower left")
    return _finish(plt, fig, path, title, title_size=10)


ROBUSTNESS_CLASSES = ("none oscillates", "A only", "F only", "A and F (the paper)", "W oscillates")


def plot_robustness(robustness: dict, path) -> Path:
    """Fig. 5's outcome over working points x delays x band angles, one cell each.

    Parameters
    ----------
    robustness : dict
        ``passivity(...)["robustness"]`` of :mod:`haptex.experiments`.
    path : str or Path
        PNG file to write.

    Returns
    -------
    pathlib.Path
        The figure written.
    """
    plt = _pyplot()
    from matplotlib.colors import ListedColormap

    cases = robustness["cases"]
    points = sorted({tuple(c["working_point"]) for c in cases})
    conds = sorted({(c["delay"], c["band_angle_deg"]) for c in cases})
    grid = np.full((len(points), len(conds)), np.nan)
    for c in cases:
        r = c["runs"]
        w, a, f = (r[L]["oscillating"] for L in "WAF")
        cls = 4 if w else (3 if a and f else (1 if a else (2 if f else 0)))
        grid[points.index(tuple(c["working_point"])), conds.index((c["delay"], c["band_angle_deg"]))] = cls
    fig, ax = plt.subplots(figsize=(8, 0.35 * len(points) + 2))
    cmap = ListedColormap(["#e8e8e8", "#fdae61", "#abd9e9", "#1a9641", "#d7191c"])
    ax.imshow(grid, cmap=cmap, vmin=-0.5, vmax=4.5, aspect="auto")
    ax.set_xticks(range(len(conds)), [f"{d} / {g:g}" for d, g in conds], rotation=45)
    ax.set_yticks(range(len(points)), [f"({x * 1e3:g}, {z * 1e3:g})" for x, z in points])
    ax.set_xlabel("delay (samples) / band angle (degrees)")
    ax.set_ylabel("handle working point (mm)")
    handles = [plt.Rectangle((0, 0), 1, 1, color=cmap(i)) for i in range(5)]
    ax.legend(handles, ROBUSTNESS_CLASSES, loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8)
    return _finish(plt, fig, path, "Fig. 5 at kappa_0 = 2 kN/m: which algorithms oscillate")


def plot_speed_sweep(sweep: list, path) -> Path:
    """Fig. 6's energies per texture period against scanning speed, relative to A's |E_z|.

    Parameters
    ----------
    sweep : list of dict
        ``conservativity(...)["speed_sweep"]`` of :mod:`haptex.experiments`.
    path : str or Path
        PNG file to write.

    Returns
    -------
    pathlib.Path
        The figure written.
    """
    plt = _pyplot()
    fig, axes = plt.subplots(1, 3, figsize=(12, 3.6), sharex=True)
    letters = sorted({s["algorithm"] for s in sweep})
    for ax, key, label in zip(axes, ("relative_x", "relative_z", "relative_lost"),
                              ("E_x per period", "E_z per period", "(E - dV) per period")):
        for L in letters:
            rows = sorted((s for s in sweep if s["algorithm"] == L), key=lambda s: s["velocity"])
            ax.plot([s["velocity"] * 1e3 for s in rows], [s[key] for s in rows], "o-", label=L)
        ax.axhline(0.0, color="k", lw=0.6)
        ax.axhspan(-0.1, 0.1, color="0.85", zorder=0, label="marginal (the verdict band)" if key == "relative_x" else None)
        ax.set_xlabel("scanning speed (mm/s)")
        ax.set_ylabel(f"{label} / |E_z,A| (1)")
        ax.set_xscale("log")
        speeds = sorted({s["velocity"] * 1e3 for s in sweep})
        ax.set_xticks(speeds, [f"{v:g}" for v in speeds])
        ax.minorticks_off()
    axes[0].legend()
    return _finish(plt, fig, path, "Fig. 6 in steady contact: energy per texture period (< 0: supplied)")


def plot_wall_map(wall_map: dict, path) -> Path:
    """The virtual wall's passivity and closed-loop behaviour over beta = b/(KT) and
    sigma = f_c/(K Delta) (:func:`haptex.experiments.wall_map`).

    Parameters
    ----------
    wall_map : dict
        From :func:`haptex.experiments.wall_map`.
    path : str or Path
        PNG file to write.

    Returns
    -------
    pathlib.Path
        The figure written.
    """
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(7, 5))
    style = {"rest": ("o", "#1a9641"), "limit cycle": ("s", "#fdae61"), "unstable": ("X", "#d7191c")}
    for behaviour, (marker, color) in style.items():
        for passive in (True, False):
            pts = [p for p in wall_map["points"] if p["behaviour"] == behaviour and p["passive"] is passive]
            if pts:
                ax.scatter([p["beta"] for p in pts], [p["sigma"] for p in pts], marker=marker, s=60,
                           facecolors=color if passive else "none", edgecolors=color,
                           label=f"{behaviour}, {'passive' if passive else 'not passive'}")
    ax.axvline(0.5, color="k", lw=0.8, ls="--")
    ax.axhline(0.5, color="k", lw=0.8, ls=":")
    ax.set_xscale("log")
    ax.set_xlabel("beta = b / (K T) (1); dashed: b = K T / 2 (Colgate & Schenkel)")
    ax.set_ylabel("sigma = f_c / (K Delta) (1); dotted: K = 2 f_c / Delta")
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    return _finish(plt, fig, path, "Sampled, quantised virtual wall: passivity and behaviour")


def plot_stabilisers(rows: list, path) -> Path:
    """The stabiliser comparison: per case, the energy the port supplied (J, log scale) and the
    share of the texture's force spectrum up to 300 Hz each stabiliser kept.

    Parameters
    ----------
    rows : list of dict
        ``stabilisers(...)["rows"]`` of :mod:`haptex.experiments`.
    path : str or Path
        PNG file to write.

    Returns
    -------
    pathlib.Path
        The figure written.
    """
    plt = _pyplot()
    from .experiments import STABILISER_NAMES

    cases = list(dict.fromkeys((r["case"], r["algorithm"]) for r in rows))
    short = {r["case"]: r["short"] for r in rows}
    by = {(r["case"], r["algorithm"], r["stabiliser"]): r for r in rows}
    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(9, 6.5), sharex=True)
    width = 0.8 / len(STABILISER_NAMES)
    x = np.arange(len(cases))
    for j, name in enumerate(STABILISER_NAMES):
        sup = [max(by[(c, a, name)]["supplied"], 1e-6) for c, a in cases]
        kept = [100 * by[(c, a, name)]["kept"] for c, a in cases]
        ax1.bar(x + (j - 1.5) * width, sup, width, label=name)
        ax2.bar(x + (j - 1.5) * width, kept, width, label=name)
    ax1.set_yscale("log")
    ax1.set_ylabel("energy the port supplied (J)\n(at least 1e-6 shown)")
    ax1.legend(fontsize=8, ncol=2)
    ax2.axhline(0.0, color="k", lw=0.8)
    ax2.set_ylim(-100, 105)
    ax2.set_ylabel("texture force kept\nup to 300 Hz (%, clipped at -100)")
    ax2.set_xticks(x, [f"{short[c]}\n{a}" for c, a in cases], fontsize=8)
    return _finish(plt, fig, path, "Stabilisers with one sample of delay")


def plot_atlas(ds, x: str, y: str, where: dict, path) -> Path:
    """Heat maps of one 2-D slice of a stability atlas: the verdict (decays / persists /
    grows) and the energy the environment supplies per second (W), with the analytic
    boundary along the stiffness where one exists (:func:`haptex.atlas.analytic_boundary`).

    Parameters
    ----------
    ds : xarray.Dataset
        From :func:`haptex.atlas.sweep` or :func:`haptex.atlas.open_atlas`.
    x, y : str
        Dimensions along the horizontal and vertical axes.
    where : dict
        Values of the other dimensions (nearest coordinate).
    path : str or Path
        Figure file (PNG also writes its SVG twin).

    Returns
    -------
    pathlib.Path
        The figure written.

    Raises
    ------
    ParameterError
        For unknown or free dimensions (see :func:`haptex.atlas.select`).
    """
    from matplotlib.colors import ListedColormap, SymLogNorm

    from .atlas import analytic_boundary, select

    s = select(ds, x, y, where)
    plt = _pyplot()
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
    xs, ys = s[x].values, s[y].values
    if "regime" in s:  # 0-2 stable (decaying, settling, driven), 3 limit cycle, 4-5 growing or diverged
        code = s["regime"].values
        verdict = np.where(code >= 4, 2, np.where(code == 3, 1, 0))
    else:  # a store written before the regime (growing and oscillating alone)
        verdict = np.where(s["growing"].values, 2, np.where(s["oscillating"].values, 1, 0))
    rate = sum(s[v].values for v in s.data_vars if v.startswith("energy_rate_"))
    xlog = x in ("stiffness", "mass", "damping") and np.all(xs > 0) and xs.max() / xs.min() > 20
    ylog = y in ("stiffness", "mass", "damping") and np.all(ys > 0) and ys.max() / ys.min() > 20
    im0 = axes[0].pcolormesh(xs, ys, verdict, shading="nearest", vmin=-0.5, vmax=2.5,
                             cmap=ListedColormap(["#d9ead3", "#ffe599", "#e06666"]))
    cb = fig.colorbar(im0, ax=axes[0], ticks=[0, 1, 2])
    cb.ax.set_yticklabels(["stable", "limit cycle", "grows"])
    lim = float(np.nanmax(np.abs(rate))) if np.any(np.isfinite(rate)) else 1.0
    im1 = axes[1].pcolormesh(xs, ys, rate, shading="nearest", cmap="RdBu_r",
                             norm=SymLogNorm(linthresh=max(lim * 1e-6, 1e-12), vmin=-lim, vmax=lim))
    fig.colorbar(im1, ax=axes[1], label="energy supplied by the environment (W)")
    bound = analytic_boundary(ds, x, y, where) if y in s.dims else None
    for ax, title in zip(axes, ("verdict", "energy rate")):
        if bound is not None and np.any(np.isfinite(bound)):
            ax.plot(bound, ys, "k--", lw=1.2, label="analytic limit")
            ax.legend(loc="lower right", fontsize=8)
        ax.set_xlabel(f"{x} ({ds[x].attrs.get('units', '')})")
        ax.set_ylabel(f"{y} ({ds[y].attrs.get('units', '')})")
        ax.set_xlim(xs.min(), xs.max())
        if xlog:
            ax.set_xscale("log")
        if ylog:
            ax.set_yscale("log")
        ax.set_title(title)
    fixed = ", ".join(f"{k} = {v}" for k, v in where.items())
    return _finish(plt, fig, path, "stability atlas" + (f" ({fixed})" if fixed else ""))
