# The mobile tier with its light window (the default) and without
# (`--mobile-without-light-window`), one build, one device call, interleaved, 1920x1080: does
# the window's read of the cache's surfels explain the lag after a sun's turn? Each run starts
# only while under $BUDGET seconds (default 400); the results are packed whatever ran.
. .gpu/setup.sh 2>/dev/null
xz -dc .gpu/gi-bench-new.xz > /tmp/bin/gi-bench-new && chmod +x /tmp/bin/gi-bench-new
R=/tmp/res; mkdir -p $R/strips-on $R/strips-off; BUDGET=${BUDGET:-400}
ok() { [ $SECONDS -lt $BUDGET ] || { echo "skipped (time): $*"; return 1; }; }
settle() {
  w=$1; sc=$2; c=$3; n=$(basename $sc .gltf); ok $w $n $c || return
  a=""; [ $w = off ] && a="--mobile-without-light-window"
  timeout 150 gi-bench-new stability --tier mobile --size 1920x1080 --no-flicker --settle-scene $sc \
    --change $c --settle-frames ${SETTLE:-160} --converged-frames 8 --clock-settle-s 0.5 $a \
    --strip-dir $R/strips-$w --json $R/$n-$c-$w.json > $R/$n-$c-$w.md 2>&1
  echo "$n $c window $w: $(grep -E '^\| mobile' $R/$n-$c-$w.md | tr -s ' ' | tr '\n' ' ')"
}
S=.gpu/scenes/Sponza/glTF/Sponza.gltf
{
for w in on off; do settle $w atrium turn; done
for w in on off; do settle $w atrium off; done
for w in on off; do settle $w $S turn; done
for w in on off; do SETTLE=64 settle $w cornell-box emissive-off; done
for w in on off; do settle $w $S off; done
} 2>&1 | tee $R/summary.txt
cp benchmarks/results/h100-2026-12-07-window-off/run.sh $R/
cd $R && tar cJf $OUT/window-off.tar.xz .
