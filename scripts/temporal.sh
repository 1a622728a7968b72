#!/usr/bin/env bash
# Temporal behaviour of every technique, the table of docs/performance.md ("Flicker and lag"):
# flicker held still (the Cornell box), flicker while a light in another room circles
# (`two-rooms-far-light`) and while the camera flies through Sponza (`sponza-flythrough` from
# 5 s, inside the atrium), and lag after the Cornell box's spot switches on and off, after the
# swinging spot of `cornell-animated` jumps (its block with it) and after the sphere of
# `cornell-crossing` jumps into the beam. Every technique is judged against the
# unlimited-bounce reference.
#
#   scripts/temporal.sh [BINARY] [OUT_DIR]
#
# Environment: GI (technique list, default: all), SIZE (default 64x48), SPP (reference
# samples, default 64), OCTOLUX_SCENES (where Sponza lies, default ../shared/scenes).
set -euo pipefail
cd "$(dirname "$0")/.."

bin=${1:-target/release/octolux}
out=${2:-temporal}
[ -x "$bin" ] || { echo "temporal: '$bin' is not an executable" >&2; exit 1; }
gi=${GI:-none,lpv,clpv,olpv,vct-svo,vct-clipmap,vpl,probes-grid,probes-octree}
size=${SIZE:-64x48}
spp=${SPP:-64}
export OCTOLUX_SCENES=${OCTOLUX_SCENES:-../shared/scenes}
mkdir -p "$out"

run() {
  local name=$1
  shift
  echo "temporal: $name" >&2
  "$bin" bench "$@" --gi "$gi" --width "${size%x*}" --height "${size#*x}" --warmup 3 \
    --frames 2 --spp "$spp" --seed 7 --against unlimited --no-work-counts \
    --json "$out/$name.json" > "$out/$name.txt"
}

run cornell-box scenes/cornell-box.toml --lag on:ceiling-spot --lag off:ceiling-spot
run cornell-animated scenes/cornell-animated.toml --lag jump:0..1
run cornell-crossing scenes/cornell-crossing.toml --lag jump:0..1
run two-rooms-far-light scenes/two-rooms-far-light.toml
run sponza-flythrough scenes/sponza-flythrough.toml --time 5

python3 - "$out" <<'PY'
import json, sys
out = sys.argv[1]
def load(name):
    return {t["technique"]: t for t in json.load(open(f"{out}/{name}.json"))["scenes"][0]["techniques"]}
box, animated, crossing = load("cornell-box"), load("cornell-animated"), load("cornell-crossing")
far, flight = load("two-rooms-far-light"), load("sponza-flythrough")
def lag(t, i):
    l = t["lag"][i]
    return f'{l["frames"]} ({l["rel_mse"][0]:.3g} -> {l["settled_rel_mse"]:.3g})'
print("| technique | still flicker | far light | camera flight | lag: spot on | spot off | spot jumps | sphere jumps |")
print("| --- | ---: | ---: | ---: | --- | --- | --- | --- |")
for name, t in box.items():
    print(f'| {name} | {t["flicker"]:.2e} | {far[name]["motion_flicker"]:.2e} | '
          f'{flight[name]["motion_flicker"]:.2e} | {lag(t, 0)} | {lag(t, 1)} | '
          f'{lag(animated[name], 0)} | {lag(crossing[name], 0)} |')
PY
