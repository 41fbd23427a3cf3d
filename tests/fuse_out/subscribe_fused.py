"""A Zenoh peer that glint did not write (eclipse-zenoh), for tests/fuse_out.rs: listens on an
endpoint with multicast scouting off, subscribes to what `glint fuse --publish KEY` sends, and
prints every sample decoded, one JSON object per line, until its standard input closes.

    subscribe_fused.py ENDPOINT KEY

The first line is {"ready": true}, once the subscription is declared. Then per sample:
{"key", "encoding", "form", "step"} with form
  "json": the fused JSON line, parsed;
  "bin":  the binary form, decoded by this file's reading of src/net/fused.rs's table.
"""

import json
import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "common"))
from zenoh_peer import emit, f32, f32_pair, option, serve, varint  # noqa: E402


def decode_binary(b):
    step = {"version": b[0]}
    i = 1
    step["t_us"], i = varint(b, i)
    step["unit"] = b[i]
    i += 1
    count, i = varint(b, i)
    tracks = []
    for _ in range(count):
        t = {}
        t["id"], i = varint(b, i)
        if b[i] not in (0, 1):
            raise ValueError(f"bool {b[i]} at {i}")
        t["found"] = b[i] == 1
        i += 1
        t["floor"], i = option(b, i, f32_pair)
        t["velocity"], i = option(b, i, f32_pair)
        t["sigma"], i = option(b, i, f32)
        t["cameras"], i = varint(b, i)
        tracks.append(t)
    step["tracks"] = tracks
    if i != len(b):
        raise ValueError(f"{len(b) - i} bytes left over")
    return step


def main():
    endpoint, key = sys.argv[1:3]

    def decode(k, encoding, payload, _attachment):
        out = {"key": k, "encoding": encoding}
        try:
            if k == key + "/fused":
                out.update(form="json", step=json.loads(payload))
            elif k == key + "/fused/bin":
                out.update(form="bin", step=decode_binary(payload))
            else:
                out.update(form="unexpected")
        except Exception as e:  # reported to the test, which fails on it
            out.update(form="error", error=repr(e))
        emit(out)

    serve(endpoint, [f"{key}/**"], decode, {"ready": True})


if __name__ == "__main__":
    main()
