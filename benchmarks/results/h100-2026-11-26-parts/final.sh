# The build 79bcef8: the brick cache flying through Sponza x1/x4/x16 (with the CPU update's
# steps), and the real-time tiers' GI at a still camera on x4 and x16.
. .gpu/setup.sh 2>/dev/null
R=/tmp/res; mkdir -p $R; S=.gpu/scenes/Sponza
for n in 1 4 16; do python3 benchmarks/scale/tile_gltf.py $S/Sponza.gltf --copies $n --step 60 --fly 15 --out $S/Sponza-x$n.gltf; done
for n in 1 4 16; do
  timeout 150 gi-bench cache-update --scene $S/Sponza-x$n.gltf --frames 240 --screen-inject --json $R/fly-final-x$n.json > $R/fly-final-x$n.md 2>&1
  echo "x$n: $(grep 'worst frame' $R/fly-final-x$n.md)"; grep "cpu update steps" $R/fly-final-x$n.md
done 2>&1 | tee $R/summary.txt
for n in 4 16; do for t in pc mobile; do
  timeout 120 gi-bench $t --scenes $S/Sponza-x$n.gltf --frames 32 --settle-s 1 --json $R/$t-x$n.json > $R/$t-x$n.md 2>&1
  echo "$t x$n: $(grep -E "^\| (\*\*GI|GI of the pipelined)" $R/$t-x$n.md | tr "\n" " ")"
done; done 2>&1 | tee -a $R/summary.txt
cd /tmp/res && tar cJf $OUT/final.tar.xz .
