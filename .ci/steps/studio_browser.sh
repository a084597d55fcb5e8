#!/usr/bin/env bash
# CI: ss_studio in a real browser (tests/studio/browser_test.mjs). Installs Debian's chromium
# (and nodejs/npm when missing) and cpp-httplib, playwright-core (pinned) from npm into the build
# folder, builds only ss_studio, ss_calibrate and ss_gesture_data in the existing build folder,
# makes a 640x480 MJPG video of a small generated dataset (tests/studio/video_frames.py, OpenCV
# in Python), and drives the page headless on it: frames advance, overlay drawn, recording from
# the video, boxes drawn with the mouse, calibration equal to ss_calibrate's on the same frames
# and boxes, a phone-sized screen, path traversal refused, the token enforced. Prints the frames
# shown per second and the frame-to-screen latency (not asserted).
set -euo pipefail
cd "$(dirname "$0")/../.."
export DEBIAN_FRONTEND=noninteractive
PLAYWRIGHT_CORE=1.57.0 # node >= 18 (Debian 12's nodejs)

need=()
for p in chromium libcpp-httplib-dev; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || need+=("$p")
done
command -v node > /dev/null || need+=(nodejs)
command -v npm > /dev/null || need+=(npm)
if ((${#need[@]})); then
  sudo_cmd=(); [[ $(id -u) -ne 0 ]] && sudo_cmd=(sudo)
  "${sudo_cmd[@]}" apt-get update -qq
  "${sudo_cmd[@]}" apt-get install -y -qq --no-install-recommends "${need[@]}"
fi

build=build
[[ -f $build/CMakeCache.txt ]] || cmake -S . -B "$build" -DSHADOWSENSE_WERROR=ON
cmake -S . -B "$build" > /dev/null # finds cpp-httplib if it was installed just now
cmake --build "$build" -j2 --target ss_studio ss_calibrate ss_gesture_data

work=$build/studio_browser
npm_dir=$work/npm
if [[ ! -f $npm_dir/node_modules/playwright-core/package.json ]] ||
   ! grep -q "\"version\": \"$PLAYWRIGHT_CORE\"" "$npm_dir/node_modules/playwright-core/package.json"; then
  mkdir -p "$npm_dir"
  npm install --prefix "$npm_dir" --no-save --no-audit --no-fund --silent \
    "playwright-core@$PLAYWRIGHT_CORE"
fi

"$build/examples/ss_gesture_data" --out "$work/data" --users 1 --frames 6 --lightings daylight \
  --overwrite > /dev/null
/usr/bin/python3 tests/studio/video_frames.py write "$work/data" "$work/skin.avi" > /dev/null
timeout 600 node tests/studio/browser_test.mjs --playwright "$npm_dir" --chromium /usr/bin/chromium \
  --studio "$build/examples/ss_studio" --calibrate "$build/examples/ss_calibrate" \
  --data "$work/data" --video "$work/skin.avi" --python /usr/bin/python3 --work "$work/run"
