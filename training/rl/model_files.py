"""Model files: an SB3 zip and the training config beside it, loaded without running code.

Loading a model runs no code from its file. A stable-baselines3 zip holds JSON (``data``),
torch tensors (``*.pth``) and two text files; ``data`` carries some entries as cloudpickle
(``{":serialized:": ...}``), and unpickling is running whatever the file's author wrote.
``load_model`` therefore unpickles nothing:

- every pickled entry of ``data`` is handed to SB3 as ``custom_objects``, rebuilt: the
  observation and action spaces from the env the config beside the model describes (one
  vehicle of it; their shape and dtype checked against what ``data`` records in plain text),
  ``policy_class`` from the algorithm's own class for the config's ``policy`` name,
  ``learning_rate``, ``lr_schedule`` and ``clip_range`` as constants, ``train_freq`` from the
  config, and what only training uses (last observations, episode buffers, buffer classes,
  action noise, ``clip_range_vf``) as None, which SB3 fills with its defaults (a saved
  ``env``, which SB3 would make by its id, is None too);
- a zip with any other pickled entry (a custom policy class or features extractor, say) is
  refused, naming the entry; ``trust_pickle=True`` (``--trust-pickle``) loads it as SB3
  does, unpickling its entries (only the schedules are still skipped);
- the ``.pth`` files (weights, optimizer state, torch variables) are read first with torch's
  ``weights_only=True`` (tensors and plain containers only; SB3 2.9 reads them so itself,
  older versions need not), and one holding any other object is refused; the zip's two
  text files are not read.

The JSON's plain values (sizes, coefficients, ``policy_kwargs``) are used as saved. The
observation statistics come from the config (``observation_normalization``), never from a
pickled ``VecNormalize``. A run's own checkpoints, which ``quad-dob train --resume`` reads
with their pickled env, go through ``load_zip``, which unpickles.
"""

from __future__ import annotations

import hashlib
import io
import json
import sys
import zipfile
from pathlib import Path
from typing import Any

import yaml

from quad_dob_composition import make_vector_env
from quad_dob_env.memory import check_memory
from quad_dob_env.validation import unknown_name_error
from quad_dob_training.rl import ALGORITHMS, SHIPPED_SHA256
from quad_dob_training.rl.run_folder import zip_env_id, zip_run_id
from quad_dob_training.rl.vec_env import env_options

PRETRAINED = Path(__file__).parents[1] / "pretrained"
SHIPPED_RESIDUAL = PRETRAINED / "residual_random_tracks.zip"
# sha256 of the shipped zip and of the config beside it (base controller, env options,
# observation statistics: what the policy flies with), both checked before either is read
SHIPPED_RESIDUAL_SHA256 = SHIPPED_SHA256["v1"]
SHIPPED_RESIDUAL_CONFIG_SHA256 = "000896053c3fd23bf7ff3082e0c56301c6d8b1d93298bfb81e7049f1bd9aff52"
# the policy trained in Benchmark v2's loop (issue 29's recipe, the median of its seeds),
# ``residual:v2``; checked the same way
SHIPPED_RESIDUAL_V2 = PRETRAINED / "residual_v2.zip"
SHIPPED_RESIDUAL_V2_SHA256 = SHIPPED_SHA256["v2"]
SHIPPED_RESIDUAL_V2_CONFIG_SHA256 = (
    "2600763be939f9a93ac487073df10322be3730a28bd8c5829e4faa803e5e3839")
# the policy trained in Benchmark v3's loop (issue 42's recipe, QuadDOB/TracksResidual-v3;
# seed 2, the median of seeds 0-2 by mean RMS over the wind scenarios on its evaluation
# seeds 10000-10007: 35.0, 42.6, 39.9 mm), ``residual:v3``; checked the same way
SHIPPED_RESIDUAL_V3 = PRETRAINED / "residual_v3.zip"
SHIPPED_RESIDUAL_V3_SHA256 = SHIPPED_SHA256["v3"]
SHIPPED_RESIDUAL_V3_CONFIG_SHA256 = (
    "cb8e558f1abb9f0fda26fe475bebe3187542106f613defe421ff0022c380189a")
# the policy trained in Benchmark v4's loop (issue 56's recipe, QuadDOB/TracksResidual-v4;
# seed 1, the median of seeds 0-2 by the mean change against its base over eight scenarios
# on its evaluation seeds 10000-10007: -3.4, -4.3, -8.6 %), ``residual:v4``; checked the
# same way
SHIPPED_RESIDUAL_V4 = PRETRAINED / "residual_v4.zip"
SHIPPED_RESIDUAL_V4_SHA256 = SHIPPED_SHA256["v4"]
SHIPPED_RESIDUAL_V4_CONFIG_SHA256 = (
    "1ba65c67383df730fdd053c24b5a82bb557727089c288239b1c46de6c4074d8f")
def _check_env_id(path: Path, raw: bytes, told: str | None, env_id: str | None) -> None:
    """A zip flown without its config under ``env_id``: refused where the zip records
    another id (``quad-dob train`` saves it in the zip); one warning line where it records
    none and the id came from ``--env`` (``told``), as an SB3 zip's cannot be checked
    (an rl-zoo3 run's id comes from its own ``args.yml``)."""
    recorded = zip_env_id(path, raw)
    if recorded is not None and env_id is not None and recorded != env_id:
        raise ValueError(f"model file {str(path)!r} was trained on {recorded} (the zip "
                         f"records it), not {env_id}: give --env {recorded}")
    if recorded is None and told is not None:
        print(f"warning: {str(path)!r} records no env id (saved by stable-baselines3 "
              f"itself): flown as {told}, which cannot be checked", file=sys.stderr)


TRUST_PICKLE_HINT = ("only if you made the file or trust where it came from, load it with "
                     "--trust-pickle (trust_pickle=True), which unpickles the zip's entries")


def sha256(path: Path) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def model_zip(path: str | Path) -> Path:
    """The zip a model path names: a run folder's model (``foreign_models.model_in_folder``),
    or ``PATH.zip`` for a ``PATH`` that does not exist, as SB3's own save and load add the
    suffix."""
    from quad_dob_training.rl.foreign_models import model_in_folder

    path = Path(path)
    if path.is_dir():
        return model_in_folder(path)
    if not path.exists() and path.with_name(path.name + ".zip").is_file():
        return path.with_name(path.name + ".zip")
    return path


def load_model(path: str | Path, expected_sha256: str | None = None, *,
               expected_config_sha256: str | None = None,
               trust_pickle: bool = False, env_id: str | None = None,
               kind: str | None = None) -> tuple[Any, dict]:
    """An SB3 model and the training config saved beside it by ``quad-dob train``
    (``NAME.yaml`` beside ``NAME.zip``, else ``config.yaml``); ``path`` may be a run folder
    (its ``model.zip``, or an rl-zoo3 run's ``ENV.zip``).

    A zip with no config beside it (saved by SB3 or rl-zoo3) takes ``env_id``, the id it
    was trained on, which supplies what the config would (``foreign_models.config_for_id``;
    ``kind`` is the spec's ``ppo`` / ``sac`` / ``td3`` / ``residual``); an rl-zoo3 run's
    is the id its ``args.yml`` names where ``env_id`` is not given
    (``foreign_models.zoo_env_id``); without one it is refused, naming ``--env``. With
    ``env_id``, a ``config.yaml`` beside the zip that is no training config (another tool's)
    is ignored, and one naming another id is refused naming both (``_config_path``).

    Nothing in the zip is unpickled (see the module docstring): its pickled entries are
    rebuilt from the config and the env it describes, and a zip with one that cannot be is
    refused unless ``trust_pickle``, which loads it as stable-baselines3 does, running
    whatever its pickles hold. ``expected_sha256`` (the zip) and ``expected_config_sha256``
    (the config) are checked on the bytes that are then loaded, before either is parsed.
    """
    from quad_dob_training.rl.foreign_models import config_for_id, zoo_env_id

    path = model_zip(path)
    if not path.is_file():
        raise ValueError(f"policy file {str(path)!r} does not exist")
    told = env_id  # --env, as given
    if env_id is None and not path.with_name(path.stem + ".yaml").is_file() \
            and not (path.parent / "config.yaml").is_file():
        env_id = zoo_env_id(path)  # an rl-zoo3 run says what it was trained on
    config_path = _config_path(path, env_id)
    raw = _read(path, "policy file")
    _check_sha256(path, raw, expected_sha256, "policy file")
    if config_path is None:  # saved by SB3 or rl-zoo3: the id says what the config would
        if not zipfile.is_zipfile(io.BytesIO(raw)):
            raise _not_a_zip(path)
        _check_env_id(path, raw, told, env_id)
        config = config_for_id(env_id, kind or "ppo", path, _zip_data(raw, path),
                               trust_pickle=trust_pickle)
        source = f"--env {env_id}"
    else:
        config_bytes = _read(config_path, "training config")
        _check_sha256(config_path, config_bytes, expected_config_sha256, "training config")
        try:
            config = yaml.safe_load(config_bytes)
        except yaml.YAMLError as error:
            raise ValueError(f"training config {str(config_path)!r} is not valid YAML "
                             f"({(str(error).splitlines() or [''])[0]})") from None
        if not isinstance(config, dict):
            raise ValueError(f"training config {str(config_path)!r} is not a YAML mapping")
        source = f"its config {str(config_path)!r}"
    if not zipfile.is_zipfile(io.BytesIO(raw)):
        raise _not_a_zip(path)
    zip_id, config_id = zip_run_id(path, raw), config.get("run_id")
    if zip_id is not None and config_id is not None and zip_id != config_id:
        raise ValueError(f"model file {str(path)!r} is of run {zip_id} but "
                         f"{str(config_path)!r} beside it is of run {config_id} (a newer run "
                         "began in that folder and has not written its model yet): evaluate "
                         "it when that run has finished, or a model beside its own config")
    algo = config.get("algo", "ppo")
    if algo not in ALGORITHMS:
        raise ValueError(f"{source} names algorithm {algo!r}; this version loads "
                         + ", ".join(ALGORITHMS))
    algorithm = algorithm_class(algo)
    if trust_pickle:
        # the zip's own objects, as SB3 loads them; only the schedules (code pickled by
        # value, tied to the Python that made them, and needed by no flight) are skipped
        schedules = {"learning_rate": 0.0, "lr_schedule": _no_schedule,
                     "clip_range": _no_schedule}
        return _load(algorithm, io.BytesIO(raw), path, custom_objects=schedules), config
    data = _checked_archive(raw, path)
    entries = _rebuilt_entries(algorithm, config, data, path, source)
    return _load(algorithm, io.BytesIO(raw), path, custom_objects=entries), config


def load_weights(model: Any, path: str | Path) -> None:
    """A model zip's weights, optimizer state and torch variables into ``model`` (built
    from its run's config), and its timestep count; nothing is unpickled: the ``.pth`` files
    are read with ``weights_only=True`` and only a plain number of ``data``. What
    ``quad-dob train --resume MODEL.zip`` trains on from."""
    from stable_baselines3.common.save_util import load_from_zip_file, recursive_setattr

    path = Path(path)
    if not path.is_file():
        raise ValueError(f"model file {str(path)!r} does not exist")
    raw = _read(path, "model file")
    if not zipfile.is_zipfile(io.BytesIO(raw)):
        raise _not_a_zip(path)
    data = _checked_archive(raw, path)
    try:
        _, params, variables = load_from_zip_file(io.BytesIO(raw), device="cpu",
                                                  load_data=False)
    except Exception as error:  # zipfile, torch
        raise _damaged(path, error) from error
    try:
        model.set_parameters(params, exact_match=True, device="cpu")
    except Exception as error:  # missing or extra tensors, other shapes
        first_line = (str(error).splitlines() or [""])[0][:160]
        raise ValueError(f"the weights in {str(path)!r} do not fit the network the run's "
                         f"config builds ({type(error).__name__}: {first_line}): train with "
                         "the hyperparameters it was trained with (--conf-file)") from error
    for name, value in (variables or {}).items():  # SAC's entropy coefficient
        if value is not None:
            recursive_setattr(model, f"{name}.data", value.data)
    model.num_timesteps = int(data.get("num_timesteps", 0))


def algorithm_class(name: str) -> Any:
    """SB3's class for an ``ALGORITHMS`` name (imported here: torch takes seconds to load,
    and listing or evaluating controllers needs none of it)."""
    import stable_baselines3

    if name not in ALGORITHMS:
        raise unknown_name_error("algorithm", name, ALGORITHMS)
    return getattr(stable_baselines3, name.upper())


def load_zip(algorithm: Any, path: Path | str, **options: Any) -> Any:
    """``algorithm.load(path)``, with a cut-off or corrupted file named in a ValueError
    instead of a traceback from deep inside zipfile, torch or pickle.

    This unpickles what the zip holds, as SB3 does: it is for a run's own checkpoints
    (``quad-dob train --resume``); ``load_model`` loads models without unpickling."""
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"model file {str(path)!r} does not exist")
    if not zipfile.is_zipfile(path):
        raise _not_a_zip(path)
    return _load(algorithm, path, path, **options)


def _load(algorithm: Any, source: Path | io.BytesIO, path: Path, **options: Any) -> Any:
    try:
        return algorithm.load(source, device="cpu", **options)
    except Exception as error:  # zipfile, torch, pickle and json all raise their own
        raise _damaged(path, error) from error


def _not_a_zip(path: Path) -> ValueError:
    return ValueError(f"model file {str(path)!r} is not a stable-baselines3 zip (cut off "
                      "while written, or not a model): train again or pick another "
                      "checkpoint")


def _damaged(path: Path, error: Exception) -> ValueError:
    first_line = (str(error).splitlines() or [""])[0][:160]
    return ValueError(f"model file {str(path)!r} could not be loaded "
                      f"({type(error).__name__}: {first_line}): it is damaged or was written "
                      "by an incompatible stable-baselines3; train again or pick another "
                      "checkpoint")


def _no_schedule(_: float) -> float:
    return 0.0


# the keys that make a config.yaml a training config (``quad-dob train`` writes both; a
# hand-written one names at least one), not another tool's (a Hydra config)
TRAINING_CONFIG_KEYS = ("algo", "env_id")


def _config_path(path: Path, env_id: str | None = None) -> Path | None:
    """The training config beside ``path``: ``NAME.yaml`` beside ``NAME.zip``, else the
    folder's ``config.yaml``. With ``env_id`` (``--env``), None where there is none, and a
    ``config.yaml`` that is no training config (none of ``TRAINING_CONFIG_KEYS``: another
    tool's) is ignored; one that is must name ``env_id``, else it is refused naming both.
    Without ``env_id``, a model with none is refused, naming ``--env``."""
    config_path = path.with_name(path.stem + ".yaml")
    if config_path.is_file():
        return config_path
    config_path = path.parent / "config.yaml"
    if env_id is not None:
        if not config_path.is_file():
            return None
        try:
            document = yaml.safe_load(config_path.read_text())
        except (yaml.YAMLError, UnicodeDecodeError):
            return config_path  # named as invalid where it is read
        if not isinstance(document, dict) or not any(key in document
                                                     for key in TRAINING_CONFIG_KEYS):
            return None  # another tool's config.yaml: --env says what the model fits
        named = document.get("env_id")
        if named != env_id:
            trained_on = (f"env_id {named}" if named is not None else
                          "no env_id (its mode and env_kwargs describe the env)")
            raise ValueError(f"the training config {str(config_path)!r} beside "
                             f"{str(path)!r} names {trained_on}, but --env is {env_id}: "
                             "drop --env to fly the env its config describes, or give the "
                             f"model its own {path.stem}.yaml naming env_id {env_id} "
                             "(docs/training-config.md)")
        return config_path
    if not config_path.is_file():
        raise ValueError(f"no training config beside {str(path)!r} (looked for "
                         f"{path.stem}.yaml and config.yaml): cannot tell which env it fits; "
                         "for a model saved by stable-baselines3 or rl-zoo3, give the env id "
                         "it was trained on with --env (quad-dob evaluate --env ID; "
                         "load_model(..., env_id=ID))")
    return config_path


def _read(path: Path, what: str) -> bytes:
    size = path.stat().st_size
    check_memory(size, f"reading {what} {str(path)!r}", "pick another file")
    return path.read_bytes()


def _check_sha256(path: Path, content: bytes, expected: str | None, what: str) -> None:
    if expected is not None and hashlib.sha256(content).hexdigest() != expected:
        raise ValueError(f"{what} {str(path)!r} does not match its recorded sha256 "
                         f"{expected}: refusing to load it")


def _zip_data(raw: bytes, path: Path) -> dict[str, Any]:
    """The zip's ``data`` member: JSON, whose pickled entries are ``{":serialized:": ...}``."""
    try:
        with zipfile.ZipFile(io.BytesIO(raw)) as archive:
            info = archive.getinfo("data")
    except Exception as error:  # no data member, a broken directory
        raise _damaged(path, error) from error
    check_memory(info.file_size, f"the data of model file {str(path)!r}",
                 "pick another file")
    try:
        with zipfile.ZipFile(io.BytesIO(raw)) as archive:
            data = json.loads(archive.read("data").decode())
        if not isinstance(data, dict):
            raise TypeError(f"data is a JSON {type(data).__name__}, not an object")
    except Exception as error:  # zlib, unicode, json
        raise _damaged(path, error) from error
    return data


def _checked_archive(raw: bytes, path: Path) -> dict[str, Any]:
    """A model zip's ``data``, read as JSON, once every ``.pth`` in it has been read as
    tensors only; nothing is unpickled."""
    data = _zip_data(raw, path)
    _check_weights(raw, path)
    return data


def _check_weights(raw: bytes, path: Path) -> None:
    """Every ``.pth`` in the zip (weights, optimizer state, torch variables) read with
    ``weights_only=True``: tensors and plain containers, no other pickled object. SB3 2.9
    reads them so itself; checking here keeps that true whatever version is installed."""
    import torch

    with zipfile.ZipFile(io.BytesIO(raw)) as archive:
        for name in archive.namelist():
            if not name.endswith(".pth"):
                continue
            try:
                with archive.open(name) as member:
                    torch.load(member, map_location="cpu", weights_only=True)
            except Exception as error:
                if "unsupported global" in str(error).lower():
                    raise ValueError(f"model file {str(path)!r}: {name} holds pickled objects "
                                     "other than tensors, which loading would run as code; "
                                     + TRUST_PICKLE_HINT) from error
                raise _damaged(path, error) from error


# the zip's pickled entries that flying needs none of: what SB3 makes when it trains
# (buffers and their class, the last observations, episode statistics, action noise, the
# value clip range); None makes SB3 build its defaults
NOT_NEEDED_TO_FLY = ("_last_obs", "_last_episode_starts", "_last_original_obs",
                     "ep_info_buffer", "ep_success_buffer", "rollout_buffer_class",
                     "replay_buffer_class", "action_noise", "clip_range_vf")
# every pickled entry load_model rebuilds instead of unpickling
REBUILT_ENTRIES = ("policy_class", "observation_space", "action_space", "learning_rate",
                   "lr_schedule", "clip_range", "train_freq", "env", *NOT_NEEDED_TO_FLY)


def pickled_entries(data: dict[str, Any]) -> list[str]:
    """The entries of a zip's ``data`` that SB3 would unpickle (as its ``json_to_data``
    picks them: a top-level object with a ``":serialized:"`` key)."""
    return [key for key, item in data.items() if isinstance(item, dict) and ":serialized:" in item]


def _rebuilt_entries(algorithm: Any, config: dict, data: dict, path: Path,
                     source: str) -> dict[str, Any]:
    """SB3's ``custom_objects``: every pickled entry of ``data``, rebuilt from the config,
    the env it describes and the algorithm, so that none is unpickled."""
    unknown = [key for key in pickled_entries(data) if key not in REBUILT_ENTRIES]
    if unknown:
        raise ValueError(f"model file {str(path)!r} holds pickled entries that loading would "
                         "run as code and that cannot be rebuilt from its config: "
                         f"{', '.join(unknown)}; {TRUST_PICKLE_HINT}")
    policy_class = _policy_class(algorithm, config, data, path, source)
    observation_space, action_space = _spaces(config, data, path, source)
    train_freq = (config.get("algo_kwargs") or {}).get("train_freq", 1)
    return {"policy_class": policy_class, "observation_space": observation_space,
            "action_space": action_space,
            # the schedules: constants (flying takes no gradient step)
            "learning_rate": 0.0, "lr_schedule": _no_schedule, "clip_range": _no_schedule,
            "train_freq": tuple(train_freq) if isinstance(train_freq, list) else train_freq,
            "env": None,  # SB3 would make an env from a saved id string
            **dict.fromkeys(NOT_NEEDED_TO_FLY)}


def _policy_class(algorithm: Any, config: dict, data: dict, path: Path,
                  source: str) -> Any:
    """The algorithm's own class for the config's ``policy`` name (``MlpPolicy``: PPO's
    ``ActorCriticPolicy``, SAC's ``SACPolicy``), checked against the module the zip records
    for its class in plain text."""
    name = config.get("policy", "MlpPolicy")
    aliases = algorithm.policy_aliases
    if name not in aliases:
        raise ValueError(f"{source} names policy {name!r}, which is not one of "
                         f"{algorithm.__name__}'s own ({', '.join(aliases)}): the model "
                         f"beside it cannot be rebuilt without unpickling; {TRUST_PICKLE_HINT}")
    policy_class = aliases[name]
    recorded = data.get("policy_class")
    module = recorded.get("__module__") if isinstance(recorded, dict) else None
    if module is not None and module != policy_class.__module__:
        from quad_dob_training.rl.foreign_models import POLICY_MODULES

        if module in POLICY_MODULES:  # another algorithm's: the config is not this zip's
            raise ValueError(f"model file {str(path)!r} holds a {POLICY_MODULES[module].upper()} "
                             f"policy ({module}), but {source} names algorithm "
                             f"{config.get('algo', 'ppo')} ({algorithm.__name__}'s {name}): "
                             "the config is not this model's; put the model beside its own "
                             "config, or give it a NAME.yaml naming its algo and env_id "
                             "(docs/training-config.md)")
        raise ValueError(f"model file {str(path)!r} holds a policy class from {module!r}, "
                         f"not {algorithm.__name__}'s {name} ({policy_class.__module__}) that "
                         f"{source} names: it cannot be rebuilt without unpickling; "
                         + TRUST_PICKLE_HINT)
    return policy_class


def config_env_options(config: dict) -> dict[str, Any]:
    """The options of the env a training config describes, for one vehicle of it: its
    ``env_kwargs`` (less the training-only keys) over its ``env_id``'s own (a hand-written
    config may name the id alone), and a residual's ``base_controller``."""
    import gymnasium as gym

    options = env_options(config.get("env_kwargs") or {})
    env_id = config.get("env_id")
    if env_id is not None:
        if env_id not in gym.registry:
            raise ValueError(f"env_id {env_id!r} is not a registered id (quad-dob list "
                             "names them)")
        options = {**env_options(dict(gym.spec(env_id).kwargs)), **options}
    if config.get("mode") == "direct":
        options.pop("base_controller", None)
    elif config.get("base_controller") is not None:
        options.setdefault("base_controller", config["base_controller"])
    return options


def _built_from(options: dict[str, Any], config: dict) -> str:
    """What env the options build, in words, for a mismatch's message."""
    described = [f"env id {config['env_id']}"] if config.get("env_id") else []
    described.append(f"scenario {options.get('scenario', 'paper-none')}")
    described.append(f"base {options['base_controller']}" if options.get("base_controller")
                     else "no base (direct)")
    if options.get("benchmark"):
        described.append(f"benchmark {options['benchmark']}")
    return ", ".join(described)


def _recorded_shape(recorded: dict) -> tuple[int, ...] | None:
    """The shape a zip's ``data`` records for a space in plain text: a list (SB3 2.x) or
    the text of one."""
    shape = recorded.get("_shape")
    try:
        if isinstance(shape, str):
            shape = json.loads(shape)
        return tuple(int(n) for n in shape)
    except (TypeError, ValueError):
        return None


def _spaces(config: dict, data: dict, path: Path, source: str) -> tuple[Any, Any]:
    """The observation and action spaces of the env the config trained in (one vehicle of
    it), checked against the shape and dtype the zip records for its spaces in plain
    text."""
    options = config_env_options(config)
    try:
        env = make_vector_env(1, **options)
    except Exception as error:
        raise ValueError(f"the env options of {source} do not build an env "
                         f"({type(error).__name__}: {error}), so the spaces of the model "
                         "cannot be rebuilt") from error
    spaces = env.single_observation_space, env.single_action_space
    env.close()
    for key, space in zip(("observation_space", "action_space"), spaces, strict=True):
        recorded = data.get(key)
        if not isinstance(recorded, dict):
            continue
        shape = _recorded_shape(recorded)
        dtype = recorded.get("dtype")
        if (shape is not None and shape != space.shape) or (dtype is not None
                                                             and dtype != str(space.dtype)):
            what = key.replace("_space", "")
            raise ValueError(f"model file {str(path)!r} was saved with {what}s of shape "
                             f"{shape} and dtype {dtype}, but the env {source} describes "
                             f"({_built_from(options, config)}) has {what}s of shape "
                             f"{space.shape} and dtype {space.dtype}: the model was trained "
                             "on another env (another id, mode, base or residual options); "
                             "give the id and options it was trained with")
    return spaces
