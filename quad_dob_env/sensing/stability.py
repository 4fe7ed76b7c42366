"""Whether the estimator's gains make a stable filter at the fix period and lag a scenario
gives them: the spectral radius of its error dynamics over one fix period, linearised about
a vehicle at rest, for the position / velocity / accelerometer-bias loop and the attitude /
gyroscope-bias loop (``quad_dob_env.sensing.estimator``'s equations, one axis each).

A bandwidth times the fix period below 1 is not enough: with no lag the position loop's
radius is 0.84 at ω_p T = 0.5 and 1.45 at 0.6, and a lag lowers the limit further.
"""

from __future__ import annotations

import numpy as np

# a filter whose error shrinks by less than this a fix period is refused as unstable
STABLE_RADIUS = 0.999


def _push(step: np.ndarray, history: list[int], newest: int) -> None:
    """The history shifts by one; this step's estimate goes in front."""
    for older, newer in zip(history[:0:-1], history[-2::-1], strict=True):
        step[older] = 0.0
        step[older, newer] = 1.0
    step[history[0]] = step[newest]


def position_radius(bandwidth: float, velocity_bandwidth: float, dt: float, period: int,
                    lag: int) -> float:
    """The position loop's radius: states δp, δv, δb, and the estimates' history."""
    size = 3 + 2 * (lag + 1)
    heights, speeds = list(range(3, 4 + lag)), list(range(4 + lag, size))
    predict = np.eye(size)
    predict[0, 1], predict[0, 2], predict[1, 2] = dt, -dt * dt / 2, -dt  # a = -δb
    _push(predict, heights, 0)
    _push(predict, speeds, 1)
    fix = np.eye(size)
    T = period * dt
    # y = -δp(t - L): p̂ += 3 ω T y, v̂ += 3 ω² T y, b̂ -= ω³ T y, and the history moves
    for row, gain in [(0, 3 * bandwidth * T), (1, 3 * bandwidth**2 * T),
                      (2, -(bandwidth**3) * T)] + [(h, 3 * bandwidth * T) for h in heights] + [
                          (s, 3 * bandwidth**2 * T) for s in speeds]:
        fix[row, heights[-1]] -= gain
    for row in [1, *speeds]:  # a GNSS velocity fix: v̂ += ω_v T (-δv(t - L))
        fix[row, speeds[-1]] -= velocity_bandwidth * T
    return float(np.abs(np.linalg.eigvals(fix @ np.linalg.matrix_power(predict, period))).max())


def attitude_radius(bandwidth: float, dt: float, period: int, lag: int) -> float:
    """The attitude loop's radius: states δθ, δb_g, and the estimates' history."""
    size = 2 + lag + 1
    history = list(range(2, size))
    predict = np.eye(size)
    predict[0, 1] = -dt
    _push(predict, history, 0)
    fix = np.eye(size)
    T = period * dt
    for row, gain in [(0, bandwidth * T), (1, -bandwidth**2 / 4 * T)] + [
            (h, bandwidth * T) for h in history]:
        fix[row, history[-1]] -= gain
    return float(np.abs(np.linalg.eigvals(fix @ np.linalg.matrix_power(predict, period))).max())


def check_stability(name: str, gains: tuple[float, float, float], dt: float, period: int,
                    lag: int) -> None:
    """Refuse gains (ω_p, ω_R, ω_v) whose filter would not settle, with the loop and its
    radius."""
    position, attitude, velocity = gains
    radii = {"position": position_radius(position, velocity, dt, period, lag),
             "attitude": attitude_radius(attitude, dt, period, lag)}
    for loop, radius in radii.items():
        if radius >= STABLE_RADIUS:
            raise ValueError(
                f"sensing {name!r}: its estimator's {loop} loop is unstable at dt = {dt:g} s "
                f"with a fix every {period} step(s), {lag} step(s) late (error growth "
                f"{radius:.3g} a fix period, allowed below {STABLE_RADIUS}): lower its "
                f"bandwidths (position {position:g}, attitude {attitude:g}, velocity "
                f"{velocity:g} rad/s)")
