"""PNG plots of a run's invariants over time: the first thing to look at when an integrator is in question.

``plot_trajectory(traj, out_dir)`` writes three figures (matplotlib, Agg backend,
bare Figures, no pyplot, so no display is needed), each 1200 x 900 pixels:

* ``energy.png``: kinetic, potential and total energy (J), and the total's
  relative drift (E(t) - E(0)) / |E(0)|;
* ``momentum.png``: total linear momentum (kg m/s) and total angular momentum
  about the world origin (kg m^2/s), components and magnitude, and their
  relative change |P(t) - P(0)| / |P(0)|;
* ``orthonormality.png``: the largest orthonormality error of the orientations
  (|R^T R - 1| entry, or | |q|^2 - 1 | for quaternions), log scale.

Where a reference value is zero (a run at rest, zero total energy) the
relative quantities are taken relative to the largest magnitude over the run
instead, and the axis label says so.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import InputError
from ..trajectory import write_atomic

PLOT_NAMES = ("energy.png", "momentum.png", "orthonormality.png")
FIGSIZE, DPI = (8.0, 6.0), 150  # 1200 x 900 pixels


def plot_trajectory(traj, out_dir) -> list[Path]:
    """Write the PNG plots of ``traj`` into ``out_dir`` (created if needed); return their paths.

    Existing files of the same names are replaced (the CLI asks for --force first).
    """
    out_dir = Path(out_dir)
    if out_dir.exists() and not out_dir.is_dir():
        raise InputError("exists and is not a folder", None, str(out_dir))
    if traj.frame_count < 1:
        raise InputError("the trajectory has no frames", None, None)
    makers = (_energy_figure, _momentum_figure, _orthonormality_figure)
    paths = []
    for name, make in zip(PLOT_NAMES, makers):
        fig = make(traj)  # a bare Figure (no pyplot): Agg canvas, no display, nothing global left open
        paths.append(write_atomic(out_dir / name, lambda fh, fig=fig: fig.savefig(fh, format="png", dpi=DPI)))
    return paths


def _figure(rows: int, title: str):
    from matplotlib.figure import Figure

    fig = Figure(figsize=FIGSIZE, dpi=DPI, layout="constrained")
    axes = fig.subplots(rows, 1, sharex=True, squeeze=False)[:, 0]
    fig.suptitle(title)
    for ax in axes:
        ax.grid(True, alpha=0.3)
    axes[-1].set_xlabel("time (s)")
    return fig, axes


def _relative(values: np.ndarray, reference: float, scale: float):
    """``values / |reference|``, or over ``scale`` when the reference is zero; and the label of the denominator."""
    if abs(reference) > 0:
        return values / abs(reference), "initial"
    if scale > 0:
        return values / scale, "largest"
    return values, None  # everything is zero: plot the zeros as they are


def _energy_figure(traj):
    t = np.asarray(traj.time, float)
    ke, pe = np.asarray(traj.kinetic_energy, float), np.asarray(traj.potential_energy, float)
    total = ke + pe
    fig, (ax, ax_drift) = _figure(2, f"Energy ({len(traj.names)} bodies, {traj.frame_count} frames)")
    ax.plot(t, ke, label="kinetic")
    ax.plot(t, pe, label="potential")
    ax.plot(t, total, label="total", color="black", linewidth=1.5)
    ax.set_ylabel("energy (J)")
    ax.set_title("Kinetic, potential and total energy")
    ax.legend(loc="best")
    drift, ref = _relative(total - total[0], total[0], float(np.max(np.abs(total))))
    ax_drift.plot(t, drift, color="tab:red")
    ax_drift.set_title("Relative drift of the total energy")
    ax_drift.set_ylabel({"initial": "(E - E0) / |E0|", "largest": "(E - E0) / max |E|", None: "E - E0 (J)"}[ref])
    ax_drift.ticklabel_format(axis="y", style="sci", scilimits=(-2, 3), useOffset=False)
    return fig


def _momentum_figure(traj):
    t = np.asarray(traj.time, float)
    fig, axes = _figure(3, "Total momentum (moving bodies)")
    for ax, values, name, unit, symbol in (
        (axes[0], traj.total_linear_momentum, "Linear momentum", "kg m/s", "P"),
        (axes[1], traj.total_angular_momentum, "Angular momentum about the world origin", "kg m²/s", "L"),
    ):
        values = np.asarray(values, float)
        for k, axis in enumerate("xyz"):
            ax.plot(t, values[:, k], label=f"{symbol}{axis}")
        ax.plot(t, np.linalg.norm(values, axis=1), label=f"|{symbol}|", color="black", linestyle="--", linewidth=1)
        ax.set_title(name)
        ax.set_ylabel(f"{symbol} ({unit})")
        ax.legend(loc="best", ncols=4, fontsize="small")
    ax = axes[2]
    for values, symbol in ((traj.total_linear_momentum, "P"), (traj.total_angular_momentum, "L")):
        values = np.asarray(values, float)
        norms = np.linalg.norm(values, axis=1)
        change, ref = _relative(np.linalg.norm(values - values[0], axis=1), norms[0], float(norms.max()))
        denominator = {"initial": f" / |{symbol}0|", "largest": f" / max |{symbol}|", None: f" ({symbol} = 0 throughout)"}[ref]
        ax.plot(t, change, label=f"|{symbol} - {symbol}0|{denominator}")
    ax.set_title("Relative change of the total momentum")
    ax.set_ylabel("relative change")
    ax.ticklabel_format(axis="y", style="sci", scilimits=(-2, 3), useOffset=False)
    ax.legend(loc="best", fontsize="small")
    return fig


def _orthonormality_figure(traj):
    t = np.asarray(traj.time, float)
    err = np.abs(np.asarray(traj.orthonormality_error, float))
    fig, (ax,) = _figure(1, "Orthonormality error of the orientations")
    positive = err > 0
    shown = np.where(positive, err, np.nan)  # exact zeros leave gaps: a log axis has no 0
    ax.semilogy(t, shown, color="tab:purple", marker="." if len(t) <= 200 else None, markersize=4)
    eps = np.finfo(float).eps
    ax.axhline(eps, color="gray", linestyle=":", linewidth=1, label="machine epsilon (2.2e-16)")
    top = float(err.max()) if np.any(positive) else eps
    bottom = float(err[positive].min()) if np.any(positive) else eps
    ax.set_ylim(min(bottom / 3, 1e-17), max(top * 3, 1e-14))  # at least three decades, so noise looks like noise
    if not np.all(positive):
        ax.text(0.01, 0.02, f"{int((~positive).sum())} of {len(err)} frames exactly 0 (gaps: not on a log scale)",
                transform=ax.transAxes, va="bottom", fontsize="small")
    ax.set_ylabel("largest |RᵀR - 1| entry (or ||q|² - 1|)")
    ax.set_title("Drift of the orientation off SO(3): log scale")
    ax.legend(loc="upper right", fontsize="small")
    if len(t) == 1:
        ax.set_xlim(t[0] - 0.5, t[0] + 0.5)
    return fig
