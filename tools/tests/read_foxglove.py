#!/usr/bin/env python3
"""Independent check of an aisle MCAP file with the Python `mcap` reader and
`mcap-protobuf-support`: every Foxglove viewer channel decodes with the schema the file
carries, and the raw channels have the metadata replay needs.

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
RAW_KEYS = {"type_name", "size", "align", "layout_hash", "schema_hash"}


def main(path):
    counts = {}
    problems = []
    with open(path, "rb") as f:
        reader = make_reader(f, validate_crcs=True, decoder_factories=[DecoderFactory()])
        summary = reader.get_summary()
        if summary is None:
            problems.append("no summary: the file was not finalised")
        else:
            for ch in summary.channels.values():
                if ch.message_encoding == "aisle-raw":
                    missing = RAW_KEYS - set(ch.metadata)
                    if missing:
                        problems.append(f"{ch.topic}: metadata lacks {sorted(missing)}")
                    schema = summary.schemas.get(ch.schema_id)
                    if schema is None or schema.name != ch.metadata.get("type_name"):
                        problems.append(f"{ch.topic}: schema name is not the type name")
        for schema, channel, message, decoded in reader.iter_decoded_messages(
            topics=list(EXPECTED)
        ):
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
        attachments = [a.name for a in reader.iter_attachments()]
    for topic in EXPECTED:
        if counts.get(topic, 0) == 0:
            problems.append(f"{topic}: no decoded messages")
    print(json.dumps({"counts": counts, "attachments": attachments, "problems": problems}))
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1]))
