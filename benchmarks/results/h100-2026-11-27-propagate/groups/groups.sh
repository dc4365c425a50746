# Workgroup shapes: the PC denoiser's passes at 8x8 (control), 32x2 (a) and 16x4 (b); the
# cache's propagation at 16 sides x 4 lanes (control), 32 x 2 and 64 x 1 (shader folders).
# The shader folders .gpu/sh-p32 and .gpu/sh-p64 are copies of shaders/ with RAY_LANES 2 and 1 and
# GROUP_SIDES 32 and 64 in cache/propagate.wgsl and cache/propagate_list.wgsl (first entry read
# within the list); gi-bench-a and -b are builds with GROUP_X, GROUP_Y of pc/denoise.wgsl (since
# split into the files of pc/denoise/) and GROUP of gi_tiers::pc::denoise set to 32 x 2 and
# 16 x 4.
. .gpu/setup.sh 2>/dev/null
for b in a b; do xz -dc .gpu/gi-bench-$b.xz > /tmp/bin/gi-bench-$b; chmod +x /tmp/bin/gi-bench-$b; done
R=/tmp/res; mkdir -p $R; S=.gpu/scenes
SC=$S/Sponza/Sponza.gltf,$S/ToyCar/ToyCar.gltf,cornell-box
for r in 1 2; do for v in control a b; do b=gi-bench; [ $v != control ] && b=gi-bench-$v
  timeout 150 $b pc --scenes $SC --frames 64 --settle-s 1 > $R/pc-$v-$r.md 2>&1
  echo "pc $v round $r: $(grep -E '^\| \*\*GI|denoise_(atrous|temporal|variance) \|' $R/pc-$v-$r.md | tr -s ' ' | tr '\n' ' ')"
done; done 2>&1 | tee $R/pc.txt
for r in 1 2; do for v in control p32 p64; do
  if [ $v = control ]; then timeout 150 gi-bench mobile --scenes $SC --frames 64 --settle-s 1 > $R/mobile-$v-$r.md 2>&1
  else GI_SHADER_DIR=$PWD/.gpu/sh-$v timeout 150 gi-bench mobile --scenes $SC --frames 64 --settle-s 1 > $R/mobile-$v-$r.md 2>&1; fi
  echo "mobile $v round $r: $(grep -E '^\| \*\*GI|cache/propagate \|' $R/mobile-$v-$r.md | tr -s ' ' | tr '\n' ' ')"
done; done 2>&1 | tee $R/mobile.txt
cd $R && tar cJf $OUT/groups.tar.xz .
