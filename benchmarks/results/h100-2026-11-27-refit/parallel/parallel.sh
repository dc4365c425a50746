# Scene::evaluate on all cores and the refit's parallel vertex writes: gi-bench deform with
# the build of ddaac1c (old) and of the commit after 6929120 (new), alternating, in one call.
. .gpu/setup.sh
xz -dc .gpu/gi-bench-old.xz > /tmp/bin/gi-bench-old; chmod +x /tmp/bin/gi-bench-old
cp /tmp/bin/gi-bench /tmp/bin/gi-bench-new
R=/tmp/res; mkdir -p $R
for round in 1 2; do for s in "256 64" "1024 128"; do for b in old new; do set -- $s
  gi-bench-$b deform --rings $1 --sides $2 --frames 30 > $R/parallel-$b-$1x$2-$round.md 2>&1
  echo "$b $1x$2 r$round: $(head -1 $R/parallel-$b-$1x$2-$round.md | grep -o 'CPU skinning.*')"
  grep -E '^\| (refit|default|rebuild) ' $R/parallel-$b-$1x$2-$round.md
done; done; done 2>&1 | tee $R/summary.txt
cp benchmarks/results/h100-2026-11-27-refit/parallel.sh $R/; cd $R && tar cJf $OUT/parallel.tar.xz .
