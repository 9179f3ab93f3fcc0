"""Reads an `aisle export --ros2` bag with rosbags (AnyReader over the .mcap file),
deserializes every message and compares it with the source record as
tests/ros2_export.rs decoded it (expected.json, points.bin, grids.bin).

Usage: ros2_export.py BAG.mcap EXPECTED.json
Prints one JSON line: {"decoded": {topic: count}, "problems": [...]}; exit 1 on a problem.
"""

import json
import math
import sys
from collections import defaultdict
from pathlib import Path

import numpy as np
from rosbags.highlevel import AnyReader
from rosbags.typesys import Stores, get_typestore

TOL = 1e-9
problems = []


def check(cond, what):
    if not cond and len(problems) < 40:
        problems.append(what)


def ns(stamp):
    return stamp.sec * 1_000_000_000 + stamp.nanosec


def yaw(q):
    return math.atan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y * q.y + q.z * q.z))


def angle_diff(a, b):
    return abs(math.remainder(a - b, math.tau))


def close_pose(pose, x, y, th, what):
    p, q = pose.position, pose.orientation
    check(abs(p.x - x) < TOL and abs(p.y - y) < TOL and p.z == 0.0, f"{what}: position {p} vs {x, y}")
    check(angle_diff(yaw(q), th) < TOL, f"{what}: yaw {yaw(q)} vs {th}")
    check(abs(q.x) < TOL and abs(q.y) < TOL, f"{what}: not planar {q}")


def main():
    bag, expected_path = Path(sys.argv[1]), Path(sys.argv[2])
    exp = json.loads(expected_path.read_text())
    points = np.fromfile(exp["points"], dtype="<f4")
    grids = np.fromfile(exp["grids"], dtype=np.uint8)
    by_topic = defaultdict(list)
    jazzy = get_typestore(Stores.ROS2_JAZZY)
    with AnyReader([bag]) as reader:
        # The definitions in the bag are the standard ones (ROS 2 Jazzy's): constants and
        # fields, so the type hashes (RIHS01) agree too.
        for conn in reader.connections:
            check(conn.msgdef.format.name == "MSG", f"{conn.topic}: definition {conn.msgdef.format}")
        types = reader.typestore.fielddefs
        check(len(types) == 20, f"{len(types)} types defined: {sorted(types)}")
        for name, fields in types.items():
            check(fields == jazzy.fielddefs.get(name), f"{name}: differs from Jazzy's")
            check(reader.typestore.hash_rihs01(name) == jazzy.hash_rihs01(name), f"{name}: hash")
        qos = {c.topic: c.ext.offered_qos_profiles for c in reader.connections}
        check(qos["/tf_static"][0].durability.name == "TRANSIENT_LOCAL", f"/tf_static QoS {qos['/tf_static']}")
        for conn, log_time, raw in reader.messages():
            check(raw[:4] == b"\x00\x01\x00\x00", f"{conn.topic}: encapsulation {raw[:4]!r}")
            by_topic[conn.topic].append((log_time, reader.deserialize(raw, conn.msgtype)))
    decoded = {t: len(v) for t, v in by_topic.items()}
    for msgs in by_topic.values():
        msgs.sort(key=lambda m: ns(m[1].header.stamp) if hasattr(m[1], "header") else m[0])
    compare_robot(exp, by_topic)
    compare_clouds(exp, by_topic, points)
    compare_grids(exp["global"], by_topic["/map"], grids, "/map")
    compare_grids(exp["local"], by_topic["/aisle/local_map"], grids, "/aisle/local_map")
    compare_paths(exp, by_topic)
    cmds = [m for _, m in sorted(by_topic["/cmd_vel"], key=lambda m: m[0])]
    check(len(cmds) == len(exp["cmds"]), f"/cmd_vel: {len(cmds)} vs {len(exp['cmds'])}")
    for m, (_, v, w) in zip(cmds, sorted(exp["cmds"], key=lambda c: c[0])):
        check(m.linear.x == v and m.angular.z == w, f"/cmd_vel {m} vs {v, w}")
    print(json.dumps({"decoded": decoded, "problems": problems}))
    return 1 if problems else 0


def compare_robot(exp, by_topic):
    robot = exp["robot"]
    odom, tf = by_topic["/odom"], by_topic["/tf"]
    check(len(odom) == len(robot) == len(tf), f"/odom {len(odom)}, /tf {len(tf)}, states {len(robot)}")
    for (_, o), (_, t), (stamp, x, y, th, v, w) in zip(odom, tf, robot):
        check(ns(o.header.stamp) == stamp, f"/odom stamp {o.header.stamp} vs {stamp}")
        check((o.header.frame_id, o.child_frame_id) == ("odom", "base_link"), "/odom frames")
        close_pose(o.pose.pose, x, y, th, f"/odom at {stamp}")
        check(o.twist.twist.linear.x == v and o.twist.twist.angular.z == w, f"/odom twist at {stamp}")
        frames = [(f.header.frame_id, f.child_frame_id) for f in t.transforms]
        check(frames == [("map", "odom"), ("odom", "base_link")], f"/tf frames {frames}")
        base = t.transforms[1].transform
        check(ns(t.transforms[1].header.stamp) == stamp, f"/tf stamp at {stamp}")
        check(abs(base.translation.x - x) < TOL and abs(base.translation.y - y) < TOL, f"/tf at {stamp}")
        check(angle_diff(yaw(base.rotation), th) < TOL, f"/tf yaw at {stamp}")


def compare_clouds(exp, by_topic, points):
    clouds = by_topic["/aisle/points"]
    check(len(clouds) == len(exp["clouds"]), f"/aisle/points: {len(clouds)} vs {len(exp['clouds'])}")
    statics = by_topic["/tf_static"]
    check(len(statics) >= 1, "no /tf_static")
    mount = statics[0][1].transforms[0]
    check((mount.header.frame_id, mount.child_frame_id) == ("base_link", "sensor"), "mount frames")
    for (_, m), e in zip(clouds, exp["clouds"]):
        what = f"/aisle/points at {e['stamp']}"
        check(ns(m.header.stamp) == e["stamp"] and m.header.frame_id == "sensor", f"{what}: header")
        check((m.height, m.width) == (e["rows"], e["cols"]), f"{what}: shape")
        fields = {f.name: (f.offset, f.datatype, f.count) for f in m.fields}
        check(fields == {"x": (0, 7, 1), "y": (4, 7, 1), "z": (8, 7, 1)}, f"{what}: fields {fields}")
        check(m.point_step == 12 and m.row_step == 12 * m.width and not m.is_bigendian, f"{what}: steps")
        n = e["rows"] * e["cols"]
        got = np.frombuffer(np.asarray(m.data, dtype=np.uint8).tobytes(), dtype="<f4").reshape(-1, 3)
        want = points[3 * e["offset"] : 3 * (e["offset"] + n)].reshape(-1, 3)
        check(np.array_equal(got, want, equal_nan=True), f"{what}: points differ")
        check(m.is_dense == bool(np.isfinite(want).all()), f"{what}: is_dense")
        # The mount placed at the scan's robot pose is the scan's sensor position.
        rx, ry, rth = e["robot"]
        t = mount.transform.translation
        sx = rx + math.cos(rth) * t.x - math.sin(rth) * t.y
        sy = ry + math.sin(rth) * t.x + math.cos(rth) * t.y
        sp = e["sensor"]
        check(abs(sx - sp[0]) < 1e-6 and abs(sy - sp[1]) < 1e-6 and abs(t.z - sp[2]) < 1e-9, f"{what}: mount")


def compare_grids(expected, got, cells, topic):
    check(len(got) == len(expected), f"{topic}: {len(got)} vs {len(expected)}")
    lut = np.full(256, -1, dtype=np.int8)
    lut[0], lut[1], lut[2] = 0, 100, 100
    for (_, m), e in zip(got, expected):
        what = f"{topic} at {e['stamp']}"
        i = m.info
        check(ns(m.header.stamp) == e["stamp"] and m.header.frame_id == "map", f"{what}: header")
        check((i.width, i.height) == (e["width"], e["height"]), f"{what}: size")
        check(abs(i.resolution - e["resolution"]) < 1e-6, f"{what}: resolution")
        close_pose(i.origin, e["origin"][0], e["origin"][1], 0.0, f"{what}: origin")
        n = e["width"] * e["height"]
        want = lut[cells[e["offset"] : e["offset"] + n]]
        check(np.array_equal(np.asarray(m.data, dtype=np.int8), want), f"{what}: cells differ")


def compare_paths(exp, by_topic):
    plans = by_topic["/plan"]
    check(len(plans) == len(exp["plans"]), f"/plan: {len(plans)} vs {len(exp['plans'])}")
    for (_, m), e in zip(plans, exp["plans"]):
        check(len(m.poses) == len(e["poses"]), f"/plan at {e['stamp']}: length")
        for p, (x, y, th) in zip(m.poses, e["poses"]):
            close_pose(p.pose, x, y, th, f"/plan at {e['stamp']}")
    bands = by_topic["/aisle/band"]
    check(len(bands) == len(exp["bands"]), f"/aisle/band: {len(bands)} vs {len(exp['bands'])}")
    for (_, m), e in zip(bands, exp["bands"]):
        check(len(m.poses) == len(e["poses"]), f"/aisle/band at {e['stamp']}: length")
        for p, (t, x, y, th) in zip(m.poses, e["poses"]):
            close_pose(p.pose, x, y, th, f"/aisle/band at {e['stamp']}")
            check(abs(ns(p.header.stamp) - (e["stamp"] + t * 1e9)) <= 1, f"/aisle/band pose stamp")
    # The driven path: every DRIVEN_EVERY-th state, the distinct poses so far.
    driven = by_topic["/aisle/driven_path"]
    every = exp["driven_every"]
    check(len(driven) == len(exp["robot"]) // every, f"/aisle/driven_path: {len(driven)}")
    so_far = []
    for k, (stamp, x, y, th, _, _) in enumerate(exp["robot"], start=1):
        if not so_far or so_far[-1] != (x, y, th):
            so_far.append((x, y, th))
        if k % every == 0 and k // every <= len(driven):
            m = driven[k // every - 1][1]
            check(ns(m.header.stamp) == stamp, f"/aisle/driven_path stamp {stamp}")
            check(len(m.poses) == len(so_far), f"/aisle/driven_path at {stamp}: {len(m.poses)} vs {len(so_far)}")
            for p, (px, py, pth) in zip(m.poses, so_far):
                close_pose(p.pose, px, py, pth, f"/aisle/driven_path at {stamp}")


if __name__ == "__main__":
    sys.exit(main())
