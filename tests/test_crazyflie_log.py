"""The Crazyflie's uSD log format: logs this project's writer makes, read back exactly,
and every damage named (training/real_flights/crazyflie_log.py)."""

import struct
import zlib

import numpy as np
import pytest

from quad_dob_training.real_flights.crazyflie_log import EventType, read_log, write_log

STEADY = EventType(0xFFFF, "fixedFrequency", (
    ("stateEstimateZ.x", "h"), ("ctrltargetZ.x", "h"), ("ctrlLee.thrustSI", "f"),
    ("locSrv.qw", "e"), ("pm.state", "B"), ("pm.vbatMV", "H"), ("tick.count", "I"),
    ("offset.signed", "i"), ("flag.signed", "b")))
TAKEOFF = EventType(3, "takeoff", (("height", "f"),))
UNUSED = EventType(4, "landing", (("height", "f"),))


def records(n=50):
    rng = np.random.default_rng(4)
    rows = []
    for k in range(n):
        rows.append((0xFFFF, 0.004 * k, (int(rng.integers(-3000, 3000)), -k, 0.25 + k / 8,
                                         0.5, k % 256, 3700 + k, 2**31 + k, -k * 1000, -k % 100)))
        if k == 10:
            rows.append((3, 0.0405, (1.0,)))
    return rows


@pytest.mark.parametrize("version", [1, 2])
def test_a_log_reads_back_as_written(tmp_path, version):
    path = tmp_path / "log182"
    rows = records()
    write_log(path, [STEADY, TAKEOFF, UNUSED], rows, version)
    log = read_log(path)
    assert log.version == version and set(log.events) == {"fixedFrequency", "takeoff", "landing"}
    steady = log.event("fixedFrequency")
    written = [values for event, _, values in rows if event == 0xFFFF]
    for column, (name, _) in enumerate(STEADY.variables):
        expected = np.array([values[column] for values in written])
        np.testing.assert_array_equal(steady[name], expected.astype(steady[name].dtype))
    # a millisecond clock in version 1, microseconds in version 2
    times = np.array([time for event, time, _ in rows if event == 0xFFFF])
    np.testing.assert_allclose(steady["timestamp"], times, atol=0.5e-3 if version == 1 else 1e-9)
    assert log.event("takeoff")["height"].tolist() == [1.0]
    assert log.event("landing")["height"].size == 0
    with pytest.raises(ValueError, match="no event 'hover'; it has fixedFrequency"):
        log.event("hover")


def corrupted(tmp_path, change, keep_crc=False):
    """A written log with its body changed by ``change``; the CRC recomputed unless
    ``keep_crc``."""
    path = tmp_path / "log"
    write_log(path, [STEADY, TAKEOFF], records(5))
    body = change(bytearray(path.read_bytes()[:-4]))
    crc = path.read_bytes()[-4:] if keep_crc else struct.pack("<I", zlib.crc32(bytes(body)))
    return bytes(body) + crc


def test_damage_is_named(tmp_path):
    def flip(body):
        body[-1] ^= 0xFF
        return body

    with pytest.raises(ValueError, match=r"CRC-32 .* damaged or truncated"):
        read_log(corrupted(tmp_path, flip, keep_crc=True))

    def magic(body):
        body[0] = 0xAA
        return body

    with pytest.raises(ValueError, match="first byte 0xaa, not a Crazyflie log's 0xbc"):
        read_log(corrupted(tmp_path, magic))

    def version(body):
        body[1:3] = struct.pack("<H", 7)
        return body

    with pytest.raises(ValueError, match="version 7; this reader knows 1, 2"):
        read_log(corrupted(tmp_path, version))

    def cut(body):
        return body[:-3]

    with pytest.raises(ValueError, match=r"a record at byte .* is cut short"):
        read_log(corrupted(tmp_path, cut))

    write_log(tmp_path / "empty", [STEADY, TAKEOFF], [])
    header_end = len((tmp_path / "empty").read_bytes()) - 4  # the first record starts here

    def stray(body):
        body[header_end:header_end + 2] = struct.pack("<H", 9)
        return body

    with pytest.raises(ValueError, match="event id 9, which the header does not declare"):
        read_log(corrupted(tmp_path, stray))
    with pytest.raises(ValueError, match="too short"):
        read_log(b"\xbc\x02")


def test_a_variable_must_name_its_type(tmp_path):
    path = tmp_path / "log"
    body = bytearray(struct.pack("<BHH", 0xBC, 2, 1) + struct.pack("<H", 1) + b"odd\0"
                     + struct.pack("<H", 1) + b"x(d)\0")
    path.write_bytes(bytes(body) + struct.pack("<I", zlib.crc32(bytes(body))))
    with pytest.raises(ValueError, match=r"variable 'x\(d\)' is not group.name\(T\)"):
        read_log(path)
