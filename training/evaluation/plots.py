"""Figures in the form of the paper's (Figs. 2-16): path, states, errors, disturbance, thrust."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from quad_dob_training.evaluation.metrics import attitude_errors
from quad_dob_training.rollout import Flight

AXES = ("x", "y", "z")


def _save(fig: plt.Figure, path: Path) -> Path:
    # fixed margins: a layout engine costs more than drawing the figure
    fig.subplots_adjust(left=0.1, right=0.97, bottom=0.08, top=0.9, hspace=0.35, wspace=0.3)
    fig.savefig(path, dpi=80)
    plt.close(fig)
    return path


def _three_panels(flights: list[Flight], series, labels: list[str], title: str,
                  path: Path) -> Path:
    """One panel per component of ``series(flight)`` (T, 3), a line per controller."""
    fig, axes = plt.subplots(3, 1, figsize=(7, 6), sharex=True)
    for k, f in enumerate(flights):
        values = series(f)
        for col in range(3):
            axes[col].plot(f.time, values[:, col], color=f"C{k}", label=f.controller)
    for ax, label in zip(axes, labels, strict=True):
        ax.set_ylabel(label)
    axes[0].legend(fontsize=7)
    axes[-1].set_xlabel("t [s]")
    fig.suptitle(title)
    return _save(fig, path)


def scenario_figures(flights: list[Flight], out_dir: Path) -> list[Path]:
    """Six PNGs for one scenario, one line per controller in ``flights``."""
    out_dir.mkdir(parents=True, exist_ok=True)
    scenario = flights[0].scenario
    first = flights[0]
    written = []

    fig = plt.figure(figsize=(6, 5))
    ax = fig.add_subplot(projection="3d")
    ax.plot(*first.reference_position.T, "k--", label="desired")
    for k, f in enumerate(flights):
        ax.plot(*f.position.T, color=f"C{k}", label=f.controller)
    ax.set(xlabel="x [m]", ylabel="y [m]", zlabel="z [m]", title=f"{scenario}: path")
    ax.legend(fontsize=7)
    written.append(_save(fig, out_dir / f"{scenario}_path.png"))

    fig, axes = plt.subplots(3, 3, figsize=(11, 7), sharex=True)
    for row, (name, ref) in enumerate((("position", "reference_position"),
                                       ("velocity", "reference_velocity"),
                                       ("acceleration", "reference_acceleration"))):
        for col in range(3):
            ax = axes[row, col]
            ax.plot(first.time, getattr(first, ref)[:, col], "k--", label="desired")
            for k, f in enumerate(flights):
                ax.plot(f.time, getattr(f, name)[:, col], color=f"C{k}", label=f.controller)
            ax.set_title(f"{name} {AXES[col]}", fontsize=9)
    axes[0, 0].legend(fontsize=6)
    fig.suptitle(f"{scenario}: position, velocity, acceleration")
    written.append(_save(fig, out_dir / f"{scenario}_states.png"))

    written.append(_three_panels(
        flights, lambda f: f.position - f.reference_position,
        [f"e_{a} [m]" for a in AXES], f"{scenario}: position error",
        out_dir / f"{scenario}_position_error.png"))
    written.append(_three_panels(
        flights, lambda f: np.stack(list(attitude_errors(f.rotation,
                                                          f.desired_rotation).values()), 1),
        ["geodesic ‖log RdᵀR‖ [rad]", "tilt ∠(b3, b3d) [rad]", "heading [rad]"],
        f"{scenario}: attitude error",
        out_dir / f"{scenario}_attitude_error.png"))

    fig, axes = plt.subplots(3, 2, figsize=(10, 6), sharex=True)
    for col in range(3):
        axes[col, 0].plot(first.time, first.disturbance_force[:, col], "k", lw=2, label="true")
        axes[col, 1].plot(first.time, first.disturbance_torque[:, col], "k", lw=2, label="true")
        for k, f in enumerate(flights):
            if f.force_estimate.any() or f.torque_estimate.any():
                for side, estimate in ((0, f.force_estimate), (1, f.torque_estimate)):
                    axes[col, side].plot(f.time, estimate[:, col], color=f"C{k}",
                                         label=f.controller)
        axes[col, 0].set_ylabel(f"d_x,{AXES[col]} [N]")
        axes[col, 1].set_ylabel(f"d_Ω,{AXES[col]} [N m]")
    axes[0, 0].legend(fontsize=7)
    fig.suptitle(f"{scenario}: true disturbance and observer estimates")
    written.append(_save(fig, out_dir / f"{scenario}_disturbance.png"))

    fig, ax = plt.subplots(figsize=(7, 3.5))
    ax.axhline(first.thrust_limit, color="r", label="thrust limit")
    for k, f in enumerate(flights):
        ax.plot(f.time, f.applied_thrust, color=f"C{k}", label=f"{f.controller} applied")
        ax.plot(f.time, f.requested_thrust, ":", color=f"C{k}", label="requested")
    ax.set(xlabel="t [s]", ylabel="thrust [N]", title=f"{scenario}: total thrust")
    ax.legend(fontsize=6, ncol=2)
    written.append(_save(fig, out_dir / f"{scenario}_thrust.png"))
    return written


def evaluation_bars(rows: list[dict], path: Path) -> None:
    """``quad-dob evaluate``'s bars: each policy's RMS position error per scenario with its
    95 % interval."""
    scenarios = list(dict.fromkeys(row["scenario"] for row in rows))
    policies = list(dict.fromkeys(row["policy"] for row in rows))
    figure, axis = plt.subplots(figsize=(1.6 + 1.4 * len(scenarios) * len(policies) / 2, 3.6))
    width = 0.8 / len(policies)
    for j, policy in enumerate(policies):
        mine = {row["scenario"]: row for row in rows if row["policy"] == policy}
        x = np.arange(len(scenarios)) + (j - (len(policies) - 1) / 2) * width
        means = np.array([mine[s]["rms_position_settled_mean"] for s in scenarios])
        intervals = np.array([[mine[s]["rms_position_settled_low"],
                               mine[s]["rms_position_settled_high"]] for s in scenarios])
        axis.bar(x, means, width, yerr=np.abs(intervals.T - means), capsize=3, label=policy)
    axis.set_xticks(np.arange(len(scenarios)), scenarios)
    axis.set_ylabel("RMS position error, t ≥ 2 s [m]\n(mean, 95 % CI over seeds)")
    axis.legend(fontsize=8)
    figure.tight_layout()
    figure.savefig(path, dpi=120)
    plt.close(figure)
