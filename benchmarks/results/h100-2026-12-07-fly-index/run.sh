# The brick cache flown through GasStation with its lighting file (1920x1080, screen injection on,
# 240 frames along +x at 15 m/s from the scene's first camera, 60 m), this build, two rounds.
. .gpu/setup.sh
R=/tmp/fly; mkdir -p $R
python3 benchmarks/scale/tile_gltf.py .gpu/scenes/GasStation/glTF/GasStation.gltf --copies 1 --step 60 --fly 15 \
  --out .gpu/scenes/GasStation/glTF/GasStation-fly.gltf >/dev/null
for round in 1 2; do
  timeout 150 gi-bench cache-update --scene .gpu/scenes/GasStation/glTF/GasStation-fly.gltf --frames 240 \
    --screen-inject --json $R/fly-new-GasStation-$round.json > $R/fly-new-GasStation-$round.md 2>&1
  echo "r$round: $(grep -E '^\| cpu update|cpu update steps' $R/fly-new-GasStation-$round.md | tr '\n' ' ')"
done
python3 benchmarks/results/h100-2026-12-07-fly-real/summary.py $R | tee $R/summary.md
cd $R && tar czf $OUT/fly.tgz .
