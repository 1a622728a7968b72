#!/usr/bin/env bash
# Every technique's error on every shipped scene against the unlimited-bounce reference (the
# image a user would call correct), the table the default technique is chosen from (README,
# "Global illumination by default"). Writes OUT_DIR/<scene>.json (bench JSON: the figures, the
# commit, adapter, date and command line), <scene>.txt (bench's own table) and every image
# and reference in OUT_DIR/<scene>/ (EXR + PNG; the PNGs are committed with the JSON) and
# their sheet OUT_DIR/<scene>.png (GI off, the techniques, the reference). The
# tables in README.md and docs/ are then remade from the committed data with
# `cargo run -p octolux-tables` (results/README.md).
#
#   scripts/error-table.sh [BINARY] [OUT_DIR]     (OUT_DIR default: results/lavapipe/error-SIZE)
#
# Environment: GI (technique list, default: all), SIZE (default 160x90), SPP (reference
# samples, default 128), SCENES (default: every scene file in scenes/), WARMUP (frames before
# the measured one, default 3; techniques that converge over frames, such as probes-octree at
# max_depth 4, need more), ARGS (more `bench` arguments, such as a technique's settings),
# OCTOLUX_SCENES (where the external models lie, default ../shared/scenes).
set -euo pipefail
cd "$(dirname "$0")/.."

bin=${1:-target/release/octolux}
[ -x "$bin" ] || { echo "error-table: '$bin' is not an executable" >&2; exit 1; }
gi=${GI:-none,lpv,clpv,olpv,vct-svo,vct-clipmap,vpl,probes-grid,probes-octree}
size=${SIZE:-160x90}
out=${2:-results/lavapipe/error-$size}
spp=${SPP:-128}
warmup=${WARMUP:-3}
scenes=${SCENES:-$(ls scenes/*.toml scenes/*.xml)}
export OCTOLUX_SCENES=${OCTOLUX_SCENES:-../shared/scenes}
mkdir -p "$out"

for scene in $scenes; do
  name=$(basename "${scene%.*}")
  echo "error-table: $name" >&2
  "$bin" bench "$scene" --gi "$gi" --width "${size%x*}" --height "${size#*x}" --warmup "$warmup" \
    --frames 1 --spp "$spp" --seed 7 --against unlimited --no-work-counts --no-flicker ${ARGS:-} \
    --json "$out/$name.json" --out-dir "$out/$name" > "$out/$name.txt"
  # The scene's sheet: GI off, the techniques, the reference, side by side.
  cargo run -q -p octolux-tables -- sheet "$out/$name" "$out/$name.png" 5 >&2
done

echo "error-table: wrote $out; remake the docs' tables with: cargo run -p octolux-tables" >&2
