#!/usr/bin/env bash
# One sitting: does the PC tier's darkness on thin-wall and atrium shrink with a longer still
# warm-up (a cache still converging) or stay (a bias)? rmse_srgb8 and luminance bias after 63,
# 255 and 1023 warm-up frames, with and without ReSTIR.
set -u
for f in .gl/*.deb; do dpkg -x $f /; done; ldconfig
export VK_DRIVER_FILES=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json XDG_RUNTIME_DIR=/tmp
nvidia-smi --query-gpu=name,driver_version --format=csv > $OUT/gpu.txt 2>&1
for scene in thin-wall atrium; do
  exposure=10; [ $scene = atrium ] && exposure=0.6
  for warmup in 63 255 1023; do
    for variant in default restir; do
      extra=""; [ $variant = restir ] && extra="--pc-without restir"
      dir=/tmp/cmp/${scene}_${warmup}_$variant
      timeout 240 .gpu/gi compare $scene --tiers pc --width 1280 --height 720 --reference-spp 256 \
        --warmup $warmup $extra --cache-dir /tmp/refs --out-dir $dir > /tmp/cmp.txt 2>> $OUT/errors.txt
      echo "$scene $warmup $variant compare rc $?" >> $OUT/errors.txt
      rmse=$(grep "^pc " /tmp/cmp.txt | awk '{print $2}')
      bias=$(.gpu/gi error --reference $dir/reference_256spp.exr $dir/pc.exr --exposure $exposure 2>> $OUT/errors.txt | grep -i "luminance_bias")
      echo "$scene warmup $warmup $variant: rmse_srgb8 $rmse; $bias" >> $OUT/summary.txt
    done
  done
done
cat $OUT/summary.txt
# summary.txt was tidied afterwards to one line per run (gi error's bias line joined to it).
