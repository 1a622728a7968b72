#!/usr/bin/env bash
# The moving bench protocol: every technique on still scenes and on their everything-moves
# counterparts (a moving sun and lights, moving objects, a moving camera), so that a
# technique's worst case shows beside its best. Writes OUT_DIR/<scene>.json (bench JSON, work
# counts included) and <scene>.txt per scene; docs/performance.md's "moving" table is made
# from them by `cargo run -p octolux-tables`.
#
#   scripts/moving-table.sh [BINARY] [OUT_DIR]   (OUT_DIR default: results/lavapipe/moving-SIZE)
#
# Environment: GI (technique list, default: all), SIZE (default 160x90), WARMUP (default 3),
# FRAMES (measured, default 5), SCENES (default: the Cornell box and Crytek Sponza, still and
# everything-moves), OCTOLUX_SCENES (where the external models lie, default ../shared/scenes).
# No reference: the protocol measures time and work (the error tables judge the pictures).
set -euo pipefail
cd "$(dirname "$0")/.."

bin=${1:-target/release/octolux}
[ -x "$bin" ] || { echo "moving-table: '$bin' is not an executable" >&2; exit 1; }
gi=${GI:-none,lpv,clpv,olpv,vct-svo,vct-clipmap,vpl,probes-grid,probes-octree}
size=${SIZE:-160x90}
warmup=${WARMUP:-3}
frames=${FRAMES:-5}
scenes=${SCENES:-"scenes/cornell-box.toml scenes/cornell-everything-moves.toml scenes/crytek-sponza.toml scenes/sponza-everything-moves.toml"}
out=${2:-results/lavapipe/moving-$size}
export OCTOLUX_SCENES=${OCTOLUX_SCENES:-../shared/scenes}
mkdir -p "$out"

for scene in $scenes; do
  name=$(basename "${scene%.*}")
  echo "moving-table: $name" >&2
  "$bin" bench "$scene" --gi "$gi" --width "${size%x*}" --height "${size#*x}" \
    --warmup "$warmup" --frames "$frames" --no-reference --no-flicker \
    --json "$out/$name.json" > "$out/$name.txt"
done
echo "moving-table: wrote $out; run 'cargo run -p octolux-tables' to refresh the docs" >&2
