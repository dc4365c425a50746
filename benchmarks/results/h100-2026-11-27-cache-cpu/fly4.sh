# The brick cache's CPU update flying through Sponza x1/x4/x16 and the first frame: the build
# before (old, a225d79) and after (new) the binning and selection changes, alternating.
. .gpu/setup.sh 2>/dev/null
for b in gi gi-bench; do xz -dc .gpu/$b-old.xz > /tmp/bin/$b-old; chmod +x /tmp/bin/$b-old; done
S=.gpu/scenes/Sponza; R=/tmp/res; mkdir -p $R
for n in 1 4 16; do python3 benchmarks/scale/tile_gltf.py $S/Sponza.gltf --copies $n --step 60 --fly 15 --out $S/Sponza-x$n.gltf >/dev/null; done
for round in 1 2; do for n in 4 16 1; do for b in old new; do
  g=gi-bench; [ $b = old ] && g=gi-bench-old
  timeout 120 $g cache-update --scene $S/Sponza-x$n.gltf --frames 240 --screen-inject --json $R/fly-$b-x$n-$round.json > $R/fly-$b-x$n-$round.md 2>&1
  echo "$b x$n r$round: $(grep -E '^\| (cpu update|cache GPU total)' $R/fly-$b-x$n-$round.md | tr '\n' ' ')"
  grep -E "cpu update steps|worst frame" $R/fly-$b-x$n-$round.md
done; done; done 2>&1 | tee $R/summary.txt
for r in 1 2; do for n in 4 16; do for b in old new; do
  g=gi; [ $b = old ] && g=gi-old
  echo "$b x$n pc round $r: $(timeout 100 $g render $S/Sponza-x$n.gltf --tier pc --width 1920 --height 1080 --frames 1 --out /tmp/f.png 2>&1 | grep '^load')"
done; done; done 2>&1 | tee $R/first.txt
cp .gpu/fly4.sh $R/; cd $R && tar cJf $OUT/fly4.tar.xz .
