"""With sensing on, a residual policy sees the measurement record alone: its observation,
rebuilt here from the estimate the vehicle measured, the reference, the base's command and
its observer's estimates (the equations of ``QuadrotorEnv``'s and ``quad_dob_env.envs
.residual``'s observation tables, written out), is the env's bit for bit, step after step,
while the true state it never reads drifts away from that estimate."""

from __future__ import annotations

import numpy as np
import pytest

from quad_dob_composition import make_vector_env
from quad_dob_env import make_scenario


def _normalised(value, centre, up, down):
    """[0, centre, centre + up] -> [-1, 0, 1], piecewise linear, clipped."""
    scaled = np.where(value >= centre, (value - centre) / up, (value - centre) / down)
    return np.clip(scaled, -1.0, 1.0)


def _rebuilt(core, residual) -> np.ndarray:
    measured, reference, vehicle = core.measurement, core.reference, core.vehicle
    rotation = measured.rotation
    position_error = measured.position - reference.position
    velocity_error = measured.velocity - reference.velocity
    own = np.concatenate([position_error, velocity_error, rotation.reshape(-1, 9),
                          measured.angular_velocity, reference.acceleration,
                          reference.heading], axis=1)
    limit = core.actuator.moment_limit
    # the command the observation shows: the base's coming one, or in acceleration mode (the
    # base runs within the step) the one just flown, as the flight records it
    shown_thrust, shown_moment = (residual.requested_command()
                                  if residual.residual_mode == "acceleration"
                                  else (residual.base_thrust, residual.base_moment))
    thrust = _normalised(shown_thrust, vehicle.hover_thrust,
                         vehicle.max_total_thrust - vehicle.hover_thrust, vehicle.hover_thrust)
    moment = np.clip(shown_moment / limit, -1.0, 1.0)
    # Rᵀ e: the errors in the (estimated) body frame
    body = np.einsum("nji,nj->ni", rotation, position_error)
    body_velocity = np.einsum("nji,nj->ni", rotation, velocity_error)
    extra = np.concatenate([thrust[:, None], moment,
                            residual.force_estimate / (vehicle.mass * vehicle.gravity),
                            residual.torque_estimate / limit, body, body_velocity], axis=1)
    return np.concatenate([own, extra], axis=1).astype(np.float32)


# residual:v2's own options: acceleration residuals behind the wind gate
V2_RESIDUAL = {"residual_mode": "acceleration", "moment_scale": 0.3, "authority_gate": 0.04,
               "authority_signal": "wind"}


@pytest.mark.parametrize("options", [{}, V2_RESIDUAL], ids=["thrust_moments", "v2"])
@pytest.mark.parametrize("sensing", ["mocap", "gnss-imu"])
def test_the_residual_observation_is_rebuilt_from_the_measurement_record_bit_for_bit(sensing,
                                                                                     options):
    scenario = make_scenario("dryden-helix-gusts", benchmark="v2", sensing=sensing)
    env = make_vector_env(3, scenario, base_controller="geometric-ndob:tuned", **options)
    obs, _ = env.reset(seed=[5, 6, 7])
    rng = np.random.default_rng(0)
    gaps = []
    for _ in range(60):
        np.testing.assert_array_equal(obs, _rebuilt(env.core, env.residual))
        gaps.append(np.abs(env.core.measurement.position - env.core.state.position).max())
        obs, *_ = env.step(rng.uniform(-0.3, 0.3, (3, 4)))
    assert max(gaps) > 1e-4  # the estimate is not the truth: the check is not vacuous
