#!/bin/bash
# hexapod_animate end to end (registered only when it is built and xvfb-run exists): a one-episode
# hexapod run, its episode replayed to a GIF, then the GIF checked: one frame per recorded state
# (41, or fewer when Pillow merges identical frames), 800 x 600, and the robot moves between the
# first and the last frame.
# Usage: test_hexapod_animate.sh DROPS HEXAPOD_ANIMATE SOURCE_DIR
set -euo pipefail
drops=$1 animate=$2 src=$3
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
"$drops" run "$src/configs/hexapod-gp_mi.yaml" episodes=1 optimizer.max_evaluations=10 \
  optimizer.prior_optimizations=1 threads=1 --output "$dir" --name run -q
xvfb-run -a "$animate" "$dir/run" 1 --output "$dir/ep1.gif"
/usr/bin/python3 - "$dir/ep1.gif" <<'PY'
import sys
from PIL import Image, ImageChops
im = Image.open(sys.argv[1])
assert im.size == (800, 600), im.size
assert 30 <= im.n_frames <= 41, im.n_frames
im.seek(0); first = im.convert("RGB")
im.seek(im.n_frames - 1); last = im.convert("RGB")
box = ImageChops.difference(first, last).getbbox()
assert box is not None, "the first and last frames are identical"
print("ok:", im.n_frames, "frames, changed region", box)
PY
# bad input: an episode that does not exist
if "$animate" "$dir/run" 7 --output "$dir/x.gif" 2> "$dir/err"; then
  echo "expected a failure for episode 7" >&2; exit 1
fi
grep -q "cannot open" "$dir/err"
