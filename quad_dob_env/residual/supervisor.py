"""``Supervisor``: a safety net that fades the residual out where the loop looks unwell, and
back in once it has been calm for a while (``supervisor``, a ``SupervisorLimits``).

It reads measured signals only, never a disturbance estimate, at the start of each step:

| signal               | what it is                                                     | unit  |
|----------------------|----------------------------------------------------------------|-------|
| ``body_rate``        | ``‖ω‖``, the estimator's body rates                            | rad/s |
| ``attitude_error``   | the angle from the measured thrust axis to the one the base    | rad   |
|                      | last asked for (its ``desired_rotation``'s third column)       |       |
| ``residual_share``   | the residual's part of the last command: ``‖m Δa‖ / ‖F_base‖`` | -     |
|                      | (acceleration mode), ``|ΔT| / T_base`` (thrust and moments)    |       |

Any signal above its limit trips the vehicle's supervisor; the factor then falls to 0 over
``fade_time``. It is released once every signal has stayed below ``release`` times its
limit for ``hold`` seconds, and the factor rises back to 1 over ``recover_time``: the
hysteresis keeps it from chattering on a signal that hovers at a limit. The losses it is
there for are slow attitude oscillations through a lagged loop (issue 56: body rates and
the attitude error swell over a second or more before the attitude is lost), which trip it
long before the end.

The limits are chosen on tuning seeds (docs/residual-v4.md says how); with them, nominal
flight fades the residual below 0.9 on under 1 % of steps.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from quad_dob_env.validation import as_finite, unknown_name_error

__all__ = ["SIGNALS", "Supervisor", "SupervisorLimits", "supervisor_limits"]

# what the supervisor reads, in the order of its limits
SIGNALS = ("body_rate", "attitude_error", "residual_share")


@dataclass(frozen=True, kw_only=True)
class SupervisorLimits:
    """The supervisor's limits (module docstring), validated when made."""

    body_rate: float  # [rad/s]
    attitude_error: float  # [rad]
    residual_share: float  # [-]
    release: float = 0.5  # the fraction of each limit every signal must fall below
    hold: float = 0.5  # [s] how long they must stay there
    fade_time: float = 0.1  # [s] 1 -> 0 once tripped
    recover_time: float = 1.0  # [s] 0 -> 1 once released

    def __post_init__(self) -> None:
        for name, value in asdict(self).items():
            checked = as_finite(value, f"supervisor {name}", 0.0, strictly=name != "hold")
            object.__setattr__(self, name, checked)
        if self.release >= 1.0:
            raise ValueError(f"supervisor release is a fraction of each limit in (0, 1), got "
                             f"{self.release}")


SUPERVISOR_KEYS = tuple(SupervisorLimits.__dataclass_fields__)


def supervisor_limits(value: SupervisorLimits | Mapping[str, Any] | None
                      ) -> SupervisorLimits | None:
    """``value`` as the record (a config gives a mapping of its fields), or None."""
    if value is None or isinstance(value, SupervisorLimits):
        return value
    if not isinstance(value, Mapping):
        raise ValueError(f"supervisor must be a mapping of {', '.join(SUPERVISOR_KEYS)} or "
                         f"None, got {value!r}")
    for key in value:
        if key not in SUPERVISOR_KEYS:
            raise unknown_name_error("supervisor key", key, SUPERVISOR_KEYS)
    return SupervisorLimits(**value)


def attitude_angle(rotation: NDArray[np.float64], desired: NDArray[np.float64]
                   ) -> NDArray[np.float64]:
    """The angle [rad] between the thrust axes b₃ = R e₃ of (N, 3, 3) ``rotation`` and
    ``desired``. The heading is left out because a heading error does not threaten the
    attitude. In v4's helix the base's nominal tilt error itself reaches 2.13 rad, with a
    99th percentile of 0.76 (tuning seeds 100-119, ``benchmarks/supervisor_signals.py``).
    """
    cosine = np.einsum("ni,ni->n", rotation[:, :, 2], desired[:, :, 2])
    return np.arccos(np.clip(cosine, -1.0, 1.0))


class Supervisor:
    """The supervisor's state for N vehicles at the control period ``dt``."""

    def __init__(self, n: int, dt: float, limits: SupervisorLimits) -> None:
        self.limits, self.dt = limits, dt
        self.factor = np.ones(n)
        self.tripped = np.zeros(n, bool)
        self.calm_time = np.zeros(n)  # [s] how long every signal has been under release
        # the signals of the last step, over their limits (``SIGNALS``' order)
        self.ratios = np.zeros((n, len(SIGNALS)))

    def restart(self, indices: NDArray[np.intp]) -> None:
        self.factor[indices] = 1.0
        self.tripped[indices] = False
        self.calm_time[indices] = 0.0

    def advance(self, body_rate: NDArray, attitude_error: NDArray,
                residual_share: NDArray) -> NDArray[np.float64]:
        """Once per flown step, with the signals (N,) at its start: the factor (N,) on the
        residual."""
        limits = self.limits
        self.ratios = np.column_stack([body_rate / limits.body_rate,
                                       attitude_error / limits.attitude_error,
                                       residual_share / limits.residual_share])
        ratio = self.ratios.max(axis=1)
        over = ratio > 1.0
        self.calm_time = np.where(ratio < limits.release, self.calm_time + self.dt, 0.0)
        self.tripped = over | (self.tripped & (self.calm_time < limits.hold))
        self.factor = np.where(self.tripped,
                               np.maximum(self.factor - self.dt / limits.fade_time, 0.0),
                               np.minimum(self.factor + self.dt / limits.recover_time, 1.0))
        return self.factor
