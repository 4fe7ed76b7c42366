"""``quad-dob list``: every name the CLI takes, and the source of every preset number."""

from __future__ import annotations

from quad_dob_training.rl import ALGORITHMS, HYPERPARAMS


def main() -> int:
    """Print the ids, scenarios, wind presets, controllers, vehicles and sensing presets."""
    import quad_dob_env
    from quad_dob_baselines import CONTROLLERS, GAIN_SETS, controller_names
    from quad_dob_env.params import VEHICLE_SOURCES
    from quad_dob_env.scenarios import WIND_PRESETS, make_scenario

    print("Environment ids:")
    for env_id, scenario in quad_dob_env.ENV_IDS.items():
        print(f"  {env_id:<26} default scenario {scenario}")
    for env_id, scenario in {**quad_dob_env.ENV_IDS_V2, **quad_dob_env.ENV_IDS_V3,
                               **quad_dob_env.ENV_IDS_V4}.items():
        print(f"  {env_id:<26} default scenario {scenario}, "
              f"benchmark {quad_dob_env.BENCHMARK_OF_ID[env_id]}")
    print("Scenarios (margins: share of each actuator limit the reference leaves, by "
          "differential flatness without disturbance):")
    for name in quad_dob_env.list_scenarios():
        scenario = make_scenario(name)
        print(f"  {name:<22} {scenario.description}")
        print(f"  {'':<22} {scenario.actuation} actuation; margins "
              f"{scenario.feasibility.summary()}")
    print("Wind presets (mean wind at the flight altitude, turbulence W20 of MIL-F-8785C):")
    for name, (mean, w20) in WIND_PRESETS.items():
        print(f"  {name:<10} {mean:g} m/s mean, W20 = {w20:.2f} m/s")
    print("Controllers:", ", ".join(CONTROLLERS))
    installed = [name for name in controller_names() if name not in CONTROLLERS]
    print("  installed by packages (entry points quad_dob_env.controllers):",
          ", ".join(installed) or "none")
    print("  your own: py:package.module:Name (quad-dob check-controller SPEC checks one)")
    print("  gains: v1's are the modules' defaults; v2's, tuned in v2's loop with the margin "
          "(quad-dob tune), per vehicle (others fly the paper vehicle's):")
    for (name, benchmark, vehicle), options in GAIN_SETS.items():
        gains = ", ".join(f"{key} {value:.4g}" for key, value in options.items())
        print(f"    {name:<27} {benchmark} {vehicle:<11} {gains}")
    print("Policies: any controller, residual:v1, residual:v2, residual:v3 and residual:v4 "
          "(the shipped policies trained in v1's to v4's loops), residual (the shipped one of the "
          "benchmark flown), residual:PATH, "
          + ", ".join(f"{algo}:PATH" for algo in ALGORITHMS)
          + " (a zip saved by stable-baselines3 or rl-zoo3 with evaluate --env ID)")
    print("Vehicles (every number and its source):")
    for name, sources in VEHICLE_SOURCES.items():
        vehicle = quad_dob_env.VEHICLES[name]
        print(f"  {name}")
        for field, source in sources.items():
            print(f"    {field:<20} {_number(getattr(vehicle, field)):<24} {source}")
    _list_sensing()
    _list_vehicle_loop()
    return 0


def _list_vehicle_loop() -> None:
    from quad_dob_env.envs.vehicle_loop import SAG_RATE_RANGE, THRUST_SCALE_RANGE

    print("Vehicle loop (Benchmark v2 part 2; scenario options, each off by default = v1):")
    print("  inner_rate=HZ          controllers' attitude laws (and thrust_rates' rate loop) "
          "at HZ, a multiple of 1/dt (PX4: attitude 200 Hz, rates 400 Hz)")
    print("  speed_motors=true      rotor speed first-order with motor_time_constant, "
          "thrust and yaw torque ∝ ω²")
    print(f"  thrust_uncertainty=true  k_F x U{THRUST_SCALE_RANGE} per episode (air density "
          f"0-30 °C, ISA), battery sag (1 - r t)², r ~ U{SAG_RATE_RANGE} /s (LiPo 4.05->3.5 "
          "V a cell over 10-15 min, PX4 BAT_V_*)")
    print("  rotor_aerodynamics=true  rotor drag -k_d ω u_inplane at the hubs and its moment, "
          "thrust k_F ω² (1 + a_μ μ² + a_λ λ²) - k_z ω u_axial (Gill & D'Andrea 2019's "
          "oblique-flow fit); replaces drag_linear (vehicle fields above)")


def _list_sensing() -> None:
    from quad_dob_env.sensing import SENSING_PRESETS, SENSING_SOURCES

    print("Sensing presets (scenario option sensing=NAME; every number and its source):")
    print("  ideal                  the true state, no delay (v1's loop)")
    for name, suite in SENSING_PRESETS.items():
        if suite is None:
            continue
        print(f"  {name}")
        for path, source in SENSING_SOURCES[name].items():
            part, field = path.split(".")
            value = getattr(getattr(suite, part), field)
            print(f"    {path:<34} {_number(value):<12} {source}")


def _number(value: object) -> str:
    """A vehicle field for the listing: 4 significant digits, inertia by its diagonal."""
    if isinstance(value, tuple) and value and isinstance(value[0], tuple):
        return "diag(" + ", ".join(f"{value[k][k]:.4g}" for k in range(3)) + ")"
    if isinstance(value, tuple):
        return "(" + ", ".join(f"{v:.4g}" for v in value) + ")"
    return f"{value:.4g}" if isinstance(value, float) else str(value)


def print_hyperparams(algo: str) -> int:
    """``quad-dob hyperparams ALGO``: the installed hyperparameter file's path (rl-zoo3's
    ``--conf-file`` from any directory; ``quad-dob train`` reads the same file)."""
    print(HYPERPARAMS / f"{algo}.yml")
    return 0
