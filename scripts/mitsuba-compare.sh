#!/usr/bin/env bash
# Compares the reference path tracer with Mitsuba 3 on Mitsuba's own Cornell box, at every
# bounce setting, lit by its area light (cbox-rgb.xml) and by scenes/skies/afternoon.hdr
# through its open front (scripts/mitsuba/cbox-sky.xml).
#
#   scripts/mitsuba-compare.sh [WORK_DIR]
#
# Renders with octolux at --bounces direct, 1, 2 and unlimited (Mitsuba's max_depth 2, 3, 4
# and -1) and prints a markdown table: octolux's mean over Mitsuba's, relMSE between them, and
# the seed-to-seed relMSE of each renderer at the same sample count (two seeds), which is what
# relMSE between two unbiased renders of the same thing comes to.
#
# The Mitsuba images are stored in scripts/mitsuba/cbox/ (Mitsuba 3.9.1, scalar_rgb, path
# integrator, 128x128, 1024 spp, seeds 0 and 1). To render them again (pip install mitsuba):
#   MITSUBA_RENDER=1 scripts/mitsuba-compare.sh
# which runs scripts/mitsuba/render.py into scripts/mitsuba/cbox/ first.
#
# Environment: OCTOLUX (binary; default target/release/octolux, else target/debug/octolux),
# OCTOLUX_SCENES (folder holding cornell-box-mitsuba/; default ../shared/scenes), SPP (octolux's
# samples per pixel, default 1024), PYTHON (for MITSUBA_RENDER, default python3).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
OCTOLUX=${OCTOLUX:-}
if [ -z "$OCTOLUX" ]; then
    OCTOLUX=$root/target/release/octolux
    [ -x "$OCTOLUX" ] || OCTOLUX=$root/target/debug/octolux
fi
SCENES=${OCTOLUX_SCENES:-$root/../shared/scenes}
SPP=${SPP:-1024}
SIZE=128
work=${1:-$(mktemp -d)}
stored=$root/scripts/mitsuba/cbox
cbox=$SCENES/cornell-box-mitsuba
[ -f "$cbox/cbox-rgb.xml" ] || { echo "error: $cbox/cbox-rgb.xml not found (set OCTOLUX_SCENES)" >&2; exit 1; }
mkdir -p "$work"
# The sky variant includes the box's fragments; its meshes resolve next to the scene file.
sed -e "s|CBOX|$cbox|" -e "s|SKIES|$root/scenes/skies|" "$root/scripts/mitsuba/cbox-sky.xml" \
    > "$work/cbox-sky.xml"
ln -sfn "$cbox/meshes" "$work/meshes"
declare -A xml=([area]=$cbox/cbox-rgb.xml [sky]=$work/cbox-sky.xml)
settings="direct:2 1:3 2:4 unlimited:-1"

if [ -n "${MITSUBA_RENDER:-}" ]; then
    mkdir -p "$stored"
    for scene in area sky; do
        depths=$(for s in $settings; do printf '%s ' "${s#*:}"; done)
        ${PYTHON:-python3} "$root/scripts/mitsuba/render.py" "${xml[$scene]}" "$stored/$scene" $SIZE 1024 0 $depths
        ${PYTHON:-python3} "$root/scripts/mitsuba/render.py" "${xml[$scene]}" "$stored/$scene" $SIZE 1024 1 2 -1
    done
fi

field() { sed -n "s/.*\"$1\": *\([^,]*\),\{0,1\}$/\1/p" | head -1; }
compare() { "$OCTOLUX" diff "$1" "$2" --json; }
printf '| light | bounces (max_depth) | mean octolux / Mitsuba | relMSE octolux vs Mitsuba | seed to seed: octolux | Mitsuba |\n'
printf '| --- | --- | ---: | ---: | ---: | ---: |\n'
for scene in area sky; do
    for s in $settings; do
        bounces=${s%%:*} depth=${s#*:}
        for seed in 1 2; do
            "$OCTOLUX" render "${xml[$scene]}" --gi reference --bounces "$bounces" --spp "$SPP" \
                --width $SIZE --height $SIZE --seed $seed --out "$work/$scene-$bounces-$seed.png" \
                --exr "$work/$scene-$bounces-$seed.exr" > /dev/null 2>> "$work/octolux.log"
        done
        mitsuba=$stored/$scene-d$depth-s0.exr
        json=$(compare "$work/$scene-$bounces-1.exr" "$mitsuba")
        ratio=$(echo "$json" | field mean_ratio)
        rel=$(echo "$json" | field rel_mse)
        ours=$(compare "$work/$scene-$bounces-1.exr" "$work/$scene-$bounces-2.exr" | field rel_mse)
        theirs=-
        if [ -f "$stored/$scene-d$depth-s1.exr" ]; then
            theirs=$(compare "$stored/$scene-d$depth-s1.exr" "$mitsuba" | field rel_mse)
        fi
        printf '| %s | %s (%s) | %.4f | %.2e | %.2e | %s |\n' "$scene" "$bounces" "$depth" \
            "$ratio" "$rel" "$ours" "$theirs"
    done
done
