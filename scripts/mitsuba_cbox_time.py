#!/usr/bin/env python3
"""Time Mitsuba 3 on its Cornell box (BENCHMARKS.md §6.4's peer), M camera paths per second.

Usage: mitsuba_cbox_time.py [--variant llvm_ad_rgb] [--res 256] [--spp 16] [--max-depth -1]
                            [--frames 5] [--threads 2] [--scene .../cbox/cbox.xml]
Loads the scene from its XML (defaults spp/res/max_depth overridden), renders one warm-up frame
(the LLVM variant compiles its kernel there), then --frames timed frames with different seeds,
each forced to completion (dr.eval + dr.sync_thread). Prints per-frame seconds and, last,
`mpaths_per_s_median=X` (= res*res*spp / median seconds), like `glint bench path`.
The llvm variants need DRJIT_LIBLLVM_PATH: Debian's libllvm19 (/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1).
drjit 1.5.0 with LLVM 15 aborts here: "LLVM ERROR: Cannot select ... fminimum" (its AVX-512 code).
"""
import argparse
import os
import statistics
import sys
import time

p = argparse.ArgumentParser()
p.add_argument("--variant", default="llvm_ad_rgb")
p.add_argument("--res", type=int, default=256)
p.add_argument("--spp", type=int, default=16)
p.add_argument("--max-depth", type=int, default=-1)
p.add_argument("--frames", type=int, default=5)
p.add_argument("--threads", type=int, default=2)
p.add_argument("--scene", default=os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "shared", "data", "mitsuba", "scenes", "cbox", "cbox.xml"))
a = p.parse_args()

if a.variant.startswith("llvm") and not os.environ.get("DRJIT_LIBLLVM_PATH"):
    for cand in ("/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1", "/usr/lib/x86_64-linux-gnu/libLLVM-16.so.1"):
        if os.path.exists(cand):
            os.environ["DRJIT_LIBLLVM_PATH"] = cand
            break

import drjit as dr  # noqa: E402
import mitsuba as mi  # noqa: E402

mi.set_variant(a.variant)
dr.set_thread_count(a.threads)
scene = mi.load_file(a.scene, spp=a.spp, res=a.res, max_depth=a.max_depth)


def frame(seed):
    t0 = time.perf_counter()
    img = mi.render(scene, spp=a.spp, seed=seed)
    dr.eval(img)
    dr.sync_thread()
    return time.perf_counter() - t0


warm = frame(1000)
times = [frame(i) for i in range(a.frames)]
med = statistics.median(times)
paths = a.res * a.res * a.spp
llvm = ".".join(map(str, dr.detail.llvm_version())) if a.variant.startswith("llvm") else "-"
print(f"mitsuba {mi.__version__} drjit {dr.__version__} llvm {llvm} variant={a.variant} threads={dr.thread_count()} "
      f"{a.res}x{a.res} spp={a.spp} max_depth={a.max_depth} warm-up {warm:.3f} s, frames "
      + " ".join(f"{t:.3f}" for t in times) + " s")
print(f"mpaths_per_s_median={paths / med / 1e6:.3f}")
sys.stdout.flush()
