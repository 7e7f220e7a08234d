#!/usr/bin/env bash
# Runs every fuzz target in turn, one process at a time (one core), for SECONDS each
# (default 600), on the corpus that seed.sh made; logs go to fuzz/logs/<target>.log and
# crashing inputs to fuzz/artifacts/<target>/. Build first: cargo fuzz build -s none -O
# Usage: fuzz/campaign.sh [SECONDS] [TARGET...]
set -uo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
secs="${1:-600}"; shift || true
targets=("$@")
[ ${#targets[@]} -gt 0 ] || targets=(xml_scene pipeline overrides image obj ply spec rgl merl serialized)
bin="$here/target/x86_64-unknown-linux-gnu/release"
mkdir -p "$here/logs"
for t in "${targets[@]}"; do
    mkdir -p "$here/artifacts/$t" "$here/corpus/$t" "$here/logs/$t"
    echo "$(date -u +%H:%M:%S) $t: start"
    ( cd "$here/logs/$t" && RAYON_NUM_THREADS=1 timeout $((secs + 60)) "$bin/$t" \
        "$here/corpus/$t" -jobs=1 -workers=1 -max_total_time="$secs" -max_len=65536 \
        -rss_limit_mb=2048 -malloc_limit_mb=2048 -timeout=20 \
        -artifact_prefix="$here/artifacts/$t/" > "$here/logs/$t.log" 2>&1 )
    echo "$(date -u +%H:%M:%S) $t: exit $? — $(grep -E '^#[0-9]+' "$here/logs/$t/fuzz-0.log" 2>/dev/null | tail -1)"
done
