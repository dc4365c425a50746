# Deforming levels refit on the GPU against rebuilt (gi-bench deform), and the BVH traversal
# stack in workgroup memory against the private array (gi-bench rays, the shaders of
# .gpu/shaders-shared through GI_SHADER_DIR), alternating, in one call.
. .gpu/setup.sh
R=/tmp/res; mkdir -p $R; S=.gpu/scenes/Sponza
nvidia-smi -L > $R/gpu.txt
gi-bench deform --rings 256 --sides 64 --frames 60 > $R/deform-32k.md 2>&1
gi-bench deform --rings 1024 --sides 128 --frames 60 > $R/deform-262k.md 2>&1
for round in 1 2; do for v in private shared; do
  if [ $v = shared ]; then export GI_SHADER_DIR=.gpu/shaders-shared; else unset GI_SHADER_DIR; fi
  for scene in $S/Sponza.gltf open-world; do
    n=$(basename $scene .gltf)
    timeout 120 gi-bench rays --scene $scene --rays 2097152 --settle-s 1 > $R/rays-$n-$v-$round.md 2>&1
    echo "$n $v r$round: $(grep -E '^\| (primary|shadow|incoherent)' $R/rays-$n-$v-$round.md | awk -F'|' '{printf "%s %s G/s; ", $2, $6}')"
  done
done; done 2>&1 | tee $R/summary.txt
cat $R/deform-*.md
cp benchmarks/results/h100-2026-11-27-refit/refit.sh $R/; cd $R && tar cJf $OUT/refit.tar.xz .
