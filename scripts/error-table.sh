#!/usr/bin/env bash
# Every technique's error on every shipped scene against the unlimited-bounce reference (the
# image a user would call correct), the table the default technique is chosen from (README,
# "Global illumination by default"). Prints one markdown table: FLIP / relMSE per technique
# and scene, `*` where a technique beats GI off (`none`) on both. Every image and reference
# stays in OUT_DIR/<scene>/ (EXR + PNG).
#
#   scripts/error-table.sh [BINARY] [OUT_DIR]
#
# Environment: GI (technique list, default: all), SIZE (default 160x90), SPP (reference
# samples, default 128), SCENES (default: every scene file in scenes/), WARMUP (frames before
# the measured one, default 3; techniques that converge over frames, such as probes-octree at
# max_depth 4, need more), ARGS (more `bench` arguments, such as a technique's settings),
# OCTOLUX_SCENES (where the external models lie, default ../shared/scenes).
set -euo pipefail
cd "$(dirname "$0")/.."

bin=${1:-target/release/octolux}
out=${2:-error-table}
[ -x "$bin" ] || { echo "error-table: '$bin' is not an executable" >&2; exit 1; }
gi=${GI:-none,lpv,clpv,olpv,vct-svo,vct-clipmap,vpl,probes-grid,probes-octree}
size=${SIZE:-160x90}
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
done

python3 - "$out" $scenes <<'PY'
import json, os, sys
out, scenes = sys.argv[1], sys.argv[2:]
names = [os.path.basename(s).rsplit(".", 1)[0] for s in scenes]
rows = {}
for name in names:
    for t in json.load(open(f"{out}/{name}.json"))["scenes"][0]["techniques"]:
        rows.setdefault(t["technique"], {})[name] = t["metrics"]
print("| technique | " + " | ".join(names) + " | beats GI off |")
print("| --- |" + " --- |" * (len(names) + 1))
for technique, by_scene in rows.items():
    cells, wins = [], 0
    for name in names:
        m, off = by_scene[name], rows["none"][name]
        win = technique != "none" and m["flip"] < off["flip"] and m["rel_mse"] < off["rel_mse"]
        wins += win
        cells.append(f'{m["flip"]:.3f} / {m["rel_mse"]:.4f}' + (" *" if win else ""))
    count = "-" if technique == "none" else f"{wins} / {len(names)}"
    print(f"| {technique} | " + " | ".join(cells) + f" | {count} |")
PY
