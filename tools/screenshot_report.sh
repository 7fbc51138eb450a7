#!/usr/bin/env bash
# Renders a diagnosis report.html with headless Chromium and saves a screenshot, to check
# the page as a reader sees it (docs/diagnose.md, "Outputs").
#
#   tools/screenshot_report.sh [REPORT.html] [OUT.png] [HEIGHT]
#
# Without REPORT.html, builds ivdyn and diagnoses the hidden-effect log
# fixtures/diagnose/viscous_payload.mcap (MuJoCo UR5: viscous friction + a payload) into
# out/diagnose_report_demo/ and screenshots its report into
# docs/figures/diagnose_report_screenshot.png. Needs `chromium` (Debian: apt-get install
# chromium) and, to shrink it to a 256-colour PNG, Pillow (in .venv via matplotlib, or
# python3; optional: without it the screenshot is kept as Chromium wrote it).
set -euo pipefail
cd "$(dirname "$0")/.."

report="${1:-}"
out="${2:-docs/figures/diagnose_report_screenshot.png}"
height="${3:-3000}"
if [[ -z "$report" ]]; then
    cargo build --release -q -p ivdyn --bin ivdyn
    ./target/release/ivdyn diagnose --urdf fixtures/ur5.urdf --base base_link --tip tool0 \
        --log fixtures/diagnose/viscous_payload.mcap --out out/diagnose_report_demo --quiet
    report=out/diagnose_report_demo/report.html
fi
[[ -f "$report" ]] || { echo "no such report: $report" >&2; exit 1; }
command -v chromium >/dev/null || { echo "chromium not found (Debian: apt-get install -y chromium)" >&2; exit 1; }

profile="$(mktemp -d)"
trap 'rm -rf "$profile"' EXIT
raw="$profile/raw.png"
# No network and no first-run work: the page is self-contained, nothing is fetched.
chromium --headless --no-sandbox --disable-gpu --disable-quic --no-first-run \
    --disable-background-networking --disable-component-update --disable-sync \
    --hide-scrollbars --user-data-dir="$profile" --window-size="1400,$height" \
    --screenshot="$raw" "file://$(realpath "$report")" 2>/dev/null
mkdir -p "$(dirname "$out")"
# Quantise to 256 colours (the page is flat colours and antialiased text) to keep the
# committed figure small; fall back to the raw screenshot.
py=python3
[[ -x .venv/bin/python ]] && py=.venv/bin/python
if ! "$py" - "$raw" "$out" <<'PY' 2>/dev/null; then
import sys
from PIL import Image
Image.open(sys.argv[1]).convert("RGB").quantize(colors=256, method=Image.Quantize.MEDIANCUT).save(sys.argv[2], optimize=True)
PY
    cp "$raw" "$out"
fi
echo "screenshot: $out ($(stat -c %s "$out") bytes)"
