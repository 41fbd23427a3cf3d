"""A Zenoh peer that glint did not write (eclipse-zenoh), for tests/publish.rs: listens on an
endpoint with multicast scouting off, subscribes to everything glint publishes for one camera,
and prints every sample decoded, one JSON object per line, until its standard input closes.

    subscribe.py ENDPOINT KEY CAMERA DOMAIN

The first line is {"ready": true}, once the subscriptions are declared. Then per sample:
{"key", "encoding", "form", ...} with form
  "json":  "report", the JSON line parsed;
  "bin":   "report", the binary form decoded by this file's reading of src/net/wire.rs's table;
  "point": "msg", the CDR payload decoded by rosbags as geometry_msgs/msg/PointStamped;
  "rmw":   the same, and "attachment", decoded by zenoh-ros2-sdk.
The rmw_zenoh key is built here with zenoh-ros2-sdk's key builder and rosbags' type hash, so a
sample arrives on it only if glint names the topic as rmw_zenoh does.
"""

import json
import os
import struct
import sys

from rosbags.typesys import Stores, get_typestore
from zenoh_ros2_sdk.attachment import Attachment
from zenoh_ros2_sdk.keyexpr import topic_keyexpr
from zenoh_ros2_sdk.utils import ros2_to_dds_type

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "common"))
from zenoh_peer import emit, f32, f32_pair, option, serve, varint  # noqa: E402

POINT_STAMPED = "geometry_msgs/msg/PointStamped"


def floor(b, i):
    unit = b[i]
    x, y = struct.unpack_from("<2f", b, i + 1)
    velocity, i = option(b, i + 9, f32_pair)
    heading, i = option(b, i, f32)
    return {"unit": unit, "x": x, "y": y, "velocity": velocity, "heading_deg": heading}, i


def decode_binary(b):
    r = {"version": b[0]}
    i = 1
    for name in ("frame", "sequence", "t_us", "unix_us"):
        r[name], i = varint(b, i)
    r["position_px"], i = option(b, i, f32_pair)
    r["velocity_px_s"], i = option(b, i, f32_pair)
    r["floor"], i = option(b, i, floor)
    r["flags"] = b[i]
    if i + 1 != len(b):
        raise ValueError(f"{len(b) - i - 1} bytes left over")
    return r


def main():
    endpoint, key, camera, domain = sys.argv[1:5]
    typestore = get_typestore(Stores.ROS2_JAZZY)
    topic = f"/{key}/{camera}/point"
    rmw_key = topic_keyexpr(
        int(domain), topic, ros2_to_dds_type(POINT_STAMPED), typestore.hash_rihs01(POINT_STAMPED)
    )
    prefix = f"{key}/{camera}"

    def point(payload):
        msg = typestore.deserialize_cdr(payload, POINT_STAMPED)
        return {
            "sec": msg.header.stamp.sec,
            "nanosec": msg.header.stamp.nanosec,
            "frame_id": msg.header.frame_id,
            "x": msg.point.x,
            "y": msg.point.y,
            "z": msg.point.z,
        }

    def decode(k, encoding, payload, attachment):
        out = {"key": k, "encoding": encoding}
        try:
            if k == prefix:
                out.update(form="json", report=json.loads(payload))
            elif k == prefix + "/bin":
                out.update(form="bin", report=decode_binary(payload))
            elif k == prefix + "/point":
                out.update(form="point", msg=point(payload))
            elif k == rmw_key:
                out.update(form="rmw", msg=point(payload))
                if attachment is not None:
                    a = Attachment.from_bytes(attachment)
                    out["attachment"] = {
                        "sequence": a.sequence_id,
                        "timestamp_ns": a.timestamp_ns,
                        "gid_len": len(a.gid),
                    }
            else:
                out.update(form="unexpected")
        except Exception as e:  # reported to the test, which fails on it
            out.update(form="error", error=repr(e))
        emit(out)

    serve(
        endpoint,
        [f"{key}/**", rmw_key],
        decode,
        {"ready": True, "rmw_key": rmw_key},
    )


if __name__ == "__main__":
    main()
