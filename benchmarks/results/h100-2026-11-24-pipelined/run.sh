#!/usr/bin/env bash
# One sitting: (1) the GI time around a light change with the relight budget
# (`relight_bricks_per_frame` 1024) at 1080p, PC and mobile tiers; (2) the per-pass cost of both
# tiers at 1080p on every bundled scene, now with each frame's wall-clock time waiting for the
# GPU and pipelined (`gi-bench pc|mobile` report both); (3) the PC tier's settle metrics at
# 640x360 after atrium's sun turns, as in "Relighting every brick after a light change".
set -u
for f in .gl/*.deb; do dpkg -x $f /; done; ldconfig
export VK_DRIVER_FILES=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json XDG_RUNTIME_DIR=/tmp
mkdir -p $OUT/raw
nvidia-smi --query-gpu=name,driver_version --format=csv > $OUT/gpu.txt 2>&1
scenes=cornell-box,atrium,glossy,thin-wall,dynamic,open-world
for tier in pc mobile; do
  timeout 150 .gpu/gi-bench $tier --scenes $scenes --size 1920x1080 --frames 64 \
    --json $OUT/raw/bench_$tier.json > $OUT/raw/bench_$tier.txt 2>> $OUT/errors.txt
  echo "bench $tier rc $?" >> $OUT/errors.txt
done
for tier in pc mobile; do
  for scene in atrium thin-wall open-world; do
    timeout 120 .gpu/gi-bench stability --tier $tier --size 1920x1080 --frames 2 \
      --settle-scene $scene --settle-frames 200 --converged-frames 10 \
      --json $OUT/raw/change_${tier}_${scene}.json > $OUT/raw/change_${tier}_${scene}.txt 2>> $OUT/errors.txt
    echo "change $tier $scene rc $?" >> $OUT/errors.txt
  done
done
timeout 120 .gpu/gi-bench stability --tier pc --size 640x360 --settle-frames 400 --frames 64 \
  --json $OUT/raw/stability_pc.json > $OUT/raw/stability_pc.txt 2>> $OUT/errors.txt
echo "stability pc rc $?" >> $OUT/errors.txt
python3 - "$OUT" <<'PY'
import json, sys, glob, os
out = sys.argv[1]
rows = []
for tier in ("pc", "mobile"):
    path = os.path.join(out, "raw", f"bench_{tier}.json")
    if not os.path.exists(path):
        continue
    for run in json.load(open(path))["runs"]:
        w = run["frame_wall"]
        rows.append(
            f"bench {tier} {run['scene']}: GI {run['gi_ms']:.3f} (pipelined {w['pipelined_gi_ms']:.3f}) "
            f"frame wall waiting {w['waiting_ms']:.3f} pipelined {w['pipelined_ms']:.3f} "
            f"ratio {w['pipelined_ms']/w['waiting_ms']:.3f}"
        )
for path in sorted(glob.glob(os.path.join(out, "raw", "change_*.json"))):
    r = json.load(open(path))
    name = os.path.basename(path)[:-5]
    for run in r["runs"]:
        c = run["settle"]["cost_ms"]
        after = c["after"]
        rows.append(
            f"{name}: before {c['before']:.3f} first {c['first_after']:.3f} peak {c['peak']:.3f} "
            f"converged {c['converged']:.3f} elevated {c['elevated_frames']} "
            f"frames 1-8 {' '.join(f'{x:.2f}' for x in after[:8])} "
            f"settle {run['settle']['settle_frames']} floor_frames {run['settle']['floor_frames']}"
        )
open(os.path.join(out, "summary.txt"), "w").write("\n".join(rows) + "\n")
print("\n".join(rows))
PY
sed -i 's#/root/out/#out/#g' $OUT/raw/*.txt
(cd $OUT && tar -czf raw.tgz raw && rm -r raw)
