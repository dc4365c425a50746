#!/usr/bin/env bash
# One sitting: temporal stability and settle time of both GPU tiers, with every brick settling
# again after a light change (gi-bench) and without (gi-bench-base, the parent commit's build).
set -u
for f in .gl/*.deb; do dpkg -x $f /; done; ldconfig
export VK_DRIVER_FILES=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json XDG_RUNTIME_DIR=/tmp
mkdir -p $OUT
nvidia-smi --query-gpu=name,driver_version --format=csv > $OUT/gpu.txt 2>&1
for build in base new; do
  bin=.gpu/gi-bench; [ $build = base ] && bin=.gpu/gi-bench-base
  for tier in pc mobile; do
    start=$(date +%s)
    timeout 200 $bin stability --tier $tier --size 640x360 --settle-frames 400 --frames 64 \
      --json $OUT/stability_${tier}_$build.json > $OUT/stability_${tier}_$build.txt 2>&1
    echo "$build $tier: rc $? in $(( $(date +%s) - start )) s" >> $OUT/summary.txt
  done
done
cat $OUT/summary.txt; for f in $OUT/stability_*.txt; do echo "== $f"; cat $f; done
