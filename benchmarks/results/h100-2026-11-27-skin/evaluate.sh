# The renderer's evaluation of animated frames moved in place (Scene::evaluate_into) against
# fresh evaluations, complete and positions only, and GpuScene::update with the skin pass:
# gi-bench deform at 32k and 262k tube triangles, and the 32k tube in a level of 1M static
# triangles; the build of the evaluate_into commit, two rounds in one call.
. .gpu/setup.sh
R=/tmp/res; mkdir -p $R; nvidia-smi -L > $R/gpu.txt
for round in 1 2; do for s in "256 64 0" "1024 128 0" "256 64 1000000"; do set -- $s
  gi-bench deform --rings $1 --sides $2 --frames 30 --level-triangles $3 > $R/evaluate-$1x$2-level$3-$round.md 2>&1
  echo "$1x$2 level $3 r$round: $(head -1 $R/evaluate-$1x$2-level$3-$round.md | grep -o 'CPU skinning.*')"
done; done 2>&1 | tee $R/summary.txt
cp benchmarks/results/h100-2026-11-27-skin/evaluate.sh $R/; cd $R && tar cJf $OUT/evaluate.tar.xz .
