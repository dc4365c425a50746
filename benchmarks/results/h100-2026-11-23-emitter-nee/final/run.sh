#!/usr/bin/env bash
# One sitting: the final build on every scene, the cornell-box ablations, 1080p costs.
set -u
for f in .gl/*.deb; do dpkg -x $f /; done; ldconfig
export VK_DRIVER_FILES=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json XDG_RUNTIME_DIR=/tmp
mkdir -p $OUT /tmp/o/q
nvidia-smi --query-gpu=name,driver_version --format=csv > $OUT/gpu.txt 2>&1
q() { # name scene args...
  local name=$1 scene=$2; shift 2
  .gpu/gi compare $scene --width 1280 --height 720 --reference-spp 256 --cache-dir /tmp/refcache --out-dir /tmp/o/${scene}_$name "$@" > /tmp/o/q/${scene}_$name.txt 2>&1
  cp /tmp/o/${scene}_$name/compare.json /tmp/o/q/${scene}_$name.json 2>/dev/null
  for t in pc mobile; do
    [ -f /tmp/o/${scene}_$name/$t.exr ] && .gpu/gi error --reference /tmp/o/${scene}_$name/reference_256spp.exr /tmp/o/${scene}_$name/$t.exr --exposure $E > /tmp/o/q/${scene}_${name}_${t}_error.txt 2>&1
  done
  echo "$scene $name $*: $(grep -E '^(pc|mobile) ' /tmp/o/q/${scene}_$name.txt | awk '{print $1"="$2}' | tr '\n' ' ') bias pc: $(grep luminance_bias /tmp/o/q/${scene}_${name}_pc_error.txt 2>/dev/null | awk '{print $2}') mobile: $(grep luminance_bias /tmp/o/q/${scene}_${name}_mobile_error.txt 2>/dev/null | awk '{print $2}')" >> $OUT/summary.txt
}
E=2.0
q def cornell-box --tiers pc,mobile
q nr cornell-box --tiers pc --pc-without restir
q nomss cornell-box --tiers pc --pc-without multi-sample
q nospatial cornell-box --tiers pc --pc-without spatial
E=1.5
q def glossy --tiers pc,mobile
q nr glossy --tiers pc --pc-without restir
E=0.6
q def atrium --tiers pc
q nr atrium --tiers pc --pc-without restir
E=10
q def thin-wall --tiers pc
q nr thin-wall --tiers pc --pc-without restir
E=1.5
q def dynamic --tiers pc
E=0.5
q def open-world --tiers pc
.gpu/gi-bench pc --scenes cornell-box,atrium,glossy,thin-wall,dynamic,open-world --size 1920x1080 --frames 64 --json /tmp/o/q/bench_pc.json > $OUT/bench_pc.txt 2>&1
.gpu/gi-bench mobile --scenes cornell-box,glossy --size 1920x1080 --frames 64 --json /tmp/o/q/bench_mobile.json > $OUT/bench_mobile.txt 2>&1
sed -i 's#/tmp/o/#out/#g' $OUT/*.txt /tmp/o/q/*.txt 2>/dev/null
tar -C /tmp/o -czf $OUT/q.tar.gz q
cat $OUT/summary.txt
