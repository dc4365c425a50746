# The mobile tier's over-bright far arches of Sponza against the cache's pool size.
. .gpu/setup.sh 2>/dev/null
R=/tmp/res; mkdir -p $R; S=.gpu/scenes/Sponza/Sponza.gltf; W="--width 480 --height 270"
timeout 60 gi render $S --tier path --spp 1024 $W --out $R/path.png 2>&1 | tail -1
for p in 12288 16384 24576; do
  echo "== pool $p"
  timeout 60 gi debug-cache $S --view occupancy --size 480x270 --frames 128 --pool-bricks $p --out $R/occ-$p.png 2>&1 | grep -E "per level|dropped|memory|pool of"
  timeout 60 gi render $S --tier mobile $W --frames 32 --cache-pool-bricks $p --out $R/mobile-$p.png 2>&1 | grep -v "texture is dropped" | tail -2
  timeout 60 gi render $S --tier pc --pc-trace-mode probes $W --frames 32 --cache-pool-bricks $p --out $R/pcprobes-$p.png 2>&1 | grep -v "texture is dropped" | tail -1
done
cd $R && tar cJf $OUT/arches3.tar.xz .
