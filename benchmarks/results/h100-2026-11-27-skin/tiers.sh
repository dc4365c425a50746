# The tiers' frames on the animated bundled scene `dynamic` (and `atrium`, still, as a
# control) with the build of dfdf8df (old: every animated frame evaluated afresh, the moving
# triangles' shading uploaded) and of d0d5e39 (new: frames moved in place), alternating, two
# rounds: GI and frame wall-clock per frame.
. .gpu/setup.sh
xz -dc .gpu/gi-bench-old.xz > /tmp/bin/gi-bench-old; chmod +x /tmp/bin/gi-bench-old
cp /tmp/bin/gi-bench /tmp/bin/gi-bench-new
R=/tmp/res; mkdir -p $R; nvidia-smi -L > $R/gpu.txt
for r in 1 2; do for v in old new; do for t in mobile pc; do
  timeout 150 gi-bench-$v $t --scenes dynamic,atrium --frames 64 --settle-s 1 > $R/tiers-$t-$v-$r.md 2>&1
  echo "$t $v round $r: $(grep -E 'GI \(cache|wall-clock' $R/tiers-$t-$v-$r.md | tr -s ' ' | tr '\n' ' ')"
done; done; done 2>&1 | tee $R/tiers-summary.txt
cp benchmarks/results/h100-2026-11-27-skin/tiers.sh $R/; cd $R && tar cJf $OUT/tiers.tar.xz .
