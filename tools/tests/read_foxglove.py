#!/usr/bin/env python3
"""Independent check of an aisle MCAP file with the Python `mcap` reader and
`mcap-protobuf-support`: every channel has an encoding Foxglove decodes (what Lichtblick's
`parseChannel` accepts: protobuf with a protobuf schema, json with a JSON Schema), every
Foxglove viewer channel decodes with the schema the file carries, the plot channels'
JSON holds only fields their schema declares, and the raw channels have the metadata
replay needs and decode as their protobuf envelope (one `data` bytes field of at most
the type's size).

Usage: read_foxglove.py FILE.mcap. Prints one JSON object with counts per topic and
exits non-zero when something does not decode or is missing.
"""
import json
import sys

from mcap.reader import make_reader
from mcap_protobuf.decoder import DecoderFactory

EXPECTED = {
    "/viz/scene": "foxglove.SceneUpdate",
    "/viz/lidar/points": "foxglove.PointCloud",
    "/viz/map/global": "foxglove.Grid",
    "/viz/map/local": "foxglove.Grid",
    "/viz/path/reference": "foxglove.PosesInFrame",
    "/viz/path/band": "foxglove.PosesInFrame",
    "/viz/path/driven": "foxglove.PosesInFrame",
    "/tf": "foxglove.FrameTransforms",
    "/viz/log": "foxglove.Log",
}
PLOTS = {
    "/plot/odometry": "aisle.plot.Odometry",
    "/plot/cmd_vel": "aisle.plot.Command",
    "/plot/teb": "aisle.plot.TebStep",
    "/plot/latency": "aisle.plot.StageLatency",
}
RAW_KEYS = {"aisle_raw", "layout", "type_name", "size", "align", "layout_hash", "schema_hash"}
# Message encoding -> the schema encoding Foxglove expects with it.
FOXGLOVE_ENCODINGS = {"protobuf": "protobuf", "json": "jsonschema"}


def undeclared(value, schema, path=""):
    """The fields of `value` its JSON Schema does not declare (recursively)."""
    if not isinstance(value, dict):
        return []
    props = schema.get("properties", {})
    out = []
    for k, v in value.items():
        if k not in props:
            out.append(f"{path}.{k}")
        else:
            out.extend(undeclared(v, props[k], f"{path}.{k}"))
    return out


def main(path):
    counts = {}
    problems = []
    raw_sizes = {}
    raw_decoded = 0
    with open(path, "rb") as f:
        reader = make_reader(f, validate_crcs=True, decoder_factories=[DecoderFactory()])
        summary = reader.get_summary()
        if summary is None:
            problems.append("no summary: the file was not finalised")
        else:
            for ch in summary.channels.values():
                schema = summary.schemas.get(ch.schema_id)
                want = FOXGLOVE_ENCODINGS.get(ch.message_encoding)
                if want is None or schema is None or schema.encoding != want:
                    problems.append(
                        f"{ch.topic}: encoding {ch.message_encoding} with schema "
                        f"{schema.encoding if schema else None}: Foxglove would flag it"
                    )
                if ch.metadata.get("aisle_raw") == "protobuf_envelope":
                    raw_sizes[ch.topic] = int(ch.metadata.get("size", "0"))
                    missing = RAW_KEYS - set(ch.metadata)
                    if missing:
                        problems.append(f"{ch.topic}: metadata lacks {sorted(missing)}")
                    schema = summary.schemas.get(ch.schema_id)
                    if schema is None or schema.name != ch.metadata.get("type_name"):
                        problems.append(f"{ch.topic}: schema name is not the type name")
        for schema, channel, message, decoded in reader.iter_decoded_messages(
            topics=list(EXPECTED) + list(raw_sizes)
        ):
            if channel.topic in raw_sizes:
                raw_decoded += 1
                if not 0 < len(decoded.data) <= raw_sizes[channel.topic]:
                    problems.append(f"{channel.topic}: {len(decoded.data)} payload bytes")
                continue
            if schema.name != EXPECTED[channel.topic]:
                problems.append(f"{channel.topic}: schema {schema.name}")
            counts[channel.topic] = counts.get(channel.topic, 0) + 1
            if channel.topic == "/viz/map/global":
                if decoded.column_count * decoded.row_stride == 0 or len(decoded.data) % decoded.row_stride:
                    problems.append("grid data does not fill its rows")
            if channel.topic == "/viz/lidar/points" and len(decoded.data) % decoded.point_stride:
                problems.append("point cloud data is not a whole number of points")
            if channel.topic == "/tf":
                for t in decoded.transforms:
                    if not t.parent_frame_id or not t.child_frame_id:
                        problems.append("transform without frames")
        for schema, channel, message in reader.iter_messages(topics=list(PLOTS)):
            if schema.name != PLOTS[channel.topic]:
                problems.append(f"{channel.topic}: schema {schema.name}")
            extra = undeclared(json.loads(message.data), json.loads(schema.data))
            if extra:
                problems.append(f"{channel.topic}: fields not in the schema: {extra}")
            counts[channel.topic] = counts.get(channel.topic, 0) + 1
        attachments = [a.name for a in reader.iter_attachments()]
    for topic in list(EXPECTED) + list(PLOTS):
        if counts.get(topic, 0) == 0:
            problems.append(f"{topic}: no decoded messages")
    if raw_decoded == 0:
        problems.append("no raw message decoded as its envelope")
    counts["raw"] = raw_decoded
    print(json.dumps({"counts": counts, "attachments": attachments, "problems": problems}))
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1]))
