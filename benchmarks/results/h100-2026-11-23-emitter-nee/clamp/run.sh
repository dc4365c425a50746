#!/usr/bin/env bash
# The denoiser's clamp box 1.25x and 1.5x wider (2.5 and 3 sigma), shaders through GI_SHADER_DIR.
set -u
for f in .gl/*.deb; do dpkg -x $f /; done; ldconfig
export VK_DRIVER_FILES=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json XDG_RUNTIME_DIR=/tmp
mkdir -p $OUT /tmp/o/q
q() { # name shaderdir scene args...
  local name=$1 dir=$2 scene=$3; shift 3
  if [ "$dir" = base ]; then unset GI_SHADER_DIR; else export GI_SHADER_DIR=.gpu/$dir/shaders; fi
  .gpu/gi compare $scene --width 1280 --height 720 --reference-spp 256 --cache-dir /tmp/refcache --out-dir /tmp/o/${scene}_$name "$@" > /tmp/o/q/${scene}_$name.txt 2>&1
  echo "$scene $name $*: $(grep -E '^pc ' /tmp/o/q/${scene}_$name.txt | awk '{print $1"="$2}')" >> $OUT/summary.txt
}
q base-def base cornell-box --tiers pc
q base-nr base cornell-box --tiers pc --pc-without restir
for k in k125 k150; do
  q $k-def sh-$k cornell-box --tiers pc
  q $k-nr sh-$k cornell-box --tiers pc --pc-without restir
  q $k-def sh-$k atrium --tiers pc
  q $k-def sh-$k thin-wall --tiers pc
  q $k-def sh-$k glossy --tiers pc
done
sed -i 's#/tmp/o/#out/#g' /tmp/o/q/*.txt 2>/dev/null
tar -C /tmp/o -czf $OUT/q.tar.gz q
cat $OUT/summary.txt
