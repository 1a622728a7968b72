#!/usr/bin/env bash
# The error table as people see the pictures: every technique at 640 x 360 after it has
# settled (`bench --settle`: each technique held still for as many frames as `octolux render`
# waits for it, at least WARMUP: the probes' 32-frame histories, the cone tracers' bounces),
# and its early frame (EARLY, the fourth) beside it, against the unlimited-bounce reference at
# 1024 spp, whose own noise is measured seed to seed and printed beside it. Writes OUT_DIR/<scene>.json (bench JSON),
# <scene>.txt, <scene>-noise.txt (the reference against a second one of another seed) and a
# sheet of the images, OUT_DIR/<scene>.jpg (GI off, the techniques, the reference;
# `cargo run -p octolux-tables -- sheet`; JPEG at quality 90, a fifth of the PNG's bytes in
# the repository). The images themselves stay in OUT_DIR/<scene>/ as PNG and EXR and are not
# committed (ignored: only the sheet is).
#
#   scripts/settled-table.sh [BINARY] [OUT_DIR]   (OUT_DIR default: results/lavapipe/settled-SIZE)
#
# Environment: GI (technique list, default: all), SIZE (default 640x360), SPP (reference
# samples, default 1024), SCENES (default: scenes/cornell-box.toml), WARMUP (default 3),
# EARLY (the early frame judged, default 4),
# OCTOLUX_SCENES (where the external models lie, default ../shared/scenes), REFERENCES (the
# reference cache, default target/reference-cache: `bench --reference-cache`, so a second
# run renders no reference; the noise file of a scene is kept, not rendered again), TABLES
# (the tables tool, default `cargo run -q -p octolux-tables --`).
# The references take minutes to hours on a CPU (bench prints their progress); where SPP
# cannot reach a tenth of the smallest error judged, the noise file says how far it is.
# A technique changed since the table was made can be measured again alone: the bench command
# below with `--gi none,<it>`, its JSON and text kept as OUT_DIR/reruns/<scene>.json and .txt,
# which the tables merge into the scene's file (its techniques replace the scene file's; its
# GI off must be the same); a later re-run of another technique goes beside it as
# OUT_DIR/reruns/<scene>.<label>.json (merged after it, in name order). Its images go into
# OUT_DIR/<scene>/ for the sheet command; where the other techniques' images are gone (they
# are not committed), `$TABLES unsheet OUT_DIR/<scene>.jpg OUT_DIR/<scene>` first puts the
# committed sheet's tiles of the techniques not re-run beside them.
set -euo pipefail
cd "$(dirname "$0")/.."

bin=${1:-target/release/octolux}
[ -x "$bin" ] || { echo "settled-table: '$bin' is not an executable" >&2; exit 1; }
gi=${GI:-none,lpv,clpv,olpv,vct-svo,vct-clipmap,vpl,probes-grid,probes-octree}
size=${SIZE:-640x360}
spp=${SPP:-1024}
warmup=${WARMUP:-3}
early=${EARLY:-4}
scenes=${SCENES:-scenes/cornell-box.toml}
out=${2:-results/lavapipe/settled-$size}
references=${REFERENCES:-target/reference-cache}
tables=${TABLES:-cargo run -q -p octolux-tables --}
export OCTOLUX_SCENES=${OCTOLUX_SCENES:-../shared/scenes}
mkdir -p "$out"

for scene in $scenes; do
  name=$(basename "${scene%.*}")
  echo "settled-table: $name" >&2
  "$bin" bench "$scene" --gi "$gi" --width "${size%x*}" --height "${size#*x}" --warmup "$warmup" \
    --settle --early "$early" --frames 1 --spp "$spp" --seed 7 --against unlimited --no-work-counts --no-flicker \
    --reference-cache "$references" --json "$out/$name.json" --out-dir "$out/$name" \
    > "$out/$name.txt"
  # The reference's own noise: a second render with another seed, compared with the first
  # (once per scene and reference size).
  if [ -s "$out/$name-noise.txt" ] && grep -q "spp $spp" "$out/$name-noise.txt"; then
    $tables sheet "$out/$name" "$out/$name.jpg" 5
    continue
  fi
  "$bin" render "$scene" --gi reference --bounces unlimited --spp "$spp" --seed 8 \
    --width "${size%x*}" --height "${size#*x}" --out "$out/$name/reference-seed8.png" \
    --exr "$out/$name/reference-seed8.exr" > /dev/null
  { echo "spp $spp"; "$bin" diff "$out/$name/reference-seed8.exr" \
    "$out/$name/reference-unlimited.exr"; } > "$out/$name-noise.txt"
  rm "$out/$name/reference-seed8.png"
  $tables sheet "$out/$name" "$out/$name.jpg" 5
done
echo "settled-table: wrote $out; remake the docs' tables with: cargo run -p octolux-tables" >&2
