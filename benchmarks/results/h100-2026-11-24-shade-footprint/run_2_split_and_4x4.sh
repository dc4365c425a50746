#!/usr/bin/env bash
# Two more multi-sample shading footprints (variant shaders through GI_SHADER_DIR): C, the
# irradiance from the 2 x 2 nearest trace pixels and the rough reflection's lobe ratio from the
# 3 x 3; E, the 4 x 4 nearest. The default's figures come from the call before (same binary).
set -u
for f in .gl/*.deb; do dpkg -x $f /; done; ldconfig
export VK_DRIVER_FILES=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json XDG_RUNTIME_DIR=/tmp
nvidia-smi --query-gpu=name,driver_version --format=csv > $OUT/gpu.txt 2>&1
for scene in cornell-box glossy atrium thin-wall; do
  for v in c e; do
    GI_SHADER_DIR=$PWD/.gpu/shaders_$v timeout 200 .gpu/gi compare $scene --tiers pc --width 1280 --height 720 \
      --reference-spp 256 --cache-dir /tmp/refs --out-dir /tmp/cmp/${scene}_$v > /tmp/cmp.txt 2>> $OUT/errors.txt
    echo "$scene $v rc $?" >> $OUT/errors.txt
    echo "$scene $v: $(grep '^pc ' /tmp/cmp.txt)" | tee -a $OUT/summary.txt
  done
done
