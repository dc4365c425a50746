#!/bin/bash
# Before (9dd33b3) and after (e543333) BVH builds on the H100: Sponza and two bundled scenes,
# the path and pc tiers; three rounds, the two binaries alternating.
for f in .gl/*.deb; do dpkg -x $f /; done; ldconfig
export VK_DRIVER_FILES=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json XDG_RUNTIME_DIR=/tmp
for b in old new; do xz -dc .gpu/gi-$b.xz > /tmp/gi-$b; chmod +x /tmp/gi-$b; done
S=.gpu/scenes/Sponza/glTF/Sponza.gltf
L=.gpu/scenes/Sponza.lighting.json
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
for round in 1 2 3; do
  for b in old new; do
    echo "== round $round $b"
    /tmp/gi-$b render $S --lighting $L --tier path --width 1920 --height 1080 --spp 16 --out $OUT/sp-path-$b.png 2>&1 | grep -E "spp:|first frame"
    /tmp/gi-$b render $S --lighting $L --tier pc --width 1920 --height 1080 --out $OUT/sp-pc-$b.png 2>&1 | grep -E "GI |first frame"
    for scene in open-world atrium; do
      /tmp/gi-$b render $scene --tier path --width 1920 --height 1080 --spp 16 --out $OUT/$scene-path-$b.png 2>&1 | grep -E "spp:|first frame"
    done
  done
done
