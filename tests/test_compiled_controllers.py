"""The compiled controller equations equal the same source run as plain Python."""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np

# Three control steps of geometric + NDOB for 300 vehicles (above the threaded-kernel
# threshold) in random states, with the observer advanced between them.
SCRIPT = """
import sys
import numpy as np
from quad_dob_baselines import kernels, make_controller
from quad_dob_env.dynamics import VehicleState
from quad_dob_env.params import get_vehicle
from quad_dob_env.so3 import exp
from quad_dob_env.trajectories import Reference

rng = np.random.default_rng(7)
n = 300
vehicle = get_vehicle("paper")
controller = make_controller("geometric-ndob:tuned", vehicle)
controller.reset(n, vehicle, 0.01)
out = {}
for step in range(3):
    state = VehicleState(rng.normal(size=(n, 3)), rng.normal(size=(n, 3)),
                         exp(rng.normal(size=(n, 3))), rng.normal(size=(n, 3)))
    yaw = rng.uniform(-np.pi, np.pi, n)
    heading = np.stack([np.cos(yaw), np.sin(yaw), np.zeros(n)], 1)
    reference = Reference(*[rng.normal(size=(n, 3)) for _ in range(5)], heading,
                          0.3 * rng.normal(size=(n, 3)), 0.3 * rng.normal(size=(n, 3)))
    thrust, moment = controller.compute(np.zeros(n), state, reference)
    out[f"thrust{step}"], out[f"moment{step}"] = thrust, moment
    for key, value in controller.diagnostics.items():
        out[f"{key}{step}"] = value
    controller.applied(state, thrust, moment)
out["is_compiled"] = np.array(hasattr(kernels.geometric_law, "py_func"))
np.savez(sys.argv[1], **out)
"""


def _run(path, disable_jit: bool) -> dict:
    env = {**os.environ, "NUMBA_DISABLE_JIT": "1" if disable_jit else "0"}
    subprocess.run([sys.executable, "-c", SCRIPT, str(path)], env=env, check=True,
                   cwd=os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    return dict(np.load(path))


def test_compiled_geometric_ndob_equals_plain_python(tmp_path):
    compiled = _run(tmp_path / "compiled.npz", disable_jit=False)
    interpreted = _run(tmp_path / "interpreted.npz", disable_jit=True)
    assert compiled.pop("is_compiled") and not interpreted.pop("is_compiled")
    assert compiled.keys() == interpreted.keys()
    assert len(compiled) == 3 * 9
    for key, value in compiled.items():
        assert np.all(np.isfinite(value)), key
        np.testing.assert_allclose(value, interpreted[key], rtol=1e-13, atol=1e-12, err_msg=key)
    # the observer did move: its estimates are not all zero after the first step
    assert np.abs(compiled["force_estimate2"]).max() > 1e-3
