import numpy as np
import pytest

from quad_dob_env.disturbances import (
    AtanRamp,
    Constant,
    GroundEffect,
    Impulse,
    Sinusoid,
    Sum,
    Window,
)
from quad_dob_env.params import get_vehicle

PAPER = get_vehicle("paper")
TIMES = np.linspace(0.0, 10.0, 1001)[None, :]  # (N=1, K=1001)
FORCE, TORQUE = np.array([1.3, 2.0, 2.6]), np.array([0.78, 1.2, 1.56])


def test_constant():
    force, torque, _ = Constant(FORCE, TORQUE).evaluate(TIMES)
    np.testing.assert_array_equal(force[0], np.tile(FORCE, (1001, 1)))
    np.testing.assert_array_equal(torque[0], np.tile(TORQUE, (1001, 1)))


def test_atan_ramp_is_the_papers_scenario_one():
    force, torque, _ = AtanRamp(FORCE, TORQUE, time_scale=2.0).evaluate(TIMES)
    expected = np.arctan(TIMES[0] / 2)[:, None]
    np.testing.assert_allclose(force[0], expected * FORCE, rtol=1e-15)
    np.testing.assert_allclose(torque[0], expected * TORQUE, rtol=1e-15)


def test_sinusoid():
    force, _, _ = Sinusoid(FORCE, frequency=0.5, phase=0.3).evaluate(TIMES)
    np.testing.assert_allclose(force[0], np.sin(np.pi * TIMES[0] + 0.3)[:, None] * FORCE,
                               atol=1e-15)


def test_window_is_on_only_inside_its_interval():
    force, torque, _ = Constant(FORCE, TORQUE).during(5.0, 7.0).evaluate(TIMES)
    inside = (TIMES[0] >= 5.0) & (TIMES[0] < 7.0)
    np.testing.assert_array_equal(force[0][inside], np.tile(FORCE, (inside.sum(), 1)))
    assert not force[0][~inside].any() and not torque[0][~inside].any()


def test_impulse_delivers_its_impulse():
    impulse = Impulse(force_impulse=(0.5, 0.0, -0.2), start=2.0, duration=0.05)
    fine = np.arange(0, 4, 1e-4)[None, :]
    force, _, _ = impulse.evaluate(fine)
    np.testing.assert_allclose(force[0].sum(axis=0) * 1e-4, [0.5, 0.0, -0.2], rtol=1e-2)
    assert not force[0][fine[0] < 2.0].any()


def test_random_impulse_start_is_seeded_per_vehicle():
    impulse = Impulse(force_impulse=(1.0, 0, 0), start=(1.0, 3.0))
    assert impulse.is_random
    impulse.bind(3, 0.01)
    impulse.resample(np.arange(3), [np.random.default_rng(s) for s in (1, 2, 1)])
    assert impulse.starts[0] == impulse.starts[2] != impulse.starts[1]
    assert np.all((impulse.starts >= 1.0) & (impulse.starts <= 3.0))


def test_sum_adds_parts_and_flattens():
    total = Constant(FORCE) + AtanRamp(TORQUE) + Constant(torque=TORQUE)
    assert isinstance(total, Sum) and len(total.parts) == 3
    force, torque, _ = total.evaluate(TIMES)
    np.testing.assert_allclose(force[0], FORCE + np.arctan(TIMES[0] / 2)[:, None] * TORQUE)
    np.testing.assert_allclose(torque[0], np.tile(TORQUE, (1001, 1)))


@pytest.mark.parametrize(
    ("build", "message"),
    [
        (lambda: Constant(force=(1.0, 2.0)), "Constant.force must be a finite 3-vector"),
        (lambda: Constant(torque=(np.nan, 0, 0)), "Constant.torque"),
        (lambda: AtanRamp(FORCE, time_scale=0), "time_scale must be > 0"),
        (lambda: Constant(FORCE).during(3.0, 2.0), "end must be > start"),
        (lambda: Impulse(start=(3.0, 1.0)), "low <= high"),
        (lambda: Window("wind", 0, 1), "wraps a Disturbance"),
        (lambda: GroundEffect("wall"), "valid: cheeseman-bennett, paper"),
    ],
)
def test_bad_disturbance_specs_are_named(build, message):
    with pytest.raises(ValueError, match=message):
        build()


class TestGroundEffect:
    radius = PAPER.rotor_radius

    def test_paper_law(self):
        heights = np.linspace(0.07, 0.5, 50)
        k = GroundEffect("paper", cutoff_height=10.0).multiplier(heights, PAPER)
        np.testing.assert_allclose(k, 1 / (1 - 3 * self.radius / (25 * heights)), rtol=1e-14)

    def test_cheeseman_bennett_law(self):
        heights = np.linspace(0.07, 0.5, 50)
        k = GroundEffect("cheeseman-bennett", cutoff_height=10.0).multiplier(heights, PAPER)
        np.testing.assert_allclose(k, 1 / (1 - (self.radius / (4 * heights)) ** 2), rtol=1e-14)

    def test_height_is_clamped_near_the_floor_and_relative_to_it(self):
        law = GroundEffect("paper")
        at_clamp = law.multiplier([self.radius / 2], PAPER)[0]
        below = law.multiplier([0.0, -1.0, self.radius / 4], PAPER)
        np.testing.assert_array_equal(below, at_clamp)
        np.testing.assert_allclose(at_clamp, 1 / (1 - 6 / 25))
        raised = law.multiplier([2.0 + 0.1], PAPER, floor_height=2.0)[0]
        assert raised == law.multiplier([0.1], PAPER)[0]

    @pytest.mark.parametrize("model", ["paper", "cheeseman-bennett"])
    def test_no_effect_above_the_cutoff_and_at_most_one_percent_at_it(self, model):
        ge = GroundEffect(model)
        cutoff = ge.law(PAPER).cutoff_height
        just_below = ge.multiplier([cutoff * (1 - 1e-9)], PAPER)[0]
        assert just_below == pytest.approx(1.01, rel=1e-6)
        np.testing.assert_array_equal(ge.multiplier([cutoff, cutoff + 1, 100.0], PAPER), 1.0)

    def test_min_height_below_the_singularity_is_rejected(self):
        with pytest.raises(ValueError, match="singular"):
            GroundEffect("cheeseman-bennett", min_height=self.radius / 5).law(PAPER)
