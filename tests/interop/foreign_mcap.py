"""MCAP files written by other tools' PyPI writers — ROS 2 (CDR with a ros2msg schema) and
protobuf (a FileDescriptorSet schema) — identified with a model file give the same
estimates as the CSV of the same samples.

usage: foreign_mcap.py FPKBENCH WORKDIR
"""

import csv
import json
import pathlib
import subprocess
import sys

from google.protobuf import descriptor_pb2, descriptor_pool, message_factory
from mcap_protobuf.writer import Writer as ProtoWriter
from mcap_ros2.writer import Writer as Ros2Writer

fpk, work = sys.argv[1], pathlib.Path(sys.argv[2])
work.mkdir(parents=True, exist_ok=True)
root = pathlib.Path(__file__).resolve().parents[2]

# The SDOF Duffing run as a rig would have logged it: 32 records of 3125 samples.
log = work / "sdof.mcap"
subprocess.run([fpk, "simulate", str(root / "scenarios" / "sdof_duffing.toml"), "-o", str(log)], check=True)
subprocess.run([fpk, "export", str(log), "--format", "csv", "-o", str(work / "sdof.csv")], check=True)
with open(work / "sdof.csv", newline="") as f:
    rows = list(csv.DictReader(f))
records = {}
for r in rows:
    records.setdefault(int(float(r["trajectory"])), []).append((float(r["t"]), float(r["x_m1"]), float(r["v_m1"])))
SPACING = 1000.0  # s between the records' starts on the loggers' clock


def ns(record, t):
    return round((record * SPACING + t) * 1e9)


# ROS 2: a message with a header-like stamp and arrays, as a joint-state logger writes.
ros = work / "ros2.mcap"
with open(ros, "wb") as f:
    w = Ros2Writer(f)
    schema = w.register_msgdef(
        "rig_msgs/msg/State",
        "builtin_interfaces/Time stamp\nuint32 record\nstring frame\nfloat64[] position\nfloat64[] velocity\n",
    )
    for k, samples in records.items():
        for t, x, v in samples:
            stamp = {"sec": int(ns(k, t) // 10**9), "nanosec": int(ns(k, t) % 10**9)}
            msg = {"stamp": stamp, "record": k, "frame": "m1", "position": [x, 0.0], "velocity": [v, 0.0]}
            w.write_message("/rig/state", schema, msg, log_time=ns(k, t), publish_time=ns(k, t))
    w.finish()

# Protobuf: a nested message, built at run time from a FileDescriptorProto.
fd = descriptor_pb2.FileDescriptorProto(name="rig.proto", package="rig", syntax="proto3")
pose = fd.message_type.add(name="Pose")
pose.field.add(name="x", number=1, type=1, label=1)
pose.field.add(name="v", number=2, type=1, label=1)
state = fd.message_type.add(name="State")
state.field.add(name="record", number=1, type=13, label=1)
state.field.add(name="pose", number=2, type=11, type_name=".rig.Pose", label=1)
pool = descriptor_pool.DescriptorPool()
pool.Add(fd)
State = message_factory.GetMessageClass(pool.FindMessageTypeByName("rig.State"))
proto = work / "proto.mcap"
with open(proto, "wb") as f:
    w = ProtoWriter(f)
    for k, samples in records.items():
        for t, x, v in samples:
            m = State(record=k)  # record 0 is left out of the wire (proto3)
            m.pose.x, m.pose.v = x, v
            w.write_message("/rig/state", m, log_time=ns(k, t), publish_time=ns(k, t))
    w.finish()

MODEL = """
name = "sdof-{kind}"
[[mass]]
name = "m1"
value = 1.0
[[link]]
ends = ["ground", "m1"]
[[excitation]]
kind = "white"
sigma = 1.0
acts_on = ["m1"]
[identify]
methods = ["weak"]
[identify.links.ground-m1]
stiffness = [1, 3]
damping = [1]
[data]
{mapping}
"""
mappings = {
    "csv": 'time = "t"\nrecord = "trajectory"\n[data.columns]\nx_m1 = "x_m1"\nv_m1 = "v_m1"',
    "ros2": 'topic = "/rig/state"\ntime = "log_time"\nrecord = "record"\n'
    '[data.columns]\nx_m1 = "position.0"\nv_m1 = "velocity.0"',
    "proto": 'topic = "/rig/state"\ntime = "log_time"\nrecord = "record"\n'
    '[data.columns]\nx_m1 = "pose.x"\nv_m1 = "pose.v"',
}
files = {"csv": work / "sdof.csv", "ros2": ros, "proto": proto}
estimates = {}
for kind, mapping in mappings.items():
    model = work / f"{kind}.toml"
    model.write_text(MODEL.format(kind=kind, mapping=mapping))
    out = subprocess.run(
        [fpk, "identify", "--model", str(model), "--data", str(files[kind]), "--json", "--no-validate",
         "--out", str(work / f"out-{kind}")],
        capture_output=True, text=True,
    )
    if out.returncode != 0:
        sys.exit(f"{kind}: exit {out.returncode}: {out.stderr}")
    report = json.loads(out.stdout)
    estimates[kind] = {p["name"]: p["estimate"] for p in report["methods"][0]["parameters"]}
for kind in ("ros2", "proto"):
    for name, e in estimates["csv"].items():
        got = estimates[kind][name]
        # The CSV holds the values to 17 significant digits; the loggers' clocks round the
        # times to ns, which only moves the batch windows' edges.
        if abs(got - e) > 1e-6 * abs(e):
            sys.exit(f"{kind}: {name} = {got!r}, the CSV gives {e!r}")
print(f"foreign MCAP: ROS 2 CDR and protobuf topics give the CSV's estimates {estimates['csv']}")
