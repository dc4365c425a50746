# The new default (3 x 3 a-trous kernel, 5 iterations) against SVGF's 5 x 5 x 4 on the real
# scenes with their lighting files: cost (`gi-bench pc --variants default,atrous-5x5-4`, two
# rounds), then rmse_srgb8 and mean FLIP of `gi compare --tiers pc` at 1920x1080 against the
# 256-spp GPU reference for both, on the real scenes and four bundled ones.
. .gpu/setup.sh 2>/dev/null
R=/tmp/res; mkdir -p $R; S=.gpu/scenes
SC=$S/Sponza/Sponza.gltf,$S/ToyCar/ToyCar.gltf,$S/GasStation/GasStation.gltf
for r in 1 2; do
  timeout 200 gi-bench pc --scenes $SC --variants default,atrous-5x5-4 --frames 64 --settle-s 1 --json $R/pc-$r.json > $R/pc-$r.md 2>&1
  grep -E '^\| \*\*GI|denoise_atrous \||^[A-Za-z-]+ 1920' $R/pc-$r.md | tr -s ' '
done 2>&1 | tee $R/cost.txt
for sc in $S/Sponza/Sponza.gltf $S/ToyCar/ToyCar.gltf $S/GasStation/GasStation.gltf cornell-box atrium thin-wall glossy; do
  n=$(basename $sc .gltf)
  for v in 3x3:5 5x5:4; do k=${v%:*}; i=${v#*:}
    timeout 120 gi compare $sc --tiers pc --width 1920 --height 1080 --reference-spp 256 \
      --reference-engine gpu --cache-dir /tmp/refs --pc-atrous-kernel $k --pc-atrous-iterations $i \
      --out-dir $R/img-$n-$k-$i --json $R/q-$n-$k-$i.json > $R/q-$n-$k-$i.txt 2>&1
    echo "$n $k x$i: $(grep -E '^pc ' $R/q-$n-$k-$i.txt | tr -s ' ')"
  done
done 2>&1 | tee $R/quality.txt
rm -rf $R/img-*/*.exr
cd $R && tar cJf $OUT/real.tar.xz --exclude='img-*' . && tar cJf $OUT/img.tar.xz img-Sponza-* 2>/dev/null
