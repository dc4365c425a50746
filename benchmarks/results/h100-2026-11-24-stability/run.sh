#!/usr/bin/env bash
# One sitting: the PC tier's temporal stability, and the mobile tier's (hsgi) with the command
# of its table in RESULTS.md, for a same-session comparison.
set -u
for f in .gl/*.deb; do dpkg -x $f /; done; ldconfig
export VK_DRIVER_FILES=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json XDG_RUNTIME_DIR=/tmp
mkdir -p $OUT
nvidia-smi --query-gpu=name,driver_version --format=csv > $OUT/gpu.txt 2>&1
for tier in pc mobile; do
  start=$(date +%s)
  timeout 280 .gpu/gi-bench stability --tier $tier --size 640x360 --settle-frames 400 --frames 64 \
    --json $OUT/stability_$tier.json > $OUT/stability_$tier.txt 2>&1
  echo "$tier: rc $? in $(( $(date +%s) - start )) s" >> $OUT/summary.txt
done
cat $OUT/summary.txt $OUT/stability_pc.txt $OUT/stability_mobile.txt
