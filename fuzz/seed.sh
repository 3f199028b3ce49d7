#!/usr/bin/env bash
# Seeds fuzz/corpus/<target>/ from ../shared/data (never checked in: corpus/ is ignored) and
# from the repository's own small files. Large files are cut to their first 64 KiB: libFuzzer
# mutates small inputs far better, and the headers are what matter.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
repo=$(dirname "$here")
data=${GLINT_DATA:-$repo/../shared/data}
[ -d "$data" ] || { echo "seed.sh: $data not found (set GLINT_DATA)" >&2; exit 1; }

seed() { # target file...
    local target=$1; shift
    mkdir -p "$here/corpus/$target"
    for f in "$@"; do
        [ -f "$f" ] || continue
        head -c 65536 "$f" > "$here/corpus/$target/$(basename "$f" | tr ' ' '_')"
    done
}

seed ply $(find "$data" "$repo/tests" -name '*.ply' | head -20)
seed obj_mtl $(find "$data" "$repo/tests" -name '*.obj' -size -256k | head -20) $(find "$data" -name '*.obj' | head -3)
seed gltf $(find "$data" "$repo" -path "$repo/fuzz" -prune -o \( -name '*.gltf' -o -name '*.glb' \) -print | head -20)
seed las $(find "$data" -name '*.las' -o -name '*.laz' | head -10)
seed xyz $(find "$data" -name '*.xyz' -o -name '*.pts' | head -10)
seed scene_toml $(find "$repo/scenes" "$data" -name '*.toml' | head -40)
seed image $(find "$data" \( -name '*.png' -o -name '*.jpg' -o -name '*.hdr' -o -name '*.exr' -o -name '*.tga' \) -size -64k | head -40)
seed sky $(find "$data/skyboxes" "$data/envmaps" \( -name '*.png' -o -name '*.jpg' -o -name '*.hdr' -o -name '*.exr' \) -size -64k | head -20)
seed mitsuba_xml $(find "$data/mitsuba" -name '*.xml' | head -60)
seed serialized $(find "$data" -name '*.serialized' | head -10)
# Hand-made malformed inputs and the inputs fuzzing found (tests/corpus/<loader>/).
for d in "$repo"/tests/corpus/*/; do
    [ -d "$d" ] || continue
    t=$(basename "$d")
    case $t in obj) t=obj_mtl ;; toml) t=scene_toml ;; esac
    mkdir -p "$here/corpus/$t"
    cp "$d"/* "$here/corpus/$t/" 2>/dev/null || true
done
for t in "$here"/corpus/*/; do echo "$(basename "$t"): $(ls "$t" | wc -l) seeds"; done
