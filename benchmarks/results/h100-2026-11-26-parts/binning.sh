# The brick cache flying through Sponza x4/x16 twice each: the build 25365e1 (per-run bins in
# a hash map) against 010d8c5 (per-run lists by the brick's bit in its cell), alternating.
. .gpu/setup.sh 2>/dev/null
R=/tmp/res; mkdir -p $R; S=.gpu/scenes/Sponza
xz -dc .gpu/gi-bench-old.xz > /tmp/bin/gi-bench-old; chmod +x /tmp/bin/gi-bench-old
for n in 4 16; do python3 benchmarks/scale/tile_gltf.py $S/Sponza.gltf --copies $n --step 60 --fly 15 --out $S/Sponza-x$n.gltf; done
for round in 1 2; do for n in 4 16; do for b in old new; do
  bin=gi-bench; [ $b = old ] && bin=gi-bench-old
  timeout 150 $bin cache-update --scene $S/Sponza-x$n.gltf --frames 240 --screen-inject --json $R/bin-$b-x$n-$round.json > $R/bin-$b-x$n-$round.md 2>&1
  echo "x$n $b round $round: $(grep 'worst frame' $R/bin-$b-x$n-$round.md)"; grep "cpu update steps" $R/bin-$b-x$n-$round.md
done; done; done 2>&1 | tee $R/summary.txt
cd /tmp/res && tar cJf $OUT/binning.tar.xz .
