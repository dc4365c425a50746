# The mobile tier's light window for changes of the lights' power only (a turned light keeps
# the probe volume and the histories), one build, one short device call, 1920x1080: atrium's
# sun turned and switched off, cornell-box's panel off. Compare with
# h100-2026-12-07-window-off (the window for every switch, and none).
. .gpu/setup.sh 2>/dev/null
xz -dc .gpu/gi-bench-new.xz > /tmp/bin/gi-bench-new && chmod +x /tmp/bin/gi-bench-new
R=/tmp/res; mkdir -p $R; BUDGET=${BUDGET:-150}
settle() {
  sc=$1; c=$2; n=$(basename $sc .gltf); [ $SECONDS -lt $BUDGET ] || { echo "skipped: $n $c"; return; }
  timeout 100 gi-bench-new stability --tier mobile --size 1920x1080 --no-flicker --settle-scene $sc \
    --change $c --settle-frames ${SETTLE:-160} --converged-frames 8 --clock-settle-s 0.5 \
    --json $R/$n-$c.json > $R/$n-$c.md 2>&1
  echo "$n $c: $(grep -E '^\| mobile' $R/$n-$c.md | tr -s ' ' | tr '\n' ' ')"
}
{ settle atrium turn; settle atrium off; SETTLE=64 settle cornell-box emissive-off; } 2>&1 | tee $R/summary.txt
cp benchmarks/results/h100-2026-12-07-light-power/run.sh $R/
cd $R && tar cJf $OUT/light-power.tar.xz .
