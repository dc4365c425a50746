# The mobile tier's lag after a light change, the build before (fcbfaad, `old`) and this one
# (`new`: the gather leaves the probe volume while the cache converges, the volume restarts its
# faces after a change), alternated: atrium's sun off, on and turned 30 degrees, Sponza's
# (lighting file) off and turned; then the still-camera flicker of both builds (gi-bench
# stability's default flicker cases, mobile).
. benchmarks/results/h200-2026-12-07-material-edits/common.sh
S=.gpu/scenes/Sponza/glTF/Sponza.gltf
{
for sc in atrium $S; do for c in off turn; do for b in old new; do
  s=""; [ $c = off ] && [ $b = new ] && s="--strip-dir $R/strips"
  run $b mobile $sc $c $s
done; done; done
for b in old new; do run $b mobile atrium on; done
for b in old new; do
  bin=gi-bench; [ $b = old ] && bin=gi-bench-old
  timeout 150 $bin stability --tier mobile --size 1920x1080 --settle-frames 64 --converged-frames 8 \
    --clock-settle-s 0.5 --json $R/flicker-mobile-$b.json > $R/flicker-mobile-$b.md 2>&1
  echo "flicker mobile $b: $(grep -E '^\| mobile' $R/flicker-mobile-$b.md | head -3 | tr -s ' ' | tr '\n' ' ')"
done
} 2>&1 | tee $R/summary-sun.txt
cd $R && tar cJf $OUT/sun.tar.xz .
