#!/usr/bin/env bash
# The committed multi-sample shading (irradiance from the trace pixels nearest each pixel, the
# rough reflection's ratio from the 3 x 3; shaders through GI_SHADER_DIR on the previous build's
# binary, whose Rust side is the same): quality on four scenes (seed 1; cornell-box also seed 2),
# and the 1080p cost on all six, with the light change's cost on atrium and thin-wall.
set -u
for f in .gl/*.deb; do dpkg -x $f /; done; ldconfig
export VK_DRIVER_FILES=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json XDG_RUNTIME_DIR=/tmp
export GI_SHADER_DIR=$PWD/.gpu/shaders_new
nvidia-smi --query-gpu=name,driver_version --format=csv > $OUT/gpu.txt 2>&1
mkdir -p $OUT/raw
for run in "cornell-box 1" "cornell-box 2" "glossy 1" "atrium 1" "thin-wall 1"; do
  set -- $run
  timeout 200 .gpu/gi compare $1 --tiers pc --width 1280 --height 720 --reference-spp 256 --seed $2 \
    --cache-dir /tmp/refs --out-dir /tmp/cmp/$1_$2 > $OUT/raw/compare_$1_seed$2.txt 2>> $OUT/errors.txt
  echo "compare $1 seed $2 rc $?" >> $OUT/errors.txt
  echo "$1 seed $2: $(grep '^pc ' $OUT/raw/compare_$1_seed$2.txt)" >> $OUT/summary.txt
done
timeout 150 .gpu/gi-bench pc --scenes cornell-box,atrium,glossy,thin-wall,dynamic,open-world --size 1920x1080 \
  --frames 64 --json $OUT/raw/bench_pc.json > $OUT/raw/bench_pc.txt 2>> $OUT/errors.txt
echo "bench rc $?" >> $OUT/errors.txt
for scene in atrium thin-wall; do
  timeout 120 .gpu/gi-bench stability --tier pc --size 1920x1080 --frames 2 --settle-scene $scene \
    --settle-frames 200 --converged-frames 10 --json $OUT/raw/change_$scene.json > $OUT/raw/change_$scene.txt 2>> $OUT/errors.txt
  echo "change $scene rc $?" >> $OUT/errors.txt
done
python3 - "$OUT" <<'PY'
import json, sys, os
out = sys.argv[1]
rows = []
for run in json.load(open(os.path.join(out, "raw", "bench_pc.json")))["runs"]:
    w = run["frame_wall"]
    rows.append(f"bench {run['scene']}: GI {run['gi_ms']:.3f} pc/shade {run['passes_ms'].get('pc/shade', 0):.3f} "
                f"wall waiting {w['waiting_ms']:.3f} pipelined {w['pipelined_ms']:.3f}")
for scene in ("atrium", "thin-wall"):
    p = os.path.join(out, "raw", f"change_{scene}.json")
    if os.path.exists(p):
        c = json.load(open(p))["runs"][0]["settle"]["cost_ms"]
        rows.append(f"change {scene}: before {c['before']:.3f} first {c['first_after']:.3f} peak {c['peak']:.3f} "
                    f"relight {c.get('relight_frames')} elevated {c['elevated_frames']}")
open(os.path.join(out, "summary.txt"), "a").write("\n".join(rows) + "\n")
PY
sed -i 's#/root/out/#out/#g' $OUT/raw/*.txt
cat $OUT/summary.txt
(cd $OUT && tar -czf raw.tgz raw && rm -r raw)
