#!/usr/bin/env bash
# Decode the typed topics of a bag with Foxglove's own ROS 2 parser and reader, and check that
# the message paths the README gives for Foxglove's Plot panel hold the values we wrote.
#
# Usage: scripts/check_plot_parsers.sh            (needs .venv with ema_phm_msgs, node and npm)
#
# 1. .venv/bin/python writes a rosbag2 MCAP bag with /ema/telemetry_batch,
#    /ema/telemetry_sample and /ema/actuator_health (rclpy's CDR bytes, BagRecorder: the
#    schemas embedded as the monitor's recordings embed them), and a JSON file with the
#    schema text, the raw bytes of each message and the value each README path should give.
# 2. npm installs the pinned @foxglove/rosmsg (the .msg parser Foxglove uses) and
#    @foxglove/rosmsg2-serialization (its CDR reader) into a temporary folder.
# 3. node parses each schema as Foxglove does (parse(text, {ros2: true})), decodes every
#    message with MessageReader, follows each path (a plain traversal: field names, [i],
#    [:] and {name=="..."} filters, as Foxglove's message-path syntax writes them) and
#    compares.  Exit 0: every path decoded to the expected value.
#
# PlotJuggler's parser (rosx_introspection) is not on PyPI, npm or Debian: not checked here.
set -euo pipefail

ROOT="$(cd -- "$(dirname -- "${BASH_SOURCE[0]}")/.." && pwd)"
VPY="$ROOT/.venv/bin/python"
ROSMSG_VERSION="5.0.5"
ROSMSG2_SERIALIZATION_VERSION="3.1.0"

die() { echo "check_plot_parsers: error: $*" >&2; exit 1; }
[ -x "$VPY" ] || die "$VPY not found; run scripts/setup_env.sh"
command -v node >/dev/null 2>&1 || die "node not found (Debian: apt-get install nodejs npm)"
command -v npm >/dev/null 2>&1 || die "npm not found (Debian: apt-get install npm)"

WORK="$(mktemp -d)"
trap 'rm -rf "$WORK"' EXIT

"$VPY" - "$WORK" <<'EOF'
import base64
import json
import math
import sys
from pathlib import Path

import numpy as np
from mcap.reader import make_reader
from rclpy.serialization import serialize_message

from ema_phm.diagnosis.health import assess
from ema_phm.domain.faults import N_K, k_with
from ema_phm.domain.window import CHANNELS, COLUMN
from ema_phm.ros import typed_messages as tm
from ema_phm.telemetry import typed, wire
from ema_phm.telemetry.bags import BagRecorder

work = Path(sys.argv[1])
n = 200
rows = np.zeros((n, len(CHANNELS)))
rows[:, COLUMN["t"]] = np.arange(n) / 2000.0
rows[:, COLUMN["i3eq"]] = np.sin(2 * np.pi * 50 * rows[:, COLUMN["t"]])  # [A]
rows[:, COLUMN["load"]] = np.nan  # load not measured
a = assess(k_with(friction=0.3, eccentricity=0.1, eccentricity_phase=0.25, gain_drift=0.55), fitness=0.01, evaluations=800, window_t0=0.0,
           window_t1=0.1)
extras = typed.HealthExtras(
    k_low=np.full(N_K, 0.05), k_high=np.full(N_K, 0.6),
    nuisances=(typed.NuisanceValue("load_torque", "N*m", -2.5),),
)
report = typed.HealthReport(a.level, a.message, "ema_sim", True, a, extras)
t_ns = 1_700_000_000_000_000_000
msgs = {
    wire.TELEMETRY_BATCH_TOPIC: [tm.telemetry_batch(rows, t_ns)],
    wire.TELEMETRY_SAMPLE_TOPIC: tm.telemetry_samples(rows, t_ns),
    wire.ACTUATOR_HEALTH_TOPIC: [tm.actuator_health(report, t_ns)],
}
bag = work / "bag"
with BagRecorder(bag, topics={t: wire.TOPIC_TYPES[t] for t in msgs}) as rec:
    for topic, items in msgs.items():
        for m in items:
            rec.write_raw(topic, bytes(serialize_message(m)), t_ns)


def num(v):
    return None if isinstance(v, float) and math.isnan(v) else v


samples = msgs[wire.TELEMETRY_SAMPLE_TOPIC]
expect = {
    "/ema/actuator_health.friction.value": [0.3],
    "/ema/actuator_health.friction.low": [0.05],
    "/ema/actuator_health.friction.high": [0.6],
    "/ema/actuator_health.gain_drift.value": [0.55],
    "/ema/actuator_health.level": [int(a.level)],
    "/ema/actuator_health.nuisances[:]{name==\"load_torque\"}.value": [-2.5],
    "/ema/actuator_health.percent_err": [None],
    "/ema/telemetry_sample.i3eq": [float(m.i3eq) for m in samples],
    "/ema/telemetry_sample.t": [float(m.t) for m in samples],
    "/ema/telemetry_sample.load": [None] * len(samples),
    "/ema/telemetry_batch.i3eq[:]": [float(v) for v in rows[:, 6]],
    "/ema/telemetry_batch.t[:]": [float(v) for v in rows[:, 0]],
}
out = {"topics": {}, "expect": expect}
[mcap_file] = bag.glob("*.mcap")
with mcap_file.open("rb") as f:
    reader = make_reader(f)
    for schema, channel, message in reader.iter_messages():
        entry = out["topics"].setdefault(
            channel.topic,
            {"schema": schema.name, "encoding": schema.encoding,
             "text": schema.data.decode(), "messages": []},
        )
        entry["messages"].append(base64.b64encode(message.data).decode())
(work / "bag.json").write_text(json.dumps(out))
print(f"check_plot_parsers: wrote {bag} ({sum(len(v['messages']) for v in out['topics'].values())} messages)")
EOF

cat > "$WORK/package.json" <<EOF
{"private": true, "dependencies": {
  "@foxglove/rosmsg": "$ROSMSG_VERSION",
  "@foxglove/rosmsg2-serialization": "$ROSMSG2_SERIALIZATION_VERSION"}}
EOF
(cd "$WORK" && npm install --no-audit --no-fund --loglevel=error >/dev/null) \
    || die "npm install of @foxglove/rosmsg@$ROSMSG_VERSION and @foxglove/rosmsg2-serialization@$ROSMSG2_SERIALIZATION_VERSION failed"

cat > "$WORK/check.js" <<'EOF'
const fs = require("fs");
const { parse } = require("@foxglove/rosmsg");
const { MessageReader } = require("@foxglove/rosmsg2-serialization");

const data = JSON.parse(fs.readFileSync(process.argv[2], "utf8"));
const decoded = {};
for (const [topic, entry] of Object.entries(data.topics)) {
  if (entry.encoding !== "ros2msg") throw new Error(`${topic}: schema encoding ${entry.encoding}`);
  const reader = new MessageReader(parse(entry.text, { ros2: true }));
  decoded[topic] = entry.messages.map((b64) => {
    const msg = reader.readMessage(Buffer.from(b64, "base64"));
    if (reader.lastReadHadTrailingBytes()) throw new Error(`${topic}: trailing bytes`);
    return msg;
  });
}

// A message path: /topic.field.sub, field[i], field[:], field[:]{name=="x"}.
function follow(values, step) {
  const m = step.match(/^(\w+)(?:\[(\d+|:)\])?(?:\{(\w+)=="([^"]*)"\})?$/);
  if (!m) throw new Error(`cannot follow ${step}`);
  const [, field, index, key, wanted] = m;
  let out = values.map((v) => v[field]);
  if (index === ":") out = out.flatMap((v) => Array.from(v));
  else if (index !== undefined) out = out.map((v) => v[Number(index)]);
  if (key !== undefined) out = out.filter((v) => v[key] === wanted);
  return out;
}
let bad = 0;
for (const [path, want] of Object.entries(data.expect)) {
  const [topic, ...steps] = path.split(/\.(?![^{]*})/);
  let values = decoded[topic];
  for (const step of steps) values = follow(values, step);
  const got = values.map((v) => (typeof v === "bigint" ? Number(v) : v));
  const same = got.length === want.length && got.every((g, i) =>
    want[i] === null ? Number.isNaN(g) : Math.abs(g - want[i]) <= 1e-12 * Math.max(1, Math.abs(want[i])));
  console.log(`${same ? "ok  " : "BAD "} ${path}: ${got.length} value(s), first ${got[0]}`);
  if (!same) bad += 1;
}
process.exit(bad ? 1 : 0);
EOF
node "$WORK/check.js" "$WORK/bag.json" || die "Foxglove's parser disagrees with the README paths (see BAD above)"
echo "check_plot_parsers: every path decoded with @foxglove/rosmsg $ROSMSG_VERSION + @foxglove/rosmsg2-serialization $ROSMSG2_SERIALIZATION_VERSION"
