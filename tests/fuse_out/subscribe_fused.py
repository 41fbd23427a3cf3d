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
import queue
import struct
import sys
import threading

import zenoh

print_lock = threading.Lock()


def emit(obj):
    with print_lock:
        sys.stdout.write(json.dumps(obj) + "\n")
        sys.stdout.flush()


def varint(b, i):
    value = shift = 0
    while True:
        byte = b[i]
        i += 1
        value |= (byte & 0x7F) << shift
        shift += 7
        if byte < 0x80:
            return value, i


def option(b, i, read):
    tag = b[i]
    if tag == 0:
        return None, i + 1
    if tag != 1:
        raise ValueError(f"option tag {tag} at {i}")
    return read(b, i + 1)


def f32(b, i):
    return struct.unpack_from("<f", b, i)[0], i + 4


def f32_pair(b, i):
    return list(struct.unpack_from("<2f", b, i)), i + 8


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
    received = queue.Queue()

    def decode(k, encoding, payload):
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

    def on_sample(sample):
        received.put((str(sample.key_expr), str(sample.encoding), sample.payload.to_bytes()))

    def decoder():
        while (item := received.get()) is not None:
            decode(*item)

    decoding = threading.Thread(target=decoder)
    decoding.start()
    conf = zenoh.Config()
    conf.insert_json5("mode", '"peer"')
    conf.insert_json5("listen/endpoints", json.dumps([endpoint]))
    conf.insert_json5("connect/endpoints", "[]")
    conf.insert_json5("scouting/multicast/enabled", "false")
    with zenoh.open(conf) as session:
        subscriber = session.declare_subscriber(f"{key}/**", on_sample)
        emit({"ready": True})
        sys.stdin.read()
        subscriber.undeclare()
    received.put(None)
    decoding.join()


if __name__ == "__main__":
    main()
