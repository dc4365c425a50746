# The PC denoiser's short-history clamp into the noisy 3 x 3 neighbourhood's box
# (`--pc-short-clamp-sigma S`; 0 is the build before it): lag after the sun is switched off or
# turned, and still-camera flicker (`gi-bench stability --tier pc`), then rmse_srgb8 and FLIP
# (`gi compare --tiers pc`, 1920x1080, 256-spp GPU references). One build, one call.
. .gpu/setup.sh 2>/dev/null
R=/tmp/res; mkdir -p $R; S=.gpu/scenes
for s in 0 2 3; do
  timeout 200 gi-bench stability --tier pc --size 1920x1080 --settle-scene atrium --change off \
    --pc-short-clamp-sigma $s --json $R/atrium-off-$s.json > $R/atrium-off-$s.md 2>&1
  echo "atrium off sigma $s: $(grep -E '^\| pc' $R/atrium-off-$s.md | tr -s ' ' | tr '\n' ' ')"
done 2>&1 | tee $R/stability.txt
for s in 0 2; do for c in off turn; do
  timeout 150 gi-bench stability --tier pc --size 1920x1080 --no-flicker --settle-scene $S/Sponza/Sponza.gltf \
    --change $c --pc-short-clamp-sigma $s --json $R/sponza-$c-$s.json > $R/sponza-$c-$s.md 2>&1
  echo "Sponza $c sigma $s: $(grep -E '^\| pc' $R/sponza-$c-$s.md | tr -s ' ' | tr '\n' ' ')"
done; done 2>&1 | tee -a $R/stability.txt
for sc in cornell-box atrium thin-wall glossy dynamic $S/Sponza/Sponza.gltf $S/GasStation/GasStation.gltf $S/ToyCar/ToyCar.gltf; do
  n=$(basename $sc .gltf)
  for s in 0 2 3; do
    timeout 120 gi compare $sc --tiers pc --width 1920 --height 1080 --reference-spp 256 \
      --reference-engine gpu --cache-dir /tmp/refs --pc-short-clamp-sigma $s --out-dir /tmp/img-$n-$s > $R/q-$n-$s.txt 2>&1
    echo "$n sigma $s: $(grep -E '^pc ' $R/q-$n-$s.txt | tr -s ' ')"
  done
done 2>&1 | tee $R/quality.txt
cd $R && tar cJf $OUT/clamp.tar.xz .
