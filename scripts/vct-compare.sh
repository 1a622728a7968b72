#!/usr/bin/env bash
# `003`'s octree-against-clipmap comparisons (Arnebäck 2017, ch. 5; docs/vct.md, "`003`'s
# comparisons"), measured with `octolux bench` in one run and printed as ratios vct-svo /
# vct-clipmap beside the thesis's (SVOCT / CVCT):
#   thin     one thin specular cone per pixel, a fixed number of samples (Fig. 46)
#   flight   a camera flight through Crytek Sponza under three suns (§5.1, §5.2)
#   light    one moving sun: voxel update + injection + filtering per frame (§5.3.4)
#   spheres  N = 1..125 spheres moving back and forth: the voxel update per frame (Fig. 42)
#   memory   both structures' GPU memory from the ledger (Fig. 43)
#
#   scripts/vct-compare.sh [WIDTH] [HEIGHT] [FRAMES] [OUT_DIR]
#       defaults 160 90 4 out/vct-compare; 003's window is 1497 1014, e.g. on a GPU:
#       scripts/vct-compare.sh 1497 1014 60
#   CASES="thin flight light spheres" (memory comes with light), RESOLUTIONS="64 128 256"
#   (003's R^3: octree R^3, clipmap (R/2)^3 x 3 levels), SPHERES="1 9 27 64 125",
#   FLIGHT_RESOLUTIONS and SPHERE_RESOLUTIONS (default 256, as 003), FLIGHT_FPS (default 30),
#   WARMUP (default 2),
#   OCTOLUX (the binary; default target/release/octolux, built when missing).
# Needs the shared scenes (Crytek Sponza; OCTOLUX_SCENES, see docs/scene-format.md) and
# python3. Every bench's JSON stays in OUT_DIR.
set -euo pipefail
cd "$(dirname "$0")/.."
repo=$(pwd)
width=${1:-160}
height=${2:-90}
frames=${3:-4}
out=${4:-out/vct-compare}
warmup=${WARMUP:-2}
cases=${CASES:-thin flight light spheres}
resolutions=${RESOLUTIONS:-64 128 256}
flight_resolutions=${FLIGHT_RESOLUTIONS:-256}
spheres=${SPHERES:-1 9 27 64 125}
sphere_resolutions=${SPHERE_RESOLUTIONS:-256}
bin=${OCTOLUX:-target/release/octolux}
if [ -z "${OCTOLUX:-}" ] && [ ! -x "$bin" ]; then
  cargo build --release -p octolux-cli
fi
mkdir -p "$out"

# Both techniques, one bench: the same adapter, scene, camera and frames.
bench() { # json scene fps flags...
  local json=$1 scene=$2 fps=$3
  shift 3
  echo "== $(basename "$json" .json): $scene $*" >&2
  "$bin" bench "$scene" --gi vct-svo,vct-clipmap --no-reference --width "$width" \
    --height "$height" --warmup "$warmup" --frames "$frames" --fps "$fps" \
    --json "$json" "$@" >/dev/null
}
# 003's "R^3" for the structures: the octree R^3; the clipmap's finest voxel as close as its
# sizing allows to the octree's (levels of (R/2)^3 covering 0.55, 1.1 and 2.2 times the
# scene from the flight's start, as 003's Table 1 levels 1-3).
sizes() { echo --vct-octree-resolution "$1" --vct-resolution $(($1 / 2)) --vct-levels 3; }
# One bounce (003 has no multiple bounces), and 003's six cones of 60 degrees for both, so
# that the two differ only in the structure (each technique's own default cones differ).
common=(--vct-multi-bounce false --vct-cones 6 --vct-aperture 60 --vct-start 1.5)

for c in $cases; do
  case $c in
    thin)
      # Every pixel one 2-degree cone of R/4 samples from the finest voxel on, with no early
      # stop (R/8 finest voxels long: the same length in the scene at every R). The clipmap
      # has one level of R^3, centred on the camera in the middle of the atrium: every sample
      # reads its finest level, as 003 restricts its cones to its lowest level's region.
      for r in $resolutions; do
        bench "$out/thin-$r.json" scenes/sponza-moving-sun.toml 30 "${common[@]}" \
          --vct-octree-resolution "$r" --vct-resolution "$r" --vct-levels 1 --vct-sparse 8 \
          --vct-specular --vct-roughness 0 --vct-specular-steps $((r / 4))
      done ;;
    flight)
      # 003's tracing: every pixel 6 diffuse cones + 1 specular cone. FLIGHT_FPS frames per
      # second of the 20 s loop (default 30, so the clipmap follows a camera moving as fast as
      # in real time): WARMUP + FRAMES frames cover the start of the loop, 600 all of it.
      for r in $flight_resolutions; do
        bench "$out/flight-$r.json" scenes/sponza-flythrough.toml "${FLIGHT_FPS:-30}" \
          "${common[@]}" $(sizes "$r") --vct-sparse 1 --vct-specular --vct-roughness 0.1
      done ;;
    light)
      for r in $resolutions; do
        bench "$out/light-$r.json" scenes/sponza-moving-sun.toml 30 "${common[@]}" \
          $(sizes "$r") --vct-sparse 8
      done ;;
    spheres)
      # Sponza, its sun still, and N spheres (radius 0.3 m, the first N points of a 5 x 5 x 5
      # lattice 0.9 m apart, filled shell by shell: 1, 8 + 1, 27, 64, 125), each moving 1 m
      # along the atrium and back every 2 s, seen from 3 to 8 m away: all inside the clipmap's
      # finest level (as 003 moves its spheres in its lowest level).
      for n in $spheres; do
        scene="$out/sponza-spheres-$n.toml"
        python3 - "$n" "$repo/scenes/models/uv-sphere.obj" >"$scene" <<'EOF'
import sys
n, obj = int(sys.argv[1]), sys.argv[2]
print(f'name = "sponza-spheres-{n}"')
print('[[model]]\nname = "sponza"\npath = "scenes:crytek-sponza/sponza_noleaf.obj"\nscale = 0.01')
print('[[light]]\ntype = "directional"\nname = "sun"\ndirection = [0.3, -1.0, 0.1]\n'
      'color = [1.0, 0.93, 0.82]\nintensity = 4.0')
print('[[camera]]\nname = "spheres"\nposition = [9.0, 2.5, -0.4]\ntarget = [0.0, 3.0, -0.4]\n'
      'fov = 50.0\nnear = 0.1\nfar = 60.0')
points = sorted(((i, j, k) for i in range(5) for j in range(5) for k in range(5)),
                key=lambda p: (max(p), p))[:n]
for i, (x, y, z) in enumerate(points):
    pos = [3.0 + 0.9 * x, 1.0 + 0.9 * y, -2.2 + 0.9 * z]
    print(f'[[model]]\nname = "sphere-{i}"\npath = "{obj}"\nscale = 0.3')
    print(f'translate = [{pos[0]:.2f}, {pos[1]:.2f}, {pos[2]:.2f}]')
    print('material = { albedo = [0.7, 0.7, 0.7] }\nloop = true')
    print('[[model.animation]]\ntime = 0.0\n[[model.animation]]\ntime = 1.0\n'
          'translate = [-1.0, 0.0, 0.0]\n[[model.animation]]\ntime = 2.0')
EOF
        for r in $sphere_resolutions; do
          bench "$out/spheres-$n-$r.json" "$scene" 30 "${common[@]}" $(sizes "$r") \
            --vct-sparse 8
        done
      done ;;
    *) echo "vct-compare: unknown case '$c' (thin, flight, light, spheres)" >&2; exit 1 ;;
  esac
done

python3 - "$out" "$resolutions" "$flight_resolutions" "$spheres" "$sphere_resolutions" <<'EOF'
import json, os, sys
out = sys.argv[1]
resolutions, flight_res, spheres, sphere_res = (a.split() for a in sys.argv[2:6])

def load(name):
    path = os.path.join(out, name + ".json")
    if not os.path.exists(path):
        return None
    with open(path) as f:
        run = json.load(f)
    techniques = {t["technique"]: t for t in run["scenes"][0]["techniques"]}
    return run, techniques

def passes(t, pick):
    """Sum of the mean times of the technique's passes that `pick` selects (by the pass's
    name after the technique's, `<technique> <pass>`)."""
    prefix = t["technique"] + " "
    return sum(p["mean_ms"] for p in t["passes"]
               if p["gi"] and pick(p["name"].removeprefix(prefix)))

TRACE = ("trace", "upsample", "specular", "bounce")
# Light: the octree's injection and its filtering up the levels; the clipmap's injection
# (into every level; its "clipmap Lk filter" passes filter the voxels after a revoxelisation).
INJECT = ("svo inject", "svo radiance mip", "clipmap inject")
def is_trace(n): return n in TRACE
def is_light(n): return not is_trace(n)
def is_voxels(n): return not is_trace(n) and not any(n.startswith(p) for p in INJECT)

def ratio(a, b):
    return f"{a / b:.2f}" if b > 0 else "-"

adapter = None
def table(title, head, rows):
    if rows:
        print(f"\n{title}\n| {' | '.join(head)} |\n|{' --- |' * len(head)}")
        for r in rows:
            print("| " + " | ".join(r) + " |")

def case(name, pick):
    global adapter
    got = load(name)
    if not got:
        return None
    run, t = got
    adapter = adapter or run["adapter"]["name"]
    return passes(t["vct-svo"], pick), passes(t["vct-clipmap"], pick), t

thesis_thin = {"64": (4.16, 0.96), "128": (7.11, 1.96), "256": (13.19, 3.36)}
rows = []
for r in resolutions:
    m = case(f"thin-{r}", lambda n: n == "specular")
    if m:
        s, c, _ = m
        th = thesis_thin.get(r)
        rows.append([f"{r}^3", f"{s:.3f}", f"{c:.3f}", ratio(s, c),
                     f"{th[0] / th[1]:.2f}" if th else "-"])
table("thin cone: the specular pass (ms, mean per frame)",
      ["R", "vct-svo", "vct-clipmap", "ratio", "003 SVOCT/CVCT"], rows)

rows = []
for r in flight_res:
    m = case(f"flight-{r}", lambda n: True)
    if m:
        s, c, t = m
        st = passes(t["vct-svo"], is_trace)
        ct = passes(t["vct-clipmap"], is_trace)
        rows.append([f"{r}^3", f"{s:.2f}", f"{c:.2f}", ratio(s, c), ratio(st, ct),
                     "3.43" if r == "256" else "-"])
table("flight: GI total per frame (ms, mean over the path); ratio of the totals and of the "
      "tracing passes alone", ["R", "vct-svo", "vct-clipmap", "ratio", "tracing ratio",
                               "003 SVOCT/CVCT"], rows)

# Memory: the octree (everything the ledger holds under "svo": nodes, albedo and radiance
# bricks, leaf sums) against the clipmap's grids (albedo/opacity, normals, emission, radiance)
# and everything the clipmap technique holds (with its copy of the scene's triangles and the
# revoxelisation's scratch), after the moving-light case's last frame (static geometry).
thesis_mem = {"64": (11.3, 0.58), "128": (58.4, 4.71), "256": (287, 37.69)}
GRIDS = ("voxels", "normals", "emission", "radiance")
rows = []
for r in resolutions:
    got = load(f"light-{r}") or load(f"flight-{r}")
    if not got:
        continue
    t = got[1]
    def mib(tech, keep):
        return sum(e["mib"] for e in t[tech]["memory_entries"] if keep(e["owner"], e["name"]))
    svo = mib("vct-svo", lambda o, n: o in ("svo", "svo dynamic"))
    grids = mib("vct-clipmap", lambda o, n: o == "vct-clipmap" and n in GRIDS)
    clip = mib("vct-clipmap", lambda o, n: o == "vct-clipmap")
    th = thesis_mem.get(r, (0, 0))
    rows.append([f"{r}^3", f"{svo:.1f}", f"{grids:.1f}", f"{clip:.1f}", ratio(svo, grids),
                 f"{th[0]}", f"{th[1]}", ratio(*th) if th[1] else "-"])
table("memory (MiB, ledger)", ["R", "octree", "clipmap grids", "clipmap all", "ratio (grids)",
                               "003 SVOCT", "003 CVCT", "003 ratio"], rows)

rows = []
for r in resolutions:
    m = case(f"light-{r}", is_light)
    if m:
        s, c, _ = m
        rows.append([f"{r}^3", f"{s:.2f}", f"{c:.2f}", ratio(s, c),
                     f"{71.75 / 5.24:.1f}" if r == "256" else "-"])
table("moving light: voxel update + injection + filtering per frame (ms)",
      ["R", "vct-svo", "vct-clipmap", "ratio", "003 SVOCT/CVCT"], rows)

thesis_spheres = {"1": (4.22, 0.14), "9": (4.38, 0.85), "27": (4.83, 3.12),
                  "64": (6.83, 8.04), "125": (22.44, 15.36)}
for r in sphere_res:
    rows = []
    for n in spheres:
        m = case(f"spheres-{n}-{r}", is_voxels)
        if m:
            s, c, _ = m
            th = thesis_spheres.get(n)
            rows.append([n, f"{s:.2f}", f"{c:.2f}", ratio(s, c),
                         ratio(*th) if th and r == "256" else "-"])
    table(f"moving spheres at {r}^3: voxel update per frame (ms)",
          ["spheres", "vct-svo", "vct-clipmap", "ratio", "003 SVOCT/CVCT (256^3)"], rows)
if adapter:
    print(f"\nadapter: {adapter}; pass times: mean of the measured frames; JSON in {out}")
EOF
