# Issue 37: what the PC tier's temporal gradients cost and change elsewhere, one build, on and
# off (`--pc-without gradients`): the flicker cases of `gi-bench stability` (a still camera and
# animated objects on dynamic, a camera path through atrium), each pass's GPU time
# (`gi-bench pc --variants default,gradients`), and rmse_srgb8 / FLIP at 1920x1080 against the
# 256-spp GPU reference (`gi compare --tiers pc`, one reference per scene through the cache).
. .gpu/setup.sh 2>/dev/null
R=$OUT/res; mkdir -p $R; S=.gpu/scenes
for v in on off; do
  a=""; [ $v = off ] && a="--pc-without gradients"
  timeout 100 gi-bench stability --tier pc --size 1920x1080 --frames 32 --settle-frames 12 \
    --converged-frames 2 --clock-settle-s 0 $a > $R/flicker-$v.md 2>&1
  echo "flicker gradients $v:"; grep -E '^\| pc \| (still|animated|camera)' $R/flicker-$v.md
done
SC=$S/Sponza/glTF/Sponza.gltf,$S/GasStation/glTF/GasStation.gltf,$S/ToyCar/glTF/ToyCar.gltf,cornell-box,atrium,glossy,thin-wall,open-world,dynamic
timeout 150 gi-bench pc --scenes $SC --frames 64 --settle-s 1 --variants default,gradients \
  --json $R/cost.json > $R/cost.md 2>&1
grep -E '^\| [A-Za-z-]+ \|' $R/cost.md | tr -s ' ' | head -40
for sc in $S/Sponza/glTF/Sponza.gltf $S/GasStation/glTF/GasStation.gltf $S/ToyCar/glTF/ToyCar.gltf cornell-box atrium glossy thin-wall open-world dynamic; do
  n=$(basename $sc .gltf)
  for v in on off; do
    a=""; [ $v = off ] && a="--pc-without gradients"
    timeout 60 gi compare $sc --tiers pc --width 1920 --height 1080 --reference-spp 256 \
      --reference-engine gpu --cache-dir /tmp/refs $a --json $R/q-$n-$v.json > $R/q-$n-$v.txt 2>&1
    echo "$n gradients $v: $(grep -E '^pc ' $R/q-$n-$v.txt | tr -s ' ')"
  done
done 2>&1 | tee $R/quality.txt
rm -f $R/*.exr; ls $R | wc -l
