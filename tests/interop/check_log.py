"""Decode an fpkbench MCAP log with Python's `mcap` + `mcap-ros2-support` and compare every
value with the Rust reader's CSV export of the same log (exact equality).

usage: python check_log.py LOG.mcap EXPORT.csv
"""
import csv
import sys

from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory


def main(log_path: str, csv_path: str) -> int:
    with open(csv_path, newline="") as f:
        rows = list(csv.reader(f))
    header, rows = rows[0], rows[1:]
    with open(log_path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        summary = reader.get_summary()
        attachments = list(reader.iter_attachments())
        metadata = {m.name: m.metadata for m in reader.iter_metadata()}
        assert [a.name for a in attachments] == ["scenario.toml"], attachments
        assert "[simulation]" in attachments[0].data.decode()
        assert "fpkbench.truth" in metadata and "fpkbench.run" in metadata, metadata.keys()
        channel = next(iter(summary.channels.values()))
        assert channel.topic == "/fpkbench/samples" and channel.message_encoding == "cdr"
        assert channel.metadata["columns"].split(",") == header[2:], (channel.metadata["columns"], header)
        n = 0
        # One message per sampling instant, element j of each array being trajectory j; file
        # order (log_time_order=False) is the order the Rust reader streams.
        for _schema, _channel, message, decoded in reader.iter_decoded_messages(log_time_order=False):
            assert message.log_time == round(decoded.t * 1e9)
            arrays = {name: getattr(decoded, name) for name in header[2:]}
            trajectories = {len(a) for a in arrays.values()}
            assert len(trajectories) == 1, trajectories
            for j in range(trajectories.pop()):
                row = rows[n]
                assert j == int(row[0]), (n, j, row[0])
                assert decoded.t == float(row[1]), (n, decoded.t, row[1])
                for name, text in zip(header[2:], row[2:]):
                    value = arrays[name][j]
                    assert value == float(text), (n, name, value, text)
                n += 1
    assert n == len(rows), (n, len(rows))
    truth = metadata["fpkbench.truth"]
    compression = ",".join(sorted({c.compression or "none" for c in summary.chunk_indexes}))
    print(f"python interop ({log_path}, chunks: {compression}): {n} samples x {len(header)} "
          f"fields decoded by mcap-ros2-support equal the Rust reader; truth {len(truth)} parameters (k1[ground-m1] = {truth.get('k1[ground-m1]')})")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1], sys.argv[2]))
