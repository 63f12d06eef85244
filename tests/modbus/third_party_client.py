#!/usr/bin/python3
"""Reads tribo-bench with pymodbus, a Modbus client not written here, using
only the register map as docs/modbus.md documents it, and
prints what it finds as JSON for tests/modbus/third_party_client_test.cc.

usage: third_party_client.py PORT
"""
import json
import struct
import sys

import numpy as np
from pymodbus.client import ModbusTcpClient
from pymodbus.utilities import computeCRC

UNIT = 1
VOLTS_PER_COUNT = 10.24 / 2**31          # sensor ADC and drive DAC: 32-bit counts over +-10.24 V
LATERAL_DRIVE_N_PER_V = 1e-3             # the drive block carries force setpoints: 1 mN/V lateral
EPS, AREA, GAP = 8.854e-12, 1e-4, 85e-6  # dissertation §5.1.1-5.1.2


def int32(hi, lo):
    return struct.unpack(">i", struct.pack(">HH", hi, lo))[0]


def uint32(hi, lo):
    return hi << 16 | lo


def capacitive_position(volts, excitation_v, feedback_f):
    """Solves dV = (V0/Cf) 2 eps A x / (d^2 - x^2) for the root inside the gap."""
    dc = volts * feedback_f / excitation_v
    if dc == 0:
        return 0.0
    roots = np.roots([dc, 2 * EPS * AREA, -dc * GAP * GAP])
    inside = [r.real for r in roots if abs(r.imag) < 1e-30 and abs(r.real) < GAP]
    return inside[0]


def decode_sensors(regs):
    crc = computeCRC(struct.pack(">" + "H" * 11, *(regs[:3] + regs[4:])))
    crc_register = (crc & 0xFF) << 8 | crc >> 8  # the register holds the CRC as a number
    volts = [int32(regs[i], regs[i + 1]) * VOLTS_PER_COUNT for i in (4, 6, 8, 10)]
    return {
        "sequence": uint32(regs[0], regs[1]),
        "status": regs[2],
        "checksum_ok": crc_register == regs[3],
        "lateral_position_m": capacitive_position(volts[0], 2.5, 1e-12),
        "lateral_force_n": volts[1] * 1e-3,
        "normal_force_n": volts[2] * 2e-3,
        "normal_displacement_m": capacitive_position(volts[3], 1.8, 1e-12),
    }


def read_sensors(client):
    rr = client.read_input_registers(0, 12, slave=UNIT)
    assert not rr.isError(), rr
    return decode_sensors(rr.registers)


def drive_block(sequence, lateral_force_n):
    """Sequence, then the normal and lateral force setpoints as signed 32-bit DAC counts."""
    counts = int(round(lateral_force_n / LATERAL_DRIVE_N_PER_V / VOLTS_PER_COUNT))
    words = struct.unpack(">HHHHHH", struct.pack(">Iii", sequence, 0, counts))
    return list(words)


def main():
    port = int(sys.argv[1])
    client = ModbusTcpClient("127.0.0.1", port=port)
    assert client.connect(), "cannot connect"
    out = {}

    ident = client.read_input_registers(100, 5, slave=UNIT).registers
    out["magic"] = uint32(ident[0], ident[1])
    out["map_version"] = ident[2]
    out["sample_period_ns"] = uint32(ident[3], ident[4])

    out["initial"] = read_sensors(client)

    # Session: seed 7, reset (four seed registers high word first, then the command).
    seed = 7
    session = list(struct.unpack(">HHHH", struct.pack(">Q", seed))) + [1]
    assert not client.write_registers(100, session, slave=UNIT).isError()
    out["after_reset"] = read_sensors(client)

    # Lock-step: a drive block with sequence 1 steps the plant once.
    lateral_force_n = 1e-4
    rq = client.write_registers(0, drive_block(1, lateral_force_n), slave=UNIT)
    assert not rq.isError(), rq
    out["after_step"] = read_sensors(client)
    out["lateral_drive_n"] = lateral_force_n

    # Repeating sequence 1 is acknowledged without a step; sequence 5 is refused.
    out["repeat_is_error"] = client.write_registers(0, drive_block(1, 0), slave=UNIT).isError()
    out["after_repeat_sequence"] = read_sensors(client)["sequence"]
    refused = client.write_registers(0, drive_block(5, 0), slave=UNIT)
    out["out_of_sequence_exception"] = refused.exception_code if refused.isError() else 0
    client.close()
    print(json.dumps(out))


if __name__ == "__main__":
    main()
