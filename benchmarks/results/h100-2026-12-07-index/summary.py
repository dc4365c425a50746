"""Summarizes `gi-bench cache-update --json` runs named index-<build>-x<copies>-<round>.json:
per scene and build, the fill frame's triangle index (CPU step `index`) and whole CPU update,
each round's figure in milliseconds."""

import glob
import json
import statistics
import sys
from collections import defaultdict

folder = sys.argv[1] if len(sys.argv) > 1 else "."
runs = defaultdict(list)
for path in sorted(glob.glob(f"{folder}/index-*-x*-*.json")):
    name = path.rsplit("/", 1)[-1][len("index-"):-len(".json")]
    build, copies, _round = name.split("-")
    runs[(copies, build)].append(json.load(open(path)))

print("| scene | build | triangles | index ms (rounds) | median | fill frame CPU ms, median |")
print("|---|---|---:|---|---:|---:|")
for (copies, build), docs in sorted(runs.items(), key=lambda kv: (int(kv[0][0][1:]), kv[0][1] != "old")):
    index = [doc["per_frame"][0]["cpu_steps_ms"]["index"] for doc in docs]
    fill = [doc["per_frame"][0]["cpu_update_ms"] for doc in docs]
    print(
        f"| Sponza-{copies} | {build} | {docs[0]['triangles']} | "
        f"{', '.join(f'{v:.1f}' for v in index)} | {statistics.median(index):.1f} | "
        f"{statistics.median(fill):.1f} |"
    )
