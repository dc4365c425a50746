# The PC denoiser's a-trous kernel: SVGF's 5 x 5 B3 taps (4 iterations, the default before)
# against 3 x 3 linear taps (4 and 5 iterations) and 5 x 5 with 3 iterations. Cost: `gi-bench
# pc --variants`, two rounds; quality: `gi compare --tiers pc` at 1920x1080 against the 256-spp
# GPU reference, the same build, one call.
. .gpu/setup.sh 2>/dev/null
R=/tmp/res; mkdir -p $R; S=.gpu/scenes
SC=$S/Sponza/Sponza.gltf,$S/GasStation/GasStation.gltf,cornell-box,atrium,glossy,thin-wall,open-world,dynamic
V=default,atrous-3x3-4,atrous-3x3-5,atrous-5x5-3
for r in 1 2; do
  timeout 280 gi-bench pc --scenes $SC --variants $V --frames 64 --settle-s 1 --json $R/pc-$r.json > $R/pc-$r.md 2>&1
  grep -E '^\| \*\*GI|denoise_atrous \||^[A-Za-z-]+ 1920' $R/pc-$r.md | tr -s ' '
done 2>&1 | tee $R/cost.txt
for sc in $S/Sponza/Sponza.gltf $S/GasStation/GasStation.gltf cornell-box atrium glossy thin-wall open-world dynamic; do
  n=$(basename $sc .gltf)
  for v in 5x5:4 3x3:4 3x3:5 5x5:3; do k=${v%:*}; i=${v#*:}
    timeout 120 gi compare $sc --tiers pc --width 1920 --height 1080 --reference-spp 256 \
      --reference-engine gpu --cache-dir /tmp/refs --pc-atrous-kernel $k --pc-atrous-iterations $i \
      --json $R/q-$n-$k-$i.json > $R/q-$n-$k-$i.txt 2>&1
    echo "$n $k x$i: $(grep -E '^\| *pc|^pc ' $R/q-$n-$k-$i.txt | tr -s ' ')"
  done
done 2>&1 | tee $R/quality.txt
cd $R && tar cJf $OUT/atrous.tar.xz .
