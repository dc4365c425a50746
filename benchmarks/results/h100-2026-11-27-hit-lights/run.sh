# The PC tier's diffuse hits lit by the sun and the other punctual lights from the brick cache
# (`--pc-hit-lights cache`, no shadow ray at the hit) against a shadow ray per light (the
# default): cost (`gi-bench pc --variants default,hit-lights-cache`, two rounds), then
# rmse_srgb8 and FLIP of `gi compare --tiers pc` at 1920x1080 against the 256-spp GPU reference.
. .gpu/setup.sh 2>/dev/null
R=/tmp/res; mkdir -p $R; S=.gpu/scenes
SC=$S/Sponza/Sponza.gltf,$S/ToyCar/ToyCar.gltf,$S/GasStation/GasStation.gltf,atrium,open-world,glossy,dynamic
for r in 1 2; do
  timeout 200 gi-bench pc --scenes $SC --variants default,hit-lights-cache --frames 64 --settle-s 1 > $R/pc-$r.md 2>&1
  grep -E '^\| \*\*GI|pc/trace \||^[A-Za-z-]+ 1920' $R/pc-$r.md | tr -s ' '
done 2>&1 | tee $R/cost.txt
for sc in $S/Sponza/Sponza.gltf $S/ToyCar/ToyCar.gltf $S/GasStation/GasStation.gltf atrium open-world glossy dynamic; do
  n=$(basename $sc .gltf)
  for v in rays cache; do
    timeout 120 gi compare $sc --tiers pc --width 1920 --height 1080 --reference-spp 256 \
      --reference-engine gpu --cache-dir /tmp/refs --pc-hit-lights $v --out-dir /tmp/img-$n-$v > $R/q-$n-$v.txt 2>&1
    echo "$n $v: $(grep -E '^pc ' $R/q-$n-$v.txt | tr -s ' ')"
  done
done 2>&1 | tee $R/quality.txt
cd $R && tar cJf $OUT/hit.tar.xz .
