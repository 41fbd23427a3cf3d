"""What the Zenoh peers of the tests (tests/publish/subscribe.py, tests/fuse_out/subscribe_fused.py)
share: printing one JSON object per line, reading postcard's varints, options and floats, and
the peer itself, which listens on an endpoint with multicast scouting off, subscribes, and
hands every sample to a decoding thread until its standard input closes.
"""

import json
import queue
import struct
import sys
import threading

import zenoh

_print_lock = threading.Lock()


def emit(obj):
    with _print_lock:
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


def serve(endpoint, key_exprs, decode, ready):
    """Listens on `endpoint`, subscribes to every key expression of `key_exprs`, prints `ready`
    once they are declared, then calls `decode(key, encoding, payload, attachment)` for every
    sample, in order, until standard input closes.

    Zenoh's callback only copies the sample out, so a slow decoder never pushes back on the link
    (which would make glint's side drop samples); a thread decodes in order.
    """
    received = queue.Queue()

    def on_sample(sample):
        att = sample.attachment
        received.put(
            (
                str(sample.key_expr),
                str(sample.encoding),
                sample.payload.to_bytes(),
                att.to_bytes() if att is not None else None,
            )
        )

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
        subscribers = [session.declare_subscriber(k, on_sample) for k in key_exprs]
        emit(ready)
        sys.stdin.read()
        for s in subscribers:
            s.undeclare()
    received.put(None)
    decoding.join()
