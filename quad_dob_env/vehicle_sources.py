"""Where every number of each vehicle preset (``quad_dob_env.params.VEHICLES``) comes from.

``quad-dob list`` prints them beside the values, docs/physics.md tabulates them, and a test holds
every field of every preset to a source here. Imports nothing.
"""

VEHICLE_SOURCES: dict[str, dict[str, str]] = {
    "paper": {
        "mass": "the paper and Lee, Leok, McClamroch 2010 (4.34 kg)",
        "inertia": "Lee 2010, diag(0.0820, 0.0845, 0.1377) kg m² (the paper prints 0.13377)",
        "arm_length": "Lee 2010, d = 0.315 m",
        "torque_coefficient": "UIUC Propeller Data Site, APC 10x4.7 SF static: C_T = 0.1155, "
                              "C_P = 0.0474 at 4319 RPM, Q/T = C_P D/(2π C_T) = 0.0166 m "
                              "(Lee 2010's 8.004e-4 m is LEE_TORQUE_COEFFICIENT)",
        "max_rotor_thrust": "our choice, 25 N (thrust/weight 2.35); the paper gives none",
        "rotor_radius": "our choice, a 10-inch propeller (0.127 m), the class whose C_T, C_P "
                        "set torque_coefficient",
        "configuration": "Lee 2010, plus (rotors on the body axes)",
        "gravity": "the paper, 9.81 m/s²",
        "drag_linear": "our estimate: rotor-induced drag of four 10-inch rotors at hover, "
                       "0.3 N s/m horizontal, 0.4 vertical",
        "drag_quadratic": "our estimate: ½ ρ C_d A with ρ = 1.2 kg/m³, C_d ≈ 1, A ≈ 0.1 m² "
                          "frontal (0.06 N s²/m²), 0.17 m² from above (0.1)",
        "motor_time_constant": "our estimate for 10-inch brushless motors, 40 ms, of the thrust "
                               "(v1's lag) or of the rotor speed (speed motors): between PX4 "
                               "x500's 12.5 ms up / 25 ms down and PX4 SIH's SIH_T_TAU 50 ms",
        "thrust_coefficient": "UIUC Propeller Data Site, APC 10x4.7 SF static C_T = 0.1155: "
                              "k_F = C_T ρ D⁴/(2π)² = 1.49e-5 N/(rad/s)² at ρ = 1.225 kg/m³ "
                              "(hover at 845 rad/s, 8,070 RPM)",
        "max_body_rate": "±2000 °/s, the full-scale range of the MPU-6000 / ICM-20602 "
                         "gyroscopes autopilots fly with (InvenSense datasheets)",
        "rotor_drag_coefficient": "PX4 x500 (2 kg, ~11-inch rotors), PX4-gazebo-models "
                                  "model.sdf rotorDragCoefficient 8.06428e-5 N/(rad/s · m/s) "
                                  "(Martin & Salaün 2010's model): 3.3 N on four rotors at "
                                  "hover in 12 m/s, where drag_linear gave 3.6 N",
        "inflow_coefficient": "Gill & D'Andrea 2019 (Drones 3(4) 77), Appendix A, the APC "
                              "10x4.7 SF's oblique-flow fit: k_z = -k_F k1/(C_s R), k1/C_s = "
                              "-2.03 (thrust falls 1.9 % per m/s of climb at hover)",
        "inflow_quadratic": "the same fit's k2/C_s = 5.31 (thrust gained with in-plane "
                            "flow μ²) and k3/C_s = -12.8 (lost with axial inflow λ², from "
                            "above only, where it was measured)",
        "rotor_height": "assumed as PX4 x500's hubs, 0.06 m above the centre of mass "
                        "(x500_base/model.sdf); Lee 2010 gives none",
        "arm_width": "unused (a plus)",
    },
    "crazyflie": {
        "mass": "Bitcraze Crazyflie 2.x, 27 g",
        "inertia": "Förster 2015 (System identification of the Crazyflie 2.0), "
                   "diag(1.4e-5, 1.4e-5, 2.17e-5) kg m², as in gym-pybullet-drones",
        "arm_length": "Bitcraze, 46 mm from centre to motor",
        "torque_coefficient": "gym-pybullet-drones cf2x.urdf, k_M/k_F = 7.94e-12 / 3.16e-10 m",
        "max_rotor_thrust": "gym-pybullet-drones cf2x, thrust/weight 2.25",
        "rotor_radius": "Bitcraze 45 mm propellers, 23.1 mm",
        "configuration": "Bitcraze, X",
        "gravity": "standard gravity, 9.81 m/s²",
        "drag_linear": "Förster 2015 rotor drag K = diag(10.2506, 10.2506, 7.4064)e-7 kg/rad "
                       "times Σω = 6788 rad/s at hover (as rotorpy 3's k_d, k_z)",
        "drag_quadratic": "zero: rotorpy 3 sets the Crazyflie's parasitic drag c_D to zero",
        "thrust_coefficient": "gym-pybullet-drones cf2x.urdf, k_F = 3.16e-10 N/RPM² "
                              "= 2.88e-8 N/(rad/s)²",
        "motor_time_constant": "our estimate, 15 ms for the thrust (rotorpy's tau_m = 72 ms "
                               "is for the rotor speed)",
        "max_body_rate": "±2000 °/s, the full-scale range of the Crazyflie 2.x's BMI088 "
                         "gyroscope (Bosch datasheet)",
        "rotor_drag_coefficient": "Förster 2015 K_xy = 10.2506e-7 kg/rad, rotorpy 3's k_d",
        "inflow_coefficient": "rotorpy 3's k_z = 7.553e-7 kg/rad (crazyflie_params.py)",
        "inflow_quadratic": "zero: no oblique-flow data for a 45 mm rotor; rotorpy 3 keeps "
                            "the linear law alone",
        "rotor_height": "rotorpy 3: hubs in the centre of mass's plane",
        "arm_width": "unused (an X)",
    },
    "crazyflie-2.1": {
        "mass": "Crazyswarm2's info files for the bare vehicle, 0.032 kg, the mass its "
                "firmware was told (ctrlLee.mass); each log's own weight comes from its "
                "hover thrust (quad_dob_training.real_flights.crazyswarm2)",
        "inertia": "Förster 2015 (ETH, 'System Identification of the Crazyflie 2.0'), "
                   "diag(16.571710, 16.655602, 29.261652)e-6 kg m², the firmware's J "
                   "(IMRCLab crazyflie-firmware controller_lee.c)",
        "arm_length": "the firmware's power distribution, 0.046 m centre to motor "
                      "(power_distribution_quadrotor.c)",
        "torque_coefficient": "the firmware's power distribution, 0.0069929 m yaw moment per "
                              "newton (power_distribution_quadrotor.c); v2's crazyflie has "
                              "4x it",
        "max_rotor_thrust": "the firmware's fit of one motor's largest thrust, "
                            "-10.29 + 3.926 pwm + 26.08 v/4.2 [g] (IMRCLab motors.c "
                            "motorsGetMaxThrust) at full PWM and a 3.9 V pack: 17.9 g",
        "rotor_radius": "Bitcraze 45 mm propellers, 23.1 mm",
        "configuration": "Bitcraze, X",
        "gravity": "standard gravity, 9.81 m/s²",
        "drag_linear": "the rotors' k_d and k_z below times 4 ω_h at 0.032 kg: what v1's "
                       "linear drag stands for",
        "drag_quadratic": "zero: rotorpy 3 sets the Crazyflie's parasitic drag c_D to zero",
        "motor_time_constant": "72 ms of the rotor speed: rotorpy's tau_m (citing Eschmann "
                               "et al. 2024), the middle of utiasDSL drone-models' 58 ms "
                               "(2.1+ propellers) and 86 ms (legacy propellers)",
        "thrust_coefficient": "Förster 2015 via rotorpy 3, k_F = 2.3e-8 N/(rad/s)²",
        "max_body_rate": "±2000 °/s, the full-scale range of the Crazyflie 2.1's BMI088 "
                         "gyroscope (Bosch datasheet)",
        "rotor_drag_coefficient": "utiasDSL drone-models cf2x_L250 (a Crazyflie 2.1 with legacy "
                                  "propellers, 31.9 g): linear drag 0.01471782 N/(m/s) "
                                  "identified in flight, as 4 k_d ω_h at its hover; Förster "
                                  "2015's K_xy (Crazyflie 2.0) gives half of it",
        "inflow_coefficient": "utiasDSL drone-models cf2x_L250: vertical linear drag "
                              "0.01277641 N/(m/s), as 4 k_z ω_h at its hover",
        "inflow_quadratic": "zero: no oblique-flow data for a 45 mm rotor; rotorpy 3 keeps "
                            "the linear law alone",
        "rotor_height": "rotorpy 3: hubs in the centre of mass's plane",
        "arm_width": "unused (an X)",
    },
    "neural-fly": {
        "mass": "O'Connell et al. 2022 (Neural-Fly), Tables S1-S2: 2.53 kg (the text rounds "
                "to 2.6)",
        "inertia": "our estimate (none published): four 0.12 kg rotor groups at the motors "
                   "and the rest a 0.2 x 0.15 x 0.1 m box",
        "arm_length": "Neural-Fly Table S2: motors 39 cm apart front to back",
        "arm_width": "Neural-Fly: 85 cm wide over its 11-inch rotors, 0.571 m between the "
                     "motors sideways",
        "configuration": "Neural-Fly: a wide X (its rotors' 10-12° tilt is not modelled)",
        "torque_coefficient": "PX4 x500 (~11-inch rotors), model.sdf momentConstant 0.016 m",
        "max_rotor_thrust": "Neural-Fly Table S1: thrust/weight 2.2",
        "rotor_radius": "Neural-Fly Table S2: 11-inch propellers",
        "gravity": "standard gravity, 9.81 m/s²",
        "drag_linear": "the rotor aerodynamics below linearised at hover (4 k_d ω_h, 4 k_z "
                       "ω_h): what v1's linear drag stands for",
        "drag_quadratic": "what the rotors' drag at hover leaves of the 15.7 N Neural-Fly "
                          "measured at 12.1 m/s (their data, custom_figure8_baseline_100wind, "
                          "near hover); vertical 0.1/0.06 of it, as the paper vehicle's",
        "motor_time_constant": "PX4 x500 timeConstantDown 25 ms (up: 12.5 ms)",
        "thrust_coefficient": "PX4 x500 motorConstant 8.54858e-6 N/(rad/s)² (hover at "
                              "852 rad/s)",
        "max_body_rate": "±2000 °/s, the full-scale range of the Pixhawk 4's ICM-20689 / "
                         "BMI055 gyroscopes",
        "rotor_drag_coefficient": "PX4 x500 rotorDragCoefficient 8.06428e-5 (same rotor "
                                  "class)",
        "inflow_coefficient": "Gill & D'Andrea 2019's APC 10x4.7 SF oblique-flow fit (the "
                              "nearest propeller they measured; Neural-Fly names no model), as "
                              "ratios to this rotor's k_F and R",
        "inflow_quadratic": "the same fit's k2/C_s, k3/C_s",
        "rotor_height": "assumed as PX4 x500's, 0.06 m",
    },
}
