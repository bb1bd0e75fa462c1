"""Benchmark of shadenet.distributed (issue 17): distribution overhead on a local Ray cluster
against a single-process render, per-task overhead, tiles/s, and the scale-out model for a
4K frame at 256 spp on 8, 32 and 128 workers.

Build the package optimised first (``maturin develop --release``), then::

    python python/benchmarks/distributed.py [--cpus 2] [--tiles 16] [--runs 3]

Times are wall-clock medians over ``--runs``; the single-process render runs on as many
threads as the cluster has CPUs, the distributed one as one single-threaded task per tile.
"""

import argparse
import math
import statistics
import time

import ray

import shadenet
from shadenet import distributed as dist


def timed(f, runs):
    times, out = [], None
    for _ in range(runs):
        t0 = time.perf_counter()
        out = f()
        times.append(time.perf_counter() - t0)
    return statistics.median(times), min(times), max(times), out


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cpus", type=int, default=2)
    ap.add_argument("--tiles", type=int, default=16)
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--scene", default=None, help="scene file (default: the embedded default scene)")
    ap.add_argument("--out", default="/tmp/shadenet-dist-bench.exr")
    a = ap.parse_args()

    single = timed(lambda: shadenet.render(a.scene, threads=a.cpus), a.runs)
    w, h = shadenet.frame_size(a.scene)
    print(f"single process, {a.cpus} threads: {w}x{h}: median {single[0]:.3f} s "
          f"(min {single[1]:.3f}, max {single[2]:.3f}; setup included)")

    t0 = time.perf_counter()
    ray.init(num_cpus=a.cpus, include_dashboard=False, log_to_driver=False)
    print(f"ray.init (local cluster, {a.cpus} CPUs): {time.perf_counter() - t0:.2f} s (not counted)")
    # The first run starts the worker processes and compiles the scene once in each.
    cold = timed(lambda: dist.render(a.scene, a.out, tiles=a.tiles, progress=False), 1)
    warm = timed(lambda: dist.render(a.scene, a.out, tiles=a.tiles, progress=False), a.runs)
    r = warm[3]
    mean_task = statistics.mean(r.task_seconds)
    print(f"distributed, {a.tiles} tiles on {r.workers} workers: cold {cold[0]:.3f} s; "
          f"warm median {warm[0]:.3f} s (min {warm[1]:.3f}, max {warm[2]:.3f})")
    print(f"ratio to single process: cold {cold[0] / single[0]:.2f}x, warm {warm[0] / single[0]:.2f}x")
    print(f"tasks/s {a.tiles / warm[0]:.1f}; mean task {mean_task * 1e3:.1f} ms; "
          f"per-task overhead {r.overhead_ms:.1f} ms (wall x workers / tasks - mean task time)")

    # Scale-out on paper: a 4K frame at 256 spp.
    spp = shadenet.Renderer(a.scene).spp
    px_time = sum(r.task_seconds) / (w * h) * 256 / spp  # one thread, seconds per pixel
    W4, H4 = 3840, 2160
    total = px_time * W4 * H4
    o = r.overhead_ms / 1e3
    print(f"\n4K at 256 spp: {total:.0f} s of one thread's work ({px_time * 1e6:.1f} us/pixel)")
    for workers in (8, 32, 128):
        best = None
        for side in (16, 32, 64, 128, 256, 512):
            n = math.ceil(W4 / side) * math.ceil(H4 / side)
            t = math.ceil(n / workers) * (total / n + o)
            if best is None or t < best[1]:
                best = (side, t)
        print(f"  {workers:>3} workers: best tile {best[0]}² -> {best[1]:.1f} s, "
              f"speed-up {total / best[1]:.1f}x ({total / best[1] / workers * 100:.0f} % of ideal)")
    side5 = math.sqrt(20 * o / px_time)
    print(f"  tiles of at least {math.ceil(side5)}² pixels keep the per-task overhead under 5 %")
    ray.shutdown()


if __name__ == "__main__":
    main()
