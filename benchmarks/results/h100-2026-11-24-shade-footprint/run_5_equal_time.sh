#!/usr/bin/env bash
# ReSTIR at equal GPU time: the pipeline without ReSTIR tracing every pixel (trace scale 1,
# dearer than the default) on cornell-box, seeds 1 and 2, and the 1080p GI cost of the default,
# without ReSTIR at trace scale 2 and at trace scale 1 (committed shaders through GI_SHADER_DIR).
set -u
for f in .gl/*.deb; do dpkg -x $f /; done; ldconfig
export VK_DRIVER_FILES=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json XDG_RUNTIME_DIR=/tmp
export GI_SHADER_DIR=$PWD/.gpu/shaders_new
nvidia-smi --query-gpu=name,driver_version --format=csv > $OUT/gpu.txt 2>&1
for seed in 1 2; do
  timeout 200 .gpu/gi compare cornell-box --tiers pc --width 1280 --height 720 --reference-spp 256 --seed $seed \
    --pc-without restir --pc-trace-scale 1 --cache-dir /tmp/refs --out-dir /tmp/cmp/s1_$seed > $OUT/compare_restir_scale1_seed$seed.txt 2>> $OUT/errors.txt
  echo "compare seed $seed rc $?" >> $OUT/errors.txt
  echo "cornell-box seed $seed, without ReSTIR, trace scale 1: $(grep '^pc ' $OUT/compare_restir_scale1_seed$seed.txt)" >> $OUT/summary.txt
done
for scale in 2 1; do
  timeout 150 .gpu/gi-bench pc --scenes cornell-box,atrium,glossy,thin-wall --size 1920x1080 --frames 64 \
    --variants default,restir --trace-scale $scale > $OUT/bench_scale$scale.txt 2>> $OUT/errors.txt
  echo "bench scale $scale rc $?" >> $OUT/errors.txt
done
sed -i 's#/root/out/#out/#g' $OUT/*.txt
cat $OUT/summary.txt; grep -h "GI (cache" $OUT/bench_scale*.txt
