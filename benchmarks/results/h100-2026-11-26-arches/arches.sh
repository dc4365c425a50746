# Where the mobile tier's over-bright far arches of Sponza come from: the tiers with the day sky
# and with a black sky, and what the brick cache holds (gi debug-cache).
. .gpu/setup.sh 2>/dev/null
R=/tmp/res; mkdir -p $R; S=.gpu/scenes/Sponza/Sponza.gltf; W="--width 480 --height 270"
for sky in day nosky; do
  L=""; [ $sky = nosky ] && L="--lighting benchmarks/results/h100-2026-11-26-arches/nosky.json"
  timeout 60 gi render $S $L --tier path --spp 1024 $W --out $R/path-$sky.png 2>&1 | tail -1
  timeout 60 gi render $S $L --tier pc $W --frames 32 --out $R/pc-$sky.png 2>&1 | tail -1
  timeout 60 gi render $S $L --tier pc --pc-trace-mode probes $W --frames 32 --out $R/pcprobes-$sky.png 2>&1 | tail -1
  timeout 60 gi render $S $L --tier mobile $W --frames 32 --out $R/mobile-$sky.png 2>&1 | tail -1
  timeout 60 gi render $S $L --tier mobile --screen-probes smartgi $W --frames 32 --out $R/mobilesg-$sky.png 2>&1 | tail -1
done
for v in radiance irradiance occupancy; do timeout 60 gi debug-cache $S --view $v --size 480x270 --frames 64 --out $R/cache-$v.png 2>&1 | tail -2; done
cd $R && tar cJf $OUT/arches.tar.xz .
