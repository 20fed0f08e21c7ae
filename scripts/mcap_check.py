#!/usr/bin/env python3
"""Every recorded run opens in Foxglove (`.ci/run`, through scripts/mcap_check.sh).

    python scripts/mcap_check.py PHYSICS_MCP_BIN FOXGLOVE_SCHEMAS_TGZ SCRATCH_DIR

For every log in replays/*.sqlite (copied to SCRATCH_DIR first: the recorded files stay as
they are), runs `physics-mcp replay LOG --mcap OUT --contacts` — the whole chain of the log's
head — and reads OUT back with the `mcap` package's reader (independent of the Rust writer):

  * the schemas are Foxglove's published JSON schemas, byte for byte in meaning: each schema
    record is compared with the one in the npm package `@foxglove/schemas` (pinned, its
    tarball's sha256 checked by the caller and again here);
  * every message on /scene, /tf and /contacts validates against the published schema for
    its channel; channels are JSON-encoded; log time = publish time, never going back, and
    per-channel sequence numbers count up from 0; the summary's message count is what was read;
  * every entity's frame has a transform on /tf (the 3D panel can place it).

A self-test first shows the validation can fail: broken messages (a required field left out,
a wrong type) must be rejected, and a truncated file must not read. Exit 1 on any failure.
"""

import hashlib
import io
import json
import re
import shutil
import subprocess
import sys
import tarfile
from pathlib import Path

import jsonschema
from mcap.reader import make_reader

SCHEMAS_VERSION = "2.1.0"
SCHEMAS_SHA256 = "c6d2746e10bbb451a680307b6e5ec3b186de3263df2a41869a7757b3042fcbf0"
TOPICS = {"/scene": "foxglove.SceneUpdate", "/tf": "foxglove.FrameTransforms", "/contacts": "foxglove.SceneUpdate"}


def check(cond, what):
    if not cond:
        raise AssertionError(what)


def published_schemas(tgz):
    """Foxglove's JSON schemas by name ("foxglove.SceneUpdate" → schema), from the package's
    `dist/jsonschema/index.js`, where each is a JSON object literal (`exports.X = {...};`)."""
    data = Path(tgz).read_bytes()
    check(hashlib.sha256(data).hexdigest() == SCHEMAS_SHA256, f"{tgz}: sha256 is not the pinned @foxglove/schemas {SCHEMAS_VERSION}")
    with tarfile.open(fileobj=io.BytesIO(data)) as tar:
        source = tar.extractfile("package/dist/jsonschema/index.js").read().decode()
    out = {}
    for name in ("SceneUpdate", "FrameTransforms"):
        m = re.search(r"^exports\." + name + r" = (\{.*?^\});$", source, re.S | re.M)
        check(m is not None, f"@foxglove/schemas has no {name}")
        schema = json.loads(m.group(1))
        check(schema["title"] == f"foxglove.{name}", f"{name}: title {schema['title']}")
        out[schema["title"]] = schema
    return out


def validators(schemas):
    return {name: jsonschema.validators.validator_for(s)(s) for name, s in schemas.items()}


def errors(validator, message):
    return [e.message for e in validator.iter_errors(message)]


def check_file(path, schemas, checkers):
    """What `path` holds: {topic: messages}; raises on anything wrong."""
    by_topic = {}
    with open(path, "rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        last = {}
        for schema, channel, message in reader.iter_messages(log_time_order=False):
            topic = channel.topic
            check(topic in TOPICS, f"unexpected topic {topic}")
            check(schema is not None and schema.name == TOPICS[topic], f"{topic}: schema {schema and schema.name}")
            check(schema.encoding == "jsonschema", f"{topic}: schema encoding {schema.encoding}")
            check(json.loads(schema.data) == schemas[schema.name], f"{topic}: the schema is not Foxglove's published {schema.name}")
            check(channel.message_encoding == "json", f"{topic}: message encoding {channel.message_encoding}")
            check(message.log_time == message.publish_time, f"{topic}: log time {message.log_time} != publish time {message.publish_time}")
            t, seq = last.get(topic, (0, -1))
            check(message.log_time >= t, f"{topic}: time goes back ({message.log_time} after {t})")
            check(message.sequence == seq + 1, f"{topic}: sequence {message.sequence} after {seq}")
            last[topic] = (message.log_time, message.sequence)
            body = json.loads(message.data)
            bad = errors(checkers[schema.name], body)
            check(not bad, f"{topic} message {message.sequence} does not validate: {bad[:3]}")
            by_topic.setdefault(topic, []).append(body)
        check(summary is not None and summary.statistics is not None, "the file has no summary statistics")
        count = sum(len(v) for v in by_topic.values())
        check(summary.statistics.message_count == count, f"statistics say {summary.statistics.message_count} messages, read {count}")
    for topic in ("/scene", "/tf", "/contacts"):
        check(topic in by_topic, f"no message on {topic}")
    frames = {t["child_frame_id"] for m in by_topic["/tf"] for t in m["transforms"]}
    check(all(t["parent_frame_id"] == "world" for m in by_topic["/tf"] for t in m["transforms"]), "a transform not from world")
    for m in by_topic["/scene"]:
        for e in m["entities"]:
            check(e["frame_id"] in frames, f"entity {e['id']}: frame {e['frame_id']} has no transform")
    return by_topic


def self_test(checkers, sample_file):
    """The checks can fail: broken messages are rejected, a truncated file does not read."""
    scene = checkers["foxglove.SceneUpdate"]
    tf = checkers["foxglove.FrameTransforms"]
    good_entity = {
        "timestamp": {"sec": 0, "nsec": 0}, "frame_id": "object_0", "id": "object_0", "lifetime": {"sec": 0, "nsec": 0},
        "frame_locked": True, "metadata": [], "arrows": [], "cubes": [], "spheres": [], "cylinders": [], "lines": [],
        "triangles": [], "texts": [], "models": [],
    }
    check(not errors(scene, {"deletions": [], "entities": [good_entity]}), "the self-test's good message is rejected")
    missing = dict(good_entity)
    del missing["frame_locked"]
    check(errors(scene, {"deletions": [], "entities": [missing]}), "an entity without frame_locked was accepted")
    wrong = {"transforms": [{"timestamp": {"sec": "0", "nsec": 0}, "parent_frame_id": "world", "child_frame_id": "a",
                             "translation": {"x": 0, "y": 0, "z": 0}, "rotation": {"x": 0, "y": 0, "z": 0, "w": 1}}]}
    check(errors(tf, wrong), "a transform with a string time was accepted")
    data = Path(sample_file).read_bytes()
    broken = Path(sample_file).with_suffix(".truncated.mcap")
    broken.write_bytes(data[: len(data) // 2])
    try:
        with open(broken, "rb") as f:
            reader = make_reader(f)
            list(reader.iter_messages())
            reader.get_summary()
    except Exception:
        return
    raise AssertionError("a truncated MCAP file read without an error")


def main():
    binary, tgz, scratch = sys.argv[1], sys.argv[2], Path(sys.argv[3])
    schemas = published_schemas(tgz)
    checkers = validators(schemas)
    logs = sorted(Path(__file__).resolve().parent.parent.glob("replays/*.sqlite"))
    check(logs, "no logs in replays/")
    tested = False
    for log in logs:
        copy = scratch / log.name
        shutil.copyfile(log, copy)
        out = scratch / (log.stem + ".mcap")
        run = subprocess.run([binary, "replay", str(copy), "--mcap", str(out), "--contacts"], capture_output=True, text=True)
        check(run.returncode == 0, f"{log.name}: replay --mcap failed: {run.stderr.strip()}")
        topics = check_file(out, schemas, checkers)
        if not tested:
            self_test(checkers, out)
            tested = True
        counts = ", ".join(f"{t} {len(m)}" for t, m in sorted(topics.items()))
        print(f"{log.name}: {out.stat().st_size} bytes, {counts}")
    print(f"mcap_check: {len(logs)} logs export to valid Foxglove MCAP")


if __name__ == "__main__":
    try:
        main()
    except AssertionError as e:
        print(f"mcap_check: FAILED: {e}", file=sys.stderr)
        sys.exit(1)
