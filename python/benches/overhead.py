"""Where the time of a Python call goes: shading a grid (the array conversions against the
shading itself) and rendering (the layers' conversion against the render). Prints medians
of a few runs; `python python/benches/overhead.py [WIDTH HEIGHT]` from the repository root.
"""

import statistics
import sys
import time

import numpy as np

import shadenet
from shadenet import _fragment_bytes


def median_s(f, runs=5):
    """Median wall time of `f()` over `runs` calls (after one warm-up call)."""
    f()
    times = []
    for _ in range(runs):
        t = time.perf_counter()
        f()
        times.append(time.perf_counter() - t)
    return statistics.median(times)


def main():
    w, h = (int(sys.argv[1]), int(sys.argv[2])) if len(sys.argv) > 2 else (256, 256)
    n = w * h
    mat = shadenet.compile("examples/networks/marble.json")
    g = shadenet.grid(w, h)
    conv = median_s(lambda: _fragment_bytes(g))
    print(f"{n} fragments: numpy -> bytes {conv * 1e3:.2f} ms ({conv / n * 1e9:.0f} ns/fragment)")
    for backend in ["interp", "jit", "jit-batch"]:
        t = median_s(lambda: mat.shade(g, backend=backend))
        print(f"shade {w}x{h} {backend}: {t * 1e3:.1f} ms ({n / t / 1e6:.2f} M fragments/s)")
    r = shadenet.render(res=(320, 180), spp=4)
    total = median_s(lambda: shadenet.render(res=(320, 180), spp=4), runs=3)
    s = r["stats"]
    print(
        f"render 320x180 4 spp: {total * 1e3:.1f} ms per call; inside: setup {s['setup_s'] * 1e3:.1f} ms, "
        f"render {s['render_s'] * 1e3:.1f} ms; {sum(a.nbytes for a in r['layers'].values()) / 1e6:.1f} MB of layers"
    )


if __name__ == "__main__":
    main()
