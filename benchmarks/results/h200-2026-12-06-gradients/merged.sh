# The kept rays drawn again inside `pc/trace`'s dispatch (build after `38f9cbb`): each pass's
# GPU time with gradients on and off (`gi-bench pc --variants default,gradients`) on the three
# real scenes and two bundled ones, and Sponza's sun switched off with gradients, one call.
. .gpu/setup.sh 2>/dev/null
R=$OUT/merged; mkdir -p $R; S=.gpu/scenes
SC=$S/Sponza/glTF/Sponza.gltf,$S/GasStation/glTF/GasStation.gltf,$S/ToyCar/glTF/ToyCar.gltf,cornell-box,atrium
timeout 120 gi-bench pc --scenes $SC --frames 64 --settle-s 1 --variants default,gradients \
  --json $R/cost.json > $R/cost.md 2>&1
grep -E '^\| (pc/gradient|pc/trace|GI of the pipelined)' $R/cost.md
timeout 100 gi-bench stability --tier pc --size 1920x1080 --no-flicker --settle-scene \
  $S/Sponza/glTF/Sponza.gltf --change off --settle-frames 96 --converged-frames 10 \
  --clock-settle-s 1 --json $R/Sponza-off-on.json > $R/Sponza-off-on.md 2>&1
grep -E '^\| pc' $R/Sponza-off-on.md
