# The brick cache's fill frame on Sponza x1, x4 and x16 (1920x1080): the triangle index's
# build (CPU step `index` of the first update) and the whole update, with the build before the
# change measured (old) and after (new), alternating, three rounds. Run from the repository root
# on the GPU machine with the kit of `.gpu/` (setup.sh, gi-bench.xz, gi-bench-old.xz,
# scenes/Sponza/glTF); the results go to $OUT/index.tar.xz.
. .gpu/setup.sh
xz -dc .gpu/gi-bench-old.xz > /tmp/bin/gi-bench-old && chmod +x /tmp/bin/gi-bench-old
cp /tmp/bin/gi-bench /tmp/bin/gi-bench-new
S=.gpu/scenes/Sponza/glTF; R=/tmp/index; mkdir -p $R
for n in 1 4 16; do
  python3 benchmarks/scale/tile_gltf.py $S/Sponza.gltf --copies $n --step 60 --fly 15 --out $S/Sponza-x$n.gltf >/dev/null
done
for round in 1 2 3; do for n in 1 4 16; do for b in old new; do
  timeout 120 gi-bench-$b cache-update --scene $S/Sponza-x$n.gltf --frames 2 \
    --json $R/index-$b-x$n-$round.json > $R/index-$b-x$n-$round.md 2>&1
done; done; done
python3 benchmarks/results/h100-2026-12-07-index/summary.py $R | tee $R/summary.md
cp benchmarks/results/h100-2026-12-07-index/*.sh benchmarks/results/h100-2026-12-07-index/*.py $R/
cd $R && tar cJf $OUT/index.tar.xz .
