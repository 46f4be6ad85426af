#!/usr/bin/env python3
"""Error against iterations and CPU time, 64 to MAX iterations, builds side by side
(docs/BENCHMARKS.md, "Error slopes").

usage: slope.py OUT_DIR MAX "SCENES" "ALGORITHMS" "SEEDS" VCMFARM [VCMFARM ...]
       [--size WxH] [--reference-algorithm A] [--reference-iterations N] [--sampler S]
       [--max-path-length L]

For each scene, one long reference (REFERENCE_ALGORITHM, default bpt, seed 99, rendered by
the first build on two threads and cached in OUT_DIR by scene, size and length). Then for
each build, algorithm and seed, one film grown by `continue` from 64 iterations to MAX in
doublings on one thread, its error against the reference read after every doubling; the
builds alternate run by run so that the host's drift falls on all of them alike. A film
grown so equals the film of its whole range rendered at once, so the points of one run are
one long render's.

Error: the relative RMSE sqrt(RMSE^2 - noise^2) / mean, the reference's noise taken from
its own estimate, as convergence_report.py. Prints per scene, algorithm and build the
median over seeds of the relative RMSE at every doubling and of the CPU seconds (the film's
own render CPU time) to reach 0.05, 0.02, 0.01 and 0.005, interpolated log-linearly between
doublings ('>' when not reached), and the slopes of log error against log iterations fitted
over [64, 1024] and [1024, MAX].
"""
import json
import math
import os
import statistics
import subprocess
import sys

TARGETS = [0.05, 0.02, 0.01, 0.005]


def run(args):
    return subprocess.run(args, check=True, capture_output=True, text=True).stdout


def info(vcmfarm, film):
    return json.loads(run([vcmfarm, "info", "--json", film]))


def rmse(vcmfarm, film, ref):
    return json.loads(run([vcmfarm, "errors", film, ref, "--json"]))["rmse"]["all"]


def fit(points, lo, hi):
    xs = [math.log(n) for n, e in points if lo <= n <= hi and e > 0]
    ys = [math.log(e) for n, e in points if lo <= n <= hi and e > 0]
    if len(xs) < 3:
        return None
    mx, my = sum(xs) / len(xs), sum(ys) / len(ys)
    return sum((x - mx) * (y - my) for x, y in zip(xs, ys)) / sum((x - mx) ** 2 for x in xs)


def time_to(points, target):
    """CPU seconds at which the relative error first reaches target, log-linear between
    doublings; None when it never does."""
    prev = None
    for n, err, cpu in points:
        if err <= target:
            if prev is None or prev[1] <= 0:
                return cpu
            (n0, e0, c0) = prev
            f = math.log(e0 / target) / math.log(e0 / err) if e0 > err else 1.0
            return math.exp(math.log(c0) + f * (math.log(cpu) - math.log(c0)))
        prev = (n, err, cpu)
    return None


def main():
    argv = sys.argv[1:]
    opts = {"--size": "64x64", "--reference-algorithm": "bpt", "--reference-iterations": "65536",
            "--sampler": "sobol", "--max-path-length": "10"}
    rest = []
    i = 0
    while i < len(argv):
        if argv[i] in opts:
            opts[argv[i]] = argv[i + 1]
            i += 2
        else:
            rest.append(argv[i])
            i += 1
    if len(rest) < 6:
        print(__doc__, file=sys.stderr)
        sys.exit(2)
    out, max_n, scenes, algorithms, seeds = rest[0], int(rest[1]), rest[2].split(), rest[3].split(), rest[4].split()
    builds = [os.path.abspath(b) for b in rest[5:]]
    size = opts["--size"]
    common = ["-R", size, "-l", opts["--max-path-length"], "-q", "--checkpoint-interval", "0"]
    os.makedirs(out, exist_ok=True)
    print(f"size {size}, max path length {opts['--max-path-length']}, sampler {opts['--sampler']}, 64 to {max_n} iterations, seeds {' '.join(seeds)}; "
          f"references: {opts['--reference-algorithm']}, {opts['--reference-iterations']} iterations")
    for scene in scenes:
        ref = os.path.join(out, f"ref-{scene}-{size}-l{opts['--max-path-length']}-{opts['--reference-algorithm']}-"
                                f"{opts['--reference-iterations']}.exr")
        if not os.path.exists(ref):
            run([builds[0], "render", scene, "-j", "2", "-a", opts["--reference-algorithm"], "-s", "99", "-n",
                 opts["--reference-iterations"], "-o", ref] + common)
        r = info(builds[0], ref)
        mean, noise = r["image_mean"], r["estimated_rmse"]
        print(f"\n{scene}: reference mean {mean:.5f}, relative noise {noise / mean:.5f}")
        for algorithm in algorithms:
            series = {b: [] for b in range(len(builds))}
            for seed in seeds:
                for b, vcmfarm in enumerate(builds):
                    film = os.path.join(out, f"{scene}-{algorithm}-{seed}-build{b}.exr")
                    if os.path.exists(film):
                        os.remove(film)
                    run([vcmfarm, "render", scene, "-j", "1", "-a", algorithm, "-s", seed, "--sampler", opts["--sampler"],
                         "-n", "64", "-o", film] + common)
                    points, n = [], 64
                    while True:
                        e = rmse(vcmfarm, film, ref)
                        rel = math.sqrt(max(e * e - noise * noise, 0.0)) / mean
                        points.append((n, rel, info(vcmfarm, film)["cpu_seconds"]))
                        if n >= max_n:
                            break
                        run([vcmfarm, "continue", film, "-n", str(n), "--threads", "1"])
                        n *= 2
                    series[b].append(points)
            for b in range(len(builds)):
                runs = series[b]
                ns = [p[0] for p in runs[0]]
                med = [statistics.median(r[k][1] for r in runs) for k in range(len(ns))]
                cpu = [statistics.median(r[k][2] for r in runs) for k in range(len(ns))]
                times = []
                for t in TARGETS:
                    ts = [time_to(r, t) for r in runs]
                    reached = [x for x in ts if x is not None]
                    times.append(f"{statistics.median(reached):.2f}" if len(reached) == len(ts) else ">")
                lo = fit(list(zip(ns, med)), 64, 1024)
                hi = fit(list(zip(ns, med)), 1024, max_n)
                fmt = lambda s: "-" if s is None else f"{s:.2f}"
                print(f"  {algorithm:4s} build{b} ({builds[b]}):")
                print("    rel. RMSE  " + " ".join(f"{n}:{e:.4f}" for n, e in zip(ns, med)))
                print(f"    CPU s at {max_n}: {cpu[-1]:.1f}; to " +
                      ", ".join(f"{t}: {x}" for t, x in zip(TARGETS, times)) +
                      f"; slope 64-1024 {fmt(lo)}, 1024-{max_n} {fmt(hi)}")


if __name__ == "__main__":
    main()
