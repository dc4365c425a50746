# A moved object's trail: `gi-bench stability --change move` at 1920x1080 for both GPU tiers.
# After 63 still warm-up frames the node slides away along x by its width plus 10%, and the
# settle figures are taken over the pixels it covered before and no longer covers (the GI
# there must go from the object's to the surface's behind it): the share of that change left
# after 4 and 8 frames, and of its resolvable part resolved within 8.
. .gpu/setup.sh 2>/dev/null
R=/tmp/res; mkdir -p $R; S=.gpu/scenes
run() { # tier scene node tag
  timeout 100 gi-bench stability --tier $1 --size 1920x1080 --no-flicker --settle-scene "$2" \
    --change move --move-node "$3" --settle-frames 96 --converged-frames 10 --clock-settle-s 1 \
    --json $R/$4-$1.json > $R/$4-$1.md 2>&1
  echo "$4 $1: $(grep -E '^\| (pc|mobile)' $R/$4-$1.md | tr -s ' ' | head -2 | tr '\n' ' ')"
}
for t in pc mobile; do
  run $t cornell-box "Tall block" cornell-box
  run $t thin-wall "Cabinet" thin-wall
  run $t atrium "Basin" atrium
  run $t $S/Sponza/Sponza.gltf "Curtain" Sponza-curtain
done 2>&1 | tee $R/trail.txt
cd $R && tar cJf $OUT/trail.tar.xz .
