# Repeated node trees share one level (build fb1ebd4) against the build before
# (010d8c5): rays (settled) with sharing off/auto on Sponza x1/x4/x16 and on the real scenes,
# the tiers' first frame and GI at x4/x16, old and new.
. .gpu/setup.sh 2>/dev/null
for b in gi gi-bench; do xz -dc .gpu/$b-old.xz > /tmp/bin/$b-old; chmod +x /tmp/bin/$b-old; done
R=/tmp/res; mkdir -p $R; S=.gpu/scenes/Sponza
for n in 1 4 16; do python3 benchmarks/scale/tile_gltf.py $S/Sponza.gltf --copies $n --step 60 --fly 15 --out $S/Sponza-x$n.gltf >/dev/null; done
for f in $S/Sponza-x1.gltf $S/Sponza-x4.gltf $S/Sponza-x16.gltf .gpu/scenes/ToyCar/ToyCar.gltf .gpu/scenes/GasStation/GasStation.gltf .gpu/scenes/SheenChair/SheenChair.gltf; do for m in off auto; do
  b=$(basename $f .gltf)
  timeout 60 gi-bench rays --scene $f --mesh-sharing $m --json $R/rays-$b-$m.json > $R/rays-$b-$m.md 2>&1
  echo "$b $m: $(head -1 $R/rays-$b-$m.md | cut -c1-220)"; grep -E "^\| (primary|shadow|incoherent)" $R/rays-$b-$m.md
done; done 2>&1 | tee $R/rays.txt
for n in 4 16; do for v in old new; do b=gi; [ $v = old ] && b=gi-old; for t in pc mobile; do
  /usr/bin/time -f "wall %e s, max RSS %M KB" timeout 100 $b render $S/Sponza-x$n.gltf --tier $t --width 1920 --height 1080 --frames 1 --out /tmp/x$n-$t-$v.png 2>&1 | grep -E "^load|wall" | sed "s/^/x$n $t $v: /"
done; done; done 2>&1 | tee $R/first.txt
for r in 1 2; do for n in 4 16; do for v in old new; do b=gi-bench; [ $v = old ] && b=gi-bench-old; for t in pc mobile; do
  timeout 80 $b $t --scenes $S/Sponza-x$n.gltf --frames 32 --settle-s 1 --json $R/$t-x$n-$v-$r.json > $R/$t-x$n-$v-$r.md 2>&1
  echo "x$n $t $v round $r: $(grep -E 'GI of the pipelined|gbuffer/primary|scene MiB|BVH' $R/$t-x$n-$v-$r.md | tr '\n' ' ')"
done; done; done; done 2>&1 | tee $R/tiers.txt
cp /tmp/x16-pc-new.png /tmp/x16-pc-old.png $R/ 2>/dev/null
cd $R && tar cJf $OUT/share3.tar.xz .
