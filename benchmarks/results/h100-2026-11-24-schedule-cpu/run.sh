#!/usr/bin/env bash
# One sitting: wall-clock time of 200 PC-tier frames at 1080p (GPU and CPU together) with the
# cache schedule on hash maps (gi-bench-base, build 868b420) and on per-pool-ID arrays
# (gi-bench), alternating builds, three rounds each.
set -u
for f in .gl/*.deb; do dpkg -x $f /; done; ldconfig
export VK_DRIVER_FILES=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json XDG_RUNTIME_DIR=/tmp
mkdir -p $OUT/raw
nvidia-smi --query-gpu=name,driver_version --format=csv > $OUT/gpu.txt 2>&1
for scene in open-world atrium cornell-box; do
  for pass in 1 2; do
    for build in base new; do
      bin=.gpu/gi-bench; [ $build = base ] && bin=.gpu/gi-bench-base
      timeout 120 $bin churn --tier pc --scene $scene --rounds 3 --size 1920x1080 --frames 200 \
        --json $OUT/raw/${scene}_${build}_$pass.json > /dev/null 2>> $OUT/errors.txt
      echo "$scene $build $pass rc $?" >> $OUT/errors.txt
    done
  done
done
python3 - "$OUT" <<'PY'
import json, sys, glob, os
out = sys.argv[1]
rows = []
for path in sorted(glob.glob(os.path.join(out, "raw", "*.json"))):
    r = json.load(open(path))
    name = os.path.basename(path)[:-5]
    frames = [x["frames_ms"] / r["frames"] for x in r["rounds"]]
    rows.append(f"{name}: ms per frame {' '.join(f'{f:.3f}' for f in frames)}")
open(os.path.join(out, "summary.txt"), "w").write("\n".join(rows) + "\n")
print("\n".join(rows))
PY
(cd $OUT && tar -czf raw.tgz raw && rm -r raw)
