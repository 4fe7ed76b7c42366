"""A controller of one's own, entered as a user would: from a package outside the checkout,
by ``py:package.module:Name`` or by an installed entry point, into every command; and any
stable-baselines3 algorithm's zip by its prefix."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from quad_dob_baselines import CascadedPID, Controller, make_controller
from quad_dob_composition.checks import check_controller
from quad_dob_training.cli.commands import main
from quad_dob_training.policies import make_policy

EXAMPLE = Path(__file__).parents[1] / "examples" / "byo_controller"
CONSOLE = Path(sys.executable).with_name("quad-dob")
SPEC = "py:example_pd.controller:HoverPD"
# a throwaway package, written by the test: one tunable gain so the descent is short
THROWAWAY = '''
from typing import ClassVar
from quad_dob_baselines import GeometricController

class SlowPosition(GeometricController):
    """Lee's law with its position gain declared for tuning, started too soft."""
    tunable_gains: ClassVar[dict[str, float]] = {"kx_per_mass": 4.0}
    def __init__(self, kx_per_mass=4.0):
        super().__init__(kx_per_mass=kx_per_mass)
'''


def _run(args: list[str], cwd: Path, packages: Path) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": str(packages)}
    done = subprocess.run(args, cwd=cwd, env=env, capture_output=True, text=True, timeout=600)
    return done


@pytest.fixture
def outside(tmp_path) -> tuple[Path, Path]:
    """(a working directory outside the checkout, a folder of user packages on PYTHONPATH:
    the example copied there and a throwaway one)."""
    packages = tmp_path / "packages"
    shutil.copytree(EXAMPLE / "example_pd", packages / "example_pd")
    (packages / "throwaway").mkdir()
    (packages / "throwaway" / "__init__.py").write_text("")
    (packages / "throwaway" / "slow.py").write_text(THROWAWAY)
    work = tmp_path / "work"
    work.mkdir()
    return work, packages


@pytest.mark.slow
def test_a_user_controller_is_checked_evaluated_tuned_and_a_residual_base_from_outside(
        outside):
    work, packages = outside
    checked = _run([str(CONSOLE), "check-controller", SPEC], work, packages)
    assert checked.returncode == 0, checked.stdout + checked.stderr
    assert "passes every check" in checked.stdout

    evaluated = _run([str(CONSOLE), "evaluate", "--policies", f"{SPEC},pid", "--scenarios",
                      "hover-step-force", "--seeds", "3", "--baseline", SPEC, "--json"],
                     work, packages)
    assert evaluated.returncode == 0, evaluated.stderr[-3000:]
    rows = {row["policy"]: row for row in json.loads(evaluated.stdout)}
    assert set(rows) == {SPEC, "pid"} and rows[SPEC]["crashes"] == 0
    # a PD without integral holds the push off by kx: 0.2 g / 4 s⁻² ≈ 0.5 m, PID does not
    assert rows[SPEC]["rms_position_settled_mean"] > 2 * rows["pid"]["rms_position_settled_mean"]
    assert rows["pid"]["rms_position_settled_diff_high"] < 0  # compared with the user's

    tuned = _run([str(CONSOLE), "tune", "--benchmark", "v1", "--controllers",
                  "py:throwaway.slow:SlowPosition", "--seeds", "100-100", "--passes", "1",
                  "--out", "tuned"], work, packages)
    assert tuned.returncode == 0, tuned.stderr[-3000:]
    report = json.loads((work / "tuned" / "tuning.json").read_text())
    result = report["py:throwaway.slow:SlowPosition"]
    assert set(result["winner"]) == {"kx_per_mass"} and report["seeds"] == [100]
    assert result["winner"]["kx_per_mass"] > 4.0  # the soft start is left behind
    assert [trial["gains"]["kx_per_mass"] for trial in result["history"]] == \
        [4.0, 2.0, 2.8, 5.6, 8.0]

    script = (f"import gymnasium as gym, numpy as np, quad_dob_env\n"
              f"env = gym.make('QuadDOB/HoverResidual-v2', base_controller='{SPEC}')\n"
              "obs, info = env.reset(seed=3)\n"
              "for _ in range(200):\n"
              "    obs, reward, terminated, truncated, _ = env.step(np.zeros(4))\n"
              "    assert not terminated\n"
              "print(info['base_controller']['name'], info['base_controller']['kR'])\n")
    flown = _run([sys.executable, "-c", script], work, packages)
    assert flown.returncode == 0, flown.stderr[-3000:]
    assert flown.stdout.split() == ["example-pd", "60.0"]  # its describe(), in the env's info


@pytest.mark.slow
def test_check_controller_names_what_a_broken_controller_gets_wrong(outside):
    _, packages = outside
    (packages / "broken.py").write_text('''
import numpy as np
from quad_dob_baselines import Controller, NonlinearDisturbanceObserver, make_controller
from quad_dob_baselines.geometric import GeometricController
from quad_dob_env.params import get_vehicle

class MixesTheBatch(Controller):
    def compute(self, time, state, reference):
        error = state.position - reference.position
        thrust = np.full(self.n, self.vehicle.hover_thrust) - 4.0 * error[:, 2].mean()
        return thrust, np.zeros((self.n, 3))

class WrongShape(Controller):
    def compute(self, time, state, reference):
        return np.zeros((self.n, 1)), np.zeros(3)

class WritesState(Controller):
    def compute(self, time, state, reference):
        state.position -= reference.position
        return np.full(self.n, 1.0), np.zeros((self.n, 3))

class ScalesVelocity(Controller):
    """an in-place write the first step of a hover hides: its velocity is exactly zero"""
    def compute(self, time, state, reference):
        state.velocity *= 0.5
        return np.full(self.n, self.vehicle.hover_thrust), np.zeros((self.n, 3))

class ZeroesReferenceJerk(Controller):
    def compute(self, time, state, reference):
        reference.jerk[:] = 0.0
        return np.full(self.n, self.vehicle.hover_thrust), np.zeros((self.n, 3))

class Transposed(Controller):
    def compute(self, time, state, reference):
        return np.full(self.n, self.vehicle.hover_thrust), np.zeros((3, self.n))

class ForgetsEveryone(GeometricController):
    """geometric + NDOB whose restart of some vehicles wipes every vehicle's estimate"""
    has_inner_law = False
    def __init__(self):
        super().__init__(observer=NonlinearDisturbanceObserver.from_rates(
            40, 5, get_vehicle("paper")))
    def reset(self, num_vehicles, vehicle, dt, indices=None, actuation="rotors"):
        super().reset(num_vehicles, vehicle, dt, None, actuation)

def dead_gain(vehicle, kx=1.0):
    return make_controller("pid", vehicle)  # kx goes nowhere
dead_gain.tunable_gains = {"kx": 1.0}

class NotAController:
    pass
''')
    (packages / "syntax_error.py").write_text("def broken(:\n")
    sys.path.insert(0, str(packages))
    try:
        mixes = check_controller("py:broken:MixesTheBatch")
        assert any("depend on its own rows only" in p for p in mixes), mixes
        assert any("strayed" in p or "ended early" in p for p in mixes), mixes
        shape = check_controller("py:broken:WrongShape")
        assert shape == ["py:broken:WrongShape: compute returned thrust (4, 1) and moment (3,) "
                         "for 4 vehicles; the interface wants (4,) and (4, 3)"]
        assert "moment (3, 4) for 4 vehicles" in check_controller("py:broken:Transposed")[0]
        assert check_controller("py:broken:ForgetsEveryone") == [
            "py:broken:ForgetsEveryone: reset(indices=[1]) changed the next command of "
            "vehicles 0, 2 and 3 too: a restart must clear the state of the given rows only"]
        assert check_controller("py:broken:dead_gain") == [
            "py:broken:dead_gain declares tunable gain 'kx', but kx=1.5 flies the first 100 "
            "steps exactly as kx=1: the tuning would search a gain that does nothing (is it "
            "passed on to the law?)"]
        assert "importing module 'syntax_error' failed: SyntaxError" in \
            check_controller("py:syntax_error:X")[0]
        assert any("wrote into state.position" in p
                   for p in check_controller("py:broken:WritesState"))
        assert any("wrote into state.velocity" in p
                   for p in check_controller("py:broken:ScalesVelocity"))
        assert any("wrote into reference.jerk" in p
                   for p in check_controller("py:broken:ZeroesReferenceJerk"))
        assert "does not derive from quad_dob_baselines.Controller" in \
            check_controller("py:broken:NotAController")[0]
        assert "has no 'Missing'; it defines ForgetsEveryone, MixesTheBatch, NotAController, " \
            "ScalesVelocity, Transposed, WritesState, WrongShape, ZeroesReferenceJerk, " \
            "dead_gain" in \
            check_controller("py:broken:Missing")[0]
        assert "cannot import module 'not_there'" in check_controller("py:not_there:X")[0]
        sloppy = check_controller("py:example_pd.controller:HoverPD")
        assert sloppy == []  # the example takes its gains by name and refuses others
    finally:
        sys.path.remove(str(packages))
        for name in [m for m in sys.modules
                     if m.startswith(("broken", "example_pd", "syntax_error"))]:
            del sys.modules[name]
    for builtin in ("geometric-ndob:tuned", "indi", "pid"):
        assert check_controller(builtin) == []


def test_a_bad_user_name_is_named_with_what_is_allowed():
    with pytest.raises(ValueError, match=r"py:package\.module:Name \(the module to import"):
        make_controller("py:no_colon_here")
    with pytest.raises(ValueError, match=r"unknown controller 'pdi'.*py:package.module:Name"):
        make_controller("pdi")
    with pytest.raises(ValueError, match=r"unknown policy 'sac'.*td3:PATH"):
        make_policy("sac")


def _installed(packages: Path, extra: dict[str, str]) -> dict[str, str]:
    """What ``pip install examples/byo_controller`` leaves for importlib.metadata: a
    dist-info with the entry points its pyproject.toml declares (and ``extra`` ones);
    those of the pyproject."""
    import tomllib

    project = tomllib.loads((EXAMPLE / "pyproject.toml").read_text())["project"]
    declared = project["entry-points"]["quad_dob_env.controllers"]
    info = packages / f"{project['name'].replace('-', '_')}-{project['version']}.dist-info"
    info.mkdir()
    (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {project['name']}\n"
                                   f"Version: {project['version']}\n")
    (info / "entry_points.txt").write_text("[quad_dob_env.controllers]\n" + "".join(
        f"{k} = {v}\n" for k, v in {**declared, **extra}.items()))
    return declared


@pytest.mark.slow
def test_an_installed_package_registers_a_controller_by_name_but_cannot_shadow_one(outside):
    work, packages = outside
    declared = _installed(packages, {"pid": "example_pd.controller:HoverPD",
                                     "residual": "example_pd.controller:HoverPD",
                                     "ppo:runs/x": "example_pd.controller:HoverPD"})
    assert declared == {"example-pd": "example_pd.controller:HoverPD"}
    toml = (EXAMPLE.parents[1] / "docs" / "your-controller.md").read_text()
    assert 'example-pd = "example_pd.controller:HoverPD"' in toml  # the page shows this file
    script = ("import warnings\n"
              "from quad_dob_baselines import make_controller, controller_names\n"
              "with warnings.catch_warnings(record=True) as caught:\n"
              "    warnings.simplefilter('always')\n"
              "    found = make_controller('example-pd', 'paper', 'v2')\n"
              "    builtin = make_controller('pid')\n"
              "    names = controller_names()\n"
              "    from quad_dob_training.policies import make_policy\n"
              "    shipped = make_policy('residual')\n"
              "print(type(found).__name__, found.name, type(builtin).__name__)\n"
              "print('example-pd' in names, names.count('pid'), 'residual' in names,\n"
              "      shipped.model is not None)\n"
              "for w in caught: print(w.message)\n")
    done = _run([sys.executable, "-c", script], work, packages)
    assert done.returncode == 0, done.stderr[-3000:]
    first, second, *warnings = done.stdout.splitlines()
    assert first == "HoverPD example-pd CascadedPID" and second == "True 1 False True"
    for taken in ("pid", "residual", "ppo:runs/x"):
        assert any(f"quad-dob-example-pd registers a controller named {taken!r}" in w
                   for w in warnings), (taken, warnings)
    evaluated = _run([str(CONSOLE), "evaluate", "--policies", "example-pd", "--scenarios",
                      "hover-calm", "--seeds", "2", "--baseline", "", "--json"], work, packages)
    assert evaluated.returncode == 0, evaluated.stderr[-3000:]
    assert json.loads(evaluated.stdout)[0]["policy"] == "example-pd"
    listed = _run([str(CONSOLE), "list"], work, packages)
    assert "installed by packages (entry points quad_dob_env.controllers): example-pd" in \
        listed.stdout


def test_the_template_builds_and_the_builtin_names_are_untouched():
    assert isinstance(make_controller("pid"), CascadedPID)
    assert Controller.tunable_gains == {} and Controller.estimator_bandwidths == ()


@pytest.mark.slow
@pytest.mark.parametrize("algo", ["sac", "td3"])
def test_sac_and_td3_zips_evaluate_by_their_prefix(algo, tmp_path, capsys):
    run = tmp_path / algo
    assert main(["train", "--algo", algo, "--mode", "residual", "--env",
                 "QuadDOB/HoverResidual-v1", "--timesteps", "256", "--n-envs", "2",
                 "--evaluate-every", "256", "--no-progress", "--out", str(run)]) == 0
    capsys.readouterr()
    assert main(["evaluate", "--policies", f"{algo}:{run}", "--scenarios", "hover-calm",
                 "--seeds", "2", "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)
    assert [row["policy"] for row in rows] == [f"{algo}:{algo}"]
    assert np.isfinite(rows[0]["rms_position_settled_mean"])
    with pytest.raises(ValueError, match=rf"trained with {algo}.*name it {algo}:"):
        make_policy(f"ppo:{run}")


def test_tune_refuses_a_declared_bandwidth_above_the_cap_and_keeps_small_gains(outside):
    from quad_dob_training.tuning import tune

    _, packages = outside
    (packages / "declared.py").write_text('''
from typing import ClassVar
from quad_dob_baselines import GeometricController

class FastFilter(GeometricController):
    tunable_gains: ClassVar[dict[str, float]] = {"kv_per_mass": 5.6, "bandwidth": 80.0}
    estimator_bandwidths: ClassVar[tuple[str, ...]] = ("bandwidth",)

class TinyGain(GeometricController):
    tunable_gains: ClassVar[dict[str, float]] = {"leak": 2e-7}
''')
    sys.path.insert(0, str(packages))
    try:
        with pytest.raises(ValueError, match=r"starts estimator bandwidth 'bandwidth' at 80 "
                                             r"rad/s, above the cap of 40"):
            tune.start_gains("py:declared:FastFilter")
        assert tune.start_gains("py:declared:TinyGain") == {"leak": 2e-7}
        assert tune.searched_gains("py:declared:TinyGain") == ("leak",)
        assert [tune._rounded(2e-7 * f) for f in tune.FACTORS] == [1e-7, 1.4e-7, 2.8e-7, 4e-7]
    finally:
        sys.path.remove(str(packages))
        sys.modules.pop("declared", None)
