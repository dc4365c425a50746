# The node test's bytes made floats by integer-to-float conversions (v1, the build's shaders)
# or by setting them as the mantissa of 2^23 and subtracting it (v2, GI_SHADER_DIR=.gpu/sh-v2):
# BVH rays on the real scenes and the PC tier's passes on Sponza, two rounds alternating.
. .gpu/setup.sh 2>/dev/null
R=/tmp/res; mkdir -p $R; S=.gpu/scenes
for r in 1 2; do
  for sc in $S/Sponza/glTF/Sponza.gltf $S/GasStation/glTF/GasStation.gltf $S/ToyCar/glTF/ToyCar.gltf; do
    n=$(basename $sc .gltf)
    for v in v1 v2; do
      E=""; [ $v = v2 ] && E="GI_SHADER_DIR=.gpu/sh-v2"
      env $E timeout 60 gi-bench rays --scene $sc --rays 1048576 --repeats 5 --settle-s 1 > $R/rays-$n-$v-$r.md 2>&1
      echo "$n $v $r: $(grep -E '^\| (primary|shadow|incoherent) ' $R/rays-$n-$v-$r.md | awk -F'|' '{printf "%s %s; ", $2, $6}')"
    done
  done
  for v in v1 v2; do
    E=""; [ $v = v2 ] && E="GI_SHADER_DIR=.gpu/sh-v2"
    env $E timeout 100 gi-bench pc --scenes $S/Sponza/glTF/Sponza.gltf --frames 64 --settle-s 1 > $R/pc-$v-$r.md 2>&1
    echo "pc $v $r: $(awk '/\*\*GI/{printf "GI %s; ", $(NF-1)} /gbuffer\/primary/{printf "primary %s; ", $(NF-1)} /pc\/trace \|/{printf "trace %s; ", $(NF-1)} /pc\/shadow/{printf "shadow %s; ", $(NF-1)}' $R/pc-$v-$r.md)"
  done
done 2>&1 | tee $R/bytes.txt
cd $R && tar cJf $OUT/bytes.tar.xz .
