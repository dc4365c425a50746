# After all.sh: the build that starts the mobile tier's window on a change after stillness only
# (`new`), its still-camera flicker (the animated case on `dynamic`, whose light keeps moving,
# had risen from 1.75% to 4.87% when every changed frame restarted it) and atrium's sun off again.
. benchmarks/results/h200-2026-12-07-material-edits/common.sh
{
timeout 100 gi-bench stability --tier mobile --size 1920x1080 --settle-frames 24 --converged-frames 8 \
  --clock-settle-s 0.5 --json $R/flicker-mobile-edge.json > $R/flicker-mobile-edge.md 2>&1
echo "flicker mobile edge: $(grep -E '^\| mobile' $R/flicker-mobile-edge.md | head -3 | tr -s ' ' | tr '\n' ' ')"
SETTLE=160 run new mobile atrium off --strip-dir $R/strips
} 2>&1 | tee $R/summary-recheck.txt
cd $R && tar cJf $OUT/recheck.tar.xz .
