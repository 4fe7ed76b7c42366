"""The Crazyflie's on-board (uSD card deck) log format, read and written.

Written from the format as the firmware writes it (bitcraze/crazyflie-firmware
``src/deck/drivers/src/usddeck.c``; docs/research/crazyflie-sources.md), all little-endian:

- a header: the byte 0xBC, a ``u16`` version, a ``u16`` count of event types, then per
  event type its ``u16`` id, its name ending in a NUL byte, a ``u16`` count of variables and
  each variable as ``group.name(T)`` ending in a NUL byte, T a struct type character;
- records back to back: a ``u16`` event id, a timestamp (version 1: ``u32`` ms; version 2:
  ``u64`` µs), then the event's values in the header's order, packed;
- a ``u32`` CRC-32 (zlib's) of every byte before it.

Values are returned as the log holds them (the firmware's units and scalings, such as
``stateEstimateZ`` in mm); turning them into a flight is the caller's. A record the card
could not take is dropped by the firmware without a mark, so the times can jump.
"""

from __future__ import annotations

import struct
import zlib
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

MAGIC = 0xBC
# version -> the timestamp's struct character and its unit [s]
TIMESTAMPS = {1: ("I", 1e-3), 2: ("Q", 1e-6)}
# the struct characters a variable may have, as the firmware's log types map to them
KINDS = ("B", "b", "H", "h", "I", "i", "f", "e")


@dataclass(frozen=True)
class EventType:
    """One kind of record: its id, name and variables (name, struct character)."""

    id: int
    name: str
    variables: tuple[tuple[str, str], ...]

    @property
    def layout(self) -> struct.Struct:
        return struct.Struct("<" + "".join(kind for _, kind in self.variables))


@dataclass(frozen=True)
class CrazyflieLog:
    """A whole log: its version and, per event name, the time of each record [s] and each
    variable's values, in record order."""

    version: int
    events: dict[str, dict[str, NDArray]]

    def event(self, name: str) -> dict[str, NDArray]:
        if name not in self.events:
            raise ValueError(f"the log has no event {name!r}; it has "
                             + ", ".join(self.events))
        return self.events[name]


class _Cursor:
    """Reads the header's fields in order, and says where a truncated one was."""

    def __init__(self, data: bytes, where: str) -> None:
        self.data, self.offset, self.where = data, 0, where

    def take(self, layout: str) -> tuple:
        size = struct.calcsize(layout)
        if self.offset + size > len(self.data):
            raise ValueError(f"{self.where}: the log ends at byte {len(self.data)}, inside a "
                             f"field at byte {self.offset}: it is truncated")
        values = struct.unpack_from(layout, self.data, self.offset)
        self.offset += size
        return values

    def text(self) -> str:
        end = self.data.find(b"\0", self.offset)
        if end < 0:
            raise ValueError(f"{self.where}: a name at byte {self.offset} has no end (NUL): "
                             "the header is truncated")
        value = self.data[self.offset:end].decode("ascii")
        self.offset = end + 1
        return value


def _variable(text: str, where: str) -> tuple[str, str]:
    if len(text) < 4 or text[-3] != "(" or text[-1] != ")" or text[-2] not in KINDS:
        raise ValueError(f"{where}: variable {text!r} is not group.name(T) with T one of "
                         + " ".join(KINDS))
    return text[:-3], text[-2]


def read_log(source: str | Path | bytes) -> CrazyflieLog:
    """The log in ``source`` (a file or its bytes), checked: its magic byte, its CRC, and
    every record's event id and length; a ValueError says what was wrong and where."""
    data = Path(source).read_bytes() if isinstance(source, (str, Path)) else bytes(source)
    where = str(source) if isinstance(source, (str, Path)) else "the log"
    if len(data) < 9:
        raise ValueError(f"{where}: {len(data)} bytes is too short for a Crazyflie log")
    body, (crc,) = data[:-4], struct.unpack("<I", data[-4:])
    if zlib.crc32(body) != crc:
        raise ValueError(f"{where}: its CRC-32 is {zlib.crc32(body):#010x}, its last four bytes "
                         f"say {crc:#010x}: the file is damaged or truncated")
    cursor = _Cursor(body, where)
    magic, version, count = cursor.take("<BHH")
    if magic != MAGIC:
        raise ValueError(f"{where}: first byte {magic:#04x}, not a Crazyflie log's {MAGIC:#04x}")
    if version not in TIMESTAMPS:
        raise ValueError(f"{where}: version {version}; this reader knows "
                         + ", ".join(map(str, TIMESTAMPS)))
    types: dict[int, EventType] = {}
    for _ in range(count):
        (event_id,) = cursor.take("<H")
        name = cursor.text()
        (variables,) = cursor.take("<H")
        types[event_id] = EventType(event_id, name, tuple(
            _variable(cursor.text(), f"{where}: event {name!r}") for _ in range(variables)))
    stamp, unit = TIMESTAMPS[version]
    head = struct.Struct("<H" + stamp)
    rows: dict[int, list[tuple]] = {event_id: [] for event_id in types}
    offset = cursor.offset
    while offset < len(body):
        if offset + head.size > len(body):
            raise ValueError(f"{where}: a record at byte {offset} is cut short")
        event_id, time = head.unpack_from(body, offset)
        if event_id not in types:
            raise ValueError(f"{where}: a record at byte {offset} has event id {event_id}, "
                             "which the header does not declare")
        layout = types[event_id].layout
        if offset + head.size + layout.size > len(body):
            raise ValueError(f"{where}: a record at byte {offset} is cut short")
        rows[event_id].append((time * unit, *layout.unpack_from(body, offset + head.size)))
        offset += head.size + layout.size
    events = {}
    for event_id, event in types.items():
        columns = list(zip(*rows[event_id], strict=True)) or [()] * (1 + len(event.variables))
        events[event.name] = {"timestamp": np.asarray(columns[0], dtype=float)} | {
            name: np.asarray(column) for (name, _), column in zip(event.variables, columns[1:],
                                                                   strict=True)}
    return CrazyflieLog(version, events)


def write_log(path: str | Path, types: list[EventType],
              records: list[tuple[int, float, tuple]], version: int = 2) -> None:
    """A log of ``types`` and ``records`` (event id, time [s], values in the type's order)
    in the firmware's format, CRC included: what the reader's tests read."""
    if version not in TIMESTAMPS:
        raise ValueError(f"version {version}; the format has " + ", ".join(map(str, TIMESTAMPS)))
    stamp, unit = TIMESTAMPS[version]
    out = bytearray(struct.pack("<BHH", MAGIC, version, len(types)))
    for event in types:
        out += struct.pack("<H", event.id) + event.name.encode("ascii") + b"\0"
        out += struct.pack("<H", len(event.variables))
        for name, kind in event.variables:
            out += f"{name}({kind})".encode("ascii") + b"\0"
    by_id = {event.id: event for event in types}
    for event_id, time, values in records:
        out += struct.pack("<H" + stamp, event_id, round(time / unit))
        out += by_id[event_id].layout.pack(*values)
    out += struct.pack("<I", zlib.crc32(bytes(out)))
    Path(path).write_bytes(bytes(out))
