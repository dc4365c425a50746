# Scale sweep with the build after the binning and voxelization changes: Sponza tiled 1, 4 and
# 16 times (262k, 1.05M, 4.19M triangles as instances of the same meshes): the cache flying
# through them, load and first frame, per-frame cost and memory, BVH rays.
. .gpu/setup.sh 2>/dev/null
R=/tmp/res; mkdir -p $R; S=.gpu/scenes/Sponza
for n in 1 4 16; do python3 benchmarks/scale/tile_gltf.py $S/Sponza.gltf --copies $n --step 60 --fly 15 --out $S/Sponza-x$n.gltf; done
for n in 1 4 16; do
  timeout 120 gi-bench cache-update --scene $S/Sponza-x$n.gltf --frames 240 --screen-inject --json $R/fly-x$n.json > $R/fly-x$n.md 2>&1
  echo "x$n $(grep 'worst frame' $R/fly-x$n.md)"
done 2>&1 | tee $R/fly.txt
for n in 1 4 16; do
  f=$S/Sponza-x$n.gltf
  echo "== x$n"; timeout 60 gi info $f 2>/dev/null | grep -E "^(triangles|bvh)"
  for t in pc mobile; do
    /usr/bin/time -f "x$n $t: wall %e s, max RSS %M KB" timeout 100 gi render $f --tier $t --width 1920 --height 1080 --frames 1 --out /tmp/x$n-$t.png 2>&1 | grep -E "^load|wall"
  done
  timeout 80 gi-bench pc --scenes $f --frames 32 --settle-s 1 --json $R/pc-x$n.json > $R/pc-x$n.md 2>&1
  timeout 80 gi-bench mobile --scenes $f --frames 32 --settle-s 1 --json $R/mobile-x$n.json > $R/mobile-x$n.md 2>&1
  timeout 40 gi-bench rays --scene $f --json $R/rays-x$n.json > $R/rays-x$n.md 2>&1
  grep -E "GI of the pipelined|GI memory|total memory" $R/pc-x$n.md $R/mobile-x$n.md | head -6
done 2>&1 | tee $R/sweep.txt
cp /tmp/x16-pc.png $R/ 2>/dev/null
cd /tmp/res && tar cJf $OUT/sweep.tar.xz .
