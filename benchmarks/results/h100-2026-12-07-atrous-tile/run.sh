# One call: the PC tier's cost, this build (the gradient strata's rays in the first rows of
# `pc/trace`'s dispatch; the a-trous prefilter's variances loaded once per workgroup into
# workgroup memory) against the same build with one of the two changes undone through
# GI_SHADER_DIR (`gradlast`: those rays in the last rows; `untiled`: the prefilter's nine taps
# read from the buffer by every pixel), each with and without gradients, two rounds
# alternating.
. .gpu/setup.sh 2>/dev/null
R=/tmp/res; mkdir -p $R; S=.gpu/scenes
SP=$S/Sponza/glTF/Sponza.gltf; GS=$S/GasStation/glTF/GasStation.gltf
for r in 1 2; do for v in new gradlast untiled; do
  E=""; [ $v != new ] && E="GI_SHADER_DIR=.gpu/d/$v"
  env $E timeout 100 gi-bench pc --scenes $SP,$GS,atrium,cornell-box --variants default,gradients --frames 64 --settle-s 1 --json $R/pc-$v-$r.json > $R/pc-$v-$r.md 2>&1
  echo "$v $r: $(grep -E '^\| \*\*GI|pc/trace \||pc/denoise_atrous' $R/pc-$v-$r.md | tr -s ' ' | tr '\n' ' ')"
done; done 2>&1 | tee $R/pc.txt
cd $R && tar czf $OUT/res.tgz .
