# Issue 37: the PC tier's temporal gradients on (the default) and off (`--pc-without gradients`),
# one build: `gi-bench stability --change off|turn` at 1920x1080 on one scene (atrium: its sun;
# Sponza: its lighting file's sun), the light-off runs with their contact strips.
# Usage: bash stability.sh atrium | .gpu/scenes/Sponza/glTF/Sponza.gltf
. .gpu/setup.sh 2>/dev/null
R=/tmp/res; mkdir -p $R/strips-on $R/strips-off; sc=$1; n=$(basename $sc .gltf)
for c in off turn; do for v in on off; do
  a=""; [ $v = off ] && a="--pc-without gradients"
  s=""; [ $c = off ] && s="--strip-dir $R/strips-$v"
  timeout 110 gi-bench stability --tier pc --size 1920x1080 --no-flicker --settle-scene $sc \
    --change $c --settle-frames 96 --converged-frames 10 --clock-settle-s 1 $a $s \
    --json $R/$n-$c-$v.json > $R/$n-$c-$v.md 2>&1
  echo "$n $c gradients $v: $(grep -E '^\| pc' $R/$n-$c-$v.md | tr -s ' ' | tr '\n' ' ')"
done; done 2>&1 | tee $R/summary-$n.txt
cd $R && tar cJf $OUT/stability-$n.tar.xz .
