#!/usr/bin/env bash
# The acceptance test of drops as a library for your own robot (docs/your-own-robot.md): install
# drops into a temporary prefix, build this example against that installed package only, and run
# Black-DROPS with GP-MI on the cart-pole. At the last of 6 episodes the cart-pole must be swung up
# (balanced within 0.15 m of upright for 1 s: the task's "solved") and GP-MI must have identified
# the pole length within 10 % (the prior says 0.35 m, the real pole is 0.5 m). A second build of the
# example with -march=native, as a user's code may be compiled, must run too: the installed package
# carries the Eigen settings the library was built with (a mismatch crashes with "double free or
# corruption"); its numbers differ from the first build's by round-off (FMA, AVX), so it runs a short
# experiment that must complete. A consumer of drops::hexapod must configure (the package finds the
# hexapod's dependencies).
# Usage: test_installed.sh BUILD_DIR SOURCE_DIR
set -euo pipefail
build_dir=$1
source_dir=$2
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
step() { echo "== $*"; }

step "install drops into $tmp/prefix"
cmake --install "$build_dir" --prefix "$tmp/prefix" >"$tmp/install.log"
step "configure and build examples/cartpole against it"
cmake -S "$source_dir/examples/cartpole" -B "$tmp/build" -DCMAKE_BUILD_TYPE=Release \
  -Ddrops_DIR="$tmp/prefix/lib/cmake/drops" -DCMAKE_FIND_PACKAGE_NO_PACKAGE_REGISTRY=ON \
  >"$tmp/configure.log" || { cat "$tmp/configure.log"; exit 1; }
cmake --build "$tmp/build" -j2 >"$tmp/build.log" 2>&1 || { cat "$tmp/build.log"; exit 1; }
# Only the installed package was used: no path into the drops sources or build tree.
if grep -q -e "$source_dir/include" -e "$source_dir/tasks" -e "$build_dir" \
    "$tmp/build/CMakeFiles/cartpole_drops.dir/flags.make" "$tmp/build/CMakeFiles/cartpole_drops.dir/link.txt"; then
  echo "the example was built against the drops sources or build tree, not the installed package"
  exit 1
fi
step "the same example built with -march=native runs"
cmake -S "$source_dir/examples/cartpole" -B "$tmp/build-native" -DCMAKE_BUILD_TYPE=Release \
  -DCMAKE_CXX_FLAGS=-march=native -Ddrops_DIR="$tmp/prefix/lib/cmake/drops" \
  -DCMAKE_FIND_PACKAGE_NO_PACKAGE_REGISTRY=ON >"$tmp/configure-native.log" \
  || { cat "$tmp/configure-native.log"; exit 1; }
cmake --build "$tmp/build-native" -j2 >"$tmp/build-native.log" 2>&1 \
  || { cat "$tmp/build-native.log"; exit 1; }
"$tmp/build-native/cartpole_drops" run "$source_dir/examples/cartpole/cartpole-gp_mi.yaml" \
  episodes=2 optimizer.max_evaluations=200 --output "$tmp/runs" --name native -q
grep -q '"status": *"complete"' "$tmp/runs/native/summary.json" \
  || { echo "the -march=native build did not complete its run"; exit 1; }
if grep -q 'drops_WITH_HEXAPOD ON' "$tmp/prefix/lib/cmake/drops/dropsConfig.cmake"; then
  step "configure a consumer of drops::hexapod"
  mkdir -p "$tmp/hexapod_consumer"
  cat >"$tmp/hexapod_consumer/CMakeLists.txt" <<'CMAKE'
cmake_minimum_required(VERSION 3.22)
project(hexapod_consumer LANGUAGES CXX)
find_package(drops 0.2 REQUIRED)
add_executable(consumer main.cpp)
target_link_libraries(consumer PRIVATE drops::hexapod)
CMAKE
  echo 'int main() { return 0; }' >"$tmp/hexapod_consumer/main.cpp"
  cmake -S "$tmp/hexapod_consumer" -B "$tmp/hexapod_consumer/build" \
    -Ddrops_DIR="$tmp/prefix/lib/cmake/drops" -DCMAKE_FIND_PACKAGE_NO_PACKAGE_REGISTRY=ON \
    >"$tmp/hexapod_configure.log" 2>&1 || { cat "$tmp/hexapod_configure.log"; exit 1; }
fi
step "run GP-MI on the cart-pole"
"$tmp/build/cartpole_drops" run "$source_dir/examples/cartpole/cartpole-gp_mi.yaml" \
  --output "$tmp/runs" --name run -q
/usr/bin/python3 - "$tmp/runs/run/summary.json" <<'PY'
import json, sys
s = json.load(open(sys.argv[1]))
last = s["episodes"][-1]
length = last["phi"][0]
print(f"episodes {len(s['episodes'])}, last return {last['real_return']:.2f}, "
      f"solved {last['solved']}, pole length identified {length:.3f} m (real 0.5 m)")
assert s["status"] == "complete", s["status"]
assert len(s["episodes"]) == 6
assert last["solved"], "the cart-pole is not balanced at the last episode"
assert abs(length - 0.5) <= 0.05, f"pole length {length} not within 10 % of 0.5"
PY
step "a report and a plot of the run work for the new task"
"$tmp/build/cartpole_drops" report "$tmp/runs" --no-figures >/dev/null
test -s "$tmp/runs/report/report.md"
echo "OK"
