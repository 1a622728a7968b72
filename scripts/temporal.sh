#!/usr/bin/env bash
# Temporal behaviour of every technique, the table of docs/performance.md ("Flicker and lag"):
# flicker held still (the Cornell box), flicker while a light in another room circles
# (`two-rooms-far-light`) and while the camera flies through Sponza (`sponza-flythrough` from
# 5 s, inside the atrium), and lag after the Cornell box's spot switches on and off, after the
# swinging spot of `cornell-animated` jumps (its block with it) and after the sphere of
# `cornell-crossing` jumps into the beam. Every technique is judged against the
# unlimited-bounce reference.
#
# Writes OUT_DIR/<case>.json (bench JSON with the commit, adapter, date and command line) and
# <case>.txt; the docs' table is remade from the committed JSON with
# `cargo run -p octolux-tables` (results/README.md).
#
#   scripts/temporal.sh [BINARY] [OUT_DIR]     (OUT_DIR default: results/lavapipe/temporal-SIZE)
#
# Warm-up: 3 frames before the lag cases (each holds its scene 24 frames before the change),
# 40 before the motion cases (flicker of the settled picture).
#
# Environment: GI (technique list, default: all), SIZE (default 64x48), SPP (reference
# samples, default 64), OCTOLUX_SCENES (where Sponza lies, default ../shared/scenes).
set -euo pipefail
cd "$(dirname "$0")/.."

bin=${1:-target/release/octolux}
[ -x "$bin" ] || { echo "temporal: '$bin' is not an executable" >&2; exit 1; }
gi=${GI:-none,lpv,clpv,olpv,vct-svo,vct-clipmap,vpl,probes-grid,probes-octree}
size=${SIZE:-64x48}
out=${2:-results/lavapipe/temporal-$size}
spp=${SPP:-64}
export OCTOLUX_SCENES=${OCTOLUX_SCENES:-../shared/scenes}
mkdir -p "$out"

run() {
  local name=$1 warmup=$2
  shift 2
  echo "temporal: $name" >&2
  "$bin" bench "$@" --gi "$gi" --width "${size%x*}" --height "${size#*x}" --warmup "$warmup" \
    --frames 2 --spp "$spp" --seed 7 --against unlimited --no-work-counts \
    --json "$out/$name.json" > "$out/$name.txt"
}

# Lag: each event holds its scene 24 frames before it, so 3 warm-up frames do.
run cornell-box 3 scenes/cornell-box.toml --lag on:ceiling-spot --lag off:ceiling-spot
run cornell-animated 3 scenes/cornell-animated.toml --lag jump:0..1
run cornell-crossing 3 scenes/cornell-crossing.toml --lag jump:0..1
# Flicker under motion: after 40 frames of that motion, so that a technique that settles over
# frames (probes-grid's 32-frame history) is judged settled, as a viewer sees it.
run two-rooms-far-light 40 scenes/two-rooms-far-light.toml
run sponza-flythrough 40 scenes/sponza-flythrough.toml --time 5

echo "temporal: wrote $out; remake the docs' table with: cargo run -p octolux-tables" >&2
