"""Models trained outside ``quad-dob train``: a stable-baselines3 zip or an rl-zoo3 run, with
no project config beside it; the env id they trained on supplies what the config would.

``quad-dob evaluate --policies ppo:PATH --env ID`` loads such a model as
``model_files.load_model`` loads any, without unpickling; the training config the project
would have written beside it is rebuilt here (``config_for_id``):

- the env options are the id's (``gym.spec(ID).kwargs``: scenario, base controller,
  benchmark), with those of an rl-zoo3 run's ``config.yml`` (its ``env_kwargs``, less the
  training-only keys) laid over them;
- the algorithm is the one the zip's policy class belongs to (read from the pickle's text,
  not unpickled), which must be the one the spec names;
- the policy name is rl-zoo3's ``policy``, else the algorithm's alias for that class;
- the observation statistics come from rl-zoo3's ``vecnormalize.pkl`` (``read_vecnormalize``):
  read by a restricted unpickler that builds numpy arrays, dtypes and scalars only, every
  other name it admits (SB3's ``VecNormalize`` and ``RunningMeanStd``, Gymnasium's ``Box``,
  ``collections.OrderedDict`` as a plain dict, and numpy.random's generator state) being an
  inert record of its state, and any other refused, naming it (``ADMITTED``);
  ``trust_pickle`` unpickles it as SB3 does. A save with ``norm_obs`` false holds no
  statistics: the model flies raw observations. A run whose config says it normalised
  observations and whose file is missing is refused, naming the file expected.

An rl-zoo3 run folder (``logs/ppo/QuadDOB-HoverResidual-v3_1``) holds the model as
``<ENV>.zip`` and its files in ``<ENV>/`` (``config.yml``, ``args.yml``,
``vecnormalize.pkl``), ``<ENV>`` the id with ``/`` and ``:`` as ``-``. Its ``args.yml``
names the id it was trained on, which stands for ``--env`` when none is given
(``zoo_env_id``); a ``--env`` naming another id is refused, naming both. Its YAML files are
read with YAML's safe loader, taught only rl-zoo3's ``OrderedDict`` tag.
"""

from __future__ import annotations

import ast
import base64
import io
import pickle
import pickletools
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from quad_dob_training.rl import ALGORITHMS
from quad_dob_training.rl.sb3_adapter import id_benchmark, id_kwargs, is_residual_id

VECNORMALIZE = "vecnormalize.pkl"
# the module each algorithm's policies live in (the zip records its class's module)
POLICY_MODULES = {"stable_baselines3.common.policies": "ppo",
                  "stable_baselines3.sac.policies": "sac",
                  "stable_baselines3.td3.policies": "td3"}


def zoo_name(env_id: str) -> str:
    """rl-zoo3's name for ``env_id`` in file names (``huggingface_sb3.EnvironmentName``)."""
    return env_id.replace("/", "-").replace(":", "-")


def model_in_folder(folder: Path) -> Path:
    """The model a run folder holds: ``model.zip`` (``quad-dob train``), else rl-zoo3's
    ``<ENV>.zip`` beside a ``<ENV>/`` folder of its files."""
    folder = Path(folder)
    if (folder / "model.zip").is_file():
        return folder / "model.zip"
    found = sorted(path for path in folder.glob("*.zip") if (folder / path.stem).is_dir())
    if len(found) == 1:
        return found[0]
    if len(found) > 1:
        raise ValueError(f"run folder {str(folder)!r} holds several rl-zoo3 models ("
                         + ", ".join(path.name for path in found) + "): name the .zip")
    return folder / "model.zip"  # "does not exist", named by the caller


def zoo_files(path: Path, env_id: str | None) -> Path | None:
    """The folder of an rl-zoo3 run's files beside model ``path`` (``<ENV>/`` with
    ``config.yml`` or ``args.yml``), None for a zip saved otherwise."""
    path = Path(path)
    names = [path.stem] + ([zoo_name(env_id)] if env_id else [])
    for name in names:
        folder = path.parent / name
        if (folder / "config.yml").is_file() or (folder / "args.yml").is_file():
            return folder
    return None


def zoo_env_id(path: Path) -> str | None:
    """The env id an rl-zoo3 run's ``args.yml`` says model ``path`` was trained on (its
    ``env``): in ``<stem>/`` beside the zip, else the one folder beside it holding an
    ``args.yml`` (rl-zoo3's ``best_model.zip`` sits beside ``<ENV>/``); None for a zip saved
    otherwise, or where several such folders are beside it."""
    path = Path(path)
    own = path.parent / path.stem / "args.yml"
    found = [own] if own.is_file() else sorted(path.parent.glob("*/args.yml"))
    if len(found) != 1:
        return None
    named = read_zoo_yaml(found[0]).get("env")
    return None if named is None else str(named)


class _ZooLoader(yaml.SafeLoader):
    """YAML's safe loader, plus rl-zoo3's ``!!python/object/apply:collections.OrderedDict``
    (its hyperparameters and arguments are dumped as OrderedDicts), read as a plain dict."""


def _ordered_dict(loader: yaml.SafeLoader, node: yaml.Node) -> dict[str, Any]:
    pairs = loader.construct_sequence(node, deep=True)
    items = pairs[0] if len(pairs) == 1 and isinstance(pairs[0], list) else pairs
    return {key: value for key, value in items}


_ZooLoader.add_constructor("tag:yaml.org,2002:python/object/apply:collections.OrderedDict",
                           _ordered_dict)


def read_zoo_yaml(path: Path) -> dict[str, Any]:
    """An rl-zoo3 ``config.yml`` / ``args.yml`` as a dict, read safely (no other Python
    tag is built; a file holding one is refused, naming the tag)."""
    try:
        document = yaml.load(Path(path).read_text(), Loader=_ZooLoader)
    except yaml.constructor.ConstructorError as error:
        raise ValueError(f"rl-zoo3 file {str(path)!r} holds a Python object YAML's safe "
                         f"loader does not build ({error.problem}): only rl-zoo3's own "
                         "OrderedDicts are read") from None
    except yaml.YAMLError as error:
        raise ValueError(f"rl-zoo3 file {str(path)!r} is not valid YAML "
                         f"({(str(error).splitlines() or [''])[0]})") from None
    if not isinstance(document, dict):
        raise ValueError(f"rl-zoo3 file {str(path)!r} is not a YAML mapping")
    return document


def _normalizes_observations(value: Any, where: Path) -> bool:
    """Whether rl-zoo3's ``normalize`` (false, true, a mapping, or the string of one such
    as ``"dict(norm_obs=True, norm_reward=False)"``, which rl-zoo3 evals and this reads as
    literals only) normalises observations."""
    if isinstance(value, str):
        try:
            value = _dict_call(value)
        except (ValueError, SyntaxError):
            raise ValueError(f"normalize in {str(where)!r} is {value!r}: expected true, "
                             "false, a mapping such as {norm_obs: true} or its dict(...) "
                             "string of literals") from None
    if isinstance(value, dict):
        return bool(value.get("norm_obs", True))
    return bool(value)


def _dict_call(text: str) -> Any:
    """A literal, or ``dict(key=literal, ...)`` as a dict; anything else a ValueError."""
    tree = ast.parse(text.strip(), mode="eval").body
    if (isinstance(tree, ast.Call) and isinstance(tree.func, ast.Name)
            and tree.func.id == "dict" and not tree.args):
        return {keyword.arg: ast.literal_eval(keyword.value) for keyword in tree.keywords}
    return ast.literal_eval(tree)


# --- vecnormalize.pkl, restricted -------------------------------------------------------------

class _Record:
    """An admitted class's instance, inert: its pickled state kept, no method of the class
    run (the real ``VecNormalize`` would need a venv; a ``Box`` would check its bounds)."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        self.args = args
        self.state: Any = None

    def __setstate__(self, state: Any) -> None:
        self.state = state

    def get(self, key: str, default: Any = None) -> Any:
        state = self.state[0] if isinstance(self.state, tuple) else self.state
        return state.get(key, default) if isinstance(state, dict) else default


# what vecnormalize.pkl may name: numpy's own reconstructors (arrays, dtypes, scalars),
# built; SB3's and Gymnasium's classes and numpy's random generators, as inert records
_NUMPY_BUILT = {("numpy.core.multiarray", "_reconstruct"),
                ("numpy._core.multiarray", "_reconstruct"),
                ("numpy.core.multiarray", "scalar"), ("numpy._core.multiarray", "scalar"),
                ("numpy", "ndarray"), ("numpy", "dtype")}
_RECORDED = {("stable_baselines3.common.vec_env.vec_normalize", "VecNormalize"): _Record,
             ("stable_baselines3.common.running_mean_std", "RunningMeanStd"): _Record,
             ("gymnasium.spaces.box", "Box"): _Record,
             ("collections", "OrderedDict"): dict,
}
# a seeded space's generator (its factories, bit generator and seed sequence), inert
_RANDOM = "numpy.random"
ADMITTED = [*sorted(f"{module}.{name}" for module, name in _NUMPY_BUILT | set(_RECORDED)),
            f"{_RANDOM}.*"]


class _RestrictedUnpickler(pickle.Unpickler):
    def __init__(self, file: io.BytesIO, path: Path) -> None:
        super().__init__(file)
        self.path = path

    def find_class(self, module: str, name: str) -> Any:
        if (module, name) in _NUMPY_BUILT:
            return super().find_class(module, name)
        if (module, name) in _RECORDED:
            return _RECORDED[module, name]
        if module == _RANDOM or module.startswith(_RANDOM + "."):
            return _Record
        raise ValueError(f"{str(self.path)!r} names {module}.{name}, which reading "
                         "observation statistics does not admit (it admits only "
                         + ", ".join(ADMITTED) + "): a vecnormalize.pkl holds nothing else; "
                         "only if you made the file or trust where it came from, load it "
                         "with --trust-pickle (trust_pickle=True), which unpickles it")


def read_vecnormalize(path: Path, trust_pickle: bool = False) -> dict[str, Any] | None:
    """The observation statistics of an SB3 ``VecNormalize`` save as the training config's
    ``observation_normalization`` (mean, var, epsilon, clip), None where it did not
    normalise observations (``norm_obs`` false: SB3 then saves no ``obs_rms``, and the
    model flies raw observations). Read by the restricted unpickler (``ADMITTED``), or,
    with ``trust_pickle``, by ``pickle`` itself. A file that is not such a save is a
    ValueError naming what is wrong with it."""
    path = Path(path)
    raw = path.read_bytes()
    try:
        if trust_pickle:
            saved = pickle.loads(raw)  # the user trusts this file (--trust-pickle)
            state = dict(vars(saved))
        else:
            saved = _RestrictedUnpickler(io.BytesIO(raw), path).load()
            state = saved.state if isinstance(saved, _Record) else None
            if isinstance(state, tuple):
                state = state[0]
    except ValueError:
        raise
    except Exception as error:  # truncated, not a pickle, another layout
        raise ValueError(f"{str(path)!r} is not a readable VecNormalize save "
                         f"({type(error).__name__}: {error})") from error
    if not isinstance(state, dict):
        raise ValueError(f"{str(path)!r} is not a VecNormalize save (it holds "
                         f"{type(saved).__name__ if trust_pickle else 'no VecNormalize'}, "
                         "not a VecNormalize's state)")
    norm_obs = state.get("norm_obs", True)
    if not isinstance(norm_obs, (bool, np.bool_)):
        raise ValueError(f"{str(path)!r} is not a VecNormalize save: its norm_obs is a "
                         f"{type(norm_obs).__name__}, not true or false")
    if not norm_obs:
        return None
    if "obs_rms" not in state:
        raise ValueError(f"{str(path)!r} is not a VecNormalize save (norm_obs is true and "
                         "there is no obs_rms in it)")
    try:
        rms = state["obs_rms"]
        rms_state = rms.state if isinstance(rms, _Record) else vars(rms)
        if isinstance(rms_state, tuple):
            rms_state = rms_state[0]
        mean = np.asarray(rms_state["mean"], dtype=float)
        var = np.asarray(rms_state["var"], dtype=float)
    except (KeyError, TypeError, ValueError) as error:
        raise ValueError(f"{str(path)!r}: its obs_rms holds no mean and var arrays "
                         "(a Dict observation space's statistics are not read)") from error
    if mean.shape != var.shape:
        raise ValueError(f"{str(path)!r}: its obs_rms mean and var are of shapes "
                         f"{mean.shape} and {var.shape}, not one shape")
    numbers = {}
    for key, default in (("epsilon", 1e-8), ("clip_obs", 10.0)):
        value = state.get(key, default)
        try:
            numbers[key] = float(value)
        except (TypeError, ValueError):
            raise ValueError(f"{str(path)!r}: its {key} is a {type(value).__name__}, not a "
                             "number") from None
    return {"mean": mean.tolist(), "var": var.tolist(), "epsilon": numbers["epsilon"],
            "clip": numbers["clip_obs"]}


# --- the config rebuilt from the id ------------------------------------------------------------

def pickled_global(serialized: str) -> tuple[str, str] | None:
    """The ``(module, name)`` a pickled class reference names (what SB3 saves for
    ``policy_class``), read from the pickle's opcodes without unpickling; None for a
    pickle that is more than one class reference."""
    try:
        raw = base64.b64decode(serialized)
        strings: list[str] = []
        found = None
        for op, arg, _ in pickletools.genops(raw):
            if op.name in ("SHORT_BINUNICODE", "BINUNICODE", "UNICODE"):
                strings.append(arg)
            elif op.name == "STACK_GLOBAL" and len(strings) >= 2 and found is None:
                found = (strings[-2], strings[-1])
            elif op.name == "GLOBAL" and found is None:
                module, _, name = str(arg).partition(" ")
                found = (module, name)
            elif op.name not in ("PROTO", "FRAME", "MEMOIZE", "STOP", "PUT", "BINPUT"):
                return None
        return found
    except Exception:  # not base64, not a pickle
        return None


def zip_algorithm(data: dict[str, Any]) -> tuple[str | None, tuple[str, str] | None]:
    """The algorithm (``ALGORITHMS``) a zip's policy class belongs to, and the class's
    (module, name); None for either where the zip does not say."""
    recorded = data.get("policy_class")
    if not isinstance(recorded, dict):
        return None, None
    named = pickled_global(recorded.get(":serialized:", "")) if ":serialized:" in recorded \
        else None
    module = named[0] if named else recorded.get("__module__")
    return POLICY_MODULES.get(module), named


def config_for_id(env_id: str, kind: str, path: Path, data: dict[str, Any], *,
                  trust_pickle: bool = False) -> dict[str, Any]:
    """The training config of model ``path`` (its zip's ``data``, read as JSON), saved with
    none, rebuilt from ``env_id`` and any rl-zoo3 files beside it (module docstring).
    ``kind`` is the spec's ``ppo`` / ``sac`` / ``td3`` (or ``residual``)."""
    import stable_baselines3

    from quad_dob_training.rl.vec_env import env_options

    kwargs = id_kwargs(env_id)  # an unknown id fails here, naming the project's
    algo, named = zip_algorithm(data)
    if algo is None:
        algo = kind if kind in ALGORITHMS else "ppo"
    if kind in ALGORITHMS and kind != algo:
        raise ValueError(f"{kind}:{path}: the model was saved by {algo.upper()} (its policy "
                         f"class is {'.'.join(named) if named else 'from ' + algo}), not "
                         f"{kind.upper()}: name it {algo}:{path}")
    if kind == "residual" and not is_residual_id(env_id):
        raise ValueError(f"residual:{path} with --env {env_id}: a direct id; give the "
                         "residual id it was trained on, or name it "
                         f"{algo}:{path}")
    zoo = zoo_files(path, env_id)
    zoo_config: dict[str, Any] = {}
    if zoo is not None:
        arguments = read_zoo_yaml(zoo / "args.yml") if (zoo / "args.yml").is_file() else {}
        trained_on = arguments.get("env")
        if trained_on is not None and str(trained_on) != env_id:
            raise ValueError(f"{str(path)!r} is an rl-zoo3 run on {trained_on} (its "
                             f"{str(zoo / 'args.yml')!r} says so), but --env is {env_id}: "
                             f"give --env {trained_on}")
        if arguments.get("algo") is not None and arguments["algo"] != algo:
            raise ValueError(f"{str(path)!r} is an rl-zoo3 run of {arguments['algo']} (its "
                             f"args.yml says so), but its zip holds {algo}'s policy")
        if (zoo / "config.yml").is_file():
            zoo_config = read_zoo_yaml(zoo / "config.yml")
        extra = arguments.get("env_kwargs") or {}
        kwargs.update(zoo_config.get("env_kwargs") or {}, **(extra if isinstance(extra, dict)
                                                           else {}))
    normalization = None
    candidates = ([zoo / VECNORMALIZE] if zoo is not None else []) + [
        Path(path).parent / VECNORMALIZE]
    found = next((candidate for candidate in candidates if candidate.is_file()), None)
    if found is not None:
        normalization = read_vecnormalize(found, trust_pickle)
    elif zoo is not None and _normalizes_observations(zoo_config.get("normalize", False),
                                                      zoo / "config.yml"):
        raise ValueError(f"{str(path)!r} was trained with normalised observations (its "
                         f"{str(zoo / 'config.yml')!r} says normalize: "
                         f"{zoo_config.get('normalize')!r}), but {str(zoo / VECNORMALIZE)!r}, "
                         "which holds their statistics, is missing: put it back beside the "
                         "model (rl-zoo3 writes it there)")
    policy = zoo_config.get("policy")
    if policy is None:
        aliases = getattr(stable_baselines3, algo.upper()).policy_aliases
        policy = next((alias for alias, cls in aliases.items() if named is not None
                       and (cls.__module__, cls.__name__) == named), "MlpPolicy")
    options = env_options(kwargs)
    mode = "residual" if is_residual_id(env_id) else "direct"
    if mode == "residual" and options.get("base_controller") is None:
        raise ValueError(f"{str(path)!r}: the env options of {env_id} name no base "
                         "controller, which a residual id's model flies on")
    return {"algo": algo, "mode": mode, "env_id": env_id, "policy": str(policy),
            "env_kwargs": options, "base_controller": options.get("base_controller"),
            "observation_normalization": normalization,
            "benchmark": id_benchmark(env_id),
            "source": "rl-zoo3 run" if zoo is not None else "stable-baselines3 zip",
            "algo_kwargs": {key: value for key, value in zoo_config.items()
                            if key == "train_freq"}}
