"""A reproduction to read: ``repro_code(config)``, a few lines of Python a user could paste
that build the configuration's env (``gym.make`` or ``gym.make_vec``, in its wrappers) and
fly random actions.
"""

from __future__ import annotations

import math
from typing import Any


def _literal(value: Any) -> str:
    if isinstance(value, float) and not math.isfinite(value):
        return f"float({str(value)!r})"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{k!r}: {_literal(v)}" for k, v in value.items()) + "}"
    if isinstance(value, (list, tuple)):
        inner = ", ".join(_literal(v) for v in value)
        if isinstance(value, list):
            return f"[{inner}]"
        return f"({inner},)" if len(value) == 1 else f"({inner})"
    return repr(value)


def repro_code(config: dict[str, Any]) -> str:
    """A few lines of Python that build the configuration's env and fly random actions."""
    kwargs = dict(config["kwargs"])
    args = "".join(f", {k}={_literal(v)}" for k, v in kwargs.items())
    if config["mode"] == "single":
        make = f"env = gym.make({config['env_id']!r}{args})"
        shape = "4"
    else:
        make = (f"env = gym.make_vec({config['env_id']!r}, num_envs={config['num_envs']!r}, "
                f"vectorization_mode={config['mode']!r}{args})")
        shape = f"({config['num_envs']}, 4)"
    if config["mode"] == "sync" and "autoreset_mode" in kwargs:
        make = make.replace(f", autoreset_mode={kwargs['autoreset_mode']!r}",
                            f", vector_kwargs={{'autoreset_mode': "
                            f"AutoresetMode({kwargs['autoreset_mode']!r})}}")
    elif "autoreset_mode" in kwargs:
        make = make.replace(f"autoreset_mode={kwargs['autoreset_mode']!r}",
                            f"autoreset_mode=AutoresetMode({kwargs['autoreset_mode']!r})")
    wrapped = [f"env = gym.wrappers{'' if config['mode'] == 'single' else '.vector'}.{name}(env)"
               for name in config.get("wrappers", ())]
    return "\n".join([
        "import gymnasium as gym, numpy as np",
        "from gymnasium.vector import AutoresetMode",
        "import quad_dob_env",
        make,
        *wrapped,
        f"obs, info = env.reset(seed={config['seed']})",
        "rng = np.random.default_rng(0)",
        f"for _ in range({config['steps']}):",
        f"    obs, reward, terminated, truncated, info = env.step(rng.uniform(-1, 1, {shape}))",
    ])
