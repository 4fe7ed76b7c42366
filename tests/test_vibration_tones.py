"""The rotors' vibration tones (``quad_dob_env.sensing.vibration``, Benchmark v4), held to a
brute-force simulation of the IMU chain at its raw sample rate, written here from the
chain's description: samples at ``raw_rate``, each batch's mean, a 2nd-order Butterworth by
the bilinear transform on the batches, read at a batch's end once a control step."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from quad_dob_env.sensing.vibration import VibrationTones, tone_gain

CHAIN = VibrationTones(rotor_level=15.0, blade_pass_level=15.0, raw_rate=4000.0,
                       batch_rate=400.0, cutoff=30.0)


def _butterworth(cutoff: float, rate: float) -> tuple[np.ndarray, np.ndarray]:
    """(b, a) of the analog 2nd-order Butterworth s² + √2 s + 1 at the prewarped cutoff,
    through s = (2/T)(1 - z⁻¹)/(1 + z⁻¹): written out here, not the package's."""
    warped = 2 * rate * math.tan(math.pi * cutoff / rate)  # [rad/s]
    c = 2 * rate / warped  # s / ω_c = c (1 - z⁻¹) / (1 + z⁻¹)
    # (1 + z⁻¹)² / (c²(1 - z⁻¹)² + √2 c (1 - z⁻¹)(1 + z⁻¹) + (1 + z⁻¹)²)
    a = np.array([c * c + math.sqrt(2) * c + 1, 2 - 2 * c * c, c * c - math.sqrt(2) * c + 1])
    return np.array([1.0, 2.0, 1.0]) / a[0], a / a[0]


def _brute_force(frequency: float, phase: float, chain: VibrationTones, dt: float,
                 duration: float) -> tuple[np.ndarray, np.ndarray]:
    """The chain's readings every ``dt`` of sin(2π f t + phase) sampled at the raw rate:
    (reading times, readings)."""
    raw = np.arange(round(duration * chain.raw_rate) + 1) / chain.raw_rate
    samples = np.sin(2 * np.pi * frequency * raw + phase)
    count = chain.batch
    # batch j holds samples j M + 1 .. (j + 1) M, its mean published at the last one's time
    batches = samples[1:].reshape(-1, count).mean(axis=1)
    times = raw[count::count]
    b, a = _butterworth(chain.cutoff, chain.batch_rate)
    filtered = np.zeros_like(batches)
    for k in range(len(batches)):
        filtered[k] = (b[0] * batches[k] + sum(b[m] * batches[k - m] - a[m] * filtered[k - m]
                                                for m in (1, 2) if k - m >= 0))
    every = round(dt * chain.batch_rate)
    return times[every - 1::every], filtered[every - 1::every]


@pytest.mark.parametrize("frequency", [40.0, 95.3, 135.4, 190.6, 270.8])
@pytest.mark.parametrize("dt", [0.01, 0.02])
def test_the_chains_form_is_the_brute_force_simulation_at_the_raw_rate(frequency, dt):
    phase = 0.7
    times, readings = _brute_force(frequency, phase, CHAIN, dt, 2.0)
    gain = tone_gain(frequency, CHAIN)
    settled = times > 0.5  # the filter's start has died away (its poles: ~30 Hz)
    expected = abs(gain) * np.sin(2 * np.pi * frequency * times + phase + np.angle(gain))
    np.testing.assert_allclose(readings[settled], expected[settled], rtol=0,
                               atol=1e-9 + 1e-6 * abs(gain))


def test_a_tone_read_once_a_step_appears_at_its_alias():
    dt, frequency = 0.02, 95.3  # read at 50 Hz: 95.3 Hz folds to |95.3 - 2 x 50| = 4.7 Hz
    times, readings = _brute_force(frequency, 0.0, CHAIN, dt, 40.0)
    spectrum = np.abs(np.fft.rfft(readings[times > 1.0] * np.hanning((times > 1.0).sum())))
    frequencies = np.fft.rfftfreq((times > 1.0).sum(), dt)
    assert abs(frequencies[np.argmax(spectrum)] - 4.7) < 0.05


def test_without_a_filter_the_chain_is_the_batch_mean_alone():
    chain = replace(CHAIN, cutoff=0.0)
    frequency = 123.0
    x = 2 * np.pi * frequency / chain.raw_rate
    mean = np.mean(np.exp(-1j * x * np.arange(chain.batch)))
    assert abs(tone_gain(frequency, chain) - mean) < 1e-12
    assert abs(tone_gain(0.0, CHAIN) - 1.0) < 1e-12  # a steady force passes whole


def test_bad_chains_are_refused_naming_the_allowed():
    with pytest.raises(ValueError, match="batch_rate must divide raw_rate"):
        VibrationTones(raw_rate=1000.0, batch_rate=300.0)
    with pytest.raises(ValueError, match="below the batches' Nyquist frequency, 200 Hz"):
        VibrationTones(batch_rate=400.0, cutoff=250.0)
    with pytest.raises(ValueError, match="blade count"):
        VibrationTones(blades=0)
    with pytest.raises(ValueError, match="rotor_level"):
        VibrationTones(rotor_level=-1.0)


def test_the_readings_carry_each_rotors_tones_as_the_form_gives():
    """Two v3 batches flown alike by direct commands (the readings move no physics), one
    with the tones on: their accelerometers differ by the four rotors' tones at the
    rotors' angles and speeds, x and y at the rotation frequency, z at the blade pass (v3's
    white vibration is drawn alike in both)."""
    from quad_dob_env.envs import QuadrotorVectorEnv

    envs = [QuadrotorVectorEnv(3, "gusty-hover", benchmark="v3",
                               scenario_options=options)
            for options in ({"imu_vibration_tones": CHAIN}, {})]
    rng = np.random.default_rng(4)
    for step in range(60):
        actions = rng.uniform(-0.05, 0.05, (3, 4)).astype(np.float32)
        for env in envs:
            if step == 0:
                env.reset(seed=7)
            env.step(actions)
    shaken, still = (env.core for env in envs)
    np.testing.assert_array_equal(shaken.state.position, still.state.position)
    tones = shaken.scenario.loop.imu_vibration_tones
    speeds = np.sqrt(shaken.applied.rotor_thrusts / shaken.vehicle.thrust_coefficient)
    angles = shaken.sensing.rotor_angle
    a, b = tones.rotor_level / math.sqrt(2), tones.blade_pass_level / math.sqrt(2)
    expected = np.zeros((3, 3))
    for i in range(3):
        for r in range(4):
            first = tone_gain(speeds[i, r] / (2 * np.pi), tones) * np.exp(1j * angles[i, r])
            blade = (tone_gain(tones.blades * speeds[i, r] / (2 * np.pi), tones)
                     * np.exp(1j * tones.blades * angles[i, r]))
            expected[i] += (a * first.real, a * first.imag, b * blade.imag)
    difference = shaken.sensing.measurement.accelerometer - still.sensing.measurement.accelerometer
    assert np.abs(expected).max() > 0.01  # the tones are there to be seen
    # the compiled readings interpolate the gain in 0.25 Hz rows
    np.testing.assert_allclose(difference, expected, rtol=0, atol=2e-3 * np.abs(expected).max())
