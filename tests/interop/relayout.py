"""Re-write an fpkbench log with PyPI's `mcap` writer in every layout the MCAP
specification allows, then check that fpkbench reads each one identically: the same
samples (its CSV export, byte for byte), the same scenario, truth and run facts
(`inspect --json`), and an identification with the same estimates.

Every record is copied unchanged (messages, schema, channel with its metadata, the
`scenario.toml` attachment, both metadata records); only the layout varies. Written as a
tool that copies messages first would: attachments and metadata after the messages.

usage: python relayout.py FPKBENCH LOG.mcap WORKDIR
"""
import json
import subprocess
import sys
from pathlib import Path

from mcap.reader import make_reader
from mcap.writer import CompressionType, IndexType, Writer

LAYOUTS = {
    "chunked-64MiB": dict(chunk_size=64 << 20),
    "unchunked": dict(use_chunking=False),
    "zstd-4KiB": dict(compression=CompressionType.ZSTD, chunk_size=4096),
    "no-statistics-no-summary-offsets": dict(chunk_size=16384, use_statistics=False, use_summary_offsets=False),
    "no-indexes-no-repeats": dict(
        chunk_size=16384, index_types=IndexType(0), repeat_channels=False, repeat_schemas=False,
        use_summary_offsets=False,
    ),
    "lz4": dict(compression=CompressionType.LZ4),
    "lz4-1KiB-unindexed": dict(
        compression=CompressionType.LZ4, chunk_size=1024, index_types=IndexType(0), use_statistics=False
    ),
    "unchunked-no-summary-records": dict(
        use_chunking=False, repeat_channels=False, repeat_schemas=False, index_types=IndexType(0),
        use_statistics=False, use_summary_offsets=False,
    ),
}


def relayout(src: Path, dst: Path, options: dict) -> None:
    with open(src, "rb") as f:
        reader = make_reader(f)
        header = reader.get_header()
        summary = reader.get_summary()
        attachments = list(reader.iter_attachments())
        metadata = list(reader.iter_metadata())
        messages = list(reader.iter_messages(log_time_order=False))
    with open(dst, "wb") as out:
        w = Writer(out, **options)
        w.start(profile=header.profile, library=header.library)
        schema_ids, channel_ids = {}, {}
        for sid, s in summary.schemas.items():
            schema_ids[sid] = w.register_schema(s.name, s.encoding, s.data)
        for cid, c in summary.channels.items():
            channel_ids[cid] = w.register_channel(c.topic, c.message_encoding, schema_ids[c.schema_id], c.metadata)
        for _schema, channel, message in messages:
            w.add_message(
                channel_ids[channel.id], message.log_time, message.data, message.publish_time, message.sequence
            )
        for a in attachments:
            w.add_attachment(a.create_time, a.log_time, a.name, a.media_type, a.data)
        for m in metadata:
            w.add_metadata(m.name, m.metadata)
        w.finish()


def run(fpkbench: str, *args: str) -> str:
    """stdout of an fpkbench command; exit 1 (an accuracy gate failed) is a result too."""
    p = subprocess.run([fpkbench, *args], capture_output=True, text=True)
    if p.returncode not in (0, 1):
        raise SystemExit(f"fpkbench {' '.join(args)} exited {p.returncode}:\n{p.stderr}")
    return p.stdout


def main(fpkbench: str, log: str, workdir: str) -> int:
    work = Path(workdir)
    work.mkdir(parents=True, exist_ok=True)

    def read(path: Path, name: str):
        csv = work / f"{name}.csv"
        run(fpkbench, "export", str(path), "--format", "csv", "-o", str(csv))
        info = json.loads(run(fpkbench, "inspect", str(path), "--json"))
        report = json.loads(
            run(fpkbench, "identify", str(path), "--json", "--no-validate", "--out", str(work / f"{name}-report"))
        )
        facts = {k: info[k] for k in ("scenario_toml", "truth", "run", "columns", "samples")}
        estimates = [[p["estimate"] for p in m["parameters"]] for m in report["methods"]]
        return csv.read_bytes(), facts, estimates

    want = read(Path(log), "original")
    print(f"{'layout':36} {'bytes':>10}  result")
    failures = 0
    for name, options in LAYOUTS.items():
        path = work / f"{name}.mcap"
        relayout(Path(log), path, options)
        try:
            got = read(path, name)
            same = [what for what, a, b in zip(("samples", "description", "estimates"), want, got) if a == b]
            result = "identical" if len(same) == 3 else "DIFFERS: the same " + (", ".join(same) or "nothing")
        except SystemExit as e:
            result = "FAILS: " + str(e).strip().splitlines()[-1]
        failures += result != "identical"
        print(f"{name:36} {path.stat().st_size:>10}  {result}")
    if failures:
        print(f"{failures} of {len(LAYOUTS)} layouts do not read identically")
        return 1
    print(f"{len(LAYOUTS)} layouts written by PyPI's mcap read identically")
    return 0


if __name__ == "__main__":
    sys.exit(main(*sys.argv[1:]))
