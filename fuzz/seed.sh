#!/usr/bin/env bash
# Fills fuzz/corpus/<target>/ with seed inputs from ../shared (the scenes, meshes, images and
# measured materials beside the repository, plus the robustness reproducers) and from
# fuzz/regressions/<target>/. Files larger than MAX bytes are cut to their first MAX bytes
# (headers are what the readers check first; libFuzzer's default -max_len is 4096 anyway).
# Usage: fuzz/seed.sh [SHARED_DIR]   (default: ../shared beside the repository)
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
shared="${1:-$here/../../shared}"
MAX=65536
[ -d "$shared" ] || { echo "no shared data at $shared" >&2; exit 1; }
shared="$(cd "$shared" && pwd -P)"

add() { # target file
    local dir="$here/corpus/$1" name
    mkdir -p "$dir"
    name="$(echo "$2" | sed "s|^$shared/||; s|[/ ]|_|g")"
    head -c "$MAX" "$2" > "$dir/$name"
}
each() { # target find-args...
    local t="$1"; shift
    while IFS= read -r -d '' f; do add "$t" "$f"; done < <(find "$shared" "$@" -type f -print0)
}

each xml_scene -path "$shared/scenes/*" -name '*.xml'
each xml_scene -path "$shared/robustness/*" -name '*.xml'
each xml_scene -path "$shared/mitsuba-data/docs/scenes/*" -name '*.xml'
each pipeline -path "$shared/robustness/*" -name '*.xml'
each pipeline -path "$shared/scenes/*" -name 'mat_*.xml'
each obj -name '*.obj'
each ply -name '*.ply'
each merl -name '*.binary'
# serialized: the first byte picks the shape index
while IFS= read -r -d '' f; do
    mkdir -p "$here/corpus/serialized"
    { printf '\000'; head -c "$MAX" "$f"; } > "$here/corpus/serialized/$(basename "$f")"
done < <(find "$shared" -name '*.serialized' -type f -print0)
each rgl -name '*.bsdf'
each image \( -name '*.exr' -o -name '*.png' -o -name '*.hdr' -o -name '*.jpg' \) -size -256k
mkdir -p "$here/corpus/spec"
cp "$shared/robustness/spec/"*.txt "$here/corpus/spec/"
mkdir -p "$here/corpus/overrides"
# the pipeline target renders films of at most 64 pixels: small copies of the material scenes
for f in "$here/corpus/pipeline/"scenes_mat_*.xml; do
    [ -e "$f" ] || continue
    sed -i 's/value="\$resx"/value="8"/; s/value="\$resy"/value="8"/' "$f"
done
# hand-written seeds and every crash the fuzzer found, now fixed
for d in "$here/regressions/"*/; do
    t="$(basename "$d")"
    mkdir -p "$here/corpus/$t"
    cp "$d"* "$here/corpus/$t/" 2>/dev/null || true
done
for d in "$here/corpus/"*/; do echo "$(basename "$d"): $(ls "$d" | wc -l) seeds"; done
