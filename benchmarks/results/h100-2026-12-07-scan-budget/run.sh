# The fill's tail and the flight through Sponza x1 and x4 (1920x1080, screen injection on, 240
# frames at 15 m/s) at three scan budgets of binning (`voxelize_scan_per_frame`: 65536, the
# default, 32768 and 16384 triangle list entries a frame), one build, two rounds. Run from the
# repository root on the GPU machine with the kit of `.gpu/` (setup.sh, gi-bench.xz,
# scenes/Sponza/glTF); the results go to $OUT/scan-budget.tar.xz.
. .gpu/setup.sh
S=.gpu/scenes/Sponza/glTF; R=/tmp/scan; mkdir -p $R
COPIES=${COPIES:-1 4}; ROUNDS=${ROUNDS:-2}; SCANS=${SCANS:-65536 32768 16384}
for n in $COPIES; do
  python3 benchmarks/scale/tile_gltf.py $S/Sponza.gltf --copies $n --step 60 --fly 15 --out $S/Sponza-x$n.gltf >/dev/null
done
for round in $(seq 1 $ROUNDS); do for n in $COPIES; do for scan in $SCANS; do
  timeout 150 gi-bench cache-update --scene $S/Sponza-x$n.gltf --frames 240 --screen-inject \
    --voxelize-scan $scan --json $R/scan-$scan-x$n-$round.json > $R/scan-$scan-x$n-$round.md 2>&1
  echo "scan $scan x$n r$round: $(grep -E '^\| (cpu update|cache GPU total)' $R/scan-$scan-x$n-$round.md | tr '\n' ' ')"
done; done; done 2>&1 | tee $R/runs.txt
python3 benchmarks/results/h100-2026-12-07-scan-budget/summary.py $R | tee $R/summary.md
cp benchmarks/results/h100-2026-12-07-scan-budget/*.sh benchmarks/results/h100-2026-12-07-scan-budget/*.py $R/
cd $R && tar cJf $OUT/scan-budget.tar.xz .
