# The build of feefa2a alone (its steps report the lighting schedule apart from its recording),
# two rounds of the cache flying through Sponza x4 and x16.
. .gpu/setup.sh >/dev/null 2>&1
S=.gpu/scenes/Sponza; R=/tmp/res7; mkdir -p $R
for n in 4 16; do python3 benchmarks/scale/tile_gltf.py $S/Sponza.gltf --copies $n --step 60 --fly 15 --out $S/Sponza-x$n.gltf >/dev/null; done
for r in 1 2; do for n in 4 16; do
  gi-bench cache-update --scene $S/Sponza-x$n.gltf --frames 240 --screen-inject > $R/fly-new-x$n-$r.md 2>&1
done; done
