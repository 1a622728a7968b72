#!/usr/bin/env bash
# Packs what a check on another machine with a GPU needs, so that machine needs no toolchain:
# the release `octolux` binary, every test binary (stripped), the shared scenes, and `run.sh`,
# which runs the whole test suite (default thread count) and the performance bench there.
#
#   scripts/gpu-kit.sh [KIT_DIR]          # default: gpu-kit/ (ignored by git)
#   # copy the repository checkout with KIT_DIR inside to the GPU machine, then there:
#   KIT_DIR/run.sh [RESULTS_DIR]          # default: KIT_DIR/results/
#   (tests, then the bench, then the voxel structures' measuring tests with VOXEL_TABLE=full)
#   (BENCH_ARGS="--width 320 --height 180 --warmup 1 --frames 3" for a quick try;
#    LOADER_DEBS=DIR: .deb packages of the Vulkan loader to unpack first on a machine without one)
#
# The test binaries find the repository's `scenes/` through the path the repository had when
# they were built; `run.sh` links that path to the checkout it runs in when it is missing.
set -euo pipefail
cd "$(dirname "$0")/.."
kit="${1:-gpu-kit}"
scenes="${OCTOLUX_SCENES:-../shared/scenes}"

cargo build --release -p octolux-cli
mapfile -t tests < <(cargo test --workspace --no-run --message-format=json 2>/dev/null |
  grep '"profile":{[^}]*"test":true' | grep -o '"executable":"[^"]*"' | sed 's/"executable":"\(.*\)"/\1/')
[ "${#tests[@]}" -gt 0 ] || { echo "gpu-kit: no test binaries were built" >&2; exit 1; }

rm -rf "$kit"
mkdir -p "$kit/stage/tests" "$kit/stage/bin"
for t in "${tests[@]}"; do
  strip -o "$kit/stage/tests/$(basename "$t")" "$t"
done
strip -o "$kit/stage/bin/octolux" target/release/octolux
# The CLI tests and the example's run the debug binaries cargo built for them, by their
# build-time paths.
strip -o "$kit/stage/bin/octolux-test" target/debug/octolux
strip -o "$kit/stage/bin/deferred-test" target/debug/deferred
if [ -d "$scenes" ]; then
  mkdir -p "$kit/stage/shared-scenes"
  cp -r "$scenes"/. "$kit/stage/shared-scenes/"
else
  echo "gpu-kit: no shared scenes at $scenes (set OCTOLUX_SCENES); tests that need them will say so" >&2
fi
pwd >"$kit/stage/repo-root"
tar -C "$kit/stage" -cf - . | xz -9e -T0 >"$kit/kit.tar.xz"
rm -rf "$kit/stage"

cat >"$kit/run.sh" <<'EOF'
#!/usr/bin/env bash
# Runs the packed test binaries and the bench on this machine's GPU; results in RESULTS_DIR.
set -uo pipefail
kit="$(cd "$(dirname "$0")" && pwd)"
repo="$(cd "$kit/.." && pwd)"
results="${1:-$kit/results}"
if ! ldconfig -p | grep -q 'libvulkan\.so\.1' && [ -n "${LOADER_DEBS:-}" ]; then
  for f in "$LOADER_DEBS"/*.deb; do dpkg -x "$f" /; done
  ldconfig
fi
# Driver manifests outside the loader's search path (some container layouts).
nvidia_icd=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
if [ -z "${VK_DRIVER_FILES:-}" ] && [ -f "$nvidia_icd" ]; then export VK_DRIVER_FILES="$nvidia_icd"; fi
rm -rf /tmp/octolux-kit
mkdir -p "$results" /tmp/octolux-kit
xz -dc "$kit/kit.tar.xz" | tar -C /tmp/octolux-kit -xf -
root="$(cat /tmp/octolux-kit/repo-root)"
if [ ! -e "$root" ]; then mkdir -p "$(dirname "$root")" && ln -s "$repo" "$root"; fi
mkdir -p "$root/target/debug"
[ -e "$root/target/debug/octolux" ] || cp /tmp/octolux-kit/bin/octolux-test "$root/target/debug/octolux"
[ -e "$root/target/debug/deferred" ] || cp /tmp/octolux-kit/bin/deferred-test "$root/target/debug/deferred"
export OCTOLUX_SCENES=/tmp/octolux-kit/shared-scenes XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-/tmp}"
bin=/tmp/octolux-kit/bin/octolux
"$bin" render --gi none --width 64 --height 64 --out /tmp/octolux-kit/probe.png -v 2>&1 |
  tee "$results/adapter.txt"
if [ -z "${DISPLAY:-}" ] && ! command -v Xvfb >/dev/null; then
  echo "note: no DISPLAY and no Xvfb here: view_cli (the viewer's window tests) fails saying so"
fi
failed=0
for t in /tmp/octolux-kit/tests/*; do
  log="$results/test-$(basename "$t").log"
  # A hung binary must not take the bench's time: TEST_TIMEOUT seconds each (default 180).
  (cd "$root/crates/octolux" && timeout "${TEST_TIMEOUT:-180}" "$t") >"$log" 2>&1
  rc=$?
  echo "== $(basename "$t"): exit $rc; $(grep -E "^test result" "$log" | tail -1)"
  grep -E "panicked|FAILED" "$log" | head -5
  [ "$rc" -eq 0 ] || failed=$((failed + 1))
done
# BENCH_ARGS replaces the size and frame counts (e.g. for a quick try on a CPU adapter).
read -r -a args <<<"${BENCH_ARGS:---width 1920 --height 1080 --warmup 5 --frames 20}"
(cd "$root" && "$bin" bench scenes/cornell-box.toml scenes/cornell-afternoon.toml scenes/crytek-sponza.toml \
  --gi none,lpv,clpv,olpv,vct-svo,vct-clipmap,vpl,probes-grid,probes-octree --no-reference "${args[@]}" --json "$results/bench.json") 2>&1 |
  tee "$results/bench.txt"
# The probes' two ray structures while the bunny turns (docs/probes.md, "Rays").
for rays in bvh voxels; do
  (cd "$root" && "$bin" bench scenes/cornell-bunny-turn.toml --gi probes-grid,probes-octree \
    --probes-rays "$rays" --time 4.0 --fps 60 --no-reference "${args[@]}" \
    --json "$results/bench-probe-rays-$rays.json") 2>&1 | tee "$results/bench-probe-rays-$rays.txt"
done
# The voxel structures' measuring tests, with their tables (docs/voxels.md, docs/performance.md).
for spec in "voxel measure" "voxel_svo_dynamic measure" "voxel_clipmap_perf sponza" "voxel_svo_aniso measure"; do
  set -- $spec
  b="$(ls /tmp/octolux-kit/tests/"$1"-* | head -1)"
  echo "== $1 $2" | tee -a "$results/voxel-perf.txt"
  (cd "$root/crates/octolux" && VOXEL_TABLE=full timeout 300 "$b" "$2" --nocapture) 2>&1 |
    grep -v '^\[' | tee -a "$results/voxel-perf.txt"
done
echo "test binaries failed: $failed"
exit "$failed"
EOF
chmod +x "$kit/run.sh"
du -sh "$kit"
