"""The docs pages generated from the code, and the MkDocs hook that holds them to it.

- ``environments/ID.md``, one per registered id (``quad_dob_env.ENV_IDS``, ``ENV_IDS_V2``,
  ``ENV_IDS_V3``, ``ENV_IDS_V4``):
  the env made with ``gym.make`` and its spaces, default scenario, loop, base controller,
  episode length and version history read off it.
  Each page has tables for the id's default options, read off the env and the code's own
  tables: the observation entries (``observation_table``: name, unit, range, columns), the
  action entries (``ActionMap``, or the residual's range), the reward terms and the end
  conditions (``TerminationCode``, its comments, and the env's ``EpisodeLimits``).
- ``cli.md``: ``quad-dob --help`` and each command's ``--help``, as the parser prints them.
- ``scenarios.md``'s table of every registered scenario (``SCENARIOS``), between the two
  ``<!-- generated ... -->`` marks; the prose around it is written by hand.

``on_config`` lists ``docs/research/*.md`` as the nav's "Research notes" section, so a new
note needs no edit of ``mkdocs.yml``.

The pages are committed, so they read on a plain checkout too; ``python docs/hooks.py``
writes them again, and the docs build (``mkdocs build``) fails on one that is stale.
"""

from __future__ import annotations

import contextlib
import io
import math
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
    "v4": "v3's loop with five mechanisms corrected against Neural-Fly's logs: the "
          "estimators told the autopilot's command (INDI modelling its actuators), the drag "
          "fitted in the simulator's tilted equilibrium, the rotors' vibration as tones "
          "through the IMU's chain, an identified throttle curve, the tunnel's reference "
          "from rest",
}


def page_name(env_id: str) -> str:
    return f"environments/{env_id.replace('/', '-')}.md"


def generated_pages() -> dict[str, str]:
    """Each generated page's path under ``docs/`` and its content."""
    import quad_dob_env

    pages = {page_name(env_id): env_page(env_id)
             for env_id in quad_dob_env.ALL_ENV_IDS}
    pages["cli.md"] = cli_page()
    pages["scenarios.md"] = scenarios_page((DOCS / "scenarios.md").read_text())
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


RESEARCH_SECTION = "Research notes"


def research_pages() -> list[str]:
    """``docs/research/*.md`` in name order, as paths under ``docs/``."""
    return [f"research/{path.name}" for path in sorted((DOCS / "research").glob("*.md"))]


def page_title(name: str) -> str:
    """A page's first ``# `` heading, or its file name."""
    for line in (DOCS / name).read_text().splitlines():
        if line.startswith("# "):
            return line[2:].strip()
    return Path(name).stem


def on_config(config):
    """MkDocs: fill the nav's "Research notes" section with every ``docs/research/*.md``."""
    for entry in config["nav"] or []:
        if isinstance(entry, dict) and RESEARCH_SECTION in entry:
            entry[RESEARCH_SECTION] = [{page_title(name): name} for name in research_pages()]
    return config


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
    residual = quad_dob_env.is_residual_id(env_id)
    version = env_id.rsplit("-", 1)[1]
    family = env_id.rsplit("-", 1)[0]
    other = f"{family}-{'v2' if version != 'v2' else 'v1'}"
    known = set(quad_dob_env.ALL_ENV_IDS)
    spec = gym.spec(env_id)  # the entry points as registered
    entry, vector = spec.entry_point, spec.vector_entry_point
    rows = [
        ("made by", f"`gym.make(\"{env_id}\")`; N vehicles: `gym.make_vec(\"{env_id}\", "
                    "num_envs=N, vectorization_mode=\"vector_entry_point\")`"),
        ("entry points", f"`{entry}`; vector: `{vector}`"),
        ("default scenario", f"`{scenario.name}`: {scenario.description}"),
        ("loop", f"Benchmark {scenario.loop.benchmark}: " + LOOPS[scenario.loop.benchmark]),
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
    lines = [f"# {env_id}", "", "| property | value |", "|---|---|",
             *(f"| {key} | {value} |" for key, value in rows), ""]
    lines += ["The tables below are for the id's default options, generated from the code "
              "(`docs/hooks.py`). The observation, action, reward, start and end are those of "
              "[`QuadrotorEnv`](../api.md#quad_dob_env.envs.QuadrotorEnv)"
              + (", with the base's command and its observer's estimates appended to the "
                 "observation and the action a residual on that command, as "
                 "[`quad_dob_env.residual`](../api.md#quad_dob_env.residual) "
                 "describes" if residual else "") + ".", ""]
    lines += observation_section(env, residual)
    lines += action_section(env, residual)
    lines += reward_section(env, residual)
    lines += end_section(env)
    lines += ["## Version history", ""]
    if version == "v3":
        lines += [f"- v3 (2026-12-04): the scenario of `{other}` in Benchmark v3's loop (the "
                  "real vehicle's lag and thrust path, every value sourced: "
                  "[Benchmark v3](../benchmark-v3.md)), its controllers at the gains v3's "
                  "own search chose for that loop (shipped 2026-12-05; a name with no v3 set "
                  "of its own flies its v2 set). "
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


def residual_command(env):
    """The residual env's ``ResidualCommand`` (its options, range and weights)."""
    return env.get_wrapper_attr("residual")


def _range(bounds: tuple[float, float]) -> str:
    low, high = bounds
    if math.isinf(low) and math.isinf(high):
        return "(-∞, ∞)"
    return f"[{low:g}, {high:g}]"


def _columns(entry) -> str:
    first, last = entry.columns.start, entry.columns.stop - 1
    return str(first) if first == last else f"{first}-{last}"


def observation_rows(env, residual: bool, rotation_representation: str | None = None):
    """The observation entries of ``env``'s layout, placed (``observation_table``)."""
    from quad_dob_env.envs.observation import observation_table

    core = env.unwrapped.core
    options = residual_command(env).options if residual else None
    return observation_table(rotation_representation or core.rotation_representation, options)


def observation_section(env, residual: bool) -> list[str]:
    from quad_dob_env.envs.observation import ROTATION_ENTRIES, observation_size
    from quad_dob_env.residual.observation import RESIDUAL_ENTRIES

    table = observation_rows(env, residual)
    size = observation_size(table)
    lines = ["## Observation space", "",
             f"`{env.observation_space}`: {size} columns, world frame unless stated. Every "
             "value is clamped to float32's range, so it stays finite; the range below is "
             "the one an entry takes by construction.", "",
             "| columns | entry | what | unit | range |", "|---|---|---|---|---|"]
    lines += [f"| {_columns(e)} | `{e.name}` | {e.description} | {e.unit} | {_range(e.bounds)} |"
              for e in table]
    core = env.unwrapped.core
    lines += ["", "Options that change the observation:", ""]
    for name, entry in ROTATION_ENTRIES.items():
        if name != core.rotation_representation:
            other = observation_size(observation_rows(env, residual, name))
            lines.append(f"- `rotation_representation=\"{name}\"`: `rotation` is {entry.size} "
                         f"columns ({entry.description}), so the observation has {other}.")
    extra = observation_size(RESIDUAL_ENTRIES)
    if residual:
        lines.append(f"- `base_controller=` picks the base whose command and estimates fill "
                     f"the last {extra} columns; every residual option set has the same "
                     "entries (`ResidualOptions` adds none).")
    else:
        lines.append(f"- a base controller (the `...Residual` ids, or `base_controller=` on "
                     f"`ResidualQuadrotorVectorEnv`) appends the residual's {extra} columns: "
                     + ", ".join(f"`{e.name}`" for e in RESIDUAL_ENTRIES) + ".")
    return [*lines, ""]


def action_section(env, residual: bool) -> list[str]:
    from quad_dob_env.envs.actions import ACTION_MODES, MAX_RATE_COMMAND

    core = env.unwrapped.core
    vehicle, moment = core.vehicle, core.actuator.moment_limit
    lines = ["## Action space", ""]
    if residual:
        command = residual_command(env)
        options = command.options
        scale = command.residual_range
        lines += [f"`{env.action_space}`: a residual on the base's command, clipped to "
                  f"[-1, 1]; `residual_mode=\"{options.residual_mode}\"`.", "",
                  "| entry | adds to the base's | at ±1 |", "|---|---|---|"]
        if options.residual_mode == "thrust_moments":
            lines += [f"| 0 | collective thrust (`thrust_scale` {options.thrust_scale:g} of "
                      f"{vehicle.max_total_thrust:g} N) | ±{scale[0]:.4g} N |"]
            lines += [f"| {i} | moment M{axis} (`moment_scale` {options.moment_scale:g} of "
                      f"{moment[i - 1]:.4g} N m) | ±{scale[i]:.4g} N m |"
                      for i, axis in enumerate("xyz", start=1)]
        else:
            lines += [f"| {i} | acceleration Δa{axis} in its force law (world frame) | "
                      f"±{options.acceleration_scale:g} m/s² |"
                      for i, axis in enumerate("xyz")]
            lines += [f"| 3 | yaw moment Mz | ±{scale[3]:.4g} N m |"]
        lines += ["", "Options: `residual_mode=\"acceleration\"` (entries 0-2 a world-frame "
                  "acceleration `acceleration_scale` · a in the base's force law, entry 3 the "
                  "yaw moment; geometric bases only), `thrust_scale`, `moment_scale`, "
                  "`authority_gate`, `floor_fade`: the [residual's options]"
                  "(../api.md#quad_dob_env.residual).", ""]
        return lines
    mode = core.action_map.action_mode
    lines += [f"`{env.action_space}`, `action_mode=\"{mode}\"`. Each entry maps "
              "piecewise-linearly, 0 at hover: [-1, 0, 1] -> [0, hover, max]; values outside "
              "[-1, 1] are clipped.", "",
              "| entry | commands | -1 | 0 | 1 |", "|---|---|---|---|---|"]
    hover, top = vehicle.hover_thrust, vehicle.max_total_thrust
    if mode in ("thrust_moments", "thrust_rates"):
        lines.append(f"| 0 | collective thrust [N] | 0 | {hover:.4g} | {top:.4g} |")
        for i, axis in enumerate("xyz", start=1):
            if mode == "thrust_moments":
                lines.append(f"| {i} | moment M{axis} [N m] | {-moment[i - 1]:.4g} | 0 | "
                             f"{moment[i - 1]:.4g} |")
            else:
                lines.append(f"| {i} | body rate ω{axis} [rad/s] | {-MAX_RATE_COMMAND:g} | 0 | "
                             f"{MAX_RATE_COMMAND:g} |")
    else:
        lines += [f"| {i} | thrust of rotor {i + 1} [N] | 0 | {hover / 4:.4g} | "
                  f"{vehicle.max_rotor_thrust:.4g} |" for i in range(4)]
    others = [f"`\"{m}\"`" for m in ACTION_MODES if m != mode]
    lines += ["", f"Other `action_mode`s: {', '.join(others)} (the table in "
              "[`QuadrotorEnv`](../api.md#quad_dob_env.envs.QuadrotorEnv)). NaN or ±inf "
              "raise `ValueError`, or with `invalid_actions=\"terminate\"` end the episode.",
              ""]
    return lines


def reward_section(env, residual: bool) -> list[str]:
    weights = env.unwrapped.core.reward_weights
    lines = ["## Reward", "", "The sum of these terms each step (a the action):", "",
             "| term | formula | weight |", "|---|---|---|",
             f"| tracking | exp(-‖x - x_d‖ / `reward_position_scale`) | 1, scale "
             f"{weights.position_scale:g} m |"]
    if residual:
        command = residual_command(env)
        lines += [f"| residual effort | -`residual_effort_weight` · mean(a²) | "
                  f"{command.effort_weight:g} |",
                  f"| residual rate | -`residual_rate_weight` · mean((a - a_prev)²), a_prev "
                  f"the step before's | {command.rate_weight:g} |",
                  f"| env effort | -`reward_effort_weight` · mean(action²) | "
                  f"{weights.effort_weight:g} (off: only the residual's own effort is "
                  "penalised) |"]
    else:
        lines.append(f"| effort | -`reward_effort_weight` · mean(a²) | "
                     f"{weights.effort_weight:g} |")
    return [*lines, "", "The tracking term is 1 on the reference and positive near it, so "
            "ending early never pays.", ""]


def termination_comments() -> dict[str, str]:
    """Each ``TerminationCode`` member's comment in ``termination.py``, by name."""
    import inspect

    from quad_dob_env.envs import termination

    comments = {}
    for line in inspect.getsource(termination.TerminationCode).splitlines():
        found = re.match(r"\s+([A-Z_]+) = \d+\s+# (.+)", line)
        if found:
            comments[found.group(1)] = found.group(2)
    return comments


def end_section(env) -> list[str]:
    from quad_dob_env.envs.termination import TIME_LIMIT, TerminationCode

    core = env.unwrapped.core
    limits, floor = core.limits, core.scenario.floor_height
    values = {
        "CRASHED": ("this scenario's floor is at "
                    f"{floor:g} m" if floor is not None else "this scenario has no floor"),
        "OUT_OF_BOUNDS": f"max_position_error = {limits.max_position_error:g} m",
        "ATTITUDE_LOST": (f"max_tilt = {math.degrees(limits.max_tilt):g}°, max_body_rate = "
                          f"{limits.max_body_rate:g} rad/s"),
    }
    comments = termination_comments()
    lines = ["## Episode end", "",
             "`terminated` with `info[\"termination_reason\"]` (`TerminationCode`):", "",
             "| reason | code | when | here |", "|---|---|---|---|"]
    for code in TerminationCode:
        if code is TerminationCode.FLYING:
            continue
        lines.append(f"| `{code.reason}` | {int(code)} | {comments.get(code.name, '')} | "
                     f"{values.get(code.name, '')} |")
    scenario = core.scenario
    lines += ["", f"`truncated` with reason `{TIME_LIMIT}` after {scenario.steps} steps "
              f"({scenario.duration:g} s), the scenario's end.", ""]
    return lines


SCENARIOS_BEGIN = "<!-- generated from quad_dob_env.scenarios.SCENARIOS by docs/hooks.py -->"
SCENARIOS_END = "<!-- end of the generated table -->"


def scenarios_page(text: str) -> str:
    """``text`` (scenarios.md) with the table between the marks made again from
    ``SCENARIOS``: every registered scenario, its default build's description, episode and
    vehicle, and the ids that fly it by default."""
    import quad_dob_env
    from quad_dob_env.scenarios import SCENARIOS, make_scenario

    ids = quad_dob_env.ALL_ENV_IDS
    rows = ["| name | what | episode | vehicle | default of |", "|---|---|---|---|---|"]
    for name in SCENARIOS:
        scenario = make_scenario(name)
        of = ", ".join(f"[`{env_id.split('/')[1]}`]({page_name(env_id)})"
                       for env_id, default in ids.items() if default == name)
        rows.append(f"| `{name}` | {scenario.description} | {scenario.duration:g} s at "
                    f"{1 / scenario.dt:g} Hz | `{scenario.vehicle.name}` | {of} |")
    start, end = text.index(SCENARIOS_BEGIN), text.index(SCENARIOS_END)
    return (text[:start] + SCENARIOS_BEGIN + "\n\n" + "\n".join(rows) + "\n\n"
            + text[end:])


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
