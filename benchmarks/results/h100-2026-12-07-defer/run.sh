# One call: (1) BVH rays with this build's shaders (`full`) and `defer` (a node's remaining
# children pushed only when the child has internal children to descend, Ylitie et al. 2017),
# two rounds alternating; (2) the PC tier, the build before (gi-bench-old) against this one
# (screen buffers shared by passes whose lives do not overlap, the denoiser's output packed,
# `pc/specular_resolve` before `pc/shade`, one specular history updated in place),
# two rounds alternating; (3) where `pc/trace`'s time goes on Sponza: this build with parts of
# the GI rays' work left out through GI_SHADER_DIR (diagnostic shaders, not a renderer):
# `noalpha` (no alpha test in any traversal), `noshadow` (no shadow ray at the GI rays' hits),
# `nocache` (no cache lookup at the hits), `noshade` (hits not shaded at all), `defer`, and
# `noprefilter` (the a-trous luminance weight from the center variance, not its 3 x 3 Gaussian).
. .gpu/setup.sh 2>/dev/null
xz -dc .gpu/gi-bench-old.xz > /tmp/bin/gi-bench-old && chmod +x /tmp/bin/gi-bench-old
R=$OUT; S=.gpu/scenes
SP=$S/Sponza/glTF/Sponza.gltf; GS=$S/GasStation/glTF/GasStation.gltf
for r in 1 2; do
  for sc in $SP $GS; do
    n=$(basename $sc .gltf)
    for v in full defer; do
      E=""; [ $v != full ] && E="GI_SHADER_DIR=.gpu/d/$v"
      env $E timeout 45 gi-bench rays --scene $sc --rays 1048576 --repeats 5 --settle-s 1 > $R/rays-$n-$v-$r.md 2>&1
      echo "$n $v $r: $(grep -E '^\| (primary|shadow|incoherent) ' $R/rays-$n-$v-$r.md | awk -F'|' '{printf "%s %s; ", $2, $6}')"
    done
  done
done 2>&1 | tee $R/rays.txt
for r in 1 2; do
  for v in old new; do
    B=gi-bench; [ $v = old ] && B=gi-bench-old
    timeout 80 $B pc --scenes $SP,$GS,cornell-box --frames 64 --settle-s 1 --json $R/pc-$v-$r.json > $R/pc-$v-$r.md 2>&1
    echo "== $v round $r"; grep -E '^\| [A-Za-z-]+ \|' $R/pc-$v-$r.md | tr -s ' '
    awk '/^[A-Za-z-]+ 1920x1080/{s=$1} /\*\*GI/{printf "%s GI %s; ", s, $(NF-1)} /denoise_atrous/{printf "atrous %s; ", $(NF-1)} /pc\/compose/{printf "compose %s; ", $(NF-1)} /screen buffers MiB/{printf "screen %s\n", $(NF-1)}' $R/pc-$v-$r.md
  done
done 2>&1 | tee $R/pc.txt
for v in noalpha noshadow nocache noshade defer noprefilter; do
  GI_SHADER_DIR=.gpu/d/$v timeout 40 gi-bench pc --scenes $SP --frames 64 --settle-s 1 > $R/parts-$v.md 2>&1
  echo "$v: $(awk '/\*\*GI/{printf "GI %s; ", $(NF-1)} /gbuffer\/primary/{printf "primary %s; ", $(NF-1)} /pc\/trace \|/{printf "trace %s; ", $(NF-1)} /pc\/shadow/{printf "shadow %s; ", $(NF-1)} /pc\/shade \|/{printf "shade %s; ", $(NF-1)} /denoise_atrous/{printf "atrous %s; ", $(NF-1)}' $R/parts-$v.md)"
done 2>&1 | tee $R/parts.txt
