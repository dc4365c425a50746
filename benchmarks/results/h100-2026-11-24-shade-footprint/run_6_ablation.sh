#!/usr/bin/env bash
# The PC tier's ablation at 1280x720 (committed shaders through GI_SHADER_DIR on the build
# d7e6ce3 binary): the default and each stage off, four scenes, seed 1.
set -u
for f in .gl/*.deb; do dpkg -x $f /; done; ldconfig
export VK_DRIVER_FILES=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json XDG_RUNTIME_DIR=/tmp
export GI_SHADER_DIR=$PWD/.gpu/shaders_new
nvidia-smi --query-gpu=name,driver_version --format=csv > $OUT/gpu.txt 2>&1
mkdir -p $OUT/raw
for scene in cornell-box atrium glossy thin-wall; do
  for variant in default spatial shadow multi-sample svgf restir specular rough-specular with-temporal; do
    [ $SECONDS -gt 530 ] && { echo "$scene $variant skipped: out of time" >> $OUT/summary.txt; continue; }
    extra=""
    case $variant in
      default) ;;
      with-temporal) extra="--pc-with temporal" ;;
      *) extra="--pc-without $variant" ;;
    esac
    timeout 120 .gpu/gi compare $scene --tiers pc --width 1280 --height 720 --reference-spp 256 $extra \
      --cache-dir /tmp/refs --out-dir /tmp/cmp/${scene}_$variant > $OUT/raw/${scene}_$variant.txt 2>> $OUT/errors.txt
    echo "$scene $variant rc $?" >> $OUT/errors.txt
    echo "$scene $variant: $(grep '^pc ' $OUT/raw/${scene}_$variant.txt | awk '{print $2, $3, $4}')" >> $OUT/summary.txt
  done
done
sed -i 's#/root/out/#out/#g' $OUT/raw/*.txt
(cd $OUT && tar -czf raw.tgz raw && rm -r raw)
cat $OUT/summary.txt
