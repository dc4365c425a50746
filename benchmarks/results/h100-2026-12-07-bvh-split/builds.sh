# The static levels' build: this build's `traversal_build` (obvhs medium_build, pre-split,
# leaves of up to 3 triangles) against obvhs slow_build (gi-bench-slow: PLOC's wider search,
# 4x the reinsertion, 128-bit Morton codes, pre-split) and against leaves of up to 2 triangles
# (gi-bench-leaf2). BVH rays on the real scenes, two rounds alternating.
. .gpu/setup.sh 2>/dev/null
for b in gi-bench-slow gi-bench-leaf2; do xz -dc .gpu/$b.xz > /tmp/bin/$b && chmod +x /tmp/bin/$b; done
R=/tmp/res; mkdir -p $R; S=.gpu/scenes
for r in 1 2; do
  for sc in $S/Sponza/glTF/Sponza.gltf $S/GasStation/glTF/GasStation.gltf $S/ToyCar/glTF/ToyCar.gltf; do
    n=$(basename $sc .gltf)
    for v in medium slow leaf2; do
      B=gi-bench; [ $v = slow ] && B=gi-bench-slow; [ $v = leaf2 ] && B=gi-bench-leaf2
      timeout 60 $B rays --scene $sc --rays 1048576 --repeats 5 --settle-s 1 > $R/rays-$n-$v-$r.md 2>&1
      echo "$n $v $r: $(grep -E '^\| (primary|shadow|incoherent) ' $R/rays-$n-$v-$r.md | awk -F'|' '{printf "%s %s; ", $2, $6}') $(grep -o 'bottom levels [0-9]* nodes, depth [0-9]*, build [0-9.]* ms' $R/rays-$n-$v-$r.md)"
    done
  done
done 2>&1 | tee $R/builds.txt
cd $R && tar cJf $OUT/builds.tar.xz .
