# The brick cache's CPU update flying through Sponza x1, x4 and x16 at 15 m/s (1920x1080, screen
# injection on, 240 frames): the build before (old) and after (new) the change measured,
# alternating, two rounds. Run from the repository root on the GPU machine with the kit of
# `.gpu/` (setup.sh, gi-bench.xz, gi-bench-old.xz, scenes/Sponza/glTF). COPIES and ROUNDS
# choose the tilings and the rounds (default "1 4 16" and 2); the results go to $OUT/$NAME.tar.xz.
. .gpu/setup.sh
xz -dc .gpu/gi-bench-old.xz > /tmp/bin/gi-bench-old && chmod +x /tmp/bin/gi-bench-old
cp /tmp/bin/gi-bench /tmp/bin/gi-bench-new
S=.gpu/scenes/Sponza/glTF; R=/tmp/res; mkdir -p $R
COPIES=${COPIES:-1 4 16}; ROUNDS=${ROUNDS:-2}; NAME=${NAME:-cache-cpu}
for n in $COPIES; do
  python3 benchmarks/scale/tile_gltf.py $S/Sponza.gltf --copies $n --step 60 --fly 15 --out $S/Sponza-x$n.gltf >/dev/null
done
for round in $(seq 1 $ROUNDS); do for n in $COPIES; do for b in old new; do
  timeout 150 gi-bench-$b cache-update --scene $S/Sponza-x$n.gltf --frames 240 --screen-inject \
    --json $R/fly-$b-x$n-$round.json > $R/fly-$b-x$n-$round.md 2>&1
  echo "$b x$n r$round: $(grep -E '^\| (cpu update|cache GPU total)' $R/fly-$b-x$n-$round.md | tr '\n' ' ')"
done; done; done 2>&1 | tee $R/runs.txt
python3 benchmarks/results/h100-2026-12-07-cache-cpu/summary.py $R | tee $R/summary.md
cp benchmarks/results/h100-2026-12-07-cache-cpu/*.sh benchmarks/results/h100-2026-12-07-cache-cpu/*.py $R/
cd $R && tar cJf $OUT/$NAME.tar.xz .
