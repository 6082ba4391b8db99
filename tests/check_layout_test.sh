#!/usr/bin/env bash
# scripts/check-layout can fail: on a copy of the sources (include/ src/ tasks/ apps/ scripts/) it
# passes, then fails on an include cycle between folders made on purpose (src/gp including
# drops/algo, while algo includes gp) and names the cycle's new edge, then fails on a DART include
# outside tasks/hexapod (src/core/parallel.cpp) and names the file, then on a MuJoCo include outside
# priors/ and bench/ (the same file). The sources are not touched.
# Usage: tests/check_layout_test.sh SOURCE_DIR
set -euo pipefail
src=$1
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
for d in include src tasks priors apps scripts; do
  [ -d "$src/$d" ] && cp -r "$src/$d" "$dir/"
done
fails=0
check() {  # check NAME EXPECTED_STATUS PATTERN...: runs check-layout, tests its status and output
  local name=$1 expected=$2 status=0 out
  shift 2
  out=$("$dir/scripts/check-layout" 2>&1) || status=$?
  if [ "$status" -ne "$expected" ]; then
    echo "FAIL $name: check-layout exited with $status, expected $expected; its output:"
    echo "$out"
    fails=$((fails + 1))
    return
  fi
  for pattern in "$@"; do
    if ! grep -qF -- "$pattern" <<<"$out"; then
      echo "FAIL $name: the output does not contain '$pattern'; it is:"
      echo "$out"
      fails=$((fails + 1))
      return
    fi
  done
  echo "ok $name"
}

check "the sources hold the rules" 0 "the dependency rules hold"

# A cycle: algo includes gp (black_drops.hpp -> ... -> gp/gp.hpp), and now gp includes algo.
[ -n "$(grep -rl '#include "drops/gp/' "$dir/include/drops/algo" "$dir/src/algo")" ] ||
  { echo "FAIL: algo no longer includes gp; pick another edge that closes a cycle"; exit 1; }
cp "$dir/src/gp/gp.cpp" "$dir/gp.cpp.orig"
sed -i '1i #include "drops/algo/black_drops.hpp"' "$dir/src/gp/gp.cpp"
check "an include cycle gp -> algo -> gp fails" 1 "an include cycle between folders" \
  "gp -> algo: src/gp/gp.cpp:1"
mv "$dir/gp.cpp.orig" "$dir/src/gp/gp.cpp"

# DART outside the hexapod.
cp "$dir/src/core/parallel.cpp" "$dir/parallel.cpp.orig"
sed -i '1i #include <dart/dynamics/Skeleton.hpp>' "$dir/src/core/parallel.cpp"
check "a DART include in src/core fails" 1 "DART is included outside tasks/hexapod" \
  "src/core/parallel.cpp:1:#include <dart/dynamics/Skeleton.hpp>"
mv "$dir/parallel.cpp.orig" "$dir/src/core/parallel.cpp"

# MuJoCo outside priors/ and bench/.
cp "$dir/src/core/parallel.cpp" "$dir/parallel.cpp.orig"
sed -i '1i #include <mujoco/mujoco.h>' "$dir/src/core/parallel.cpp"
check "a MuJoCo include in src/core fails" 1 "MuJoCo is included outside priors/ and bench/" \
  "src/core/parallel.cpp:1:#include <mujoco/mujoco.h>"
mv "$dir/parallel.cpp.orig" "$dir/src/core/parallel.cpp"

check "the sources restored hold the rules again" 0 "the dependency rules hold"
exit $((fails > 0))
