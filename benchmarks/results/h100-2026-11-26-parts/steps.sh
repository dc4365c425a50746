# The brick cache flying through Sponza x1/x4/x16 with the CPU update's steps per frame
# (the build before evictions took victims from one selection: fly-steps-eviction-x*.md).
. .gpu/setup.sh 2>/dev/null
R=/tmp/res; mkdir -p $R; S=.gpu/scenes/Sponza
for n in 1 4 16; do python3 benchmarks/scale/tile_gltf.py $S/Sponza.gltf --copies $n --step 60 --fly 15 --out $S/Sponza-x$n.gltf; done
for n in 1 4 16; do
  timeout 150 gi-bench cache-update --scene $S/Sponza-x$n.gltf --frames 240 --screen-inject --json $R/fly-steps-x$n.json > $R/fly-steps-x$n.md 2>&1
  echo "x$n: $(grep 'worst frame' $R/fly-steps-x$n.md)"; grep "cpu update steps" $R/fly-steps-x$n.md
done 2>&1 | tee $R/summary.txt
cd /tmp/res && tar cJf $OUT/steps.tar.xz .
