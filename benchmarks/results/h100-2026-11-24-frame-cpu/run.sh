#!/usr/bin/env bash
# One sitting: wall-clock time against GPU time per frame (200 frames at 1080p, three rounds a
# scene, one process each): the part of a frame the GPU was not rendering it.
set -u
for f in .gl/*.deb; do dpkg -x $f /; done; ldconfig
export VK_DRIVER_FILES=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json XDG_RUNTIME_DIR=/tmp
mkdir -p $OUT/raw
nvidia-smi --query-gpu=name,driver_version --format=csv > $OUT/gpu.txt 2>&1
for tier in pc mobile; do
  for scene in cornell-box atrium open-world; do
    timeout 120 .gpu/gi-bench churn --tier $tier --scene $scene --rounds 3 --size 1920x1080 \
      --frames 200 --json $OUT/raw/${tier}_${scene}.json > $OUT/raw/${tier}_${scene}.txt 2>> $OUT/errors.txt
    echo "$tier $scene rc $?" >> $OUT/errors.txt
  done
done
python3 - "$OUT" <<'PY'
import json, sys, glob, os
out = sys.argv[1]
rows = []
for path in sorted(glob.glob(os.path.join(out, "raw", "*.json"))):
    r = json.load(open(path))
    name = os.path.basename(path)[:-5]
    n = r["frames"]
    cells = [f"wall {x['frames_ms']/n:.3f} gpu {x['gpu_ms']/n:.3f} rest {(x['frames_ms']-x['gpu_ms'])/n:.3f}" for x in r["rounds"]]
    rows.append(f"{name}: " + " | ".join(cells))
open(os.path.join(out, "summary.txt"), "w").write("\n".join(rows) + "\n")
print("\n".join(rows))
PY
sed -i 's#/root/out/#out/#g' $OUT/raw/*.txt
(cd $OUT && tar -czf raw.tgz raw && rm -r raw)
