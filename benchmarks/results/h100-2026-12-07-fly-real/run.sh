# The brick cache flown through GasStation and ToyCar with their lighting files (1920x1080,
# screen injection on, 240 frames along +x at 15 m/s from the scene's first camera, 60 m):
# the build before the day's cache work (old) and after (new), alternating, two rounds. Run
# from the repository root on the GPU machine with the kit of `.gpu/` (setup.sh, gi-bench.xz,
# gi-bench-old.xz, scenes/<Scene>/glTF with the scene's lighting file); the results go to
# $OUT/fly-real.tar.xz.
. .gpu/setup.sh
xz -dc .gpu/gi-bench-old.xz > /tmp/bin/gi-bench-old && chmod +x /tmp/bin/gi-bench-old
cp /tmp/bin/gi-bench /tmp/bin/gi-bench-new
R=/tmp/fly-real; mkdir -p $R
SCENES=${SCENES:-GasStation ToyCar}
for s in $SCENES; do
  python3 benchmarks/scale/tile_gltf.py .gpu/scenes/$s/glTF/$s.gltf --copies 1 --step 60 --fly 15 \
    --out .gpu/scenes/$s/glTF/$s-fly.gltf >/dev/null
done
for round in 1 2; do for s in $SCENES; do for b in old new; do
  timeout 150 gi-bench-$b cache-update --scene .gpu/scenes/$s/glTF/$s-fly.gltf --frames 240 \
    --screen-inject --json $R/fly-$b-$s-$round.json > $R/fly-$b-$s-$round.md 2>&1
done; done; done
python3 benchmarks/results/h100-2026-12-07-fly-real/summary.py $R | tee $R/summary.md
cp benchmarks/results/h100-2026-12-07-fly-real/*.sh benchmarks/results/h100-2026-12-07-fly-real/*.py $R/
cd $R && tar cJf $OUT/fly-real.tar.xz .
