#!/usr/bin/env bash
# Makes the README's pictures in docs/images/: the default render (GI on) beside the CPU
# reference (the first part alone with `--default-only`), and the viewer's window with its panels (needs a display; started under Xvfb when
# DISPLAY is unset and Xvfb is installed).
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release -p octolux-cli --example side_by_side
bin=target/release/octolux
out=docs/images
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

# Default render (settled: `render` runs the technique's warm-up frames first) and the
# unlimited-bounce reference (what the default technique computes) of the same view.
$bin render --width 320 --height 320 --out "$tmp/default.png"
$bin render --gi reference --bounces unlimited --spp 4096 --width 320 --height 320 --out "$tmp/reference.png"
target/release/examples/side_by_side "$tmp/default.png" "$tmp/reference.png" "$out/default-vs-reference.png"
[ "${1:-}" = "--default-only" ] && exit 0

# The viewer, under a virtual display when there is none.
view() {
  if [ -n "${DISPLAY:-}" ]; then
    "$bin" view "$@"
  else
    xvfb-run -a -s "-screen 0 1400x900x24" "$bin" view "$@"
  fi
}
view --window 1100x620 --gi lpv --split none --frames 8 --screenshot-window "$out/viewer.png"
view --window 780x570 --gi lpv --scale 0.5 --compare --compare-view error --spp 256 --frames 60 \
  --screenshot-window "$out/viewer-compare.png"
