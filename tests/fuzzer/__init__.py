"""A configuration fuzzer: random ids, scenarios, options, actions and vectorisation.

Run by hand, from the repository root: ``python tests/fuzzer --configs 1000 --seed 0``
(``--only K`` reruns configuration K alone, with a Python reproduction and the full
traceback of any failure; ``--help`` for the rest). The test suite runs a small profile,
``tests/test_fuzz.py``, without the wall-clock checks. Every configuration is drawn from its
own seeded generator, ``numpy.random.default_rng([seed, index])``, as a user could combine
things (``draw`` says what is drawn), then built, flown with random actions and checked.

What counts:

- *refused*: building (or the first reset) raised a ValueError with a message, or a
  ``gymnasium.error.Error``: bad input got a clear error.
- *refused by Gymnasium*: an argument Gymnasium itself handles (``num_envs``, a
  ``max_episode_steps`` for its ``TimeLimit``) was invalid and Gymnasium raised.
- a *failure*, anything else: any other exception (TypeError, KeyError, IndexError,
  ZeroDivisionError, MemoryError, AssertionError, numba's, a ValueError without a message,
  a ValueError while flying valid actions); a non-finite value in an observation, reward or
  ``info``; an observation outside the observation space; a non-bool terminated or
  truncated; an episode that ended without a known ``termination_reason``; a NaN action
  not refused (``invalid_actions="raise"``) or not ending its episode with
  ``invalid_action`` (``"terminate"``); an episode truncated before the scenario's end when
  the user asked for no shorter limit (``early_truncation``), or not truncated there;
  a scenario option that did not reach the scenario; a request for more memory than the
  budget that was not refused at once (``memory_not_refused``); a configuration that ran
  past its time limit.

Requests whose size comes from a huge option run in a child process with an address-space
limit (``isolation``), so a request that is not refused cannot take the machine with it.

Modules, each importing only those listed before it:

- ``draw``: drawing a configuration from (seed, index), ``draw_config``.
- ``records``: what happened: ``Failure``, ``Outcome``, ``FuzzReport`` and its summary.
- ``flight``: ``build`` (the env a configuration asks for) and ``Flight`` (flies and checks it).
- ``isolation``: one configuration in a child process with a memory limit, ``run_isolated``.
- ``run``: one configuration in this process with a time limit, ``run_config``; many, ``fuzz``.
- ``repro``: ``repro_code``, a few lines of Python that build and fly a configuration.
- ``cli``: the command line, ``main``; ``__main__`` runs it for ``python tests/fuzzer``.

It may import the standard library, gymnasium, numpy and the project's public modules
(``quad_dob_env``); nothing from other tests (``tests/`` is on ``sys.path`` for the suite,
as pytest puts it there, and for ``python tests/fuzzer``, as ``__main__`` does, so
``import fuzzer`` is the way in; its modules import each other relatively).
"""

from .cli import main
from .draw import MODES, draw_config, short_config
from .flight import REASONS, Flight, build
from .isolation import ISOLATED_MEMORY_LIMIT, ISOLATED_TIMEOUT, needs_isolation, run_isolated
from .records import Failure, FuzzReport, Outcome
from .repro import repro_code
from .run import FuzzTimeout, fuzz, run_config

__all__ = ["ISOLATED_MEMORY_LIMIT", "ISOLATED_TIMEOUT", "MODES", "REASONS", "Failure",
           "Flight", "FuzzReport", "FuzzTimeout", "Outcome", "build", "draw_config", "fuzz",
           "main", "needs_isolation", "repro_code", "run_config", "run_isolated",
           "short_config"]
