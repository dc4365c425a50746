# Contact strips of a light switched off (issue 37's proof): `gi-bench stability --change off
# --strip-dir` at 1920x1080 for both GPU tiers on atrium (its sun) and Sponza (its lighting
# file's sun): the GI term before the change, 1, 2, 4 and 8 frames after it, and converged
# (the mean of the last 10 of 96), each scaled to 320 pixels wide.
. .gpu/setup.sh 2>/dev/null
R=/tmp/res; mkdir -p $R/strips; S=.gpu/scenes
for t in pc mobile; do
  for sc in atrium $S/Sponza/Sponza.gltf; do
    n=$(basename $sc .gltf)
    timeout 100 gi-bench stability --tier $t --size 1920x1080 --no-flicker --settle-scene $sc \
      --change off --settle-frames 96 --converged-frames 10 --clock-settle-s 1 \
      --strip-dir $R/strips > $R/off-$n-$t.md 2>&1
    echo "$n $t: $(grep -E '^\| (pc|mobile)' $R/off-$n-$t.md | tr -s ' ' | head -1)"
  done
done 2>&1 | tee $R/strips.txt
cd $R && tar cJf $OUT/strips.tar.xz .
