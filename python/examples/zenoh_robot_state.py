"""Watch the robot of a spread group from any machine on its Zenoh network, without
iceoryx2: find the robot-state service among the link's offers, subscribe to the key its
samples cross on, and decode each sample with the generated layout.

Needs only `pip install eclipse-zenoh` and this checkout's `python/aisle/_generated.py`
(loaded by path, so the SDK's iceoryx2 dependency is not needed here).

    python3 zenoh_robot_state.py --connect tcp/10.20.0.1:7447 --count 20

Each line: `tick <n> stamp_ns <ns> pose <x> <y> <theta>`, the floats as `repr` writes
them (the shortest text that reads back to the same bits). Exits 0 after `--count` samples, 1 when the offer or the samples do
not arrive within `--timeout` seconds, 2 on a bad argument.

What the link puts on Zenoh (iceoryx2 0.10's Zenoh carrier), under the group's
namespace (`aisle`):
- `iox2/v1/offer/<service hash>/<fingerprint>/<peer>`: a queryable per offered service
  whose reply is the service's descriptor (postcard), which holds the service name and
  the payload's type name;
- `iox2/v1/channel/<service hash>/<fingerprint>`: one put per sample, the user header
  (none on aisle's topics) followed by the payload, byte for byte as in shared memory
  up to the part its fields use (`aisle_link::trimmed`: a map's cells, a cloud's
  points; a robot state is used whole). The rest is zeros: pad to the type's size.
"""

import argparse
import ctypes
import importlib.util
import json
import pathlib
import sys
import threading

import zenoh

NAMESPACE = "aisle"
OFFERS = "iox2/v1/offer/**"


def generated():
    """The checkout's generated layouts, loaded by path."""
    path = pathlib.Path(__file__).resolve().parent.parent / "aisle" / "_generated.py"
    spec = importlib.util.spec_from_file_location("aisle_generated", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def postcard_str(text):
    """`text` as postcard encodes a string: its length as a varint, then its bytes."""
    raw = text.encode()
    n, prefix = len(raw), bytearray()
    while True:
        byte = n & 0x7F
        n >>= 7
        prefix.append(byte | (0x80 if n else 0))
        if not n:
            return bytes(prefix) + raw


def session(connect):
    conf = zenoh.Config()
    conf.insert_json5("mode", '"peer"')
    conf.insert_json5("connect/endpoints", json.dumps(connect))
    conf.insert_json5("scouting/multicast/enabled", "false")
    conf.insert_json5("namespace", json.dumps(NAMESPACE))
    return zenoh.open(conf)


def find_channel(z, topic, timeout):
    """The channel key of the service named `topic.name` whose descriptor names the
    topic's type, asking the offers until one answers or `timeout` runs out."""
    name, type_name = postcard_str(topic.name), topic.message.TYPE_NAME.encode()
    waited = 0.0
    while waited < timeout:
        for reply in z.get(OFFERS, timeout=1.0):
            if reply.ok is None:
                continue
            descriptor = reply.ok.payload.to_bytes()
            if name in descriptor and type_name in descriptor:
                parts = str(reply.ok.key_expr).split("/")
                # [..., "offer", hash, fingerprint, peer]
                hash_, fingerprint = parts[-3], parts[-2]
                return f"iox2/v1/channel/{hash_}/{fingerprint}"
        threading.Event().wait(0.2)
        waited += 1.2
    return None


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--connect", action="append", required=True,
                    help="Zenoh endpoint of a host of the group (repeatable)")
    ap.add_argument("--count", type=int, default=20, help="samples to print")
    ap.add_argument("--timeout", type=float, default=60.0, help="seconds")
    args = ap.parse_args()
    gen = generated()
    topic = gen.ROBOT_STATE
    layout = topic.message
    size = ctypes.sizeof(layout)
    with session(args.connect) as z:
        key = find_channel(z, topic, args.timeout)
        if key is None:
            print(f"no offer of {topic.name} within {args.timeout} s", file=sys.stderr)
            return 1
        print(f"key {NAMESPACE}/{key}", flush=True)
        done, lines, bad = threading.Event(), [], []

        def on_sample(sample):
            payload = sample.payload.to_bytes()
            if len(payload) > size:
                bad.append(len(payload))
                done.set()
                return
            s = layout.from_buffer_copy(payload.ljust(size, b"\0"))
            p = s.pose
            lines.append(
                f"tick {s.header.tick} stamp_ns {s.header.stamp_ns} "
                f"pose {p.x!r} {p.y!r} {p.theta!r}"
            )
            if len(lines) >= args.count:
                done.set()

        sub = z.declare_subscriber(key, on_sample)
        done.wait(args.timeout)
        sub.undeclare()
        for line in lines[: args.count]:
            print(line)
        if bad:
            print(f"a sample of {bad[0]} bytes, more than {size}", file=sys.stderr)
            return 1
        if len(lines) < args.count:
            print(f"{len(lines)} of {args.count} samples within {args.timeout} s",
                  file=sys.stderr)
            return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
