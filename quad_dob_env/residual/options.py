"""``ResidualOptions``: every option of the residual, in one frozen record, validated once.

On disk and in ``gym.make`` the options stay flat keys beside the env's own (configs,
hyperparameter files, sweep files, gym kwargs): ``split_residual_keys`` is the one place
that turns those keys into the record. From there the record travels whole, from the env ids
down to ``ResidualCommand``, which hands its parts to the objects that use them.

| option                   | what it does                                           | exp. |
|--------------------------|--------------------------------------------------------|------|
| ``residual_mode``        | ``"thrust_moments"`` or ``"acceleration"`` (``modes``) | no   |
| ``thrust_scale``         | thrust residual, a fraction of the thrust limit         | no   |
| ``moment_scale``         | moment residual, a fraction of each moment limit        | no   |
| ``acceleration_scale``   | the acceleration mode's Δa per unit action [m/s²]       | no   |
| ``vertical_floor``       | how low Δa may take the force's vertical part [m g]     | no   |
| ``residual_effort_weight`` | the reward's penalty on mean(a²)                      | no   |
| ``residual_rate_weight`` | the reward's penalty on mean((a - a_prev)²)             | no   |
| ``authority_gate``       | the disturbance gate [m g] (``gate``); None: off        | no   |
| ``authority_signal``     | what the gate reads: ``"force"`` or ``"wind"``          | no   |
| ``floor_fade``           | heights (h₀, h₁) [m] it fades in over (``floor_fade``)  | no   |
| ``history_steps``        | K: the last K steps' residuals and velocity errors      | no   |
|                          | in the observation (``loop_view``); 0: none             |      |
| ``thrust_path_input``    | the measured thrust-path residual in the observation    | no   |
| ``period_input``         | the control period in the observation                   | no   |
| ``reference_jerk_input`` | the reference's jerk in the observation                 | no   |
| ``supervisor``           | the safety net's limits (``supervisor``); None: off      | no   |
| ``residual_washout``     | τ [s] of a high-pass on the residual (``washout``): its  | no   |
|                          | steady part is left to the observer; None: off          |      |

Two experimental options, ``lookahead`` (the reference read ahead) and ``residual_cutoff``
(a low-pass on the residual), were measured in Benchmark v3, helped nowhere and were removed
(issue 42); docs/research/removed-experiments.md keeps their findings.

``RESIDUAL_PRESETS`` holds the residual options of each shipped policy. A *recipe* is more
than its preset: the env options (scenario, benchmark, reward scale) go in the env's own
kwargs, the training-only keys (``loop_randomization``) in the SB3 adapter
(``quad_dob_training``), and the algorithm's settings in the hyperparameter file.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, fields, replace
from typing import Any

import numpy as np

from quad_dob_env.observation_entry import ObservationEntry
from quad_dob_env.residual.observation import RESIDUAL_ENTRIES, loop_entries
from quad_dob_env.residual.supervisor import SupervisorLimits, supervisor_limits
from quad_dob_env.validation import as_finite, unknown_name_error

RESIDUAL_MODES = ("thrust_moments", "acceleration")
# the longest history a policy may see: 0.5 s at 100 Hz
MAX_HISTORY_STEPS = 50
AUTHORITY_SIGNALS = ("force", "wind")


def _floor_fade(fade: Sequence[float] | None) -> tuple[float, float] | None:
    """``fade`` as (h₀, h₁) with 0 <= h₀ < h₁, or None (no fade)."""
    if fade is None:
        return None
    values = tuple(fade) if isinstance(fade, (tuple, list, np.ndarray)) else ()
    if len(values) != 2:
        raise ValueError(f"floor_fade must be two heights (h0, h1) in m, got {fade!r}")
    low, high = (as_finite(v, "floor_fade height", 0.0) for v in values)
    if not low < high:
        raise ValueError(f"floor_fade needs h0 < h1 (the residual fades in between), got "
                         f"{fade!r}")
    return low, high


@dataclass(frozen=True, kw_only=True)
class ResidualOptions:
    """The residual's options (table in the module docstring); validated when made."""

    residual_mode: str = "thrust_moments"
    thrust_scale: float = 0.1
    moment_scale: float = 0.1
    acceleration_scale: float = 3.0
    vertical_floor: float = 0.5
    residual_effort_weight: float = 0.01
    residual_rate_weight: float = 0.0
    authority_gate: float | None = None
    authority_signal: str = "force"
    floor_fade: tuple[float, float] | None = None
    history_steps: int = 0
    thrust_path_input: bool = False
    period_input: bool = False
    reference_jerk_input: bool = False
    supervisor: SupervisorLimits | None = None
    residual_washout: float | None = None

    def __post_init__(self) -> None:
        if self.residual_mode not in RESIDUAL_MODES:
            raise unknown_name_error("residual_mode", self.residual_mode, RESIDUAL_MODES)
        checked = {
            "acceleration_scale": as_finite(self.acceleration_scale,
                                            "residual acceleration_scale", 0.0, strictly=True),
            "vertical_floor": as_finite(self.vertical_floor, "residual vertical_floor", 0.0),
            "authority_gate": (None if self.authority_gate is None else
                               as_finite(self.authority_gate, "authority_gate", 0.0,
                                         strictly=True)),
        }
        if self.authority_signal not in AUTHORITY_SIGNALS:
            raise unknown_name_error("authority_signal", self.authority_signal,
                                     AUTHORITY_SIGNALS)
        checked["floor_fade"] = _floor_fade(self.floor_fade)
        checked["thrust_scale"] = as_finite(self.thrust_scale, "residual thrust_scale", 0.0,
                                            strictly=True)
        checked["moment_scale"] = as_finite(self.moment_scale, "residual moment_scale", 0.0,
                                            strictly=True)
        if checked["thrust_scale"] > 1 or checked["moment_scale"] > 1:
            raise ValueError(f"residual thrust_scale and moment_scale are fractions of the "
                             f"limits in (0, 1], got {self.thrust_scale}, {self.moment_scale}")
        checked["residual_effort_weight"] = as_finite(self.residual_effort_weight,
                                                      "residual_effort_weight", 0.0)
        checked["residual_rate_weight"] = as_finite(self.residual_rate_weight,
                                                    "residual_rate_weight", 0.0)
        steps = self.history_steps
        if (isinstance(steps, bool) or not isinstance(steps, (int, np.integer))
                or not 0 <= steps <= MAX_HISTORY_STEPS):
            raise ValueError(f"history_steps must be a whole number of control steps from 0 to "
                             f"{MAX_HISTORY_STEPS}, got {steps!r}")
        checked["history_steps"] = int(steps)
        for name in ("thrust_path_input", "period_input", "reference_jerk_input"):
            if not isinstance(getattr(self, name), (bool, np.bool_)):
                raise ValueError(f"{name} must be true or false, got {getattr(self, name)!r}")
            checked[name] = bool(getattr(self, name))
        checked["supervisor"] = supervisor_limits(self.supervisor)
        checked["residual_washout"] = (None if self.residual_washout is None else
                                       as_finite(self.residual_washout,
                                                 "residual_washout (a time constant in s)",
                                                 0.0, strictly=True))
        for name, value in checked.items():  # frozen: the normalised values, set once
            object.__setattr__(self, name, value)

    @classmethod
    def from_keys(cls, keys: Mapping[str, Any]) -> ResidualOptions:
        """The record from flat keys (a config's, a gym kwarg's); an unknown key is named
        with the valid ones."""
        for key in keys:
            if key not in OPTION_NAMES:
                raise unknown_name_error("residual option", key, OPTION_NAMES)
        return cls(**keys)

    def keys(self) -> dict[str, Any]:
        """The flat keys that differ from the defaults, as a config writes them (the
        supervisor's limits as a mapping)."""
        defaults = asdict(DEFAULT_RESIDUAL_OPTIONS)
        return {name: value for name, value in asdict(self).items()
                if value != defaults[name]}

    def with_keys(self, **keys: Any) -> ResidualOptions:
        """This record with ``keys`` changed (validated again)."""
        return replace(self, **keys)

    @property
    def observation_entries(self) -> tuple[ObservationEntry, ...]:
        """The entries an env flying these options appends after its own: the 16 every
        residual sees, then the loop view's where asked for (``observation``);
        ``envs.observation_table`` reads them here, as the envs sit below the residual and
        do not import it."""
        return RESIDUAL_ENTRIES + loop_entries(self)


OPTION_NAMES = tuple(option.name for option in fields(ResidualOptions))
DEFAULT_RESIDUAL_OPTIONS = ResidualOptions()


def split_residual_keys(kwargs: dict[str, Any],
                        options: ResidualOptions | None = None) -> ResidualOptions:
    """The one place flat keys become the record: pops every residual option out of
    ``kwargs`` (the rest stay the env's) and applies them over ``options`` (the defaults
    without). Giving both a record and a flat key for the same option is refused."""
    flat = {name: kwargs.pop(name) for name in OPTION_NAMES if name in kwargs}
    if options is None:
        return ResidualOptions.from_keys(flat)
    if not isinstance(options, ResidualOptions):
        raise ValueError(f"residual_options must be a ResidualOptions, got {options!r}")
    return options.with_keys(**flat) if flat else options


# the residual options of each shipped policy (training/pretrained/*.yaml's env_kwargs;
# tests/test_residual_options.py holds them to those files)
RESIDUAL_PRESETS: dict[str, ResidualOptions] = {
    "residual:v1": ResidualOptions(residual_mode="acceleration", acceleration_scale=3.0,
                                   vertical_floor=0.5, moment_scale=0.3,
                                   residual_effort_weight=0.1, authority_gate=0.02),
    "residual:v2": ResidualOptions(residual_mode="acceleration", acceleration_scale=3.0,
                                   vertical_floor=0.5, moment_scale=0.3,
                                   residual_effort_weight=0.1, residual_rate_weight=0.5,
                                   authority_gate=0.04, authority_signal="wind",
                                   floor_fade=(0.3, 0.6)),
}
# v3's recipe keeps v2's options; what changed is the loop it trained in
RESIDUAL_PRESETS["residual:v3"] = RESIDUAL_PRESETS["residual:v2"]
# v4's: always on (no gate), seeing its loop, under a supervisor, its steady part washed out
RESIDUAL_PRESETS["residual:v4"] = ResidualOptions(
    residual_mode="acceleration", acceleration_scale=3.0, vertical_floor=0.5, moment_scale=0.3,
    residual_effort_weight=0.1, residual_rate_weight=0.5, floor_fade=(0.3, 0.6),
    history_steps=10, thrust_path_input=True, period_input=True, reference_jerk_input=True,
    supervisor={"body_rate": 7.0, "attitude_error": 2.2, "residual_share": 0.45},
    residual_washout=0.3)
