# First frame of Sponza x1/x4/x16 with the grid built in parts on all cores (build fdc5fde),
# two rounds, and the cache flying through x4 once more.
. .gpu/setup.sh 2>/dev/null
S=.gpu/scenes/Sponza
for n in 1 4 16; do python3 benchmarks/scale/tile_gltf.py $S/Sponza.gltf --copies $n --step 60 --fly 15 --out $S/Sponza-x$n.gltf >/dev/null; done
for r in 1 2; do for n in 1 4 16; do for t in pc mobile; do
  echo "x$n $t round $r: $(timeout 100 gi render $S/Sponza-x$n.gltf --tier $t --width 1920 --height 1080 --frames 1 --out /tmp/f.png 2>&1 | grep '^load')"
done; done; done 2>&1 | tee $OUT/first.txt
timeout 120 gi-bench cache-update --scene $S/Sponza-x4.gltf --frames 240 --screen-inject > $OUT/fly-x4.md 2>&1; grep -E "worst frame|cpu update" $OUT/fly-x4.md
