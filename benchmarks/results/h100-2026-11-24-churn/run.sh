#!/usr/bin/env bash
# One sitting: 100 PC tiers created one after another in one process, first with the default
# device sharing (shared on the H100), then with a device opened and destroyed every round.
set -u
for f in .gl/*.deb; do dpkg -x $f /; done; ldconfig
export VK_DRIVER_FILES=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json XDG_RUNTIME_DIR=/tmp
mkdir -p $OUT
nvidia-smi --query-gpu=name,driver_version --format=csv > $OUT/gpu.txt 2>&1
for sharing in auto dedicated; do
  nvidia-smi --query-gpu=memory.used --format=csv,noheader -lms 500 > $OUT/gpu_memory_$sharing.csv 2>&1 &
  sampler=$!
  start=$(date +%s)
  timeout 250 .gpu/gi-bench churn --tier pc --scene cornell-box --rounds 100 --size 640x360 \
    --frames 2 --sharing $sharing --json $OUT/churn_$sharing.json > $OUT/churn_$sharing.txt 2>&1
  echo "$sharing: rc $? in $(( $(date +%s) - start )) s" >> $OUT/summary.txt
  kill $sampler
done
cat $OUT/summary.txt $OUT/churn_auto.txt $OUT/churn_dedicated.txt
