# First frame of Sponza x4/x16 (gi render --frames 1) with the build of ddaac1c (old) and of
# ce90610 (new: Scene::evaluate and the scene's shading data built on all cores), alternating.
. .gpu/setup.sh
xz -dc .gpu/gi-old.xz > /tmp/bin/gi-old; chmod +x /tmp/bin/gi-old; cp /tmp/bin/gi /tmp/bin/gi-new
S=.gpu/scenes/Sponza
for n in 4 16; do python3 benchmarks/scale/tile_gltf.py $S/Sponza.gltf --copies $n --step 60 --fly 15 --out $S/Sponza-x$n.gltf >/dev/null; done
for r in 1 2; do for n in 4 16; do for t in pc mobile; do for b in old new; do
  echo "x$n $t $b round $r: $(timeout 100 gi-$b render $S/Sponza-x$n.gltf --tier $t --width 1920 --height 1080 --frames 1 --out /tmp/f.png 2>&1 | grep '^load')"
done; done; done; done 2>&1 | tee $OUT/first.txt
