# How fast the brick cache lets a switched-off sun go, against how many bricks it relights per
# frame while the change settles: `gi-bench stability --change off --cache-relight-bricks N`
# (1024 is the default; more relights every young brick sooner at a higher cost per frame),
# atrium and Sponza, both tiers, 1920x1080, one build. Runs start only while under $BUDGET
# seconds (default 420); tables beside it. BRICKS and SCENES choose the budgets (default
# "1024 8192") and the scenes (default "atrium Sponza").
. .gpu/setup.sh 2>/dev/null
R=/tmp/res-relight; mkdir -p $R; BUDGET=${BUDGET:-420}
S=.gpu/scenes/Sponza/glTF/Sponza.gltf
run() {
  sc=$1; tier=$2; n=$3; name=$(basename $sc .gltf)
  [ $SECONDS -lt $BUDGET ] || { echo "skipped (time): $name $tier $n"; return; }
  timeout 120 gi-bench stability --tier $tier --size 1920x1080 --no-flicker --settle-scene $sc \
    --change off --settle-frames ${SETTLE:-96} --converged-frames 8 --clock-settle-s 0.5 \
    --cache-relight-bricks $n --json $R/$name-$tier-$n.json > $R/$name-$tier-$n.md 2>&1
  echo "$name $tier relight $n: $(grep -E "^\| (mobile|pc)" $R/$name-$tier-$n.md | tr -s ' ' | tr '\n' ' ')"
}
for scene in ${SCENES:-atrium Sponza}; do
  [ $scene = Sponza ] && scene=$S
  for tier in pc mobile; do for n in ${BRICKS:-1024 8192}; do run $scene $tier $n; done; done
done 2>&1 | tee $R/summary.txt
cp benchmarks/results/h100-2026-12-07-relight/run.sh $R/
cd $R && tar cJf $OUT/relight.tar.xz .
