"""The state estimator (``quad_dob_env.sensing.estimator``) against an independent oracle.

For a vehicle at rest (level, still, the accelerometer reading g e3 plus its bias and
noise) the filter's error dynamics are linear to first order. The oracle here writes them
out from the equations in the estimator's docstring, step by step (the bias walk, the IMU
prediction, the history the delayed fix is compared with, the fix's corrections), builds
the discrete-time system over one fix period and solves its Lyapunov equation for the
steady-state covariance. The real filter, flown for thousands of steps on hundreds of
vehicles, must show the same RMS errors; a wrong gain, sign, delay or integration term in
the code moves them by far more than the sampling error allows.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np
import pytest

from quad_dob_env.dynamics import VehicleState
from quad_dob_env.envs import QuadrotorBatch
from quad_dob_env.params import get_vehicle
from quad_dob_env.scenarios import make_scenario
from quad_dob_env.sensing.estimator import BA, BG
from quad_dob_env.sensing.models import GNSS_IMU, MOCAP, SensorSuite
from quad_dob_env.sensing.stage import SensingStage, delay_steps

DT = 0.01
VEHICLE = get_vehicle("paper")
# Measured and analytic RMS errors must agree to 3 %. The runs below are sized so the
# RMS's sampling error (vehicles are independent: the spread of their mean squares over
# the window, over sqrt(vehicles)) is at most a quarter of that, 0.2-0.5 % in practice.
# The first-order model leaves out terms smaller than the modelled ones by about the size
# of the errors themselves (at most ~1e-2 rad of tilt, with GNSS): ~1 % at worst. Tight
# enough still: mutating the estimator by a 10 % change of any gain, comparing a fix with
# the estimate a step off, dropping the dt²/2 term or not moving the history with a
# correction each fails this file.
RMS_TOLERANCE = 0.03
# The GNSS bias and heading loops are slow (poles at -0.5 to -2 rad/s): a 30 s window holds
# few independent samples of them per vehicle, and their RMS's sampling error is up to
# ~1.1 %; 5 % keeps it at a quarter of the tolerance.
SLOW_LOOP_TOLERANCE = 0.05


# --- the oracle: linear error dynamics from the estimator's docstring -----------------

class LinearStep:
    """One simultaneous update x ← A x + B w of a named error state, w unit normals.

    ``add`` and ``assign`` write a row from the *old* values, as one step of the filter
    computes every correction from the same estimate."""

    def __init__(self, states: list[str], noises: list[str]) -> None:
        self.states, self.noises = states, noises
        self.A = np.eye(len(states))
        self.B = np.zeros((len(states), len(noises)))

    def add(self, target: str, states: dict[str, float] | None = None,
            noises: dict[str, float] | None = None) -> LinearStep:
        row = self.states.index(target)
        for name, gain in (states or {}).items():
            self.A[row, self.states.index(name)] += gain
        for name, gain in (noises or {}).items():
            self.B[row, self.noises.index(name)] += gain
        return self

    def assign(self, target: str, states: dict[str, float] | None = None,
               noises: dict[str, float] | None = None) -> LinearStep:
        row = self.states.index(target)
        self.A[row], self.B[row] = 0.0, 0.0
        return self.add(target, states, noises)

    def then(self, later: LinearStep) -> LinearStep:
        """This update followed by ``later``, whose noises are fresh draws: they get columns
        of their own (one step's walk, say, is not the next step's)."""
        both = LinearStep(self.states, self.noises + later.noises)
        both.A, both.B = later.A @ self.A, np.hstack([later.A @ self.B, later.B])
        return both


@dataclass
class ErrorModel:
    """A channel's error dynamics: ``predict`` every step, then ``fix`` on a fix step, one
    step in ``period``."""

    predict: LinearStep
    fix: LinearStep
    period: int

    @property
    def states(self) -> list[str]:
        return self.predict.states


def _timing(suite: SensorSuite) -> tuple[int, int, float]:
    """The fix period in steps, how many steps a fix is older than the estimate it meets
    (the pose latency less the IMU's: an extra latency delays both alike and leaves it
    as it is), and the period T [s] the gains are scaled by."""
    period = max(1, round(1.0 / (suite.pose.rate * DT)))
    lag = delay_steps(suite.pose.latency, DT) - delay_steps(suite.imu.latency, DT)
    return period, lag, period * DT


def _push_history(step: LinearStep, history: list[str], newest: str) -> None:
    """The history's oldest entry falls off; this step's estimate goes in front."""
    for older, newer in zip(history[:0:-1], history[-2::-1], strict=True):
        step.assign(older, {newer: 1.0})
    step.assign(history[0], {newest: 1.0})


def vertical_channel(suite: SensorSuite) -> ErrorModel:
    """Height error δp, vertical velocity error δv, accelerometer-bias error δb = b̂ - b
    (body z, the body level), and the estimates' history the delayed fix compares with."""
    period, lag, T = _timing(suite)
    imu, pose, gains = suite.imu, suite.pose, suite.estimator
    heights = [f"p[-{k}]" for k in range(lag + 1)]
    speeds = [f"v[-{k}]" for k in range(lag + 1)]
    states = ["p", "v", "b", *heights, *speeds]
    noises = ["bias walk", "accelerometer", "fix position", "fix velocity"]
    walk = LinearStep(states, noises).add(
        "b", noises={"bias walk": -imu.accelerometer_bias_walk * math.sqrt(DT)})
    # a = R̂ (f_m - b̂_a) - g e3 = -δb + n_a; p̂ += v̂ dt + a dt²/2; v̂ += a dt
    accel_std = imu.accelerometer_noise_density / math.sqrt(DT)
    integrate = LinearStep(states, noises)
    integrate.add("p", {"v": DT, "b": -DT * DT / 2}, {"accelerometer": accel_std * DT * DT / 2})
    integrate.add("v", {"b": -DT}, {"accelerometer": accel_std * DT})
    remember = LinearStep(states, noises)
    _push_history(remember, heights, "p")
    _push_history(remember, speeds, "v")
    # y = p_m - p̂(t - L): p̂ += 3 ω T y, v̂ += 3 ω² T y, b̂ -= ω³ T y; GNSS: v̂ += ω_v T u,
    # u = v_m - v̂(t - L); the history moves with the estimate
    w = gains.position_bandwidth
    innovation = ({heights[-1]: -1.0}, {"fix position": pose.vertical_std})
    velocity_innovation = ({speeds[-1]: -1.0}, {"fix velocity": pose.velocity_std})
    fix = LinearStep(states, noises)
    for target, gain in [("p", 3 * w * T), ("v", 3 * w * w * T), ("b", -(w ** 3) * T)] + [
            (h, 3 * w * T) for h in heights] + [(s, 3 * w * w * T) for s in speeds]:
        fix.add(target, *(_scaled(part, gain) for part in innovation))
    if pose.kind == "gnss":
        for target in ["v", *speeds]:
            fix.add(target, *(_scaled(part, gains.velocity_bandwidth * T)
                              for part in velocity_innovation))
    return ErrorModel(walk.then(integrate).then(remember), fix, period)


def attitude_channel(suite: SensorSuite, fix_std: float) -> ErrorModel:
    """One axis of the attitude error δθ (R̂ = R exp(δθ)), the gyroscope-bias error
    δb = b̂_g - b_g, and the history: any mocap axis (``fix_std`` the attitude noise) or
    GNSS heading (the compass's noise; its levelling enters only at second order)."""
    period, lag, T = _timing(suite)
    imu, gains = suite.imu, suite.estimator
    history = [f"θ[-{k}]" for k in range(lag + 1)]
    states = ["θ", "b", "n[-1]", *history]  # n[-1]: the gyroscope's noise a reading before
    noises = ["bias walk", "gyroscope", "fix attitude"]
    # R̂ ← R̂ exp((ω̄_m - b̂_g) dt), ω̄_m the mean of the last two readings: with the bias
    # walking by w between them, ω̄_m - ω - b̂_g = (n + n[-1]) / 2 - δb_before + w / 2 (one
    # update, so that the walk and the new noise are the same draws in every row)
    gyro_std = imu.gyroscope_noise_density / math.sqrt(DT)
    walk_std = imu.gyroscope_bias_walk * math.sqrt(DT)
    integrate = LinearStep(states, noises)
    integrate.add("b", noises={"bias walk": -walk_std})
    integrate.add("θ", {"b": -DT, "n[-1]": DT / 2},
                  {"gyroscope": gyro_std * DT / 2, "bias walk": walk_std * DT / 2})
    integrate.assign("n[-1]", noises={"gyroscope": gyro_std})
    remember = LinearStep(states, noises)
    _push_history(remember, history, "θ")
    # e = fix noise - δθ(t - L); R̂ ← R̂ exp(ω_R T e), b̂_g -= (ω_R² / 4) T e
    wr = gains.attitude_bandwidth
    error = ({history[-1]: -1.0}, {"fix attitude": fix_std})
    fix = LinearStep(states, noises)
    for target, gain in [("θ", wr * T), ("b", -wr * wr / 4 * T)] + [(h, wr * T) for h in history]:
        fix.add(target, *(_scaled(part, gain) for part in error))
    return ErrorModel(integrate.then(remember), fix, period)


def _scaled(coefficients: dict[str, float], gain: float) -> dict[str, float]:
    return {name: gain * value for name, value in coefficients.items()}


def _covariance_step(P: np.ndarray, step: LinearStep) -> np.ndarray:
    return step.A @ P @ step.A.T + step.B @ step.B.T


def steady_state_rms(model: ErrorModel) -> dict[str, float]:
    """Each state's RMS in the periodic steady state, averaged over a fix period's steps.

    Over one period (from just after a fix to the next fix's end) P ← Φ P Φᵀ + Q; its fixed
    point solves (I - Φ ⊗ Φ) vec P = vec Q, the discrete Lyapunov equation."""
    period_map = model.predict
    for _ in range(model.period - 1):
        period_map = period_map.then(model.predict)
    period_map = period_map.then(model.fix)
    phi, size = period_map.A, len(model.states)
    spectral_radius = max(abs(np.linalg.eigvals(phi)))
    assert spectral_radius < 1.0, f"the error dynamics are unstable: |λ| = {spectral_radius}"
    Q = period_map.B @ period_map.B.T
    P = np.linalg.solve(np.eye(size * size) - np.kron(phi, phi), Q.reshape(-1)).reshape(size, size)
    variances = []
    for phase in range(model.period):
        P = _covariance_step(P, model.predict)
        if phase == model.period - 1:
            P = _covariance_step(P, model.fix)
        variances.append(np.diag(P))
    return dict(zip(model.states, np.sqrt(np.mean(variances, axis=0)), strict=True))


def fix_steps(suite: SensorSuite, steps: int) -> np.ndarray:
    """Whether step s (1 ..= steps) applies a fix: one taken at a multiple of the period,
    arriving the pose latency later."""
    period = max(1, round(1.0 / (suite.pose.rate * DT)))
    taken = np.arange(1, steps + 1) - delay_steps(suite.pose.latency, DT)
    return (taken >= 0) & (taken % period == 0)


# --- the real filter on vehicles at rest --------------------------------------------

class StaticFlight:
    """``n`` vehicles at rest at 1 m, level, hovering (thrust m g, no other force), their
    ``SensingStage`` stepped on its own."""

    def __init__(self, suite: SensorSuite, n: int, seed: int,
                 extra_latency: float = 0.0) -> None:
        self.truth = VehicleState.at_rest(n, position=(0.0, 0.0, 1.0))
        mass = np.full(n, VEHICLE.mass)
        hover = mass * VEHICLE.gravity
        physics = (hover, np.zeros((n, 3)), mass, np.repeat(hover[:, None] / 4, 4, axis=1))
        self.stage = SensingStage(suite, extra_latency, self.truth, physics, VEHICLE, DT)
        rng = np.random.default_rng(seed)
        for index in range(n):
            self.stage.start(index, rng)
        self.vehicles = np.arange(n)
        self.step_count = np.zeros(n, dtype=np.int64)
        self.stage.measure(self.vehicles, self.step_count, reset=True)

    def step(self) -> None:
        self.step_count += 1
        self.stage.measure(self.vehicles, self.step_count, reset=False)

    def errors(self) -> dict[str, np.ndarray]:
        """The estimate's errors now, (n, 3) each: position, velocity, attitude (the
        rotation vector of R̂ for the true R = I, to first order), the bias estimates'."""
        m, state = self.stage.measurement, self.stage.estimate_state
        R = m.rotation
        return {
            "position": m.position - self.truth.position,
            "velocity": m.velocity - self.truth.velocity,
            "attitude": 0.5 * np.stack([R[:, 2, 1] - R[:, 1, 2], R[:, 0, 2] - R[:, 2, 0],
                                        R[:, 1, 0] - R[:, 0, 1]], axis=1),
            "gyroscope bias": state[:, BG:BG + 3] - self.stage.true_bias[:, :3],
            "accelerometer bias": state[:, BA:BA + 3] - self.stage.true_bias[:, 3:],
        }

    def mean_squares(self, steps: int, burn_in: int) -> dict[str, np.ndarray]:
        """Fly ``steps`` steps; each vehicle's mean squared errors over the steps after
        ``burn_in``, (n, 3) each."""
        sums: dict[str, np.ndarray] = {}
        for step in range(1, steps + 1):
            self.step()
            if step > burn_in:
                for name, error in self.errors().items():
                    sums[name] = sums.get(name, 0.0) + error * error
        return {name: total / (steps - burn_in) for name, total in sums.items()}


def assert_rms_matches(per_vehicle_mean_square: np.ndarray, analytic: float, what: str,
                       tolerance: float = RMS_TOLERANCE) -> None:
    """The RMS over vehicles (and the axes given) against the oracle's, to ``tolerance``
    (relative), with the sampling error shown to be well inside it."""
    per_vehicle = per_vehicle_mean_square.reshape(len(per_vehicle_mean_square), -1).mean(axis=1)
    mean_square = per_vehicle.mean()
    measured = math.sqrt(mean_square)
    # relative standard error of the RMS: half that of the mean square
    sampling_error = per_vehicle.std(ddof=1) / math.sqrt(len(per_vehicle)) / mean_square / 2
    assert sampling_error < tolerance / 4, (what, sampling_error)
    assert measured == pytest.approx(analytic, rel=tolerance), (
        f"{what}: measured RMS {measured:.5g}, analytic {analytic:.5g} "
        f"({measured / analytic - 1:+.2%}; sampling error {sampling_error:.2%})")


def assert_settled(model: ErrorModel, suite: SensorSuite, steps: int, burn_in: int) -> None:
    """The burn-in is long enough: from the filter's start (on the truth, zero biases) the
    model's mean squares over the window are the steady state's to 0.1 %."""
    window = _noise_rms(model, fix_steps(suite, steps))[burn_in:]
    settled = np.sqrt((window ** 2).mean(axis=0))
    steady = np.array(list(steady_state_rms(model).values()))
    np.testing.assert_allclose(settled, steady, rtol=1e-3)


def _without_initial_bias(suite: SensorSuite) -> SensorSuite:
    """The filter starts with zero bias estimates: with zero true biases too it starts on
    the truth, so the burn-in only has to cover the loops' settling."""
    return dataclasses.replace(suite, imu=dataclasses.replace(
        suite.imu, gyroscope_initial_bias=0.0, accelerometer_initial_bias=0.0))


def _imu_dominated(suite: SensorSuite) -> SensorSuite:
    """The mocap preset with its pose noise ~40-55x smaller and its IMU noise and bias walks
    4-200x larger, so the prediction and the bias walk, not the fix noise, set the errors
    (accelerometer walk ~70 %, noise ~25 % of the height variance; gyroscope walk and
    noise ~50 % each of the attitude's; the preset's are ~99 % its fix noise's)."""
    pose = dataclasses.replace(suite.pose, position_std=2e-5, vertical_position_std=2e-5,
                               attitude_std=3e-5)
    imu = dataclasses.replace(suite.imu, accelerometer_noise_density=3e-3,
                              accelerometer_bias_walk=3e-2, gyroscope_noise_density=2e-3,
                              gyroscope_bias_walk=5e-3)
    return dataclasses.replace(suite, name="mocap, imu-dominated", pose=pose, imu=imu)


MOCAP_CASES = {
    "mocap": (MOCAP, 0.0),
    "mocap, imu-dominated": (_imu_dominated(MOCAP), 0.0),
    # an extra latency delays the pose and the IMU alike: the fix still meets the estimate
    # of its own time, so the errors are those without it
    "mocap, extra latency": (MOCAP, 0.02),
}


@pytest.mark.slow
@pytest.mark.parametrize("case", MOCAP_CASES)
def test_mocap_steady_state_errors_match_the_linear_error_model(case):
    suite, extra_latency = MOCAP_CASES[case]
    suite = _without_initial_bias(suite)
    # the same models with or without an extra latency (``_timing``)
    models = vertical_channel(suite), attitude_channel(suite, suite.pose.attitude_std)
    vertical, attitude = (steady_state_rms(model) for model in models)
    # the slowest loop (attitude, a double pole at -ω_R / 2 = -2.5 rad/s) settles in ~5 s
    steps, burn_in = 2500, 700
    for model in models:
        assert_settled(model, suite, steps, burn_in)
    flown = StaticFlight(suite, n=300, seed=11, extra_latency=extra_latency).mean_squares(
        steps, burn_in)
    assert_rms_matches(flown["position"][:, 2], vertical["p"], f"{case}: height")
    assert_rms_matches(flown["velocity"][:, 2], vertical["v"], f"{case}: vertical velocity")
    assert_rms_matches(flown["accelerometer bias"][:, 2], vertical["b"],
                       f"{case}: accelerometer bias z")
    # roll, pitch and yaw alike: with mocap the attitude loop sees no position
    assert_rms_matches(flown["attitude"], attitude["θ"], f"{case}: attitude")
    assert_rms_matches(flown["gyroscope bias"], attitude["b"], f"{case}: gyroscope bias")


def _velocity_dominated(suite: SensorSuite) -> SensorSuite:
    """The GNSS preset with a 10x finer vertical position fix and a 2.5x faster velocity
    loop, so the velocity fixes, and which estimate they are compared with, set the vertical
    errors (the preset's are mostly its position noise's)."""
    pose = dataclasses.replace(suite.pose, vertical_position_std=0.002)
    gains = dataclasses.replace(suite.estimator, velocity_bandwidth=5.0)
    return dataclasses.replace(suite, name="gnss, velocity-dominated", pose=pose,
                               estimator=gains)


GNSS_CASES = {"gnss": GNSS_IMU, "gnss, velocity-dominated": _velocity_dominated(GNSS_IMU)}


@pytest.mark.slow
@pytest.mark.parametrize("case", GNSS_CASES)
def test_gnss_steady_state_errors_match_the_linear_error_model(case):
    """A fix every 10 steps, arriving the preset's latency later: the vertical channel
    (position and velocity fixes) and the heading (compass) channel. Roll and pitch come
    from the nonlinear levelling and are not modelled here."""
    suite = _without_initial_bias(GNSS_CASES[case])
    assert max(1, round(1.0 / (suite.pose.rate * DT))) == 10  # the case this test is for
    models = vertical_channel(suite), attitude_channel(suite, suite.pose.heading_std)
    vertical, heading = (steady_state_rms(model) for model in models)
    # slowest: the heading loop's double pole at -0.5 rad/s, settled in ~15 s; the window
    # is a whole number of fix periods, as the analytic mean is over a period
    steps, burn_in = 4500, 1500
    for model in models:
        assert_settled(model, suite, steps, burn_in)
    flown = StaticFlight(suite, n=500, seed=12).mean_squares(steps, burn_in)
    assert_rms_matches(flown["position"][:, 2], vertical["p"], f"{case}: height")
    assert_rms_matches(flown["velocity"][:, 2], vertical["v"], f"{case}: vertical velocity")
    assert_rms_matches(flown["accelerometer bias"][:, 2], vertical["b"],
                       f"{case}: accelerometer bias z", SLOW_LOOP_TOLERANCE)
    assert_rms_matches(flown["attitude"][:, 2], heading["θ"], f"{case}: heading",
                       SLOW_LOOP_TOLERANCE)
    assert_rms_matches(flown["gyroscope bias"][:, 2], heading["b"], f"{case}: gyroscope bias z",
                       SLOW_LOOP_TOLERANCE)


# --- convergence from initial biases ------------------------------------------------

def _mean_response(model: ErrorModel, fixes: np.ndarray, start: dict[str, float]) -> np.ndarray:
    """The noise-free error from the initial error ``start``, after each step (rows)."""
    x = np.zeros(len(model.states))
    for name, value in start.items():
        x[model.states.index(name)] = value
    path = []
    for fixed in fixes:
        x = model.predict.A @ x
        if fixed:
            x = model.fix.A @ x
        path.append(x.copy())
    return np.array(path)


def _noise_rms(model: ErrorModel, fixes: np.ndarray) -> np.ndarray:
    """The RMS of each state's noise-driven part after each step, from zero at the start."""
    P = np.zeros((len(model.states),) * 2)
    path = []
    for fixed in fixes:
        P = _covariance_step(P, model.predict)
        if fixed:
            P = _covariance_step(P, model.fix)
        path.append(np.sqrt(np.diag(P)))
    return np.array(path)


def test_mocap_estimates_initial_biases():
    """Large true biases at the start (zero estimates): each vehicle's bias error follows
    the linear model's response to its own initial bias, and what is left once the loops
    have settled is the estimator's noise floor, far below the initial biases."""
    initial_accelerometer_bias, initial_gyroscope_bias = 0.3, 0.02  # [m/s²], [rad/s]
    suite = dataclasses.replace(MOCAP, imu=dataclasses.replace(
        MOCAP.imu, accelerometer_initial_bias=initial_accelerometer_bias,
        gyroscope_initial_bias=initial_gyroscope_bias))
    steps, n = 500, 300
    flight = StaticFlight(suite, n=n, seed=13)
    true_start = flight.stage.true_bias.copy()
    # the draws have the configured std (over n x 3 draws: a sampling error of ~2.5 %)
    drawn_std = np.sqrt((true_start ** 2).reshape(n, 2, 3).mean(axis=(0, 2)))
    np.testing.assert_allclose(drawn_std, [initial_gyroscope_bias, initial_accelerometer_bias],
                               rtol=0.1)
    bias_errors = {"accelerometer bias": [], "gyroscope bias": []}
    for _ in range(steps):
        flight.step()
        errors = flight.errors()
        for name, path in bias_errors.items():
            path.append(errors[name].copy())
    fixes = fix_steps(suite, steps)
    cases = [
        # (name, axes, model, its bias state's initial error per vehicle and axis)
        ("accelerometer bias", [2], vertical_channel(suite), -true_start[:, 5:6]),
        ("gyroscope bias", [0, 1, 2], attitude_channel(suite, suite.pose.attitude_std),
         -true_start[:, 0:3]),
    ]
    for name, axes, model, initial_error in cases:
        measured = np.array(bias_errors[name])[:, :, axes]  # (steps, n, axes)
        response = _mean_response(model, fixes, {"b": 1.0})[:, model.states.index("b")]
        noise = _noise_rms(model, fixes)[:, model.states.index("b")]
        predicted = response[:, None, None] * initial_error[None]
        residual_rms = np.sqrt(((measured - predicted) ** 2).mean(axis=(1, 2)))
        checkpoints = [5, 10, 20, 50, 100, 200, 499]  # steps: early on the response dominates
        for step in checkpoints:
            # what is left after the vehicle's own response is the noise-driven part:
            # its RMS over n x axes samples has a sampling error of ~1/sqrt(2 n axes) <= 4 %
            assert residual_rms[step] == pytest.approx(noise[step], rel=0.15), (name, step)
        # the early error is the initial bias, the late one the noise floor
        assert abs(response[4]) > 0.5 and abs(response[-1]) < 1e-3, (name, response[[4, -1]])
        final_rms = np.sqrt((measured[-1] ** 2).mean())
        start_rms = np.sqrt((initial_error ** 2).mean())
        assert final_rms < 0.1 * start_rms, (name, final_rms, start_rms)
    # the level axes' accelerometer biases couple to the tilt the gyroscope bias makes:
    # not in the oracle above, but they must converge as well
    accelerometer = np.array(bias_errors["accelerometer bias"])
    assert np.sqrt((accelerometer[-1, :, :2] ** 2).mean()) < 0.1 * initial_accelerometer_bias


# --- extra latency without an estimator ---------------------------------------------

def test_extra_latency_delays_the_true_state_exactly():
    """Ideal sensing with ``extra_latency=0.03`` at dt = 0.01: the measurement is the true
    state 3 steps before, bit for bit (before 3 steps have passed, the state at reset)."""
    scenario = make_scenario("hover-calm", sensing=None, extra_latency=0.03)
    assert scenario.dt == DT
    core = QuadrotorBatch(scenario, num_vehicles=3)
    assert not core.sensing.identity
    core.reset(np.arange(3), [np.random.default_rng(seed) for seed in range(3)])
    truths = [core.state.copy()]
    actions = np.random.default_rng(5).uniform(-0.3, 0.3, (30, 3, 4))
    fields = ("position", "velocity", "rotation", "angular_velocity")
    for step, action in enumerate(actions, start=1):
        core.step(action)
        truths.append(core.state.copy())
        delayed, now = truths[max(step - 3, 0)], truths[step]
        measurement = core.measurement
        for field in fields:
            np.testing.assert_array_equal(getattr(measurement, field), getattr(delayed, field),
                                          err_msg=f"{field} at step {step}")
        np.testing.assert_array_equal(measurement.gyroscope, delayed.angular_velocity)
        if step > 3:  # the vehicles move: the delayed state is not the current one
            assert not np.array_equal(measurement.position, now.position)
