"""Summarizes `gi-bench cache-update --json` runs named fly-<build>-<scene>-<round>.json: per
scene and build, both rounds pooled, the frames after the fill frame: the cache's CPU update
(median, 99th percentile, worst, frames over 1 ms) and GPU time (median, worst, frames over
2 ms), and the frame at which the queue first ran empty."""

import glob
import json
import statistics
import sys
from collections import defaultdict

folder = sys.argv[1] if len(sys.argv) > 1 else "."
runs = defaultdict(list)
for path in sorted(glob.glob(f"{folder}/fly-*-*-*.json")):
    name = path.rsplit("/", 1)[-1][len("fly-"):-len(".json")]
    build, scene, _round = name.split("-")
    runs[(scene, build)].append(json.load(open(path)))


def pct(values, p):
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(p * len(ordered)))]


print("| scene | build | frames | CPU median / p99 / worst ms | CPU over 1 ms | GPU median / worst ms | GPU over 2 ms | queue empty at frame |")
print("|---|---|---:|---|---:|---|---:|---|")
for (scene, build), docs in sorted(runs.items(), key=lambda kv: (kv[0][0], kv[0][1] != "old")):
    cpu, gpu, drained = [], [], []
    for doc in docs:
        frames = doc["per_frame"][1:]
        cpu += [f["cpu_update_ms"] for f in frames]
        gpu += [f["cache_gpu_ms"] for f in frames if f["cache_gpu_ms"] is not None]
        drained.append(next((i + 1 for i, f in enumerate(frames) if f["queued_remaining"] == 0), None))
    print(
        f"| {scene} | {build} | {len(cpu)} | {statistics.median(cpu):.3f} / {pct(cpu, 0.99):.3f} / "
        f"{max(cpu):.3f} | {sum(c > 1.0 for c in cpu)} | {statistics.median(gpu):.3f} / "
        f"{max(gpu):.3f} | {sum(g > 2.0 for g in gpu)} | {', '.join(str(d) for d in drained)} |"
    )
