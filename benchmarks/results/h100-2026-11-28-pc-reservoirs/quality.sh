# rmse_srgb8 and mean FLIP of the PC tier against the 256-spp GPU reference at 1920x1080, the
# build before (gi-old) and this one (gi), one reference per scene shared through the cache.
. .gpu/setup.sh 2>/dev/null
xz -dc .gpu/gi-old.xz > /tmp/bin/gi-old && chmod +x /tmp/bin/gi-old
R=/tmp/res; mkdir -p $R; S=.gpu/scenes
for sc in $S/Sponza/Sponza.gltf $S/GasStation/GasStation.gltf $S/ToyCar/ToyCar.gltf cornell-box atrium glossy thin-wall open-world dynamic; do
  n=$(basename $sc .gltf)
  for v in old new; do
    G=gi; [ $v = old ] && G=gi-old
    timeout 100 $G compare $sc --tiers pc --width 1920 --height 1080 --reference-spp 256 \
      --reference-engine gpu --cache-dir /tmp/refs --json $R/q-$n-$v.json > $R/q-$n-$v.txt 2>&1
    echo "$n $v: $(grep -E '^pc ' $R/q-$n-$v.txt | tr -s ' ')"
  done
done 2>&1 | tee $R/quality.txt
cd $R && tar cJf $OUT/quality.tar.xz .
