"""Median, p99 and worst of the cache's CPU and GPU per frame after the fill frame, from
`gi-bench cache-update --json` files: python3 flystats.py fly-final-x4.json ..."""
import json
import sys


def pct(values, p):
    values = sorted(values)
    return values[min(len(values) - 1, int(round(p / 100 * (len(values) - 1))))]


for path in sys.argv[1:]:
    frames = json.load(open(path))["per_frame"]
    after = frames[1:]
    cpu = [f["cpu_update_ms"] for f in after]
    gpu = [f["cache_gpu_ms"] for f in after]
    vox = [f["passes_ms"].get("cache/voxelize") or 0 for f in after]
    print(
        f"{path}: fill frame CPU {frames[0]['cpu_update_ms']:.0f} | "
        f"CPU median {pct(cpu, 50):.2f} p99 {pct(cpu, 99):.2f} worst {max(cpu):.1f} | "
        f"GPU median {pct(gpu, 50):.2f} p99 {pct(gpu, 99):.2f} worst {max(gpu):.2f} | "
        f"cache/voxelize median {pct(vox, 50):.2f} worst {max(vox):.2f}"
    )
