"""The docs pages generated from the code, and the MkDocs hook that holds them to it.

- ``environments/ID.md``, one per registered id (``quad_dob_env.ENV_IDS``, ``ENV_IDS_V2``,
  ``ENV_IDS_V3``):
  the env made with ``gym.make`` and its spaces, default scenario, loop, base controller,
  episode length and version history read off it.
- ``cli.md``: ``quad-dob --help`` and each command's ``--help``, as the parser prints them.

The pages are committed, so they read on a plain checkout too; ``python docs/hooks.py``
writes them again, and the docs build (``mkdocs build``) fails on one that is stale.
"""

from __future__ import annotations

import contextlib
import io
import os
import re
import warnings
from pathlib import Path

DOCS = Path(__file__).parent

# what each benchmark's loop is, in a line
LOOPS = {
    "v1": "the ideal loop (true state, instant actuators)",
    "v2": "`mocap` sensing through a state estimator, the 200 Hz inner loop, speed motors, "
          "thrust uncertainty and rotor aerodynamics",
    "v3": "v2's loop with the real vehicle's lag and thrust path: measured motor time "
          "constants, the autopilot's 30 Hz gyro low-pass, the pose's latency on the inner "
          "loop's grid, the throttle map with the battery's spread and drift, vibration on "
          "the IMU and the controllers' model off the truth",
}


def page_name(env_id: str) -> str:
    return f"environments/{env_id.replace('/', '-')}.md"


def generated_pages() -> dict[str, str]:
    """Each generated page's path under ``docs/`` and its content."""
    import quad_dob_env

    pages = {page_name(env_id): env_page(env_id)
             for env_id in [*quad_dob_env.ENV_IDS, *quad_dob_env.ENV_IDS_V2,
                            *quad_dob_env.ENV_IDS_V3]}
    pages["cli.md"] = cli_page()
    return pages


def stale_pages() -> list[str]:
    return [name for name, content in generated_pages().items()
            if not (DOCS / name).is_file() or (DOCS / name).read_text() != content]


def on_pre_build(config) -> None:
    """MkDocs: refuse to build with a generated page that no longer matches the code."""
    from mkdocs.exceptions import PluginError

    stale = stale_pages()
    if stale:
        raise PluginError(f"generated docs pages are stale: {', '.join(stale)}; run "
                          "`python docs/hooks.py` to write them again")


def write_pages() -> None:
    for name, content in generated_pages().items():
        (DOCS / name).parent.mkdir(parents=True, exist_ok=True)
        (DOCS / name).write_text(content)
        print(f"wrote docs/{name}")


def env_page(env_id: str) -> str:
    import gymnasium as gym

    import quad_dob_env

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # Gymnasium's "a newer version exists"
        env = gym.make(env_id)
    core = env.unwrapped
    scenario = core.scenario
    residual = "Residual" in env_id
    version = env_id.rsplit("-", 1)[1]
    family = env_id.rsplit("-", 1)[0]
    other = f"{family}-{'v2' if version != 'v2' else 'v1'}"
    known = {*quad_dob_env.ENV_IDS, *quad_dob_env.ENV_IDS_V2, *quad_dob_env.ENV_IDS_V3}
    spec = gym.spec(env_id)  # the entry points as registered
    entry, vector = spec.entry_point, spec.vector_entry_point
    rows = [
        ("made by", f"`gym.make(\"{env_id}\")`; N vehicles: `gym.make_vec(\"{env_id}\", "
                    "num_envs=N, vectorization_mode=\"vector_entry_point\")`"),
        ("entry points", f"`{entry}`; vector: `{vector}`"),
        ("default scenario", f"`{scenario.name}`: {scenario.description}"),
        ("loop", f"Benchmark {scenario.benchmark}: " + LOOPS[scenario.benchmark]),
        ("vehicle", f"`{scenario.vehicle.name}`, {scenario.vehicle.mass:g} kg"),
        ("action space", f"`{env.action_space}`"),
        ("observation space", f"`{env.observation_space}`"),
        ("episode", f"{scenario.steps} steps of {scenario.dt:g} s ({scenario.duration:g} s), "
                    "then `truncated` (`time_limit`)"),
    ]
    if residual:
        base = core.base_controller
        gains = ", ".join(f"{k} {v:.4g}" for k, v in base.items()
                          if isinstance(v, float))
        rows.append(("base controller", f"`{base['name']}` ({gains}); any controller name, "
                                        "or `py:package.module:Name`, by `base_controller=`"))
    lines = [f"# {env_id}", "", "| | |", "|---|---|",
             *(f"| {key} | {value} |" for key, value in rows), ""]
    lines += ["## Spaces, reward and episode end", "",
              "The observation, action, reward, start and end are those of "
              "[`QuadrotorEnv`](../api.md#quad_dob_env.envs.QuadrotorEnv)"
              + (", with the base's command and its observer's estimates appended to the "
                 "observation and the action a residual on that command, as "
                 "[`quad_dob_env.residual`](../api.md#quad_dob_env.residual) "
                 "describes" if residual else "")
              + "; the [overview](../environments.md) has them in short.", ""]
    lines += ["## Version history", ""]
    if version == "v3":
        lines += [f"- v3 (2026-12-04): the scenario of `{other}` in Benchmark v3's loop (the "
                  "real vehicle's lag and thrust path, every value sourced: "
                  "[Benchmark v3](../benchmark-v3.md)); until v3's own search has run, its "
                  "controllers fly the gains tuned for v2. "
                  f"`{other}` stays registered and flies as before."]
    elif version == "v2":
        lines += [f"- v2 (2026-12-02): the scenario of `{other}` in Benchmark v2's loop, its "
                  "controllers at the gains tuned for that loop"
                  + (f"; `{other}` stays registered and flies as before." if other in known
                     else ".")]
    else:
        lines += ["- v1: the benchmark's first version; every change within v1 is in the "
                  "[overview's version history](../environments.md#version-history)"
                  + (f"; `{other}` flies the same scenario in Benchmark v2's loop." if
                     other in known else ".")]
    env.close()
    return "\n".join(lines) + "\n"


def cli_page() -> str:

    top = _help([])
    commands = re.search(r"\{([a-z,-]+)\}", top).group(1).split(",")
    lines = ["# Command line", "",
             "`quad-dob` is installed with the project. Every value is checked before any "
             "work starts; a failure it can name comes back as `quad-dob: error: ...` with "
             "exit status 2. Each command's help, as it prints it:", "",
             "```text", top.rstrip(), "```", ""]
    for command in commands:
        lines += [f"## quad-dob {command}", "", "```text", _help([command]).rstrip(), "```",
                  ""]
    return "\n".join(lines)


def _help(words: list[str]) -> str:
    from quad_dob_training.cli.commands import build_parser

    out = io.StringIO()
    columns = os.environ.get("COLUMNS")
    os.environ["COLUMNS"] = "100"  # argparse wraps to the terminal: the page, to 100
    try:
        with contextlib.redirect_stdout(out), contextlib.suppress(SystemExit):
            build_parser().parse_args([*words, "--help"])
    finally:
        if columns is None:
            del os.environ["COLUMNS"]
        else:
            os.environ["COLUMNS"] = columns
    return out.getvalue()


if __name__ == "__main__":
    write_pages()
