#!/usr/bin/python3
"""Independent decoder of sitepose CAN logs: candump log + DBC -> JSON.

Written apart from the C++ encoder (src/output) so that a test can check one
against the other: it reads the log with python-can's CanutilsLogReader,
parses the DBC with its own small regex parser, reassembles NMEA 2000 fast
packets (messages with the SiteposeFastPacket attribute), decodes every
signal (little-endian `@1` only; `+` unsigned, `-` signed), maps the
"not available" codes (all bits 1 unsigned, largest positive signed) to null,
checks the E2E CRC-8 SAE J1850 of messages with a SiteposeE2EDataId, and
reports every value outside its signal's DBC [minimum|maximum] as an error.

Messages are matched by PGN (priority and source address ignored), as a J1939
receiver does.

Usage: /usr/bin/python3 tools/can_decode.py --dbc config/can/sitepose.dbc LOG
Prints {"messages": [...], "errors": [...]}; exit 0 when every frame decoded,
1 when some frame could not be decoded (listed in "errors"), 2 on bad usage
or an unreadable DBC/log. Needs Debian's python3-can (/usr/bin/python3).
"""

import argparse
import json
import re
import sys

BO_RE = re.compile(r"^BO_\s+(\d+)\s+(\w+)\s*:\s*(\d+)\s+(\w+)")
SG_RE = re.compile(
    r"^\s*SG_\s+(\w+)\s*(?:\w+\s*)?:\s*(\d+)\|(\d+)@([01])([+-])\s*"
    r"\(\s*([^,\s]+)\s*,\s*([^)\s]+)\s*\)\s*\[\s*([^|\s]+)\s*\|\s*([^\]\s]+)\s*\]\s*\"([^\"]*)\""
)
BA_BO_RE = re.compile(r'^BA_\s+"(\w+)"\s+BO_\s+(\d+)\s+([^;]+);')
VAL_RE = re.compile(r"^VAL_\s+(\d+)\s+(\w+)\s+(.*);")


def pgn_of(can_id):
    """PGN of a 29-bit id (PDU1: destination byte cleared)."""
    pgn = (can_id >> 8) & 0x3FFFF
    if ((pgn >> 8) & 0xFF) < 240:
        pgn &= 0x3FF00
    return pgn


def parse_dbc(path):
    """Returns {pgn: message dict}. Raises ValueError naming path:line."""
    messages = {}
    current = None
    with open(path, encoding="utf-8") as f:
        for line_no, line in enumerate(f, 1):
            m = BO_RE.match(line)
            if m:
                raw_id = int(m.group(1))
                if not raw_id & 0x80000000:
                    raise ValueError(f"{path}:{line_no}: BO_ {raw_id} is not an extended id")
                can_id = raw_id & 0x1FFFFFFF
                current = {
                    "name": m.group(2),
                    "id": can_id,
                    "dbc_id": raw_id,
                    "length": int(m.group(3)),
                    "signals": [],
                    "fast_packet": False,
                    "e2e_data_id": None,
                    "values": {},
                }
                messages[pgn_of(can_id)] = current
                continue
            m = SG_RE.match(line)
            if m:
                if current is None:
                    raise ValueError(f"{path}:{line_no}: SG_ before any BO_")
                if m.group(4) != "1":
                    raise ValueError(f"{path}:{line_no}: big-endian signal {m.group(1)} not supported")
                current["signals"].append({
                    "name": m.group(1),
                    "start": int(m.group(2)),
                    "length": int(m.group(3)),
                    "signed": m.group(5) == "-",
                    "scale": float(m.group(6)),
                    "offset": float(m.group(7)),
                    "minimum": float(m.group(8)),
                    "maximum": float(m.group(9)),
                    "unit": m.group(10),
                })
                continue
            if line.strip() == "":
                current = None
                continue
            m = BA_BO_RE.match(line)
            if m:
                attr, raw_id, value = m.group(1), int(m.group(2)), m.group(3).strip()
                target = next((x for x in messages.values() if x["dbc_id"] == raw_id), None)
                if target is None:
                    raise ValueError(f"{path}:{line_no}: attribute for unknown message {raw_id}")
                if attr == "SiteposeFastPacket":
                    target["fast_packet"] = int(value) == 1
                elif attr == "SiteposeE2EDataId":
                    target["e2e_data_id"] = int(value)
                continue
            m = VAL_RE.match(line)
            if m:
                raw_id = int(m.group(1))
                target = next((x for x in messages.values() if x["dbc_id"] == raw_id), None)
                if target is not None:
                    pairs = re.findall(r'(\d+)\s+"([^"]*)"', m.group(3))
                    target["values"][m.group(2)] = {int(k): v for k, v in pairs}
    for msg in messages.values():
        for sig in msg["signals"]:
            if sig["start"] + sig["length"] > 8 * msg["length"]:
                raise ValueError(f"{path}: {msg['name']}.{sig['name']} exceeds {msg['length']} bytes")
    return messages


def crc8_sae_j1850(data):
    crc = 0xFF
    for b in data:
        crc ^= b
        for _ in range(8):
            crc = ((crc << 1) ^ 0x1D) & 0xFF if crc & 0x80 else (crc << 1) & 0xFF
    return crc ^ 0xFF


def decode_payload(msg, payload):
    """Signals of one (reassembled) payload: physical value or None (n/a)."""
    value = int.from_bytes(bytes(payload), "little")
    signals, raw = {}, {}
    for sig in msg["signals"]:
        r = (value >> sig["start"]) & ((1 << sig["length"]) - 1)
        if sig["signed"] and r >> (sig["length"] - 1):
            r -= 1 << sig["length"]
        raw[sig["name"]] = r
        not_available = (1 << (sig["length"] - 1)) - 1 if sig["signed"] else (1 << sig["length"]) - 1
        if r == not_available and sig["length"] > 1:
            signals[sig["name"]] = None
        else:
            signals[sig["name"]] = r * sig["scale"] + sig["offset"]
    out = {"name": msg["name"], "signals": signals, "raw": raw, "range_errors": []}
    for sig in msg["signals"]:
        v = signals[sig["name"]]
        # Half a step of slack: the DBC's bounds are printed rounded.
        slack = abs(sig["scale"]) / 2
        if v is not None and not sig["minimum"] - slack <= v <= sig["maximum"] + slack:
            out["range_errors"].append(
                f"{msg['name']}.{sig['name']} = {v} outside the DBC range "
                f"[{sig['minimum']}|{sig['maximum']}]")
    if msg["e2e_data_id"] is not None:
        data_id = msg["e2e_data_id"]
        expected = crc8_sae_j1850([data_id & 0xFF, data_id >> 8] + list(payload[1:]))
        out["e2e"] = {"crc_ok": payload[0] == expected, "counter": payload[1] & 0x0F}
    return out


class FastPacketAssembler:
    """Reassembles NMEA 2000 fast packets per CAN id."""

    def __init__(self):
        self.pending = {}

    def add(self, can_id, data):
        """Returns (payload or None, error or None)."""
        seq, index = data[0] >> 5, data[0] & 0x1F
        if index == 0:
            error = None
            if can_id in self.pending:
                error = f"fast packet {can_id:08X}: sequence {self.pending[can_id]['seq']} incomplete"
            length = data[1]
            self.pending[can_id] = {"seq": seq, "next": 1, "length": length, "bytes": list(data[2:8])}
        else:
            st = self.pending.get(can_id)
            if st is None or st["seq"] != seq or st["next"] != index:
                self.pending.pop(can_id, None)
                return None, f"fast packet {can_id:08X}: unexpected frame {seq}/{index}"
            st["bytes"].extend(data[1:8])
            st["next"] += 1
            error = None
        st = self.pending[can_id]
        if len(st["bytes"]) >= st["length"]:
            del self.pending[can_id]
            return st["bytes"][: st["length"]], error
        return None, error


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dbc", required=True, help="DBC file (config/can/sitepose.dbc)")
    parser.add_argument("log", help="candump log (candump -L format)")
    args = parser.parse_args()
    try:
        import can  # Debian python3-can
    except ImportError:
        print("can_decode.py: python3-can is not installed (run with /usr/bin/python3)", file=sys.stderr)
        return 2
    try:
        messages = parse_dbc(args.dbc)
    except (OSError, ValueError) as e:
        print(f"can_decode.py: {e}", file=sys.stderr)
        return 2
    decoded, errors = [], []
    assembler = FastPacketAssembler()
    try:
        frames = list(can.io.CanutilsLogReader(args.log))
    except (OSError, ValueError) as e:
        print(f"can_decode.py: {args.log}: {e}", file=sys.stderr)
        return 2
    for frame in frames:
        if not frame.is_extended_id:
            errors.append(f"{frame.timestamp:.6f}: standard id {frame.arbitration_id:03X} not in the DBC")
            continue
        can_id = frame.arbitration_id
        msg = messages.get(pgn_of(can_id))
        if msg is None:
            errors.append(f"{frame.timestamp:.6f}: PGN {pgn_of(can_id)} ({can_id:08X}) not in the DBC")
            continue
        data = list(frame.data)
        if msg["fast_packet"]:
            payload, error = assembler.add(can_id, data)
            if error:
                errors.append(f"{frame.timestamp:.6f}: {error}")
            if payload is None:
                continue
        else:
            payload = data
        if len(payload) != msg["length"]:
            errors.append(f"{frame.timestamp:.6f}: {msg['name']} has {len(payload)} bytes, DBC says {msg['length']}")
            continue
        out = decode_payload(msg, payload)
        errors.extend(f"{frame.timestamp:.6f}: {e}" for e in out.pop("range_errors"))
        out.update({
            "t": frame.timestamp,
            "channel": frame.channel,
            "id": f"{can_id:08X}",
            "pgn": pgn_of(can_id),
            "priority": (can_id >> 26) & 0x7,
            "source_address": can_id & 0xFF,
        })
        decoded.append(out)
    for can_id in assembler.pending:
        errors.append(f"fast packet {can_id:08X}: incomplete at the end of the log")
    json.dump({"messages": decoded, "errors": errors}, sys.stdout, indent=1)
    sys.stdout.write("\n")
    return 1 if errors else 0


if __name__ == "__main__":
    sys.exit(main())
