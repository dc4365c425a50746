# Scale sweep: Sponza tiled 1, 4 and 16 times (262k, 1.05M, 4.19M triangles as instances of the
# same meshes), load, first frame, memory, per-frame cost, BVH rays, and the cache while flying.
. .gpu/setup.sh 2>/dev/null
S=.gpu/scenes/Sponza
for n in 1 4 16; do
  python3 benchmarks/scale/tile_gltf.py $S/Sponza.gltf --copies $n --step 60 --fly 15 --out $S/Sponza-x$n.gltf
done
for n in 1 4 16; do
  f=$S/Sponza-x$n.gltf
  echo "== x$n"; timeout 120 gi info $f 2>/dev/null | grep -E "^(triangles|bvh)"
  for t in pc mobile; do
    /usr/bin/time -f "x$n $t: wall %e s, max RSS %M KB" timeout 120 gi render $f --tier $t --width 1920 --height 1080 --frames 1 --out /tmp/x$n-$t.png 2>&1 | grep -E "^load|wall"
  done
  timeout 100 gi-bench pc --scenes $f --frames 32 --settle-s 1 --json $OUT/pc-x$n.json 2>&1 | grep -v WARN | tail -40 > $OUT/pc-x$n.md
  timeout 100 gi-bench mobile --scenes $f --frames 32 --settle-s 1 --json $OUT/mobile-x$n.json 2>&1 | grep -v WARN | tail -40 > $OUT/mobile-x$n.md
  timeout 60 gi-bench rays --scene $f --json $OUT/rays-x$n.json 2>&1 | grep -v WARN | tail -12 > $OUT/rays-x$n.md
  grep -E "^\| (GI|gi|memory|GI memory)" $OUT/pc-x$n.md $OUT/mobile-x$n.md | head; tail -5 $OUT/rays-x$n.md
done 2>&1 | tee $OUT/sweep.txt
for n in 1 4 16; do
  timeout 120 gi-bench cache-update --scene $S/Sponza-x$n.gltf --frames 240 --screen-inject --json $OUT/fly-x$n.json 2>&1 | grep -v WARN | tail -30 > $OUT/fly-x$n.md
  head -20 $OUT/fly-x$n.md
done 2>&1 | tee $OUT/fly.txt
cp /tmp/x16-pc.png /tmp/x16-mobile.png $OUT/ 2>/dev/null; true
