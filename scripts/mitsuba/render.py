#!/usr/bin/env python3
"""Renders the Mitsuba side of scripts/mitsuba-compare.sh with Mitsuba 3 (pip install mitsuba).

usage: render.py SCENE.xml OUT_PREFIX SIZE SPP SEED MAX_DEPTH...

Writes OUT_PREFIX-d<MAX_DEPTH>-s<SEED>.exr (linear RGB, box filter as the scene's film has it)
for each max_depth, with Mitsuba's path integrator: max_depth 2 is direct light, n + 2 is n
bounces, -1 is unlimited.
"""
import sys
import time

import mitsuba as mi

mi.set_variant("scalar_rgb")
scene_file, prefix, size, spp, seed = sys.argv[1:6]
for depth in sys.argv[6:]:
    start = time.time()
    scene = mi.load_file(scene_file, res=int(size), spp=int(spp), max_depth=int(depth))
    image = mi.render(scene, seed=int(seed))
    out = f"{prefix}-d{depth}-s{seed}.exr"
    mi.util.write_bitmap(out, image)
    print(f"{out}: {time.time() - start:.1f} s", flush=True)
