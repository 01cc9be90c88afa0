#!/usr/bin/env bash
# Opens a community_mapper result in COLMAP's GUI under Xvfb, waits until the
# window shows the model (its red camera frusta), takes a screenshot, and
# checks that the GUI did not crash. The screenshot is kept as
# $ARTIFACT_DIR/gui.png (default: build/test-artifacts/).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
BUILD_DIR=${BUILD_DIR:-$here/../build}
ARTIFACT_DIR=${ARTIFACT_DIR:-$BUILD_DIR/test-artifacts}
mkdir -p "$ARTIFACT_DIR"
work=$(mktemp -d /tmp/colmap_gui_test.XXXXXX)
xvfb_pid=""
gui_pid=""
cleanup() {
  [ -n "$gui_pid" ] && kill "$gui_pid" 2>/dev/null || true
  [ -n "$xvfb_pid" ] && kill "$xvfb_pid" 2>/dev/null || true
  rm -rf "$work"
}
trap cleanup EXIT

"$BUILD_DIR/scene_generator" --output_path "$work/scene" --num_clusters 2 \
  --num_images_per_cluster 20 --num_images_per_link 25 --close_loop 0 \
  --seed 5 >"$work/generate.log" 2>&1
"$BUILD_DIR/colmap" community_mapper --database_path "$work/scene/database.db" \
  --image_path "$work/scene/images" --output_path "$work/sparse" \
  >"$work/mapper.log" 2>&1

# Xvfb picks a free display and tells which.
exec 3<> "$work/display"
Xvfb -displayfd 3 -screen 0 1280x1024x24 -nolisten tcp >"$work/xvfb.log" 2>&1 &
xvfb_pid=$!
for _ in $(seq 50); do
  [ -s "$work/display" ] && break
  sleep 0.1
done
display=":$(head -n1 "$work/display")"
echo "Xvfb on display $display"

DISPLAY=$display "$BUILD_DIR/colmap" gui --import_path "$work/sparse/0" \
  --database_path "$work/scene/database.db" \
  --image_path "$work/scene/images" >"$work/gui.log" 2>&1 &
gui_pid=$!

# The model is drawn once the view shows the cameras, whose frames COLMAP
# draws in red (204, 25, 0): count the strongly red pixels (an empty window
# has a few dozen, in its toolbar icons; the translucent image planes over
# the white background are too pale to count).
red_pixels() {
  /usr/bin/python3 - "$1" <<'PY'
import sys
from PIL import Image
image = Image.open(sys.argv[1]).convert("RGB")
print(sum(1 for r, g, b in image.getdata() if r > 180 and g < 90 and b < 90))
PY
}
min_red_pixels=${GUI_MIN_RED_PIXELS:-200}
shot="$ARTIFACT_DIR/gui.png"
red=0
for _ in $(seq "${GUI_WAIT_SECONDS:-60}"); do
  sleep 1
  if ! kill -0 "$gui_pid" 2>/dev/null; then
    echo "FAIL: the GUI exited early:"; tail -20 "$work/gui.log"; exit 1
  fi
  DISPLAY=$display import -window root "$shot" 2>/dev/null || continue
  red=$(red_pixels "$shot") || red=0
  [ "$red" -ge "$min_red_pixels" ] && break
done
# Let it render a little longer, then take the picture that is kept.
sleep 2
DISPLAY=$display import -window root "$shot"
if ! kill -0 "$gui_pid" 2>/dev/null; then
  echo "FAIL: the GUI crashed while shown:"; tail -20 "$work/gui.log"; exit 1
fi

red=$(red_pixels "$shot") || { echo "FAIL: cannot read $shot"; exit 1; }
colors=$(identify -format "%k" "$shot")
echo "screenshot: $colors colours, $red red (camera) pixels"
if [ "$colors" -lt 50 ]; then
  echo "FAIL: the screenshot is blank"; exit 1
fi
if [ "$red" -lt "$min_red_pixels" ]; then
  echo "FAIL: the window shows no cameras ($red red pixels, expected at" \
    "least $min_red_pixels)"; exit 1
fi
echo "PASS: the GUI shows the model ($shot)"
