# The PC and mobile tiers on the real scenes, the build before (gi-bench-old) against this one
# (node test four children at a time, pre-split static levels), two rounds alternating; then
# BVH rays on ToyCar, both builds.
. .gpu/setup.sh 2>/dev/null
xz -dc .gpu/gi-bench-old.xz > /tmp/bin/gi-bench-old && chmod +x /tmp/bin/gi-bench-old
R=/tmp/res; mkdir -p $R; S=.gpu/scenes
SC=$S/Sponza/glTF/Sponza.gltf,$S/GasStation/glTF/GasStation.gltf,$S/ToyCar/glTF/ToyCar.gltf
for r in 1 2; do
  for v in old new; do
    B=gi-bench; [ $v = old ] && B=gi-bench-old
    for t in pc mobile; do
      timeout 140 $B $t --scenes $SC --frames 64 --settle-s 1 --json $R/$t-$v-$r.json > $R/$t-$v-$r.md 2>&1
      echo "== $t $v round $r"; grep -E '^\| [A-Za-z-]+ \|' $R/$t-$v-$r.md | tr -s ' '
    done
  done
done 2>&1 | tee $R/tiers.txt
for r in 1 2; do
  for v in old new; do
    B=gi-bench; [ $v = old ] && B=gi-bench-old
    timeout 60 $B rays --scene $S/ToyCar/glTF/ToyCar.gltf --rays 1048576 --repeats 5 --settle-s 1 > $R/rays-ToyCar-$v-$r.md 2>&1
    echo "ToyCar $v $r: $(grep -E '^\| (primary|shadow|incoherent) ' $R/rays-ToyCar-$v-$r.md | awk -F'|' '{printf "%s %s; ", $2, $6}')"
  done
done 2>&1 | tee $R/rays-toycar.txt
cd $R && tar cJf $OUT/tiers.tar.xz .
