# Deforming levels refit on the GPU against rebuilt every frame and the default rule
# (gi-bench deform), 32k and 262k triangles, the tube bent by 90 degrees at the last frame.
. .gpu/setup.sh
R=/tmp/res; mkdir -p $R
for round in 1 2; do for s in "256 64" "1024 128"; do set -- $s
  gi-bench deform --rings $1 --sides $2 --frames 30 > $R/deform-$1x$2-$round.md 2>&1
  cat $R/deform-$1x$2-$round.md
done; done
cp benchmarks/results/h100-2026-11-27-refit/deform.sh $R/; cd $R && tar cJf $OUT/deform.tar.xz .
