"""Scores of a flight, in the form of the paper's Table I and beyond.

One implementation for every report: ``quad-dob paper`` and ``quad-dob evaluate``.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from quad_dob_training.rollout import Flight


def error_euler_angles(rotation: NDArray, desired_rotation: NDArray) -> NDArray:
    """Roll, pitch, yaw (ZYX) of the error rotation ``Rdᵀ R``, (T, 3) in radians: what the
    paper's Table I reports. Their norm saturates at π/√3 once yaw wraps: compare
    controllers with ``attitude_errors`` instead."""
    error = np.swapaxes(desired_rotation, 1, 2) @ rotation
    roll = np.arctan2(error[:, 2, 1], error[:, 2, 2])
    pitch = -np.arcsin(np.clip(error[:, 2, 0], -1.0, 1.0))
    yaw = np.arctan2(error[:, 1, 0], error[:, 0, 0])
    return np.stack([roll, pitch, yaw], axis=1)


def attitude_errors(rotation: NDArray, desired_rotation: NDArray) -> dict[str, NDArray]:
    """Three angles of the error rotation ``E = Rdᵀ R`` (T, 3, 3), each (T,) in radians:

    - ``geodesic``: ‖log E‖ = arccos((tr E − 1)/2), the whole attitude error;
    - ``tilt``: ∠(b3, b3d) = arccos(E₃₃), how far the thrust points off its command;
    - ``heading``: the twist of E about body z (swing-twist decomposition),
      atan2(E₂₁ − E₁₂, E₁₁ + E₂₂) = 2 atan2(q_z, q_w), signed in (−π, π]; zero for a pure tilt.

    Unlike Euler angles of E, none of them saturates or mixes the others when one is large.
    """
    error = np.swapaxes(desired_rotation, 1, 2) @ rotation
    trace = error[:, 0, 0] + error[:, 1, 1] + error[:, 2, 2]
    return {
        "geodesic": np.arccos(np.clip((trace - 1.0) / 2.0, -1.0, 1.0)),
        "tilt": np.arccos(np.clip(error[:, 2, 2], -1.0, 1.0)),
        "heading": np.arctan2(error[:, 1, 0] - error[:, 0, 1], error[:, 0, 0] + error[:, 1, 1]),
    }


def _rms(values: NDArray, axis: int = 0) -> NDArray:
    return np.sqrt(np.mean(np.square(values), axis=axis))


def _command_rate(flight: Flight, settled: NDArray) -> float | None:
    """RMS rate of change of the commanded rotor thrusts [N/s] over the settled steps, every
    rotor alike: sqrt(mean((Δf_i / dt)²)); None for a wrench-actuated flight (no rotor is
    commanded) or one of a single step. A dither of amplitude a at frequency ω adds about
    a ω / √2 per rotor: the figure that shows a policy buying precision with chatter."""
    if flight.actuation != "rotors" or len(flight.time) < 2:
        return None
    rates = np.diff(flight.requested_rotor_thrusts, axis=0) / flight.dt
    settled_rates = rates[settled[1:] & settled[:-1]]  # both ends settled
    return float(np.sqrt(np.mean(np.square(settled_rates)))) if len(settled_rates) else None


def flight_metrics(flight: Flight) -> dict[str, float | str | None]:
    """RMS position error (norm and per axis), RMS attitude errors (geodesic, tilt, heading;
    roll, pitch, yaw for the paper's table), the same after the scenario's settle time (2 s
    unless it says otherwise), final errors, peak
    thrust against the limit, and how the flight ended."""
    position_error = flight.position - flight.reference_position
    norm = np.linalg.norm(position_error, axis=1)
    angles = error_euler_angles(flight.rotation, flight.desired_rotation)
    attitude = attitude_errors(flight.rotation, flight.desired_rotation)
    settled = flight.time >= flight.settle_time
    if not settled.any():
        settled = np.zeros_like(settled)
        settled[-1] = True
    has_observer = bool(flight.force_estimate.any() or flight.torque_estimate.any())
    estimate_error = np.linalg.norm(flight.force_estimate - flight.disturbance_force, axis=1)
    axis_rms = _rms(position_error)
    estimator = _estimator_errors(flight, settled)
    angle_rms = _rms(angles)
    return {
        "scenario": flight.scenario,
        "controller": flight.controller,
        "rms_position": float(_rms(norm)),
        "rms_x": float(axis_rms[0]), "rms_y": float(axis_rms[1]), "rms_z": float(axis_rms[2]),
        "rms_roll": float(angle_rms[0]), "rms_pitch": float(angle_rms[1]),
        "rms_yaw": float(angle_rms[2]),
        **{f"rms_{name}": float(_rms(attitude[key]))
           for name, key in (("attitude", "geodesic"), ("tilt", "tilt"),
                             ("heading", "heading"))},
        "rms_position_settled": float(_rms(norm[settled])),
        # per axis: where the settled error lies (the figure-8s' vertical share)
        **{f"rms_position_settled_{axis}": float(value) for axis, value in
           zip("xyz", _rms(position_error[settled]), strict=True)},
        **{f"rms_{name}_settled": float(_rms(attitude[key][settled]))
           for name, key in (("attitude", "geodesic"), ("tilt", "tilt"),
                             ("heading", "heading"))},
        "final_position_error": float(norm[-1]),
        # None (shown as "—") for controllers that estimate nothing
        "final_estimate_error": float(estimate_error[-1]) if has_observer else None,
        "peak_thrust": float(flight.requested_thrust.max()),
        "rms_command_rate": _command_rate(flight, settled),
        # control effort: RMS of the applied collective thrust and moment norm
        "rms_thrust": float(_rms(flight.applied_thrust)),
        "rms_moment": (float(_rms(np.linalg.norm(flight.applied_moment, axis=1)))
                       if flight.applied_moment is not None else None),
        **estimator,
        "crashed": flight.termination_reason not in ("", "time_limit"),
        "thrust_limit": float(flight.thrust_limit),
        "flown": float(flight.time[-1] + flight.dt),
        "ended": flight.termination_reason,
    }


def _estimator_errors(flight: Flight, settled: NDArray[np.bool_]) -> dict[str, float]:
    """RMS error of what the controller read against the truth, once settled: position
    [m], velocity [m/s], attitude (geodesic angle) [rad]; zero with ideal sensing."""
    if flight.estimated_position is None:
        return {}
    position = np.linalg.norm(flight.estimated_position - flight.position, axis=1)
    velocity = np.linalg.norm(flight.estimated_velocity - flight.velocity, axis=1)
    attitude = attitude_errors(flight.rotation, flight.estimated_rotation)["geodesic"]
    return {"rms_estimate_position_settled": float(_rms(position[settled])),
            "rms_estimate_velocity_settled": float(_rms(velocity[settled])),
            "rms_estimate_attitude_settled": float(_rms(attitude[settled]))}
