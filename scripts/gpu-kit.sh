#!/usr/bin/env bash
# Packs what a check on another machine with a GPU needs, so that machine needs no toolchain:
# the release `octolux` binary, every test binary (stripped), the shared scenes, and `run.sh`,
# which runs the performance bench and the whole test suite there.
#
#   scripts/gpu-kit.sh [KIT_DIR]          # default: gpu-kit/ (ignored by git)
#   # copy the repository checkout with KIT_DIR inside to the GPU machine, then there:
#   KIT_DIR/run.sh [RESULTS_DIR]          # default: KIT_DIR/results/
#
# The kit is split so that no transfer has to carry all of it: `base.tar.xz` (the release
# binary and the scenes, about 33 MB), `cli.tar.xz` (the debug binaries the CLI and example
# tests run, about 8 MB) and `tests.tar.xz` (every test binary, about 43 MB for 49). The test
# binaries link the same library code, so they go into one xz stream with a dictionary that
# spans all of them (KIT_DICT, default 768MiB) and the x86 branch filter, which makes the
# calls of identical code identical bytes: 501 MB of stripped binaries pack into 43 MB, where
# compressed one by one they took 129 MB. That takes a few minutes on one thread (threads
# would split the stream into blocks that do not share a dictionary) and 8.3 GiB of memory
# (xz's figure for these settings; 769 MiB to unpack). `run.sh` runs whatever parts are present (a part already unpacked by an
# earlier run on the same machine is kept), steps chosen by STEPS (default "bench tests";
# add "voxel" for the voxel structures' tables, "steps" for every step of the octree's
# multi-step passes timed as a pass of its own):
#   BENCH_ARGS="--width 320 --height 180 --warmup 1 --frames 3"   a quick try
#   BENCH_SCENES="scenes/cornell-box.toml ..."                     other scenes
#   BENCH_GI=vpl,vct-svo                                             other techniques
#   TEST_JOBS=4       test binaries run at once (each with the default thread count)
#   TEST_TIMEOUT=480  seconds per test binary (the library's integration tests are one)
#   LOADER_DEBS=DIR   .deb packages of the Vulkan loader to unpack first on a machine without one
#
# What travels to the device machine (its 64 MiB limit) is the whole working tree plus the
# parts a call carries: with 34.8 MiB of tracked files (commit bd96aec) the base part with the
# Sponzas (about 33 MB) does not fit beside it; point OCTOLUX_SCENES at a folder holding only the
# small shared scenes (the bunny, the dragon, McGuire's and Mitsuba's boxes: 15 MB unpacked)
# for a base that does, and run the Sponza benches where the tree is smaller.
#
# The test binaries find the repository's `scenes/` through the path the repository had when
# they were built; `run.sh` links that path to the checkout it runs in when it is missing.
set -euo pipefail
cd "$(dirname "$0")/.."
kit="${1:-gpu-kit}"
dict="${KIT_DICT:-768MiB}"
scenes="${OCTOLUX_SCENES:-../shared/scenes}"

cargo build --release -p octolux-cli
mapfile -t tests < <(cargo test --workspace --ignore-rust-version --no-run --message-format=json 2>/dev/null |
  grep '"profile":{[^}]*"test":true' | grep -o '"executable":"[^"]*"' | sed 's/"executable":"\(.*\)"/\1/')
[ "${#tests[@]}" -gt 0 ] || { echo "gpu-kit: no test binaries were built" >&2; exit 1; }

rm -rf "$kit"
mkdir -p "$kit/stage/base/bin" "$kit/stage/cli/bin" "$kit/stage/tests"
for t in "${tests[@]}"; do
  strip -o "$kit/stage/tests/$(basename "$t")" "$t"
done
strip -o "$kit/stage/base/bin/octolux" target/release/octolux
# The CLI tests and the example's run the debug binaries cargo built for them, by their
# build-time paths.
strip -o "$kit/stage/cli/bin/octolux-test" target/debug/octolux
strip -o "$kit/stage/cli/bin/deferred-test" target/debug/deferred
if [ -d "$scenes" ]; then
  mkdir -p "$kit/stage/base/shared-scenes"
  cp -r "$scenes"/. "$kit/stage/base/shared-scenes/"
else
  echo "gpu-kit: no shared scenes at $scenes (set OCTOLUX_SCENES); tests that need them will say so" >&2
fi
pwd >"$kit/stage/base/repo-root"
cat >"$kit/run.sh" <<'EOF'
#!/usr/bin/env bash
# Runs the packed bench and test binaries on this machine's GPU; results in RESULTS_DIR.
set -uo pipefail
kit="$(cd "$(dirname "$0")" && pwd)"
repo="$(cd "$kit/.." && pwd)"
results="${1:-$kit/results}"
steps=" ${STEPS:-bench tests} "
unpacked=/tmp/octolux-kit
if ! ldconfig -p | grep -q 'libvulkan\.so\.1' && [ -n "${LOADER_DEBS:-}" ]; then
  for f in "$LOADER_DEBS"/*.deb; do dpkg -x "$f" /; done
  ldconfig
fi
# Driver manifests outside the loader's search path (some container layouts).
nvidia_icd=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
if [ -z "${VK_DRIVER_FILES:-}" ] && [ -f "$nvidia_icd" ]; then export VK_DRIVER_FILES="$nvidia_icd"; fi
mkdir -p "$results" "$unpacked"
# Each part unpacks into its own folder; parts unpacked by an earlier run stay.
for part in "$kit"/*.tar.xz; do
  name="$(basename "$part" .tar.xz)"
  rm -rf "${unpacked:?}/$name" && mkdir -p "$unpacked/$name"
  xz -dc "$part" | tar -C "$unpacked/$name" -xf - || { echo "run.sh: cannot unpack $part"; exit 1; }
done
[ -f "$unpacked/base/repo-root" ] || { echo "run.sh: base.tar.xz was never unpacked here"; exit 1; }
root="$(cat "$unpacked/base/repo-root")"
if [ ! -e "$root" ]; then mkdir -p "$(dirname "$root")" && ln -s "$repo" "$root"; fi
mkdir -p "$root/target/debug"
# The CLI tests run target/debug/octolux: the debug build when cli.tar.xz came along, else
# the release binary (same behaviour, without debug assertions).
if [ -f "$unpacked/cli/bin/octolux-test" ]; then
  cp "$unpacked/cli/bin/octolux-test" "$root/target/debug/octolux"
  cp "$unpacked/cli/bin/deferred-test" "$root/target/debug/deferred"
elif [ ! -e "$root/target/debug/octolux" ]; then
  cp "$unpacked/base/bin/octolux" "$root/target/debug/octolux"
fi
export OCTOLUX_SCENES="$unpacked/base/shared-scenes" XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-/tmp}"
bin="$unpacked/base/bin/octolux"
"$bin" render --gi none --width 64 --height 64 --out "$unpacked/probe.png" -v 2>&1 |
  tee "$results/adapter.txt"
failed=0
if [[ "$steps" == *" bench "* ]]; then
  # BENCH_ARGS replaces the size and frame counts (e.g. for a quick try on a CPU adapter).
  read -r -a args <<<"${BENCH_ARGS:---width 1920 --height 1080 --warmup 3 --frames 10}"
  read -r -a scenes <<<"${BENCH_SCENES:-scenes/cornell-box.toml scenes/crytek-sponza.toml scenes/sponza-flythrough.toml}"
  (cd "$root" && "$bin" bench "${scenes[@]}" \
    --gi "${BENCH_GI:-none,lpv,clpv,olpv,vct-svo,vct-clipmap,vpl,probes-grid,probes-octree}" --no-reference \
    "${args[@]}" --json "$results/bench.json") >"$results/bench.txt" 2>&1
  echo "== bench: exit $?"
  grep -v '^\[' "$results/bench.txt"
fi
if [[ "$steps" == *" tests "* ]]; then
  if [ -z "${DISPLAY:-}" ] && ! command -v Xvfb >/dev/null; then
    echo "note: no DISPLAY and no Xvfb here: view_cli (the viewer's window tests) fails saying so"
  fi
  run_test() {
    t="$1"
    log="$results/test-$(basename "$t").log"
    # A hung binary must not take the others' time: TEST_TIMEOUT seconds each.
    (cd "$root/crates/octolux" && timeout "${TEST_TIMEOUT:-480}" "$t") >"$log" 2>&1
    rc=$?
    echo "== $(basename "$t"): exit $rc; $(grep -E "^test result" "$log" | tail -1)"
    grep -E "panicked|FAILED" "$log" | head -5
  }
  export -f run_test
  export results root
  ls "$kit"/tests*.tar.xz >/dev/null 2>&1 || echo "run.sh: no tests.tar.xz in $kit"
  for part in "$kit"/tests*.tar.xz; do
    [ -e "$part" ] || continue
    ls "$unpacked/$(basename "$part" .tar.xz)"/*
  done | xargs -P "${TEST_JOBS:-4}" -I{} bash -c 'run_test {}' | tee "$results/tests.txt"
  failed=$(grep -c '^== .*: exit [1-9]' "$results/tests.txt")
fi
if [[ "$steps" == *" steps "* ]]; then
  # The octree's build, dynamic update and radiance mip step by step (OCTOLUX_PROFILE_STEPS:
  # each dispatch its own timed pass), on the Cornell box held still and moving.
  (cd "$root" && OCTOLUX_PROFILE_STEPS=1 "$bin" bench scenes/cornell-box.toml \
    scenes/cornell-everything-moves.toml --gi vct-svo,vpl --no-reference \
    --width 1920 --height 1080 --warmup 3 --frames 5) >"$results/steps.txt" 2>&1
  echo "== steps: exit $?"
  grep -F ': ' "$results/steps.txt" | grep -F 'svo' | head -120
fi
if [[ "$steps" == *" voxel "* ]]; then
  # The voxel structures' measuring tests, with their tables (docs/voxels.md).
  # They are modules of the library's integration-test binary.
  b="$(ls "$unpacked"/tests*/integration-* | head -1)"
  for filter in voxel::measure voxel_svo_dynamic::measure voxel_clipmap_perf::sponza voxel_svo_aniso::measure; do
    echo "== $filter" | tee -a "$results/voxel-perf.txt"
    (cd "$root/crates/octolux" && VOXEL_TABLE=full timeout 300 "$b" "$filter" --nocapture) 2>&1 |
      grep -v '^\[' | tee -a "$results/voxel-perf.txt"
  done
fi
echo "test binaries failed: $failed"
exit "$failed"
EOF
chmod +x "$kit/run.sh"

# run.sh first, so that an interrupted packing leaves it; then the parts, each written under
# a temporary name and renamed when complete.
pack() {
  local name="$1"
  shift
  tar -C "$kit/stage/$name" -cf - . | xz "$@" >"$kit/$name.tar.xz.part"
  mv "$kit/$name.tar.xz.part" "$kit/$name.tar.xz"
}
pack base -9e -T0
pack cli -9e -T0
echo "gpu-kit: packing the test binaries into one stream (a few minutes)" >&2
pack tests -T1 --x86 --lzma2=preset=9,dict="$dict"
rm -rf "$kit/stage"
du -sh "$kit"/*
