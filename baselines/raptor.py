"""RAPTOR, an outside learned controller: the foundation policy of Eschmann et al. 2025
("RAPTOR: A Foundation Policy for Quadrotor Control", arXiv 2509.11481), flown from the
weights the ``foundation-policy`` package ships (MIT; the optional extra ``raptor``).

The policy is one small recurrent network (dense 22 -> 16 ReLU, a GRU of 16, dense 16 -> 4)
trained in the L2F simulator to fly quadrotors of many sizes from the state alone, adapting
to the vehicle in its hidden state. Its conventions, from the package's README:

- **Step:** 10 ms. It is recurrent, so each episode starts from the checkpoint's initial
  hidden state and a zero previous action (as PX4's module resets it).
- **Observation, 22 numbers:** position, the rotation matrix row by row, linear velocity
  (world frame), body angular velocity, and the previous action. The world is FLU, z up;
  the policy flies the position and attitude it reads to the origin and identity: it has
  no yaw input. To track, it is given the errors, as PX4's module (``mc_raptor``) gives
  them: position minus the reference and velocity minus the reference's velocity, each in
  a world frame turned by the reference's yaw and clipped per axis to 0.5 m and 1 m/s.
- **Action:** four numbers, motors ordered front-right, back-right, back-left, front-left,
  each clipped to [-1, 1] and mapped linearly to a rotor speed between its minimum and
  maximum. The network's last layer is linear; the previous action it reads back is its
  raw output, as L2F stored it in training (rl-tools ``70_post_integration.h``).

What it reads here is what every controller reads: the vehicle's estimate (position,
velocity, attitude, body rates), never the simulator's truth. This project's frames are
already z up with body x forward and y left (``quad_dob_env.params``), so FLU needs no sign
change. Rotors: an ``x`` or ``wide-x`` vehicle's are ordered front-right, front-left,
back-left, back-right, turning the way L2F's models turn theirs (front-right and back-left
one way, the other two the other); a ``plus`` vehicle (front, left, back, right) is flown
through a 45° frame change: the policy's body frame is the vehicle's yawed by +45°, so the
front rotor is its front-right one and the left rotor its front-left, and its world frame
is turned by the same 45°, so the vehicle holds its own heading.

The command: rotor speeds ω = ω_max (a + 1) / 2 (ω_min = 0: the rotors here idle at zero
thrust), rotor thrusts k_F ω², and from them the thrust and moments through the vehicle's
allocation matrix. The vehicle's mixer, motors, lag and rotor aerodynamics act on them as
on every controller's. The mixer is a flight controller's (thrust, roll and pitch mixed and
clipped first, then the yaw that fits), so where the policy saturates a rotor beside a yaw
moment the rotors can come back changed; PX4's RAPTOR module writes its motors directly
(docs/raptor.md measures what this changes: under 0.4 % of its error).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from quad_dob_baselines.base import E3, Controller
from quad_dob_env.dynamics import VehicleState
from quad_dob_env.params import VehicleParams
from quad_dob_env.so3 import exp
from quad_dob_env.trajectories import Reference

# [s] the policy's step: L2F's control step, at which it was trained (package README)
RAPTOR_DT = 0.01
# the package this module reads its weights from, and the extra that installs it
PACKAGE = "foundation-policy"
INSTALL_HINT = ("pip install '.[raptor]' in the clone, or pip install foundation-policy==1.0.2 "
                "(make test installs it)")
OBSERVATION_SIZE = 22
# [m], [m/s] per axis: the errors PX4's RAPTOR module clips before the policy reads them
# (PX4-Autopilot src/modules/mc_raptor, max_position_error and max_velocity_error), the
# range its students were trained from (L2F's initial states: ±0.5 m and ±1 m/s per axis)
MAX_POSITION_ERROR = 0.5
MAX_VELOCITY_ERROR = 1.0
# RAPTOR's motor order (front-right, back-right, back-left, front-left) -> this project's
# rotor index: x and wide-x are front-right 0, front-left 1, back-left 2, back-right 3; plus
# is front 0, left 1, back 2, right 3, which the 45° frame change makes front-right,
# front-left, back-left, back-right: the same permutation
RAPTOR_TO_ROTOR = (0, 3, 2, 1)
# [rad] the policy's body frame is the vehicle's yawed by this, per rotor configuration
FRAME_YAW = {"x": 0.0, "wide-x": 0.0, "plus": math.pi / 4}


def _sigmoid(x: NDArray) -> NDArray:
    return 1.0 / (1.0 + np.exp(-x))


ACTIVATIONS = {
    "IDENTITY": lambda x: x,
    "RELU": lambda x: np.maximum(x, 0.0),
    "TANH": np.tanh,
    "SIGMOID": _sigmoid,
}


@dataclass(frozen=True)
class Dense:
    """y = act(W x + b)."""

    weights: NDArray[np.float64]  # (out, in)
    biases: NDArray[np.float64]  # (out,)
    activation: str


@dataclass(frozen=True)
class Gru:
    """A gated recurrent unit, gates stacked [reset, update, new] (Cho et al. 2014, the
    convention of RLtools' checkpoints and PyTorch)."""

    input_weights: NDArray[np.float64]  # (3H, in)
    hidden_weights: NDArray[np.float64]  # (3H, H)
    input_biases: NDArray[np.float64]  # (3H,)
    hidden_biases: NDArray[np.float64]  # (3H,)
    initial_hidden: NDArray[np.float64]  # (H,)

    @property
    def size(self) -> int:
        return self.initial_hidden.shape[0]


@dataclass(frozen=True)
class RecurrentPolicy:
    """The checkpoint's network: dense layers before a GRU, dense layers after it, in
    float64. ``step`` takes a batch of observations and hidden states, one row a vehicle,
    so each vehicle's episode starts on its own."""

    before: tuple[Dense, ...]
    gru: Gru
    after: tuple[Dense, ...]
    checkpoint: str  # the checkpoint's own name, for reports

    def initial_hidden(self, n: int) -> NDArray[np.float64]:
        return np.tile(self.gru.initial_hidden, (n, 1))

    def step(self, observation: NDArray, hidden: NDArray) -> tuple[NDArray, NDArray]:
        """(output (N, 4), next hidden (N, H)) for observations (N, 22) and hidden (N, H)."""
        x = observation
        for layer in self.before:
            x = ACTIVATIONS[layer.activation](x @ layer.weights.T + layer.biases)
        g, size = self.gru, self.gru.size
        from_input = x @ g.input_weights.T + g.input_biases
        from_hidden = hidden @ g.hidden_weights.T + g.hidden_biases
        # r, z = σ(W_i x + b_i + W_h h + b_h); n = tanh(W_in x + b_in + r ⊙ (W_hn h + b_hn));
        # h' = z ⊙ h + (1 - z) ⊙ n  (Cho et al. 2014, eq. 5-8, with PyTorch's placement of r)
        reset = _sigmoid(from_input[:, :size] + from_hidden[:, :size])
        update = _sigmoid(from_input[:, size:2 * size] + from_hidden[:, size:2 * size])
        new = np.tanh(from_input[:, 2 * size:] + reset * from_hidden[:, 2 * size:])
        hidden = update * hidden + (1.0 - update) * new
        x = hidden
        for layer in self.after:
            x = ACTIVATIONS[layer.activation](x @ layer.weights.T + layer.biases)
        return x, hidden


def checkpoint_path() -> Path:
    """The weights ``foundation-policy`` installs, or a ValueError that says how to get
    them (as a missing Ray is told: the command line names it, with no traceback)."""
    from importlib import resources

    try:
        path = resources.files("foundation_policy").joinpath("blob", "checkpoint.h5")
    except ModuleNotFoundError:
        raise ValueError(f"the controller 'raptor' flies the weights of the {PACKAGE} "
                          f"package, which is not installed: {INSTALL_HINT}") from None
    if not path.is_file():
        raise ValueError(f"{PACKAGE} is installed but has no blob/checkpoint.h5; reinstall "
                          f"it: {INSTALL_HINT}")
    return Path(str(path))


def _parameters(group: Any, name: str) -> NDArray[np.float64]:
    return np.asarray(group[name]["parameters"][()], dtype=np.float64)


def _dense(group: Any, where: str) -> Dense:
    activation = str(group.attrs["activation_function"])
    if activation not in ACTIVATIONS:
        raise ValueError(f"{where}: activation {activation!r} is not one this reader knows "
                         f"({', '.join(ACTIVATIONS)})")
    return Dense(_parameters(group, "weights"), _parameters(group, "biases").reshape(-1),
                 activation)


def load_policy(path: Path | None = None, tolerance: float = 1e-5) -> RecurrentPolicy:
    """The network in an RLtools checkpoint (``path``; None: ``foundation-policy``'s),
    checked against the example sequences stored in the file: a mean absolute difference
    above ``tolerance`` raises, so a checkpoint this reader misreads is never flown."""
    import h5py  # foundation-policy's own dependency, so present wherever its weights are

    path = checkpoint_path() if path is None else Path(path)
    with h5py.File(path, "r") as file:
        actor = file["actor"]
        if actor.attrs.get("type") != "sequential":
            raise ValueError(f"{path}: the actor is a {actor.attrs.get('type')!r}, not the "
                             "sequential network this reader knows")
        layers = actor["layers"]
        before: list[Dense] = []
        after: list[Dense] = []
        gru: Gru | None = None
        for index in range(len(layers)):
            group, where = layers[str(index)], f"{path}: layer {index}"
            kind = group.attrs["type"]
            if kind == "dense":
                (before if gru is None else after).append(_dense(group, where))
            elif kind == "gru" and gru is None:
                gru = Gru(_parameters(group, "weights_input"),
                          _parameters(group, "weights_hidden"),
                          _parameters(group, "biases_input"),
                          _parameters(group, "biases_hidden"),
                          _parameters(group, "initial_hidden_state"))
            else:
                raise ValueError(f"{where} is a {kind!r} layer; this reader knows dense layers "
                                 "around one GRU")
        if gru is None:
            raise ValueError(f"{path}: no GRU layer; RAPTOR's policy is recurrent")
        inputs_taken = (before[0].weights if before else gru.input_weights).shape[1]
        if inputs_taken != OBSERVATION_SIZE:
            raise ValueError(f"{path}: the network takes {inputs_taken} inputs; RAPTOR's "
                             f"observation has {OBSERVATION_SIZE}")
        policy = RecurrentPolicy(tuple(before), gru, tuple(after),
                                 str(actor.attrs.get("checkpoint_name", path.name)))
        inputs = np.asarray(file["example"]["input"][()], dtype=np.float64)
        expected = np.asarray(file["example"]["output"][()], dtype=np.float64)
    hidden = policy.initial_hidden(inputs.shape[1])
    outputs = []
    for observation in inputs:  # (time, batch, 22): one step at a time, as it flies
        output, hidden = policy.step(observation, hidden)
        outputs.append(output)
    difference = float(np.abs(np.stack(outputs) - expected).mean())
    if difference > tolerance:
        raise ValueError(f"{path}: this reader's outputs differ from the checkpoint's stored "
                         f"example by {difference:.3g} on average (tolerance {tolerance:g})")
    return policy


def _clipped(error: NDArray, limit: float | None) -> NDArray:
    return error if limit is None else np.clip(error, -limit, limit)


def reference_yaw(reference: Reference) -> NDArray[np.float64]:
    """The reference's yaw ψ (N,) from its heading b1d = [cos ψ, sin ψ, 0]."""
    return np.arctan2(reference.heading[:, 1], reference.heading[:, 0])


def about_z(angle: NDArray) -> NDArray[np.float64]:
    """Rotations about z by ``angle`` (N,): (N, 3, 3), exp(ψ ê3)."""
    return exp(np.multiply.outer(angle, E3))


class RaptorController(Controller):
    """RAPTOR's foundation policy behind the controller interface (module docstring).

    Options: ``max_position_error`` [m] and ``max_velocity_error`` [m/s], the per-axis
    clips of the errors the policy reads (None: no clip; PX4's by default),
    ``checkpoint``, another RLtools checkpoint file of the same form."""

    name = "raptor"
    # it commands rotor speeds, at the step it was trained at
    actuations = ("rotors",)
    control_period = RAPTOR_DT

    def __init__(self, max_position_error: float | None = MAX_POSITION_ERROR,
                 max_velocity_error: float | None = MAX_VELOCITY_ERROR,
                 checkpoint: str | Path | None = None) -> None:
        super().__init__()
        for key, value in (("max_position_error", max_position_error),
                           ("max_velocity_error", max_velocity_error)):
            if value is not None and (isinstance(value, bool) or not isinstance(
                    value, (int, float)) or not math.isfinite(value) or value <= 0):
                raise ValueError(f"raptor.{key} must be a finite number > 0, or None for no "
                                 f"clip; got {value!r}")
        self.max_position_error = max_position_error
        self.max_velocity_error = max_velocity_error
        self.policy = load_policy(None if checkpoint is None else Path(checkpoint))
        # set for the vehicle at reset: its frame turn (T), ω_max, and each vehicle's
        # hidden state and previous action
        self.frame_yaw = 0.0
        self.body_turn = np.eye(3)
        self.max_rotor_speed = 0.0
        self.hidden = np.zeros((0, self.policy.gru.size))
        self.previous_action = np.zeros((0, 4))

    def reset(self, num_vehicles: int, vehicle: VehicleParams, dt: float,
              indices: NDArray[np.intp] | None = None, actuation: str = "rotors") -> None:
        super().reset(num_vehicles, vehicle, dt, indices, actuation)
        if indices is None:
            self.frame_yaw = FRAME_YAW[vehicle.configuration]
            self.body_turn = about_z(np.array([self.frame_yaw]))[0]
            # ω_max from the rotor's largest thrust: T = k_F ω²
            self.max_rotor_speed = math.sqrt(vehicle.max_rotor_thrust
                                             / vehicle.thrust_coefficient)
            self.hidden = self.policy.initial_hidden(num_vehicles)
            self.previous_action = np.zeros((num_vehicles, 4))
        else:
            self.hidden[indices] = self.policy.gru.initial_hidden
            self.previous_action[indices] = 0.0

    def observation(self, state: VehicleState, reference: Reference) -> NDArray[np.float64]:
        """The policy's 22 inputs (module docstring): the tracking error in the world frame
        turned by the reference's yaw (plus the frame yaw), the attitude and body rates of
        the policy's body frame, and its previous action."""
        world = about_z(reference_yaw(reference) + self.frame_yaw)  # its world axes
        # a world vector v reads Aᵀ v in the policy's world; its attitude is Aᵀ R T, T the
        # body turn; a body rate ω reads Tᵀ ω in its body frame
        position = _clipped(np.einsum("nji,nj->ni", world, state.position - reference.position),
                            self.max_position_error)
        velocity = _clipped(np.einsum("nji,nj->ni", world, state.velocity - reference.velocity),
                            self.max_velocity_error)
        rotation = np.einsum("nji,njk,kl->nil", world, state.rotation, self.body_turn)
        rates = state.angular_velocity @ self.body_turn  # Tᵀ ω, row by row
        return np.concatenate([position, rotation.reshape(-1, 9), velocity, rates,
                               self.previous_action], axis=1)

    def compute(self, time: NDArray, state: VehicleState,
                reference: Reference) -> tuple[NDArray, NDArray]:
        output, self.hidden = self.policy.step(self.observation(state, reference), self.hidden)
        # the network's output is unbounded (its last layer is linear): the motors take it
        # clipped, and its next input is the raw output, as L2F stored it in training
        action = np.clip(output, -1.0, 1.0)
        self.previous_action = output
        rotor_speed = np.empty_like(action)  # in this project's rotor order
        rotor_speed[:, RAPTOR_TO_ROTOR] = self.max_rotor_speed * (action + 1.0) / 2.0  # ω_min 0
        wrench = (self.vehicle.thrust_coefficient * rotor_speed**2) @ \
            self.vehicle.allocation_matrix.T
        # what it steers to in the end: the reference's heading, level (it has no other
        # attitude target)
        self.diagnostics = {"action": action, "rotor_speed_command": rotor_speed,
                            "desired_rotation": about_z(reference_yaw(reference))}
        return wrench[:, 0].copy(), wrench[:, 1:].copy()

    def describe(self) -> dict[str, Any]:
        return {"name": self.name, "checkpoint": self.policy.checkpoint,
                "frame_yaw_deg": {configuration: math.degrees(angle)
                                  for configuration, angle in FRAME_YAW.items()},
                "max_position_error": self.max_position_error,
                "max_velocity_error": self.max_velocity_error}
