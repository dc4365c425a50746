# BVH rays on the real scenes: the build before (gi-bench-old: primary rays row by row, no
# pre-split, the old node test), and this one's three changes apart: `base` (8 x 8 tiles and
# pre-split, the old shaders through GI_SHADER_DIR), `nosplit` (tiles and the new node test,
# no pre-split), `new` (all three). Two rounds alternating.
. .gpu/setup.sh 2>/dev/null
for b in gi-bench-old gi-bench-nosplit; do xz -dc .gpu/$b.xz > /tmp/bin/$b && chmod +x /tmp/bin/$b; done
R=/tmp/res; mkdir -p $R; S=.gpu/scenes
for r in 1 2; do
  for sc in $S/Sponza/glTF/Sponza.gltf $S/GasStation/glTF/GasStation.gltf open-world; do
    n=$(basename $sc .gltf)
    for v in old base nosplit new; do
      B=gi-bench; E=""
      [ $v = old ] && B=gi-bench-old
      [ $v = nosplit ] && B=gi-bench-nosplit
      [ $v = base ] && E="GI_SHADER_DIR=.gpu/sh-base"
      env $E timeout 60 $B rays --scene $sc --rays 1048576 --repeats 5 --settle-s 1 > $R/rays-$n-$v-$r.md 2>&1
      echo "$n $v $r: $(grep -E '^\| (primary|shadow|incoherent) ' $R/rays-$n-$v-$r.md | awk -F'|' '{printf "%s %s; ", $2, $6}') $(grep -o 'bottom levels [0-9]* nodes, depth [0-9]*, build [0-9.]* ms' $R/rays-$n-$v-$r.md)"
    done
  done
done 2>&1 | tee $R/rays.txt
cd $R && tar cJf $OUT/rays.tar.xz .
