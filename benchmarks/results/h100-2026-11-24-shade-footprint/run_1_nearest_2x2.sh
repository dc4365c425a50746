#!/usr/bin/env bash
# Multi-sample shading from the 2 x 2 trace pixels nearest each pixel (variant shaders through
# GI_SHADER_DIR) against the default 3 x 3, and the pipeline without ReSTIR, at 1280x720.
set -u
for f in .gl/*.deb; do dpkg -x $f /; done; ldconfig
export VK_DRIVER_FILES=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json XDG_RUNTIME_DIR=/tmp
nvidia-smi --query-gpu=name,driver_version --format=csv > $OUT/gpu.txt 2>&1
run() { # scene variant
  local scene=$1 variant=$2 extra="" env=""
  [ $variant = restir ] && extra="--pc-without restir"
  [ $variant = mss ] && extra="--pc-without multi-sample"
  local dir=/tmp/cmp/${scene}_$variant
  if [ $variant = footprint ]; then
    GI_SHADER_DIR=$PWD/.gpu/shaders_a timeout 200 .gpu/gi compare $scene --tiers pc --width 1280 --height 720 \
      --reference-spp 256 --cache-dir /tmp/refs --out-dir $dir > /tmp/cmp.txt 2>> $OUT/errors.txt
  else
    timeout 200 .gpu/gi compare $scene --tiers pc --width 1280 --height 720 --reference-spp 256 \
      $extra --cache-dir /tmp/refs --out-dir $dir > /tmp/cmp.txt 2>> $OUT/errors.txt
  fi
  echo "$scene $variant rc $?" >> $OUT/errors.txt
  echo "$scene $variant: $(grep '^pc ' /tmp/cmp.txt)" | tee -a $OUT/summary.txt
}
for scene in cornell-box atrium thin-wall glossy; do
  run $scene default
  run $scene footprint
done
run cornell-box restir
