"""``QuadrotorEnv``: one quadrotor as a Gymnasium environment (the N = 1 view of the core)."""

from __future__ import annotations

from typing import Any, ClassVar

import gymnasium as gym
import numpy as np
from numpy.typing import NDArray

from quad_dob_env.benchmark import scenario_options_for
from quad_dob_env.compile_notice import announces_compiling
from quad_dob_env.envs.actions import INVALID_ACTION_MODES, screen_actions
from quad_dob_env.envs.core import EpisodeLimits, QuadrotorBatch, RewardWeights
from quad_dob_env.envs.limits import SpecWithEpisodeLength
from quad_dob_env.envs.rendering import (
    RENDER_MODES,
    FlightRenderer,
    HumanWindow,
    check_render_mode,
)
from quad_dob_env.envs.step_kernels import OBSERVATION_BOUND
from quad_dob_env.scenarios import Scenario, make_scenario
from quad_dob_env.validation import checked_keywords, unknown_name_error


class QuadrotorEnv(SpecWithEpisodeLength, gym.Env):
    """A quadrotor tracking a reference on SE(3) under wind, ground effect and external forces.

    ## Description
    Rigid-body dynamics (z up, SI units) integrated with a fourth-order Lie-group
    Runge–Kutta scheme; the reference, disturbances, initial state and duration come from a
    scenario (``quad_dob_env.scenarios``). ``QuadDOB/Hover-v1`` uses ``hover-calm``,
    ``QuadDOB/Track-v1`` the paper helix ``paper-none``; ``scenario=`` picks any other.

    ## Action space
    ``Box(-1, 1, (4,), float32)``; values outside are clipped. NaN or ±inf raise ValueError,
    or with ``invalid_actions="terminate"`` the vehicle flies that step at hover and the
    episode ends (``invalid_action``).
    Each entry maps piecewise-linearly with 0 at hover: ``[-1, 0, 1] -> [0, hover, max]``.

    | action_mode        | entries                       | range after mapping               |
    |--------------------|-------------------------------|-----------------------------------|
    | ``thrust_moments`` | collective thrust, Mx, My, Mz | [0, 4 f_max] N; ±moment limit N m |
    | ``rotor_thrusts``  | thrust of rotors 1..4         | [0, f_max] N each                 |
    | ``thrust_rates``   | collective thrust, ωx, ωy, ωz | [0, 4 f_max] N; ±4 rad/s body rate|

    ``thrust_rates`` flies the body rates through an inner loop at the control rate,
    ``M = J k_ω (ω_cmd - ω) + ω × J ω`` with ``k_ω = 20 /s`` (``envs.actions.RateLoop``), as
    rotorpy and "Learning to Fly in Seconds" give their policies; direct control only.

    ``f_max`` is the vehicle's ``max_rotor_thrust``.

    The command then goes through the actuation (``rotors``: per-rotor clipping through the
    allocation matrix; ``wrench``: thrust and moments clipped directly, as in the paper).

    ## Observation space
    ``Box(-F, F, (24,) or (21,), float32)`` with F the largest float32 (values are clamped
    to it, so they are always finite); world frame unless stated. The same table, with
    each entry's name and range, is ``quad_dob_env.envs.observation_table`` (a test holds
    this one to it):

    | index        | observation                                   | unit   |
    |--------------|-----------------------------------------------|--------|
    | 0-2          | position error x - x_d                        | m      |
    | 3-5          | velocity error v - v_d                        | m/s    |
    | 6-14 (6-11)  | rotation R row-major (``6d``: R's first two columns) | -  |
    | 15-17 (12-14)| body rates Ω (body frame)                     | rad/s  |
    | 18-20 (15-17)| desired acceleration ẍ_d (feed-forward)       | m/s²   |
    | 21-23 (18-20)| desired heading b1d                           | -      |

    ## Reward
    ``exp(-|x - x_d| / reward_position_scale) - reward_effort_weight * mean(action²)``,
    in ``[-reward_effort_weight, 1]``: 1 on the reference, positive while it is near, so
    ending early never pays.

    ## Starting state
    The scenario's initial position, velocity, rotation and body rates, with a uniform
    position offset (``±initial_position_noise`` per axis) and attitude offset (rotation
    vector ``±initial_attitude_noise`` per axis) drawn from ``reset(seed=...)``.

    ## Episode end
    ``terminated`` with ``info["termination_reason"]``:

    | reason               | when                                                          |
    |----------------------|---------------------------------------------------------------|
    | ``crashed``          | below the floor (scenarios with a floor)                      |
    | ``out_of_bounds``    | farther than ``max_position_error`` (5 m) from the reference  |
    | ``attitude_lost``    | tilt > ``max_tilt`` (90°) or a rate > ``max_body_rate`` (35 rad/s) |
    | ``non_finite_state`` | the step produced NaN/inf; the last finite state is kept      |
    | ``invalid_action``   | a NaN/inf action with ``invalid_actions="terminate"``         |

    ``truncated`` with reason ``time_limit`` at the scenario's end, ``scenario.steps`` steps
    (``duration / dt``), whatever ``scenario_options`` made of it: the env ends its episodes
    itself and a made env's ``spec.max_episode_steps`` reports that length, so
    ``TimeAwareObservation`` sees it. ``gym.make(..., max_episode_steps=N)`` adds
    Gymnasium's ``TimeLimit`` for a shorter limit; it sets ``truncated`` and, as for any
    env, leaves ``info`` without a ``termination_reason`` (the env cannot see it; the
    native vector env's ``max_episode_steps`` names it ``time_limit``). The ids register
    no ``max_episode_steps`` (``gym.spec(id).max_episode_steps`` is None): a registered one
    would be wrapped around every env before its options are known, and cut a longer
    scenario at the default's length.

    ## Info
    A fresh dict each step: ``time``; ``position_error``, ``velocity_error``;
    ``reference_position``, ``reference_velocity``, ``reference_acceleration``,
    ``reference_heading``; the true ``disturbance_force`` (world, N; ground effect
    included) and ``disturbance_torque`` (body, N m); what the rotors actually produced:
    ``applied_thrust``, ``applied_moment``, ``rotor_thrusts``, ``actuator_saturated`` (with
    motor lag: the mean over the step); ``wind``, the air's velocity at the vehicle (world,
    m/s); ``estimate``, a dict of what the policies read (``position``, ``velocity``,
    ``rotation``, ``angular_velocity``; the true state with ideal sensing). ``reset`` adds
    ``sampled``: what domain randomisation and random disturbances drew for this episode
    (mass, inertia and drag scales, wind direction and intensity, impulse start), and the
    vehicle loop's per-episode draws where they are on (``motor_time_constant_scale``,
    ``rotor_0_thrust_factor`` to ``_3_``, ``unmodelled_pose_latency``, ``imu_vibration_scale``,
    the thrust path's and the model tolerance's).

    ## Sensing
    ``LoopOptions.sensing`` (``scenario.loop.sensing``; ``quad_dob_env.sensing``) sets what
    every policy reads: the observation above, and a base controller's input in a residual
    env. ``ideal`` (the
    default) is the true state, v1's loop bit for bit; ``mocap`` and ``gnss-imu`` fly
    sensors with their datasheets' noise and latency through a state estimator; a
    ``SensorNoise`` (``sensors=``) adds Gaussian noise to the state, ``delay_steps`` late.
    ``extra_latency`` [s] delays every reading more. Reward, termination and ``info`` (but
    ``estimate``) use the true state. Each sensor draws from its own stream, spawned off the
    episode's generator without drawing from it: for the same seed, switching sensing on,
    off or to other noise leaves the wind, gusts, start and randomisation as they were.

    ## Arguments
    ``scenario`` (name or ``Scenario``), ``scenario_options`` (dict for ``make_scenario``),
    ``action_mode``, ``rotation_representation`` (``matrix`` or ``6d``),
    ``max_position_error``, ``max_tilt``, ``max_body_rate``, ``reward_position_scale``,
    ``reward_effort_weight``, ``render_mode`` (``rgb_array``: ``render()`` returns a frame,
    headless; ``human``: a window at the control rate), ``invalid_actions`` (``raise`` or
    ``terminate``), ``benchmark`` (``"v1"`` to ``"v4"``, beneath ``scenario_options``:
    ``quad_dob_env.benchmark``; the ``-v2``, ``-v3`` and ``-v4`` ids set theirs).

    ## Version history
    - v4 (2026-12, issue 54): the ids ``QuadDOB/Hover-v4``, ``HoverResidual-v4``,
      ``TrackResidual-v4`` and ``TracksResidual-v4`` fly the v2 ids' scenarios under
      ``benchmark="v4"``: v3's loop with five mechanisms corrected against Neural-Fly's logs
      (``quad_dob_env.benchmark_v4``, every value sourced; docs/benchmark-v4.md): the
      estimators told the autopilot's command, INDI modelling its actuators, the drag fitted
      in the simulator's tilted equilibrium, the rotors' vibration as tones through the IMU's
      chain, an identified throttle curve, and the tunnel's reference from rest. Its
      controllers fly v3's gains (``INHERITED_FROM``); v3 stays the tools' default. The
      v1-v3 ids stay registered and fly as before, bit for bit.
    - v4 (2026-12-07, issue 55): the v4 ids' base controllers fly v4's own gain sets,
      searched under v3's margin on both vehicles (docs/tuning-v4/), in place of v3's; the
      v4 ids' recorded flights were recorded again. v1-v3 unchanged.
    - all versions, residual options removed (2026-12, issue 42; no flight without them
      changes): ``lookahead`` and ``residual_cutoff``, measured in Benchmark v3 and of no
      help there. Naming either raises an error that points at
      docs/research/removed-experiments.md (commands at commit 8a6fabb).
    - all versions, experiments removed (2026-12, issue 41; no flight changes): the scenario
      ``tunnel-tracks`` and training's ``termination_penalty`` are gone. Naming either raises
      an error that points at docs/research/removed-experiments.md, which keeps their
      findings and the commands that reproduce them at commit 666bb22.
    - v3 (2026-12): the ids ``QuadDOB/Hover-v3``, ``HoverResidual-v3``, ``TrackResidual-v3``
      and ``TracksResidual-v3`` fly the v2 ids' scenarios under ``benchmark="v3"``: v2's
      loop with the real vehicle's lag and thrust path (``quad_dob_env.benchmark_v3``, every
      value sourced), the figure-8s at Neural-Fly's 50 Hz. Its controllers fly the gains v3's
      own search chose (2026-12-05, ``quad_dob_baselines.gain_sets``); a name with no v3 set
      of its own flies its v2 set (``quad_dob_baselines.gain_sets.INHERITED_FROM``).
      The v1 and v2 ids stay registered and fly as before, bit for bit.
    - v2, residual options (2026-12, no id bumped: the defaults fly as before, bit for bit):
      the residual's ``authority_signal`` (``"force"``, as before, or ``"wind"``: the
      low-passed horizontal force estimate, which stays shut in calm air under noisy
      sensing) and ``residual_rate_weight``; the scenarios ``heldout-tracks`` and
      ``heldout-hops`` (reference pools seeded apart from training, the second of a kind,
      waypoint hops, no training family holds); the residual's ``lookahead`` (the error
      against the reference at given times ahead, 3 observation entries each; none by
      default); the residual's ``floor_fade`` (its authority faded out near the floor; off
      by default), the training family ``tunnel-tracks`` (training's kinds but the
      landings, in a steady wind of 0-13 m/s) and the residual's ``residual_cutoff`` (a
      first-order low-pass on the residual, its state 4 more observation entries; none by
      default).
    - v2 (2026-12): the ids ``QuadDOB/Hover-v2``, ``HoverResidual-v2``, ``TrackResidual-v2``
      and ``TracksResidual-v2`` fly the v1 ids' scenarios under ``benchmark="v2"``: ``mocap``
      sensing, the 200 Hz inner loop, speed motors, thrust uncertainty, rotor aerodynamics.
      Their controllers fly the gains tuned for that loop (Benchmark v2, part 3). The
      v1 ids stay registered and unchanged (Gymnasium now warns that a newer version
      exists when one is made); ``Track-v1``'s wrench-actuated paper helix has no v2 yet.
    - v1, sensing (2026-12, no id bumped: the defaults fly as before, bit for bit): the
      scenario options ``sensing``, ``extra_latency`` and ``motor_time_constant_scale``;
      ``info["wind"]`` and ``info["estimate"]``. ``sensors=`` (``SensorNoise``) now feeds
      every policy, the base controller of a residual env included (it perturbed only the
      observation), applies its noise to the state (the observation's errors are then
      against the current reference), and draws its noise from its own stream, so it no
      longer shifts the wind drawn for the same seed.
    - v1, bug fix (2026-12, no id bumped: default episodes are unchanged): episodes run to
      their scenario's end. Until then ``gym.make`` wrapped every env in a ``TimeLimit`` of
      the default scenario's steps, so ``scenario_options`` with a smaller ``dt`` or a longer
      ``duration`` ended at the default's length, and the vector env reported that as
      ``time_limit``; the ids now register no ``max_episode_steps`` and a made env's
      ``spec.max_episode_steps`` is its scenario's.
    - v1 (Benchmark v1; the time limit in the spec too, same episodes): every scenario's
      reference is checked flyable (thrust, moments, rotor thrusts, body rate by
      differential flatness) or refused; the paper vehicle's
      yaw moment per newton of thrust is a 10-inch propeller's (0.0166 m, was Lee 2010's
      8.004e-4 m); drag is rotation-invariant, ``‖u‖ diag(c₂) u`` (was per component);
      the wind scenarios fly the helix with a fixed heading at 2 m over a floor, with
      turbulence computed for that altitude and a mean wind set apart from the turbulence
      (calm / light / moderate presets); landings end at 8 cm, inside the ground-effect
      law's range; the residual ids default to the recommended ``geometric-ndob:tuned``
      and to a windy scenario (``gusty-hover``, ``dryden-helix-gusts``). Added within v1,
      nothing existing changed: ``action_mode="thrust_rates"``, reference families
      (``random-tracks``, ``random-lemniscates``, ``QuadDOB/TracksResidual-v1``), the
      scenario option ``reference_start_spread`` and the residual's ``authority_gate``.
    - v0: the first release (the paper's vehicle and scenarios, Dryden wind, residual RL).
    """

    metadata: ClassVar[dict[str, Any]] = {"render_modes": list(RENDER_MODES), "render_fps": 100}

    @checked_keywords()
    def __init__(self, scenario: str | Scenario = "paper-none",
                 scenario_options: dict[str, Any] | None = None,
                 action_mode: str = "thrust_moments", rotation_representation: str = "matrix",
                 max_position_error: float = 5.0, max_tilt: float = np.pi / 2,
                 max_body_rate: float = 35.0, reward_position_scale: float = 0.25,
                 reward_effort_weight: float = 0.01, render_mode: str | None = None,
                 invalid_actions: str = "raise", benchmark: str | None = None) -> None:
        if invalid_actions not in INVALID_ACTION_MODES:
            raise unknown_name_error("invalid_actions", invalid_actions, INVALID_ACTION_MODES)
        self.invalid_actions = invalid_actions
        self.render_mode = check_render_mode(render_mode)
        self._renderer: FlightRenderer | None = None
        self._window: HumanWindow | None = None
        self.scenario = make_scenario(scenario, **scenario_options_for(scenario_options,
                                                                       benchmark))
        self.core = QuadrotorBatch(
            self.scenario, 1, action_mode, rotation_representation,
            EpisodeLimits(max_position_error, max_tilt, max_body_rate),
            RewardWeights(reward_position_scale, reward_effort_weight),
        )
        self.metadata = {**self.metadata, "render_fps": round(1.0 / self.scenario.dt)}
        self.action_space = gym.spaces.Box(-1.0, 1.0, (4,), np.float32)
        self.observation_space = gym.spaces.Box(
            -OBSERVATION_BOUND, OBSERVATION_BOUND, (self.core.observation_size,), np.float32
        )
        # None for a direct env; in a residual one, the base controller's name and gains
        # (set by ResidualActionWrapper, and in the reset info)
        self.base_controller: dict[str, Any] | None = None
        self._reset_done = False

    @announces_compiling
    def reset(self, *, seed: int | None = None,
              options: dict[str, Any] | None = None) -> tuple[NDArray[np.float32], dict]:
        super().reset(seed=seed)
        self._reset_done = True
        self.core.reset(np.zeros(1, dtype=np.intp), [self.np_random])
        info = self._info()
        info["sampled"] = dict(self.core.sampled[0])
        self._after_step(reset=True)
        return self.core.obs[0].copy(), info

    @announces_compiling
    def step(self, action: Any) -> tuple[NDArray[np.float32], float, bool, bool, dict]:
        if not self._reset_done:  # as Gymnasium's OrderEnforcing does for gym.make'd envs
            raise gym.error.ResetNeeded("call reset() before step()")
        core = self.core
        actions, invalid = screen_actions(action, (4,), self.invalid_actions)
        core.step(actions[None])
        if invalid.size:
            core.end_for_invalid_actions(invalid)
        terminated, truncated = bool(core.terminated[0]), bool(core.truncated[0])
        self._after_step(reset=False)
        return core.obs[0].copy(), float(core.rewards[0]), terminated, truncated, self._info()

    def render(self) -> NDArray[np.uint8] | None:
        """``rgb_array``: the frame (H, W, 3) uint8 (``quad_dob_env.envs.rendering`` says
        what is drawn); ``human``: shows it. None without a render mode."""
        if self.render_mode is None:
            gym.logger.warn("render() without a render_mode: pass render_mode='rgb_array' or "
                            "'human' to the env")
            return None
        frame = self._renderer_now().frame(0)
        if self.render_mode == "human":
            if self._window is None:
                self._window = HumanWindow(self.metadata["render_fps"])
            self._window.show(frame)
            return None
        return frame

    def close(self) -> None:
        if self._window is not None:
            self._window.close()
        super().close()

    def _renderer_now(self) -> FlightRenderer:
        if self._renderer is None:
            self._renderer = FlightRenderer(self.core)
            self._renderer.record(0)
        return self._renderer

    def _after_step(self, reset: bool) -> None:
        if self.render_mode is None:
            return
        renderer = self._renderer_now()
        if reset:
            renderer.reset()
        renderer.record(0)
        if self.render_mode == "human":
            self.render()

    def _info(self) -> dict[str, Any]:
        core = self.core
        arrays = core.info_arrays()
        estimate = arrays.pop("estimate")
        info = {name: value[0] for name, value in arrays.items()}
        info["estimate"] = {name: value[0] for name, value in estimate.items()}
        for name, kind in (("time", float), ("applied_thrust", float),
                           ("actuator_saturated", bool)):
            info[name] = kind(info[name])
        reason = core.termination_reason(0)
        if reason:
            info["termination_reason"] = reason
        return info
