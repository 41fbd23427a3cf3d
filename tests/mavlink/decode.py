"""Decodes a MAVLink 2 byte stream with pymavlink, an implementation glint did not write.

Reads the bytes glint wrote to a pty (standard input) and prints one JSON object per message:
its type, sequence number, system and component ids, and fields (NaN as null). pymavlink checks
each frame's CRC, CRC extra included; a frame that fails is printed as type "BAD_DATA". The last
line is a summary: the bytes read, and how many frames fail when one payload byte of the first
VISION_POSITION_ESTIMATE is flipped (the CRC check at work, so the test can tell it ran).
Used by tests/mavlink.rs.
"""

import json
import math
import sys

from pymavlink.dialects.v20 import common as mavlink2


def plain(value):
    if isinstance(value, float) and math.isnan(value):
        return None
    if isinstance(value, list):
        return [plain(v) for v in value]
    if isinstance(value, (bytes, bytearray)):
        return list(value)
    return value


def decode(data):
    mav = mavlink2.MAVLink(None)
    mav.robust_parsing = True
    out = []
    for msg in mav.parse_buffer(data) or []:
        entry = {
            "type": msg.get_type(),
            "seq": msg.get_seq(),
            "sysid": msg.get_srcSystem(),
            "compid": msg.get_srcComponent(),
        }
        if msg.get_type() != "BAD_DATA":
            entry["fields"] = {k: plain(v) for k, v in msg.to_dict().items() if k != "mavpackettype"}
        out.append(entry)
    return out


def main():
    data = sys.stdin.buffer.read()
    messages = decode(data)
    for entry in messages:
        print(json.dumps(entry))
    # Flip a payload byte of the first position estimate (id 102 = 0x66, at byte 7 of a
    # MAVLink 2 header: STX, len, incompat, compat, seq, sysid, compid, msgid[3]).
    corrupted_bad = None
    for i in range(len(data) - 12):
        if data[i] == 0xFD and data[i + 7] == 102 and data[i + 8] == 0 and data[i + 9] == 0:
            corrupted = bytearray(data)
            corrupted[i + 12] ^= 0x01
            corrupted_bad = sum(1 for m in decode(bytes(corrupted)) if m["type"] == "BAD_DATA")
            break
    print(json.dumps({"summary": {"bytes": len(data), "corrupted_bad": corrupted_bad}}))


main()
