# Issue 37: atrium's sun switched on, and its basin moved away (the trail), both GPU tiers, the
# brick cache's measured change on (gain 3, the default) and off (gain 0), one build, one call.
. .gpu/setup.sh 2>/dev/null; R=$OUT/res; mkdir -p $R
for c in on move; do for t in pc mobile; do for g in 3 0; do
  m=""; [ $c = move ] && m="--move-node Basin"
  timeout 60 gi-bench stability --tier $t --size 1920x1080 --no-flicker --settle-scene atrium \
    --change $c $m --settle-frames 64 --converged-frames 8 --clock-settle-s 0.5 \
    --cache-change-gain $g --json $R/atrium-$c-$t-$g.json > $R/atrium-$c-$t-$g.md 2>&1
  echo "atrium $c $t gain $g: $(grep -E '^\| (pc|mobile)' $R/atrium-$c-$t-$g.md | tr -s ' ' | tr '\n' ' ')"
done; done; done | tee $R/summary-on-move.txt
cd $R && tar cJf $OUT/on-move.tar.xz . && rm -f *.json *.md
