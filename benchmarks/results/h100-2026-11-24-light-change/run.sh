#!/usr/bin/env bash
# One sitting: the GI time around a light change (the sun turning 30 degrees) at 1080p, PC and
# mobile tiers, on the three bundled scenes with a sun. Flicker cases at their smallest (2
# frames): the settle case is what is measured here.
set -u
for f in .gl/*.deb; do dpkg -x $f /; done; ldconfig
export VK_DRIVER_FILES=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json XDG_RUNTIME_DIR=/tmp
mkdir -p $OUT/raw
nvidia-smi --query-gpu=name,driver_version --format=csv > $OUT/gpu.txt 2>&1
for tier in pc mobile; do
  for scene in atrium thin-wall open-world; do
    timeout 150 .gpu/gi-bench stability --tier $tier --size 1920x1080 --frames 2 \
      --settle-scene $scene --settle-frames 200 --converged-frames 10 \
      --json $OUT/raw/${tier}_${scene}.json > $OUT/raw/${tier}_${scene}.txt 2>> $OUT/errors.txt
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
    for run in r["runs"]:
        c = run["settle"]["cost_ms"]
        after = c["after"]
        rows.append(
            f"{name}: before {c['before']:.3f} first {c['first_after']:.3f} peak {c['peak']:.3f} "
            f"converged {c['converged']:.3f} elevated {c['elevated_frames']} "
            f"clock {c['clock_settle']} frames 1-8 {' '.join(f'{x:.2f}' for x in after[:8])} "
            f"frames 16/32/64/128 {' '.join(f'{after[i]:.2f}' for i in (15, 31, 63, 127) if i < len(after))} "
            f"settle {run['settle']['settle_frames']} floor_frames {run['settle']['floor_frames']}"
        )
open(os.path.join(out, "summary.txt"), "w").write("\n".join(rows) + "\n")
print("\n".join(rows))
PY
(cd $OUT && tar -czf raw.tgz raw && rm -r raw)
# The fill order's tie-break changes which pool ID a brick gets: cornell-box's quality figures
# at this build (the PC tier and the pipeline without ReSTIR), as in the PC tier's sections.
for variant in default restir; do
  extra=""; [ $variant = restir ] && extra="--pc-without restir"
  timeout 200 .gpu/gi compare cornell-box --tiers pc --width 1280 --height 720 --reference-spp 256 \
    $extra --cache-dir /tmp/refs --out-dir /tmp/cmp_$variant > $OUT/compare_cornell_$variant.txt 2>> $OUT/errors.txt
  echo "compare $variant rc $?" >> $OUT/errors.txt
done
