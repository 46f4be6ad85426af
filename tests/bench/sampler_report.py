#!/usr/bin/env python3
"""Tables of docs/BENCHMARKS.md "Samplers", from the films of sampler.sh.

usage: sampler_report.py VCMFARM DIR "SCENES" "ALGORITHMS" REPEATS

Every error is a relative RMSE: sqrt(RMSE^2 - noise^2) / mean, with RMSE against the
reference, noise the reference's own estimated RMSE and mean the reference's mean pixel
value (as convergence_report.py). Per scene, algorithm and sampler, medians over the
repeats of: CPU milliseconds per iteration, the iterations and the CPU seconds to reach each
target (log-log interpolation between log entries), and the slope of log error against
log iterations (fitted over entries whose error against the reference is at least 1.5 times
the reference's noise, so its floor does not flatten the fit). A target a run does not
reach is extrapolated from its last entry along its fitted slope and marked "~"."""
import json
import math
import statistics
import subprocess
import sys

TARGETS = [0.05, 0.03, 0.02]


def info(vcmfarm, path):
    out = subprocess.run([vcmfarm, "info", "--json", path], check=True, capture_output=True, text=True)
    return json.loads(out.stdout)


def iterations_to(points, target):
    prev = None
    for n, e in points:
        if e <= target:
            if prev is None:
                return None
            n0, e0 = prev
            if e0 <= e:
                return n
            f = math.log(e0 / target) / math.log(e0 / e)
            return math.exp(math.log(n0) + f * (math.log(n) - math.log(n0)))
        prev = (n, e)
    return None


def slope(points):
    if len(points) < 4:
        return None
    lx = [math.log(n) for n, _ in points]
    ly = [math.log(e) for _, e in points]
    mx, my = sum(lx) / len(lx), sum(ly) / len(ly)
    sxx = sum((a - mx) ** 2 for a in lx)
    if sxx < 0.25:
        return None
    return sum((a - mx) * (b - my) for a, b in zip(lx, ly)) / sxx


def median(xs):
    """Median of the magnitudes; negative (extrapolated) when any value is."""
    xs = [x for x in xs if x is not None]
    if not xs:
        return None
    m = statistics.median([abs(x) for x in xs])
    return -m if any(x < 0 for x in xs) else m


def fmt(x, spec):
    if x is None:
        return "-"
    return ("~" if x < 0 else "") + format(abs(x), spec)


def main():
    vcmfarm, d, scenes, algorithms, repeats = sys.argv[1], sys.argv[2], sys.argv[3].split(), sys.argv[4].split(), int(sys.argv[5])
    print("| scene | algorithm | sampler | ms/iteration (CPU) | slope | " +
          " | ".join(f"iterations to {t}" for t in TARGETS) + " | " +
          " | ".join(f"CPU s to {t}" for t in TARGETS) + " |")
    print("|" + "---|" * (5 + 2 * len(TARGETS)))
    speedups = []
    for scene in scenes:
        ref = info(vcmfarm, f"{d}/ref-{scene}.exr")
        mean = sum(ref["image_mean"]) / 3.0 if isinstance(ref["image_mean"], list) else ref["image_mean"]
        noise = ref["estimated_rmse"]
        for algo in algorithms:
            rows = {}
            for sampler in ("independent", "sobol"):
                cost, slopes, its, secs = [], [], {t: [] for t in TARGETS}, {t: [] for t in TARGETS}
                for rep in range(1, repeats + 1):
                    f = info(vcmfarm, f"{d}/{scene}-{algo}-{sampler}-{rep}.exr")
                    n = f["iteration_count"]
                    ms = 1000.0 * f["cpu_seconds"] / n
                    cost.append(ms)
                    pts, fit = [], []
                    for e in f["convergence"]:
                        if e["rmse"] is None or e["iterations"] < 2:
                            continue
                        c2 = e["rmse"] ** 2 - noise ** 2
                        if c2 <= 0:
                            continue
                        pts.append((e["iterations"], math.sqrt(c2) / mean))
                        if e["rmse"] >= 1.5 * noise:
                            fit.append(pts[-1])
                    slopes.append(slope(fit))
                    for t in TARGETS:
                        k = iterations_to(pts, t)
                        if k is None and pts and slopes[-1] is not None and slopes[-1] < -0.3:
                            # not reached: extrapolated from the last entry along the fitted
                            # slope, kept negative to mark it ("~" in the tables)
                            n_last, e_last = pts[-1]
                            k = -n_last * (e_last / t) ** (-1.0 / slopes[-1])
                        its[t].append(k)
                        secs[t].append(None if k is None else k * ms / 1000.0)
                rows[sampler] = (median(cost), None if not [x for x in slopes if x is not None] else
                                 statistics.median([x for x in slopes if x is not None]), {t: median(its[t]) for t in TARGETS},
                                 {t: median(secs[t]) for t in TARGETS})
                c, s, it, sc = rows[sampler]
                print(f"| {scene} | {algo} | {sampler} | {fmt(c, '.3f')} | {'-' if s is None else format(s, '.2f')} | " +
                      " | ".join(fmt(it[t], '.0f') for t in TARGETS) + " | " +
                      " | ".join(fmt(sc[t], '.2f') for t in TARGETS) + " |")
            a, b = rows["independent"][3], rows["sobol"][3]
            speedups.append((scene, algo, {t: (math.copysign(abs(a[t]) / abs(b[t]), -1.0 if a[t] < 0 or b[t] < 0 else 1.0)
                                               if a[t] and b[t] else None) for t in TARGETS}))
    print()
    print("| scene | algorithm | " + " | ".join(f"speed-up to {t} (CPU time)" for t in TARGETS) + " |")
    print("|---|---|" + "---|" * len(TARGETS))
    for scene, algo, s in speedups:
        print(f"| {scene} | {algo} | " + " | ".join(fmt(s[t], '.2f') for t in TARGETS) + " |")


main()
