#!/usr/bin/env bash
# The resolution protocol: every technique on one scene at 1280x720, 1920x1080 and 3840x2160,
# so that a cost that grows with the scene instead of the screen shows (a pass whose time or
# work stays flat while the pixels quadruple does work per scene item, not per pixel). Writes
# OUT_DIR/<W>x<H>.json (bench JSON, work counts included) and <W>x<H>.txt per size;
# docs/performance.md's resolution table (a `moving` table whose "scenes" are the sizes) is
# made from them by `cargo run -p octolux-tables`.
#
#   scripts/resolution-table.sh [BINARY] [OUT_DIR]   (OUT_DIR default:
#   results/lavapipe/resolution-<scene>)
#
# Environment: GI (technique list, default: all), SCENE (default scenes/cornell-box.toml),
# SIZES (default "1280x720 1920x1080 3840x2160"), WARMUP (default 2), FRAMES (measured,
# default 2), OCTOLUX_SCENES (where the external models lie, default ../shared/scenes).
# No reference: the protocol measures time and work.
set -euo pipefail
cd "$(dirname "$0")/.."

bin=${1:-target/release/octolux}
[ -x "$bin" ] || { echo "resolution-table: '$bin' is not an executable" >&2; exit 1; }
gi=${GI:-none,lpv,clpv,olpv,vct-svo,vct-clipmap,vpl,probes-grid,probes-octree}
scene=${SCENE:-scenes/cornell-box.toml}
sizes=${SIZES:-"1280x720 1920x1080 3840x2160"}
warmup=${WARMUP:-2}
frames=${FRAMES:-2}
name=$(basename "${scene%.*}")
out=${2:-results/lavapipe/resolution-$name}
export OCTOLUX_SCENES=${OCTOLUX_SCENES:-../shared/scenes}
mkdir -p "$out"

for size in $sizes; do
  echo "resolution-table: $name at $size" >&2
  "$bin" bench "$scene" --gi "$gi" --width "${size%x*}" --height "${size#*x}" \
    --warmup "$warmup" --frames "$frames" --no-reference --no-flicker \
    --json "$out/$size.json" > "$out/$size.txt"
done
echo "resolution-table: wrote $out; run 'cargo run -p octolux-tables' to refresh the docs" >&2
