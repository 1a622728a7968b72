#!/usr/bin/env bash
# Compares two octolux binaries (the previous build and the new one) on the same scenes in one
# run: every technique's error against the reference (FLIP, relMSE) and its GI and frame times
# as new/old ratios. Runs alternate old, new, old, new... so that a machine that slows down
# over the run weighs on both alike; times are the median of each binary's runs.
#
#   scripts/compare-builds.sh OLD_BINARY NEW_BINARY [OUT_DIR] [-- extra bench flags]
#
# Environment: SCENES (default: the Cornell box and Crytek Sponza), GI (technique list,
# default: all), SIZE (default 160x90), SPP (reference samples, default 64), ROUNDS (runs per
# binary, default 2), FRAMES (measured frames per run, default 3).
set -euo pipefail
cd "$(dirname "$0")/.."

old=${1:?usage: compare-builds.sh OLD NEW [OUT_DIR] [-- bench flags]}
new=${2:?usage: compare-builds.sh OLD NEW [OUT_DIR] [-- bench flags]}
shift 2
out=${1:-compare-builds}
[ $# -gt 0 ] && shift
[ "${1:-}" = "--" ] && shift
for b in "$old" "$new"; do
  [ -x "$b" ] || { echo "compare-builds: '$b' is not an executable" >&2; exit 1; }
done

scenes=${SCENES:-"scenes/cornell-box.toml scenes/crytek-sponza.toml"}
gi=${GI:-none,lpv,clpv,olpv,vct-svo,vct-clipmap,vpl,probes-grid,probes-octree}
size=${SIZE:-160x90}
spp=${SPP:-64}
rounds=${ROUNDS:-2}
frames=${FRAMES:-3}
mkdir -p "$out"

for round in $(seq 1 "$rounds"); do
  for which in old new; do
    bin=$old
    [ "$which" = new ] && bin=$new
    echo "round $round: $which ($bin)" >&2
    # shellcheck disable=SC2086
    "$bin" bench $scenes --gi "$gi" --width "${size%x*}" --height "${size#*x}" \
      --warmup 1 --frames "$frames" --spp "$spp" --seed 7 \
      --json "$out/$which-$round.json" "$@" >"$out/$which-$round.txt" 2>&1 \
      || { echo "compare-builds: the $which binary failed, see $out/$which-$round.txt" >&2; exit 1; }
  done
done

python3 - "$out" "$rounds" <<'EOF'
import json, statistics, sys
out, rounds = sys.argv[1], int(sys.argv[2])
def load(which):
    runs = [json.load(open(f"{out}/{which}-{r}.json")) for r in range(1, rounds + 1)]
    table = {}
    for run in runs:
        for scene in run["scenes"]:
            for t in scene["techniques"]:
                key = (scene["scene"], t["technique"])
                row = table.setdefault(key, {"gi": [], "frame": [], "metrics": t["metrics"]})
                row["gi"].append(t["gi_total"]["mean_ms"])
                row["frame"].append(t["frame_total"]["mean_ms"])
    return runs[0]["adapter"]["name"], table
adapter, old = load("old")
_, new = load("new")
print(f"adapter: {adapter}; times: median over {rounds} runs per binary, mean per run")
print("| scene | technique | FLIP old | FLIP new | relMSE old | relMSE new | relMSE new/old - 1 | GI ms old | GI ms new | GI new/old | frame new/old |")
print("| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |")
worst = 0.0
for key in old:
    if key not in new:
        continue
    o, n = old[key], new[key]
    om, nm = o["metrics"] or {}, n["metrics"] or {}
    fo, fn = om.get("flip"), nm.get("flip")
    ro, rn = om.get("rel_mse"), nm.get("rel_mse")
    rel = (rn / ro - 1.0) if ro and rn is not None else None
    if rel is not None:
        worst = max(worst, abs(rel))
    go, gn = statistics.median(o["gi"]), statistics.median(n["gi"])
    fro, frn = statistics.median(o["frame"]), statistics.median(n["frame"])
    f = lambda v, p: "-" if v is None else f"{v:.{p}f}"
    print(f"| {key[0]} | {key[1]} | {f(fo, 4)} | {f(fn, 4)} | {f(ro, 6)} | {f(rn, 6)} | "
          f"{'-' if rel is None else f'{rel:.1e}'} | {go:.1f} | {gn:.1f} | "
          f"{(gn / go if go > 0 else float('nan')):.3f} | {frn / fro:.3f} |")
print(f"largest relative relMSE change: {worst:.2e}")
EOF
