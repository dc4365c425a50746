# Shared by sun.sh and emitters.sh: unpacks the kit (.gpu/setup.sh: this build's gi and
# gi-bench) and the build before this work (.gpu/gi-bench-fcbfaad.xz, as gi-bench-old), and
# defines `run BUILD TIER SCENE CHANGE [ARGS...]`: one `gi-bench stability` settle case at
# 1920x1080 ($SETTLE frames after the change, 64 by default, the last 8 converged), its table kept as
# $R/<scene>-<change>-<tier>-<build>.md and .json, its summary line printed.
. .gpu/setup.sh 2>/dev/null
xz -dc .gpu/gi-bench-fcbfaad.xz > /tmp/bin/gi-bench-old && chmod +x /tmp/bin/gi-bench-old
R=/tmp/res; mkdir -p $R/strips
run() {
  b=$1; t=$2; sc=$3; c=$4; shift 4; n=$(basename $sc .gltf)
  bin=gi-bench; [ $b = old ] && bin=gi-bench-old
  timeout 120 $bin stability --tier $t --size 1920x1080 --no-flicker --settle-scene $sc \
    --change $c --settle-frames ${SETTLE:-64} --converged-frames 8 --clock-settle-s 0.5 "$@" \
    --json $R/$n-$c-$t-$b.json > $R/$n-$c-$t-$b.md 2>&1
  echo "$n $c $t $b: $(grep -E '^\| (pc|mobile)' $R/$n-$c-$t-$b.md | tr -s ' ' | tr '\n' ' ')"
}
