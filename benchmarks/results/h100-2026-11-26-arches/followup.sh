# After the pool: the mobile tier with a black sky and 16384 bricks, SmartGI probes, and the cache's irradiance.
. .gpu/setup.sh 2>/dev/null
R=/tmp/res; mkdir -p $R; S=.gpu/scenes/Sponza/Sponza.gltf; W="--width 480 --height 270"
N="--lighting benchmarks/results/h100-2026-11-26-arches/nosky.json"
timeout 60 gi render $S $N --tier path --spp 1024 $W --out $R/path-nosky.png 2>&1 | tail -1
timeout 60 gi render $S $N --tier mobile $W --frames 32 --cache-pool-bricks 16384 --out $R/mobile-nosky.png 2>&1 | tail -1
timeout 60 gi render $S --tier mobile --screen-probes smartgi $W --frames 32 --cache-pool-bricks 16384 --out $R/mobilesg.png 2>&1 | tail -1
for v in irradiance radiance; do timeout 60 gi debug-cache $S --view $v --size 480x270 --frames 128 --pool-bricks 16384 --out $R/cache-$v.png 2>&1 | tail -1; done
timeout 60 gi debug-cache $S $N --view irradiance --size 480x270 --frames 128 --pool-bricks 16384 --out $R/cache-irradiance-nosky.png 2>&1 | tail -1
cd $R && tar cJf $OUT/a4.tar.xz .
