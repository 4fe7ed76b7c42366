"""Frames of a flight: the vehicle, its rotors' thrust, the paths, the disturbance, the ground.

A fixed perspective camera looks at the middle of the scenario's reference path from the
south-west, 25 degrees up. Drawn with Pillow (no OpenGL, no display): about a millisecond a
frame, so ``gymnasium.wrappers.RecordVideo`` stays cheap and everything works headless.

| element | drawn as |
|---|---|
| ground | grey grid at the floor (or 1 m below the lowest reference point) |
| reference path | the whole path, light grey |
| flown path | the last 600 positions, blue |
| vehicle | arms and rotor discs, drawn 1.5x its size; each rotor's thrust as a red bar |
|         | along body z, 0.6 m at the rotor limit (clipped at 1.5x)                    |
| disturbance | orange arrow from the vehicle along the true disturbance force, 0.1 m per N |
| text | time, position error, termination reason |
"""

from __future__ import annotations

from collections import deque

import numpy as np
from numpy.typing import NDArray
from PIL import Image, ImageDraw

VEHICLE_SCALE = 1.5  # the vehicle is drawn this much larger than life, to be seen
FORCE_SCALE = 0.1  # [m/N] of the disturbance arrow
TRAIL = 600  # flown positions kept per vehicle

_BACKGROUND, _GROUND, _REFERENCE = (250, 250, 247), (205, 205, 200), (170, 170, 170)
_FLOWN, _ARM, _ROTOR = (31, 119, 180), (40, 40, 40), (90, 90, 90)
_THRUST, _FORCE, _TEXT = (214, 39, 40), (255, 127, 14), (20, 20, 20)


class Camera:
    """Pinhole camera looking at ``target`` from ``distance`` m, azimuth/elevation in rad."""

    def __init__(self, target: NDArray, distance: float, width: int, height: int,
                 azimuth: float = -2.3, elevation: float = 0.45) -> None:
        self.width, self.height = width, height
        direction = np.array([np.cos(elevation) * np.cos(azimuth),
                              np.cos(elevation) * np.sin(azimuth), np.sin(elevation)])
        self.position = np.asarray(target, float) + distance * direction
        forward = -direction
        right = np.cross(forward, [0.0, 0.0, 1.0])
        right /= np.linalg.norm(right)
        up = np.cross(right, forward)
        self.rotation = np.stack([right, up, forward])  # world -> camera rows
        self.focal = 0.9 * width

    def project(self, points: NDArray) -> NDArray:
        """(K, 3) world points -> (K, 2) pixels; points behind the camera go far away."""
        local = (np.atleast_2d(points) - self.position) @ self.rotation.T
        depth = np.maximum(local[:, 2], 1e-3)
        return np.stack([self.width / 2 + self.focal * local[:, 0] / depth,
                         self.height / 2 - self.focal * local[:, 1] / depth], axis=1)


class FlightRenderer:
    """Draws vehicle ``index`` of a ``QuadrotorBatch`` as an RGB array (H, W, 3) uint8."""

    def __init__(self, core, width: int = 480, height: int = 360) -> None:
        self.core, self.width, self.height = core, int(width), int(height)
        # framed on every reference a vehicle may fly (a family's members all)
        reference = core.member_paths(core.scenario.steps + 1).reshape(-1, 3)
        low, high = reference.min(axis=0), reference.max(axis=0)
        span = float(np.max(high - low))
        self.camera = Camera((low + high) / 2, 1.3 * max(span, 2.0) + 1.5, self.width,
                             self.height)
        floor = core.scenario.floor_height
        self.floor = float(low[2] - 1.0 if floor is None else floor)
        allocation = core.vehicle.allocation_matrix
        self.rotors = np.stack([-allocation[2], allocation[1], np.zeros(4)], axis=1)
        self.trails: dict[int, deque] = {}
        self._ground = self._ground_lines((low + high) / 2, max(span, 2.0) + 2.0)

    def reset(self, index: int | None = None) -> None:
        """Forget the flown path (of one vehicle, or all)."""
        if index is None:
            self.trails.clear()
        else:
            self.trails.pop(index, None)

    def record(self, index: int) -> None:
        self.trails.setdefault(index, deque(maxlen=TRAIL)).append(
            self.core.state.position[index].copy())

    def _ground_lines(self, centre: NDArray, half: float) -> list[tuple[NDArray, NDArray]]:
        lines = []
        for offset in np.linspace(-half, half, 11):
            for axis in (0, 1):
                start, end = centre.copy(), centre.copy()
                start[axis] += offset
                end[axis] += offset
                start[1 - axis] -= half
                end[1 - axis] += half
                start[2] = end[2] = self.floor
                lines.append((start, end))
        return lines

    def frame(self, index: int = 0) -> NDArray[np.uint8]:
        core, camera = self.core, self.camera
        image = Image.new("RGB", (self.width, self.height), _BACKGROUND)
        draw = ImageDraw.Draw(image)
        for start, end in self._ground:
            a, b = camera.project(np.stack([start, end]))
            draw.line([tuple(a), tuple(b)], fill=_GROUND, width=1)
        path = core.member_reference(index, core.scenario.steps + 1)[:, 0]
        draw.line([tuple(p) for p in camera.project(path)], fill=_REFERENCE, width=2)
        trail = self.trails.get(index)
        if trail and len(trail) > 1:
            draw.line([tuple(p) for p in camera.project(np.array(trail))], fill=_FLOWN, width=2)
        position = core.state.position[index]
        rotation = core.state.rotation[index]
        rotors = position + VEHICLE_SCALE * self.rotors @ rotation.T
        centre = camera.project(position)[0]
        body_z = rotation[:, 2]
        limit = core.vehicle.max_rotor_thrust
        for rotor, thrust in zip(rotors, core.applied.rotor_thrusts[index], strict=True):
            tip = camera.project(rotor)[0]
            draw.line([tuple(centre), tuple(tip)], fill=_ARM, width=3)
            radius = max(2.0, camera.focal * 0.12 * VEHICLE_SCALE
                         / np.linalg.norm(rotor - camera.position))
            draw.ellipse([tip[0] - radius, tip[1] - radius / 2, tip[0] + radius,
                          tip[1] + radius / 2], outline=_ROTOR, width=2)
            # wrench actuation's rotor thrusts are virtual and may leave [0, limit]
            share = min(max(thrust / limit, -1.5), 1.5)
            bar = camera.project(rotor + body_z * 0.6 * share)[0]
            draw.line([tuple(tip), tuple(bar)], fill=_THRUST, width=3)
        force = core.disturbance_force[index]
        if np.linalg.norm(force) > 1e-6:
            tip = camera.project(position + FORCE_SCALE * force)[0]
            draw.line([tuple(centre), tuple(tip)], fill=_FORCE, width=3)
            draw.ellipse([tip[0] - 3, tip[1] - 3, tip[0] + 3, tip[1] + 3], fill=_FORCE)
        error = np.linalg.norm(position - core.reference.position[index])
        reason = core.termination_reason(index)
        draw.text((8, 6), f"{core.scenario.name}  t = {core.time[index]:5.2f} s  "
                          f"|e_x| = {error:.3f} m  {reason}", fill=_TEXT)
        return np.asarray(image)


RENDER_MODES = ("human", "rgb_array")


def check_render_mode(render_mode: str | None) -> str | None:
    if render_mode is not None and render_mode not in RENDER_MODES:
        raise ValueError(f"render_mode {render_mode!r} is not supported; valid: None, "
                         + ", ".join(RENDER_MODES))
    return render_mode


class HumanWindow:
    """``render_mode="human"``: the frames in a matplotlib window, paced at the control rate
    (needs a display)."""

    def __init__(self, fps: float) -> None:
        import matplotlib.pyplot as plt

        self._plt, self._pause = plt, 1.0 / fps
        self._image = None

    def show(self, frame: NDArray[np.uint8]) -> None:
        plt = self._plt
        if self._image is None:
            plt.ion()
            figure, axis = plt.subplots(figsize=(frame.shape[1] / 100, frame.shape[0] / 100))
            axis.set_axis_off()
            figure.subplots_adjust(0, 0, 1, 1)
            self._image = axis.imshow(frame)
        else:
            self._image.set_data(frame)
        plt.pause(self._pause)

    def close(self) -> None:
        if self._image is not None:
            self._plt.close(self._image.figure)
            self._image = None
