#!/usr/bin/env bash
# Headless screenshot of a reproduction report (report.html) with Debian's chromium.
#
#   scripts/screenshot_report.sh OUT_DIR/report.html [screenshot.png] [WIDTHxHEIGHT]
#
# Installs nothing itself: get chromium with `apt-get install -y chromium` (Debian/Ubuntu).
# The page is self-contained, so chromium runs with networking features off.
set -euo pipefail

report="${1:?usage: $0 REPORT_HTML [SCREENSHOT_PNG] [WIDTHxHEIGHT]}"
shot="${2:-${report%.html}.png}"
size="${3:-1400x3000}"

browser=""
for candidate in chromium chromium-browser google-chrome; do
    if command -v "$candidate" >/dev/null 2>&1; then
        browser="$candidate"
        break
    fi
done
if [[ -z "$browser" ]]; then
    echo "chromium not found; install it with: apt-get install -y chromium" >&2
    exit 2
fi
if [[ ! -f "$report" ]]; then
    echo "no such report: $report" >&2
    exit 2
fi

abs_report="$(cd "$(dirname "$report")" && pwd)/$(basename "$report")"
abs_shot="$(cd "$(dirname "$shot")" && pwd)/$(basename "$shot")"
profile="$(mktemp -d)"
trap 'rm -rf "$profile"' EXIT

"$browser" --headless --no-sandbox --disable-gpu --disable-background-networking \
    --disable-component-update --disable-sync --no-first-run --hide-scrollbars \
    --user-data-dir="$profile" --window-size="${size/x/,}" \
    --screenshot="$abs_shot" "file://$abs_report" >/dev/null 2>&1

if [[ ! -s "$abs_shot" ]]; then
    echo "chromium wrote no screenshot" >&2
    exit 1
fi
echo "$abs_shot"
