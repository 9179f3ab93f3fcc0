#!/usr/bin/env python3
"""An independent Foxglove WebSocket client for `aisle run --foxglove ADDR`.

Speaks the Foxglove WebSocket protocol (subprotocol `foxglove.sdk.v1` as the `foxglove`
crate names it, or `foxglove.websocket.v1`) with the `websockets` package: reads the server's
advertisements, subscribes to the scene, the lidar point cloud, the transforms (the
robot state: map -> base_link), the robot model and the odometry plot channel, and
decodes the binary message data with the schemas the server advertised: protobuf
(`google.protobuf`, from the FileDescriptorSet) or JSON (every field of a payload must be
declared in the advertised JSON Schema). Runs until
every topic has enough messages or the deadline passes; prints one JSON object and exits
non-zero when something is missing, does not decode or is out of range.

Usage: foxglove_live.py ws://HOST:PORT SECONDS XMIN XMAX YMIN YMAX
"""
import asyncio
import base64
import json
import struct
import sys
import time

import os

import websockets
from google.protobuf import descriptor_pb2, descriptor_pool, message_factory

# The record checker's JSON Schema test, shared rather than written twice.
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tools", "tests"))
from read_foxglove import undeclared  # noqa: E402

WANTED = {
    "/viz/scene": ("foxglove.SceneUpdate", 1),
    "/viz/lidar/points": ("foxglove.PointCloud", 3),
    "/tf": ("foxglove.FrameTransforms", 3),
    "/viz/robot": ("foxglove.SceneUpdate", 1),
    "/plot/odometry": ("aisle.plot.Odometry", 3),
}
JSON_TOPICS = {"/plot/odometry"}


class JsonChannel:
    """Decodes a JSON channel and checks each payload against its schema."""

    def __init__(self, schema_text):
        self.schema = json.loads(schema_text)

    def decode(self, data):
        value = json.loads(bytes(data).decode("utf-8"))
        missing = undeclared(value, self.schema)
        if missing:
            raise ValueError(f"fields not in the schema: {missing}")
        return value


def message_class(schema_name, schema_b64):
    fds = descriptor_pb2.FileDescriptorSet.FromString(base64.b64decode(schema_b64))
    pool = descriptor_pool.DescriptorPool()
    for f in fds.file:
        pool.Add(f)
    return message_factory.GetMessageClass(pool.FindMessageTypeByName(schema_name))


async def watch(url, seconds, bounds):
    xmin, xmax, ymin, ymax = bounds
    counts = {t: 0 for t in WANTED}
    problems = []
    poses = []
    odometry = []
    cloud_points = 0
    subs = {}
    deadline = time.monotonic() + seconds
    # The group is still starting: retry until the server listens.
    while True:
        try:
            ws = await websockets.connect(
                url,
                # The `foxglove` crate (0.30) names the protocol `foxglove.sdk.v1`;
                # the framing is that of `foxglove.websocket.v1`.
                subprotocols=["foxglove.sdk.v1", "foxglove.websocket.v1"],
                max_size=None,
            )
            break
        except (OSError, websockets.exceptions.InvalidStatus):
            if time.monotonic() > deadline:
                raise
            await asyncio.sleep(0.1)
    async with ws:
        while time.monotonic() < deadline:
            if all(counts[t] >= WANTED[t][1] for t in WANTED) and len(subs) == len(WANTED):
                break
            try:
                frame = await asyncio.wait_for(ws.recv(), timeout=1.0)
            except asyncio.TimeoutError:
                continue
            if isinstance(frame, str):
                msg = json.loads(frame)
                if msg.get("op") != "advertise":
                    continue
                new = []
                for ch in msg["channels"]:
                    topic = ch["topic"]
                    if topic not in WANTED or topic in [s[0] for s in subs.values()]:
                        continue
                    name = WANTED[topic][0]
                    encoding = "json" if topic in JSON_TOPICS else "protobuf"
                    if ch.get("schemaName") != name or ch.get("encoding") != encoding:
                        problems.append(
                            f"{topic}: advertised as {ch.get('schemaName')} "
                            f"({ch.get('encoding')})"
                        )
                        continue
                    sub_id = len(subs) + 1
                    if encoding == "json":
                        decode = JsonChannel(ch["schema"]).decode
                    else:
                        decode = message_class(name, ch["schema"]).FromString
                    subs[sub_id] = (topic, decode)
                    new.append({"id": sub_id, "channelId": ch["id"]})
                if new:
                    await ws.send(json.dumps({"op": "subscribe", "subscriptions": new}))
                continue
            if frame[0] != 0x01:  # only message data
                continue
            sub_id, _recv_ns = struct.unpack_from("<IQ", frame, 1)
            if sub_id not in subs:
                continue
            topic, decode = subs[sub_id]
            try:
                m = decode(frame[13:])
            except Exception as e:  # noqa: BLE001 - any decode failure is a finding
                problems.append(f"{topic}: {e}")
                continue
            counts[topic] += 1
            if topic == "/viz/lidar/points":
                if m.point_stride <= 0:
                    problems.append("cloud: zero point stride")
                else:
                    cloud_points = max(cloud_points, len(m.data) // m.point_stride)
            elif topic == "/tf":
                for t in m.transforms:
                    if t.parent_frame_id == "map" and t.child_frame_id == "base_link":
                        poses.append((t.translation.x, t.translation.y))
            elif topic == "/viz/scene" and not m.entities:
                problems.append("scene: no entities")
            elif topic == "/viz/robot":
                e = m.entities[0] if m.entities else None
                if e is None or e.frame_id != "base_link" or not e.frame_locked or not e.cubes:
                    problems.append(f"robot model: not a frame-locked base_link entity: {e}")
            elif topic == "/plot/odometry":
                x, y = m["x"], m["y"]
                if not (xmin <= x <= xmax and ymin <= y <= ymax):
                    problems.append(f"odometry outside the warehouse: {x}, {y}")
                odometry.append((m["v"], m["w"]))
    for t, (_, need) in WANTED.items():
        if counts[t] < need:
            problems.append(f"{t}: {counts[t]} messages, wanted {need}")
    if cloud_points == 0:
        problems.append("no cloud with points")
    if not poses:
        problems.append("no map -> base_link transform")
    outside = [p for p in poses if not (xmin <= p[0] <= xmax and ymin <= p[1] <= ymax)]
    if outside:
        problems.append(f"poses outside the warehouse: {outside[:3]}")
    return {
        "counts": counts,
        "cloud_points": cloud_points,
        "poses": len(poses),
        "first_pose": poses[0] if poses else None,
        "odometry": len(odometry),
        "max_turn_rate": max((abs(w) for _, w in odometry), default=None),
        "problems": problems,
    }


def main():
    url, seconds = sys.argv[1], float(sys.argv[2])
    bounds = [float(v) for v in sys.argv[3:7]]
    result = asyncio.run(watch(url, seconds, bounds))
    print(json.dumps(result))
    sys.exit(1 if result["problems"] else 0)


if __name__ == "__main__":
    main()
