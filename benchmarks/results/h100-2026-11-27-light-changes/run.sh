# Issue 37's light changes before any fix: `gi-bench stability --change turn|off|on` for the PC
# and mobile tiers at 1920x1080 on atrium (its sun) and Sponza (its lighting file's sun).
. .gpu/setup.sh 2>/dev/null
R=/tmp/res; mkdir -p $R; S=.gpu/scenes
for sc in atrium $S/Sponza/Sponza.gltf; do n=$(basename $sc .gltf)
  for t in pc mobile; do for c in turn off on; do
    timeout 150 gi-bench stability --tier $t --size 1920x1080 --no-flicker --settle-scene $sc \
      --change $c --json $R/$n-$t-$c.json > $R/$n-$t-$c.md 2>&1
    echo "$n $t $c: $(grep -E "^\| (pc|mobile)" $R/$n-$t-$c.md | tr -s ' ' | tr '\n' ' ')"
  done; done
done 2>&1 | tee $R/summary.txt
cd $R && tar cJf $OUT/light.tar.xz .
