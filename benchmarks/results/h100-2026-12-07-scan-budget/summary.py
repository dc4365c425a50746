"""Summarizes `gi-bench cache-update --json` runs named scan-<entries>-x<copies>-<round>.json:
per scan budget and scene, both rounds pooled, the frames after the fill frame: the frame at
which the queue first ran empty (the fill's tail), the cache's CPU update and GPU time
(median, 99th percentile, worst, frames over 1 ms of CPU and over 2 ms of GPU)."""

import glob
import json
import statistics
import sys
from collections import defaultdict

folder = sys.argv[1] if len(sys.argv) > 1 else "."
runs = defaultdict(list)
for path in sorted(glob.glob(f"{folder}/scan-*-x*-*.json")):
    name = path.rsplit("/", 1)[-1][len("scan-"):-len(".json")]
    scan, copies, _round = name.split("-")
    runs[(copies, int(scan))].append(json.load(open(path)))


def pct(values, p):
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(p * len(ordered)))]


print("| scene | scan entries | frames | queue empty at frame | CPU median / p99 / worst ms | CPU over 1 ms | GPU median / p99 / worst ms | GPU over 2 ms |")
print("|---|---:|---:|---|---|---:|---|---:|")
for (copies, scan), docs in sorted(runs.items(), key=lambda kv: (int(kv[0][0][1:]), -kv[0][1])):
    cpu, gpu, drained = [], [], []
    for doc in docs:
        frames = doc["per_frame"][1:]
        drained.append(next((i + 1 for i, f in enumerate(frames) if f["queued_remaining"] == 0), None))
        cpu += [f["cpu_update_ms"] for f in frames]
        gpu += [f["cache_gpu_ms"] for f in frames if f["cache_gpu_ms"] is not None]
    print(
        f"| Sponza-{copies} | {scan} | {len(cpu)} | {', '.join(str(d) for d in drained)} | "
        f"{statistics.median(cpu):.3f} / {pct(cpu, 0.99):.3f} / {max(cpu):.3f} | "
        f"{sum(c > 1.0 for c in cpu)} | "
        f"{statistics.median(gpu):.3f} / {pct(gpu, 0.99):.3f} / {max(gpu):.3f} | "
        f"{sum(g > 2.0 for g in gpu)} |"
    )
