# The brick cache's CPU update flying through Sponza x4/x16: a225d79 (old), b916e30 (mid:
# binning without tests) and 1417eea (new: schedule and lists kept between frames), alternating.
. .gpu/setup.sh 2>/dev/null
for b in old mid; do xz -dc .gpu/gi-bench-$b.xz > /tmp/bin/gi-bench-$b; chmod +x /tmp/bin/gi-bench-$b; done
cp /tmp/bin/gi-bench /tmp/bin/gi-bench-new
S=.gpu/scenes/Sponza; R=/tmp/res; mkdir -p $R
for n in 4 16; do python3 benchmarks/scale/tile_gltf.py $S/Sponza.gltf --copies $n --step 60 --fly 15 --out $S/Sponza-x$n.gltf >/dev/null; done
for round in 1 2; do for n in 4 16; do for b in old mid new; do
  timeout 120 gi-bench-$b cache-update --scene $S/Sponza-x$n.gltf --frames 240 --screen-inject > $R/fly-$b-x$n-$round.md 2>&1
  echo "$b x$n r$round: $(grep -E '^\| (cpu update|cache GPU total)' $R/fly-$b-x$n-$round.md | tr '\n' ' ')"
  grep -E "cpu update steps|worst frame|^bricks" $R/fly-$b-x$n-$round.md
done; done; done 2>&1 | tee $R/summary.txt
cp .gpu/fly5.sh $R/; cd $R && tar cJf $OUT/fly5.tar.xz .
