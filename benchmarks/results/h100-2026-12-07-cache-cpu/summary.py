"""Summarizes `gi-bench cache-update --json` runs named fly-<build>-x<copies>-<round>.json: the
CPU update of the frames after the fill (median, 90th and 99th percentile, worst, frames over
1 ms) and each step's median, per build and scene, both rounds pooled."""

import glob
import json
import statistics
import sys
from collections import defaultdict

folder = sys.argv[1] if len(sys.argv) > 1 else "."
runs = defaultdict(list)
for path in sorted(glob.glob(f"{folder}/fly-*-x*-*.json")):
    name = path.rsplit("/", 1)[-1][len("fly-"):-len(".json")]
    build, copies, _round = name.split("-")
    runs[(copies, build)].append(json.load(open(path)))


def pct(values, p):
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(p * len(ordered)))]


print("| scene | build | frames | median ms | p90 | p99 | worst | frames over 1 ms | steps, median ms |")
print("|---|---|---:|---:|---:|---:|---:|---:|---|")
for (copies, build), docs in sorted(runs.items(), key=lambda kv: (int(kv[0][0][1:]), kv[0][1] != "old")):
    totals, steps = [], defaultdict(list)
    for doc in docs:
        for frame in doc["per_frame"][1:]:
            totals.append(frame["cpu_update_ms"])
            for step, ms in frame["cpu_steps_ms"].items():
                steps[step].append(ms)
    over = sum(1 for t in totals if t > 1.0)
    step_text = ", ".join(
        f"{step} {statistics.median(v):.3f}"
        for step, v in sorted(steps.items(), key=lambda kv: -statistics.median(kv[1]))
        if statistics.median(v) >= 0.005
    )
    print(
        f"| Sponza-{copies} | {build} | {len(totals)} | {statistics.median(totals):.3f} | "
        f"{pct(totals, 0.9):.3f} | {pct(totals, 0.99):.3f} | {max(totals):.3f} | "
        f"{over} ({100 * over / len(totals):.0f}%) | {step_text} |"
    )
