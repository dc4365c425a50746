# Issue 37: what the measured change costs elsewhere, one build, gain 3 (the default) and 0:
# the flicker cases of `gi-bench stability` for both tiers (a still camera and animated
# objects on dynamic, a camera path through atrium), each pass's GPU time (`gi-bench pc
# --variants default,gradients` and `gi-bench mobile`) on three real and two bundled scenes.
. .gpu/setup.sh 2>/dev/null
R=$OUT/res; mkdir -p $R; S=.gpu/scenes
for t in pc mobile; do for g in 3 0; do
  timeout 75 gi-bench stability --tier $t --size 1920x1080 --frames 32 --settle-frames 12 \
    --converged-frames 2 --clock-settle-s 0 --cache-change-gain $g > $R/flicker-$t-$g.md 2>&1
  echo "flicker $t gain $g:"; grep -E '^\| (pc|mobile hsgi) \| (still|animated|camera)' $R/flicker-$t-$g.md
done; done
SC=$S/Sponza/glTF/Sponza.gltf,$S/GasStation/glTF/GasStation.gltf,$S/ToyCar/glTF/ToyCar.gltf,cornell-box,atrium
timeout 120 gi-bench pc --scenes $SC --frames 64 --settle-s 1 --variants default,gradients \
  --json $R/cost-pc.json > $R/cost-pc.md 2>&1
grep -E '^\| (pc/gradient|pc/trace|cache/change_age|GI of the pipelined)' $R/cost-pc.md
timeout 90 gi-bench mobile --scenes $SC --frames 64 --settle-s 1 --json $R/cost-mobile.json \
  > $R/cost-mobile.md 2>&1
grep -E '^\| (cache/change_age|mobile/gather|GI)' $R/cost-mobile.md
