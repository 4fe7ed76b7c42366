"""Why an episode ended: the codes the compiled step writes per vehicle, and the reasons
``info["termination_reason"]`` reports for them.

The step kernels (``step_kernels``) compare each vehicle's state with ``EpisodeLimits`` and
write one code; a code above zero ends the episode (``terminated``). Where several limits
are crossed on one step the later check wins: out of bounds, then attitude lost, then
crashed, then a diverged integration. ``TIME_LIMIT`` is no code: it is the truncation
(``truncated``) at the episode's last step.
"""

from __future__ import annotations

from enum import IntEnum


class TerminationCode(IntEnum):
    """A vehicle's ``QuadrotorBatch.termination_code``; its ``reason`` is what ``info``
    reports."""

    FLYING = 0  # still flying (or truncated by the time limit)
    CRASHED = 1  # below the floor (scenarios with a floor)
    OUT_OF_BOUNDS = 2  # position error beyond EpisodeLimits.max_position_error
    ATTITUDE_LOST = 3  # tilt beyond max_tilt, or a body rate beyond max_body_rate
    NON_FINITE_STATE = 4  # the integration diverged; the last finite state is kept
    INVALID_ACTION = 5  # a NaN or infinite action; the step flew the hover command

    @property
    def reason(self) -> str:
        """``info["termination_reason"]``: the code's name in lower case, '' while flying."""
        return "" if self is TerminationCode.FLYING else self.name.lower()


# Index = code; the strings ``info["termination_reason"]`` takes besides ``TIME_LIMIT``.
TERMINATION_REASONS = tuple(code.reason for code in TerminationCode)
TIME_LIMIT = "time_limit"

# The codes as plain ints, for the compiled kernels: numba freezes a module's int globals
# into the machine code, so a kernel reads these names at no cost.
CRASHED = int(TerminationCode.CRASHED)
OUT_OF_BOUNDS = int(TerminationCode.OUT_OF_BOUNDS)
ATTITUDE_LOST = int(TerminationCode.ATTITUDE_LOST)
NON_FINITE_STATE = int(TerminationCode.NON_FINITE_STATE)
INVALID_ACTION = int(TerminationCode.INVALID_ACTION)
