#!/usr/bin/env bash
# Variant F (GI_SHADER_DIR): the irradiance from the 2 x 2 trace pixels nearest each pixel, the
# rough reflection's lobe ratio from the 4 x 4 nearest; quality on four scenes (seed 1, and
# cornell-box at seed 2 with the pipeline without ReSTIR), and its 1080p cost beside the default.
set -u
for f in .gl/*.deb; do dpkg -x $f /; done; ldconfig
export VK_DRIVER_FILES=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json XDG_RUNTIME_DIR=/tmp
nvidia-smi --query-gpu=name,driver_version --format=csv > $OUT/gpu.txt 2>&1
cmp() { # label scene [VAR=value...] [-- gi args...]
  local label=$1 scene=$2; shift 2
  local envs=() args=()
  while [ $# -gt 0 ] && [ "$1" != "--" ]; do envs+=("$1"); shift; done
  [ $# -gt 0 ] && shift
  args=("$@")
  env "${envs[@]}" timeout 200 .gpu/gi compare $scene --tiers pc --width 1280 --height 720 \
    --reference-spp 256 --cache-dir /tmp/refs --out-dir /tmp/cmp/${scene}_$label "${args[@]}" > /tmp/cmp.txt 2>> $OUT/errors.txt
  echo "$scene $label rc $?" >> $OUT/errors.txt
  echo "$scene $label: $(grep '^pc ' /tmp/cmp.txt)" | tee -a $OUT/summary.txt
}
for scene in cornell-box glossy atrium thin-wall; do
  cmp f $scene GI_SHADER_DIR=$PWD/.gpu/shaders_f
done
# Seed 2 on cornell-box: F, the default and without ReSTIR (gi compare's --seed).
cmp f_seed2 cornell-box GI_SHADER_DIR=$PWD/.gpu/shaders_f -- --seed 2
cmp default_seed2 cornell-box -- --seed 2
cmp restir_seed2 cornell-box -- --seed 2 --pc-without restir
# The 1080p cost, the default's shaders and F's, in one process each.
timeout 120 .gpu/gi-bench pc --scenes cornell-box,atrium,glossy,thin-wall --size 1920x1080 --frames 64 > $OUT/bench_default.txt 2>> $OUT/errors.txt
GI_SHADER_DIR=$PWD/.gpu/shaders_f timeout 120 .gpu/gi-bench pc --scenes cornell-box,atrium,glossy,thin-wall --size 1920x1080 --frames 64 > $OUT/bench_f.txt 2>> $OUT/errors.txt
grep -h "GI (cache" $OUT/bench_*.txt
