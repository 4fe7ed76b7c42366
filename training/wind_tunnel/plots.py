"""The figures of ``quad-dob wind-tunnel`` (``wind_tunnel_tool``), written only under the
user's ``--out``: with ``--neural-fly`` they hold the user's copy of Neural-Fly's data."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from quad_dob_training.wind_tunnel.published import NEURAL_FLY_RMS, WIND_SPEEDS

WINDS = [float(speed) for speed in WIND_SPEEDS]


def _save(fig: plt.Figure, path: Path, bottom: float = 0.1) -> Path:
    # fixed margins, as evaluation.plots: a layout engine costs more than the figure
    fig.subplots_adjust(left=0.1, right=0.97, bottom=bottom, top=0.88, hspace=0.4, wspace=0.3)
    fig.savefig(path, dpi=80)
    plt.close(fig)
    return path


def _mine(simulated: list[dict], spec: str) -> list[dict]:
    return sorted((run for run in simulated if run["policy"] == spec),
                  key=lambda run: run["wind_speed"])


def _real(real_rows: list[dict], spec: str) -> list[dict]:
    return sorted((row for row in real_rows if row["counterpart"] == spec),
                  key=lambda row: row["wind_speed"])


def _own(run: dict) -> dict:
    return run["mean"].get(str(run["laps"])) or {}


def _pairs(simulated: list[dict]) -> dict[str, str]:
    """The counterparts flown, simulated -> real, in the order flown."""
    return {run["policy"]: run["counterpart"] for run in simulated}


def rms_by_wind(simulated: list[dict], real_rows: list[dict], path: Path) -> Path:
    """Per counterpart: the RMS after 5 s against the wind, simulated (mean, the seeds'
    range as a bar), published and, given the logs, real."""
    pairs = _pairs(simulated)
    fig, axes = plt.subplots(2, 2, figsize=(9, 7), sharex=True)
    for ax, spec in zip(axes.flat, pairs, strict=True):
        runs = _mine(simulated, spec)
        values = [1e3 * np.array(run["rms_after_skip"]) for run in runs]
        means = [v.mean() for v in values]
        spread = np.array([[m - v.min() for m, v in zip(means, values, strict=True)],
                           [v.max() - m for m, v in zip(means, values, strict=True)]])
        ax.errorbar([run["wind_speed"] for run in runs], means, yerr=spread, marker="o",
                    capsize=3, label=f"{spec} (sim)")
        ax.plot(WINDS, 1e3 * np.array(NEURAL_FLY_RMS[pairs[spec]]), "s--",
                label=f"{pairs[spec]} (published)")
        real = _real(real_rows, spec)
        if real:
            ax.plot([row["wind_speed"] for row in real],
                    [1e3 * row["statistics"]["rms_after_skip"] for row in real], "^:",
                    label="real log")
        ax.set_title(spec, fontsize=9)
        ax.set_ylabel("RMS ‖p - p_d‖ after 5 s [mm]")
        ax.legend(fontsize=7)
    for ax in axes[-1]:
        ax.set_xlabel("wind [m/s]")
    fig.suptitle("Wind-tunnel figure-8: RMS position error")
    return _save(fig, path)


def axes_by_wind(simulated: list[dict], real_rows: list[dict], path: Path) -> Path:
    """Per counterpart: the RMS per axis over the whole laps against the wind (sim: solid,
    real: dotted)."""
    fig, axes = plt.subplots(2, 2, figsize=(9, 7), sharex=True)
    for ax, spec in zip(axes.flat, _pairs(simulated), strict=True):
        runs, real = _mine(simulated, spec), _real(real_rows, spec)
        for k, axis in enumerate("xyz"):
            ax.plot([run["wind_speed"] for run in runs],
                    [1e3 * _own(run).get(f"rms.{axis}", np.nan) for run in runs], "o-",
                    color=f"C{k}", label=f"{axis} (sim)")
            if real:
                ax.plot([row["wind_speed"] for row in real],
                        [1e3 * row["statistics"][f"rms.{axis}"] for row in real], "^:",
                        color=f"C{k}", label=f"{axis} (real)")
        ax.set_title(spec, fontsize=9)
        ax.set_ylabel("RMS per axis, whole laps [mm]")
        ax.legend(fontsize=7, ncol=2)
    for ax in axes[-1]:
        ax.set_xlabel("wind [m/s]")
    fig.suptitle("Where the error lies: RMS per axis over the whole laps after 5 s")
    return _save(fig, path)


def forces_by_wind(simulated: list[dict], real_rows: list[dict], path: Path) -> Path:
    """The mean fa_x and the fa_z fit's thrust lag τ against the wind, per counterpart."""
    pairs = _pairs(simulated)
    fig, axes = plt.subplots(1, 2, figsize=(10, 4))
    for k, spec in enumerate(pairs):
        runs, real = _mine(simulated, spec), _real(real_rows, spec)
        for ax, key, scale in ((axes[0], "mean_fa_x", 1.0), (axes[1], "fa_z_fit.tau", 1e3)):
            ax.plot([run["wind_speed"] for run in runs],
                    [scale * _own(run).get(key, np.nan) for run in runs], "o-",
                    color=f"C{k}", label=f"{spec} (sim)")
            if real:
                ax.plot([row["wind_speed"] for row in real],
                        [scale * row["statistics"][key] for row in real], "^:",
                        color=f"C{k}", label=f"{pairs[spec]} (real)")
    axes[0].set_ylabel("mean reconstructed fa_x [N]")
    axes[1].set_ylabel("τ = b / (4 m) of the fa_z fit [ms]")
    for ax in axes:
        ax.set_xlabel("wind [m/s]")
        ax.legend(fontsize=7)
    fig.suptitle("The residual force: along the wind, and the vertical lag")
    return _save(fig, path, bottom=0.14)


def write_figures(simulated: list[dict[str, Any]], real_rows: list[dict[str, Any]],
                  out: Path) -> list[Path]:
    return [rms_by_wind(simulated, real_rows, out / "rms_by_wind.png"),
            axes_by_wind(simulated, real_rows, out / "axes_by_wind.png"),
            forces_by_wind(simulated, real_rows, out / "forces_by_wind.png")]
