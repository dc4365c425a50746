# The mobile tier's light window, 6c1628d (old: every change after stillness opens it for 32
# updates, history capped from its first update) against this build (new: a light that keeps
# moving leaves it after its first update; the cap starts at the update after a switch), one
# device call, interleaved, 1920x1080. Each run starts only while under $BUDGET seconds (default
# 480); the results are packed whatever ran.
. .gpu/setup.sh 2>/dev/null
xz -dc .gpu/gi-bench-6c1628d.xz > /tmp/bin/gi-bench-old && chmod +x /tmp/bin/gi-bench-old
cp /tmp/bin/gi-bench /tmp/bin/gi-bench-new
R=/tmp/res; mkdir -p $R; BUDGET=${BUDGET:-480}
ok() { [ $SECONDS -lt $BUDGET ] || { echo "skipped (time): $*"; return 1; }; }
flicker() {
  ok flicker $1 || return
  timeout 100 gi-bench-$1 stability --tier mobile --size 1920x1080 --settle-frames 24 \
    --converged-frames 8 --clock-settle-s 0.5 --json $R/flicker-$1-$2.json > $R/flicker-$1-$2.md 2>&1
  echo "flicker $1 round $2: $(grep -E '^\| mobile' $R/flicker-$1-$2.md | head -4 | tr -s ' ' | tr '\n' ' ')"
}
settle() {
  b=$1; sc=$2; c=$3; n=$(basename $sc .gltf); ok $b $n $c || return
  timeout 120 gi-bench-$b stability --tier mobile --size 1920x1080 --no-flicker --settle-scene $sc \
    --change $c --settle-frames ${SETTLE:-64} --converged-frames 8 --clock-settle-s 0.5 \
    --json $R/$n-$c-$b.json > $R/$n-$c-$b.md 2>&1
  echo "$n $c $b: $(grep -E '^\| mobile' $R/$n-$c-$b.md | tr -s ' ' | tr '\n' ' ')"
}
{
for r in 1 2; do for b in old new; do flicker $b $r; done; done
for b in old new; do settle $b cornell-box emissive-off; done
for b in old new; do SETTLE=160 settle $b atrium off; done
for b in old new; do SETTLE=160 settle $b atrium turn; done
} 2>&1 | tee $R/summary.txt
cp benchmarks/results/h100-2026-12-07-light-window/run.sh $R/
cd $R && tar cJf $OUT/light-window.tar.xz .
