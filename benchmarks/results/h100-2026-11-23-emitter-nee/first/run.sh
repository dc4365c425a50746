#!/usr/bin/env bash
# One sitting: base shaders (HEAD) against the working tree's, cornell-box and glossy.
set -u
for f in .gl/*.deb; do dpkg -x $f /; done; ldconfig
export VK_DRIVER_FILES=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json XDG_RUNTIME_DIR=/tmp
mkdir -p $OUT/q /tmp/o
nvidia-smi --query-gpu=name,driver_version --format=csv > $OUT/gpu.txt 2>&1
q() { # name shaderdir scene args...
  local name=$1 dir=$2 scene=$3; shift 3
  if [ "$dir" = base ]; then export GI_SHADER_DIR=.gpu/sh-base/shaders; else unset GI_SHADER_DIR; fi
  .gpu/gi compare $scene --width 1280 --height 720 --reference-spp 256 --cache-dir /tmp/refcache --out-dir /tmp/o/${scene}_$name "$@" > $OUT/q/${scene}_$name.txt 2>&1
  cp /tmp/o/${scene}_$name/compare.json $OUT/q/${scene}_$name.json 2>/dev/null
  for t in pc mobile; do
    [ -f /tmp/o/${scene}_$name/$t.exr ] && .gpu/gi error --reference /tmp/o/${scene}_$name/reference_256spp.exr /tmp/o/${scene}_$name/$t.exr --exposure $E > $OUT/q/${scene}_${name}_${t}_error.txt 2>&1
  done
  echo "$scene $name $*: $(grep -E '^(pc|mobile) ' $OUT/q/${scene}_$name.txt | awk '{print $1"="$2}' | tr '\n' ' ') bias: $(cat $OUT/q/${scene}_${name}_pc_error.txt 2>/dev/null | grep luminance_bias | awk '{print $2}')" >> $OUT/summary.txt
}
E=2.0
q new-def new cornell-box --tiers pc,mobile
q new-nr new cornell-box --tiers pc --pc-without restir
q base-def base cornell-box --tiers pc
q base-nr base cornell-box --tiers pc --pc-without restir
q new-def-s2 new cornell-box --tiers pc --seed 2
q new-nr-s2 new cornell-box --tiers pc --pc-without restir --seed 2
E=1.5
q new-def new glossy --tiers pc,mobile
q new-nr new glossy --tiers pc --pc-without restir
q base-def base glossy --tiers pc
q base-nr base glossy --tiers pc --pc-without restir
E=0.6
q new-def new atrium --tiers pc
unset GI_SHADER_DIR
.gpu/gi-bench pc --scenes cornell-box,glossy,atrium --size 1920x1080 --frames 64 --json $OUT/bench_new.json > $OUT/bench_new.txt 2>&1
GI_SHADER_DIR=.gpu/sh-base/shaders .gpu/gi-bench pc --scenes cornell-box,glossy --size 1920x1080 --frames 64 --json $OUT/bench_base.json > $OUT/bench_base.txt 2>&1
sed -i 's#/tmp/o/#out/#g' $OUT/*.txt $OUT/q/*.txt 2>/dev/null
cat $OUT/summary.txt
