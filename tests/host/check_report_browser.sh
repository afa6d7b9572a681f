#!/usr/bin/env bash
# The report page in a real browser: `rtusim report --quick` writes the page, headless Chromium loads it in a
# 1280x900 window, and the test fails when the page scrolls sideways (document scrollWidth > window width), an
# <img> did not load (complete && naturalWidth > 0) or a number in a table wraps onto a second line. A scene
# with a long file path (a copy of scenes/generated.json deep in folders) is in the tables, as a user's mesh
# path would be: the path must take the line breaks, never a number. The page itself has no script: a copy of it gets one that
# writes its verdict into the DOM on load, and Chromium's --dump-dom prints that DOM.
# Usage: check_report_browser.sh RTUSIM [CHROMIUM]  (CHROMIUM: found at configure time; else `chromium` on PATH)
set -uo pipefail
rtusim=$1
chromium=${2:-}
[ -n "$chromium" ] && [ -x "$chromium" ] || chromium=$(command -v chromium || true)
if [ -z "$chromium" ]; then
  echo "FAILED: chromium not found: install the Debian package chromium (scripts/setup.sh installs it)" >&2
  exit 1
fi
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
width=1280
height=900

long="$tmp/a-project-that-keeps-its-meshes/in-folders-named-at-length/by-department/and-by-year-2026/of-scene-files"
mkdir -p "$long"
cp "$(dirname "$0")/../../scenes/generated.json" "$long/a-generated-scene-with-a-rather-long-file-name.json"
"$rtusim" report --quick --threads 2 --scene builtin:seed --scene builtin:cornell \
  --scene "$long/a-generated-scene-with-a-rather-long-file-name.json" --out "$tmp/report" >"$tmp/report.log" 2>&1 || {
  cat "$tmp/report.log" >&2
  echo "FAILED: rtusim report --quick" >&2
  exit 1
}

# The verdict: window and document widths, the images the browser saw and those that did not load, and the
# elements that reach past the window's right edge (to name the culprit when it fails).
cat >"$tmp/verdict.js" <<'EOF'
<script>
window.addEventListener("load", () => {
  const lines = [];
  lines.push("window " + window.innerWidth);
  lines.push("scroll " + document.documentElement.scrollWidth);
  const imgs = Array.from(document.images);
  lines.push("images " + imgs.length);
  for (const i of imgs)
    if (!(i.complete && i.naturalWidth > 0)) lines.push("broken " + i.getAttribute("src"));
  // A number cell whose text lies on more than one line box was broken inside the number.
  for (const td of document.querySelectorAll("td.n")) {
    const r = document.createRange();
    r.selectNodeContents(td);
    const tops = new Set(Array.from(r.getClientRects()).map((q) => Math.round(q.top)));
    if (tops.size > 1) lines.push("wrapped " + td.textContent);
  }
  for (const e of document.body.querySelectorAll("*"))
    if (e.getBoundingClientRect().right > window.innerWidth + 0.5)
      lines.push("wide <" + e.tagName.toLowerCase() + (e.getAttribute("src") ? " src=" + e.getAttribute("src") : "") +
                 "> right edge " + Math.round(e.getBoundingClientRect().right));
  const v = document.createElement("pre");
  v.id = "verdict";
  v.textContent = "\n" + lines.join("\n") + "\n";
  document.body.appendChild(v);
});
</script>
EOF
page="$tmp/report/index.html"
check="$tmp/report/browser_check.html"
sed -e "/<\/body>/{r $tmp/verdict.js" -e "}" "$page" >"$check"
grep -q 'id = "verdict"' "$check" || { echo "FAILED: could not inject the check script (no </body>?)" >&2; exit 1; }

timeout 60 "$chromium" --headless=new --no-sandbox --disable-gpu --no-first-run --user-data-dir="$tmp/profile" \
  --window-size="$width,$height" --virtual-time-budget=5000 --dump-dom "file://$check" >"$tmp/dom.html" \
  2>"$tmp/chromium.log"
st=$?
verdict=$(sed -n '/<pre id="verdict">/,/<\/pre>/p' "$tmp/dom.html")
if [ -z "$verdict" ]; then
  cat "$tmp/chromium.log" >&2
  echo "FAILED: chromium (exit $st) printed no verdict" >&2
  exit 1
fi
echo "$verdict"
fail=0
win=$(sed -n 's/^window \([0-9]*\)$/\1/p' <<<"$verdict")
scroll=$(sed -n 's/^scroll \([0-9]*\)$/\1/p' <<<"$verdict")
seen=$(sed -n 's/^images \([0-9]*\)$/\1/p' <<<"$verdict")
if [ "$win" != "$width" ]; then
  echo "FAILED: the window is $win px wide, expected $width" >&2
  fail=1
fi
if [ -z "$scroll" ] || [ "$scroll" -gt "$win" ]; then
  echo "FAILED: the page scrolls sideways: document scrollWidth $scroll > window width $win" >&2
  fail=1
fi
# Every image the page embeds was seen by the browser (so that a page whose images all vanished cannot pass).
expected=$(grep -o '<img ' "$page" | wc -l)
if [ "$expected" -lt 5 ] || [ "$seen" != "$expected" ]; then
  echo "FAILED: the browser saw $seen images, the page has $expected (at least 5: renders and plots)" >&2
  fail=1
fi
if grep -q '^wrapped ' <<<"$verdict"; then
  echo "FAILED: numbers broken across lines in table cells: $(sed -n 's/^wrapped //p' <<<"$verdict" | tr '\n' ' ')" >&2
  fail=1
fi
if grep -q '^broken ' <<<"$verdict"; then
  echo "FAILED: images that did not load: $(sed -n 's/^broken //p' <<<"$verdict" | tr '\n' ' ')" >&2
  fail=1
fi
exit $fail
