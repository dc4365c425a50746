# Issue 37: the brick cache's measured change on (the default, `--cache-change-gain 3`) and off
# (`--cache-change-gain 0`), one build, both GPU tiers: `gi-bench stability --change off|turn`
# at 1920x1080 on one scene (atrium: its sun; Sponza: its lighting file's sun), the light-off
# runs with their contact strips.
# Usage: bash lag.sh atrium | .gpu/scenes/Sponza/glTF/Sponza.gltf
. .gpu/setup.sh 2>/dev/null
sc=$1; n=$(basename $sc .gltf); R=/tmp/res-$n; mkdir -p $R/strips-3 $R/strips-0
for c in off turn; do for t in pc mobile; do for g in 3 0; do
  s=""; [ $c = off ] && s="--strip-dir $R/strips-$g"
  timeout 100 gi-bench stability --tier $t --size 1920x1080 --no-flicker --settle-scene $sc \
    --change $c --settle-frames 64 --converged-frames 8 --clock-settle-s 0.5 \
    --cache-change-gain $g $s --json $R/$n-$c-$t-$g.json > $R/$n-$c-$t-$g.md 2>&1
  echo "$n $c $t gain $g: $(grep -E '^\| (pc|mobile)' $R/$n-$c-$t-$g.md | tr -s ' ' | tr '\n' ' ')"
done; done; done 2>&1 | tee $R/summary-$n.txt
cd $R && tar cJf $OUT/lag-$n.tar.xz .
