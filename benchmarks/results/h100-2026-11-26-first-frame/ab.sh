# Same machine, old build (main before this change set) against new: first frame of the real
# scenes (mip chains on every core, sRGB encoding by thresholds), and the suite's error of pc
# and mobile on the scenes with occlusion maps (applied by the new build only).
. .gpu/setup.sh
mkdir -p /tmp/old
for b in gi gi-bench; do xz -dc .gpu/$b-old.xz > /tmp/old/$b; chmod +x /tmp/old/$b; done
S=.gpu/scenes
for round in 1 2; do for b in old new; do
  bin=gi; [ $b = old ] && bin=/tmp/old/gi
  for f in $S/Sponza/Sponza.gltf $S/ToyCar/ToyCar.gltf; do for t in pc mobile; do
    echo "$b $(basename $f) $t: $($bin render $f --tier $t --width 1920 --height 1080 --frames 1 --out /tmp/first.png 2>&1 | grep '^load')"
  done; done
done; done | tee $OUT/first_frame_ab.txt
SC=$S/ToyCar/ToyCar.gltf,$S/SheenChair/SheenChair.gltf
for b in old new; do
  bin=gi-bench; [ $b = old ] && bin=/tmp/old/gi-bench
  $bin --scenes $SC --tiers pc,mobile --size 1920x1080 --repeats 1 --frames 16 --reference-engine gpu --out /tmp/suite-$b > $OUT/suite-$b.log 2>&1
  cp /tmp/suite-$b/results.md $OUT/results-$b.md
done
grep -v WARN $OUT/suite-new.log | tail -12
