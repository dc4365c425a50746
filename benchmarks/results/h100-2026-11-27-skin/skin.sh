# Skinning on the GPU: gi-bench deform with the build of dfdf8df (old: the CPU writes the
# deforming triangles' shading data every frame) and of ce20f0c (new: pass `skin`),
# alternating, 32k and 262k triangles, in one call.
. .gpu/setup.sh
xz -dc .gpu/gi-bench-old.xz > /tmp/bin/gi-bench-old; chmod +x /tmp/bin/gi-bench-old
cp /tmp/bin/gi-bench /tmp/bin/gi-bench-new
R=/tmp/res; mkdir -p $R; nvidia-smi -L > $R/gpu.txt
for round in 1 2; do for s in "256 64" "1024 128"; do for b in old new; do set -- $s
  gi-bench-$b deform --rings $1 --sides $2 --frames 30 > $R/skin-$b-$1x$2-$round.md 2>&1
  echo "$b $1x$2 r$round: $(head -1 $R/skin-$b-$1x$2-$round.md | grep -o 'CPU skinning.*')"
done; done; done 2>&1 | tee $R/summary.txt
cp benchmarks/results/h100-2026-11-27-skin/skin.sh $R/; cd $R && tar cJf $OUT/skin.tar.xz .
