#!/usr/bin/env bash
# Long fuzzing runs of the cargo-fuzz targets (docs/reliability.md).
#
#   fuzz/run.sh [SECONDS_PER_TARGET] [TARGET...]     (default: 600 s each, every target)
#
# Needs a nightly toolchain and cargo-fuzz (`cargo install cargo-fuzz --locked`). Seeds the
# corpora from the shipped scenarios and freshly simulated logs, then runs each target with
# the stated limits: a single allocation over the target's limit, an input that takes over
# 60 s, or more than 2 GB resident counts as a finding. Statistics go to fuzz/logs/.
set -euo pipefail
cd "$(dirname "$0")/.."
secs=${1:-600}
shift || true
targets=("$@")
[ ${#targets[@]} -eq 0 ] && targets=(scenario log_reader identify)

corpus=fuzz/corpus
mkdir -p "$corpus"/{scenario,log_reader,identify} fuzz/logs
cp scenarios/*.toml tests/fuzz_seeds/*.toml "$corpus/scenario/"
# The release binary seeds the corpora: FPKBENCH_BIN (CI passes the one `cargo test
# --release` built, which saves a second build of the crate with other features), else a
# fresh build.
bin=${FPKBENCH_BIN:-}
if [ -z "$bin" ]; then
  cargo build --release --quiet
  bin=target/release/fpkbench
fi
tmp=$(mktemp -d)
sed -e 's/^record_length = .*/record_length = 30.0/' -e 's/^trajectories = .*/trajectories = 2/' \
    scenarios/sdof_duffing.toml > "$tmp/small.toml"
"$bin" simulate "$tmp/small.toml" -o "$corpus/log_reader/plain.mcap" > /dev/null
"$bin" simulate "$tmp/small.toml" -o "$corpus/log_reader/zstd.mcap" --compress zstd > /dev/null
python3 - "$corpus/identify" <<'PY'
import random, struct, sys
rng = random.Random(1)
for name, values in [
    ("gauss", [rng.gauss(0, 1) for _ in range(64)]),
    ("extreme", [1e200, -1e-300, 0.0, 1.0, float("nan"), float("inf"), 3.0, -2.0]),
]:
    open(f"{sys.argv[1]}/{name}", "wb").write(struct.pack(f"<{len(values)}d", *values))
PY
rm -rf "$tmp"

for t in "${targets[@]}"; do
  case $t in
    log_reader) malloc=300 ;;  # file (<= 64 KiB) + 1 MiB read buffer, a decompressed chunk
                               # (<= its declared size, <= 256 MiB) and the zstd window (<= 32 MiB)
    *) malloc=512 ;;           # simulation and identification buffers of a tiny run
  esac
  echo "== $t: $secs s, max_len 65536, malloc_limit_mb $malloc, timeout 60 s"
  cargo +nightly fuzz run --release "$t" "$corpus/$t" -- \
      -max_total_time="$secs" -max_len=65536 -malloc_limit_mb="$malloc" \
      -rss_limit_mb=2048 -timeout=60 -print_final_stats=1 \
      > "fuzz/logs/$t.log" 2>&1 || { echo "$t: FINDING (see fuzz/logs/$t.log and fuzz/artifacts/$t/)"; tail -30 "fuzz/logs/$t.log"; exit 1; }
  grep -E "^stat::|#[0-9]+.*DONE" "fuzz/logs/$t.log" | tail -8
done
