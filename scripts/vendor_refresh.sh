#!/usr/bin/env bash
# The vendored third-party JavaScript, and how to check it. No npm at build time: cargo and the
# server use only the committed files; this script is the one place that talks to npm.
#
#   scripts/vendor_refresh.sh                  download (pinned versions, integrity checked),
#                                              bundle, and write the vendored files + SHA256SUMS
#   scripts/vendor_refresh.sh --check          offline: the committed files match their SHA256SUMS
#                                              (and no file is there that the sums leave out)
#   scripts/vendor_refresh.sh --rebuild-check  download and bundle again into a temporary
#                                              directory; the result must be byte-identical to
#                                              what is committed (the bundles are reproducible)
#
# What is vendored:
#   src/seeing/viewer/vendor/three.min.js   three.js, only the names in scripts/vendor/three-entry.js,
#                                            as one minified classic script defining global `THREE`
#                                            (the viewer and the MCP App inline it: no module loader,
#                                            no outside request)
#   tests/browser/vendor/ext-apps-host.js    the MCP Apps host side (AppBridge, PostMessageTransport)
#                                            and the MCP client, global `McpHost`, for tests/browser/
#                                            host.html only: never served by the server
# Beside each bundle: the licence of every package whose code is in it, and SHA256SUMS.
#
# Inputs are pinned twice: the exact versions and npm integrity (sha512 of the tarball) of the
# packages named below, checked against the registry's tarballs with `npm pack`; and every
# package (transitive ones too: esbuild's platform binary, zod, …) in scripts/vendor/
# package-lock.json, whose integrity fields `npm ci` verifies. To move a version: change it
# here and in scripts/vendor/package.json, run `npm install --package-lock-only
# --ignore-scripts` in scripts/vendor, put the new integrity here (the script prints what it
# got), run this script, read the diff, commit.
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$PWD

THREE_VERSION=0.187.0
ESBUILD_VERSION=0.25.12
EXT_APPS_VERSION=2.0.4
# The versions @modelcontextprotocol/ext-apps 2.0.4 is built and tested against (its
# devDependencies; its peerDependencies ask for ^2.0.0 and zod ^4.2.0).
MCP_CLIENT_VERSION=2.0.0
MCP_CORE_VERSION=2.0.0
ZOD_VERSION=4.6.7

# npm integrity of each pinned tarball, as the registry published it.
PINNED=(
  "three@$THREE_VERSION sha512-Qiu7R+Cmh8CstZsY1uJOSWnVlfo7ZtNLV7mF8Jltk3LB3AtDu9cRZlcnRKkAk8Y4z6KKw35z7Y7Urd7jWY8etA=="
  "esbuild@$ESBUILD_VERSION sha512-bbPBYYrtZbkt6Os6FiTLCTFxvq4tt3JKall1vRwshA3fdVztsLAatFaZobhkBC8/BrPetoa0oksYoKXoG4ryJg=="
  "@modelcontextprotocol/ext-apps@$EXT_APPS_VERSION sha512-B+PcbuGiaf0e5I3uy4iO5tS3Abo+5w8JvZFzHMzQdq9yVwP836zJkw2+KCGOQ0r4TM1fuQi4JdnbuWjkS4aBvg=="
  "@modelcontextprotocol/client@$MCP_CLIENT_VERSION sha512-8f1OghQ2rjzIOfqgUCP+8GiUWqRs89njoWLNqAe8kWmDePv3s1fZXseej+QXemssEuuOvLLmLO/kqM3IQHtISw=="
  "@modelcontextprotocol/core@$MCP_CORE_VERSION sha512-pJCEwGG7Lfr/+PQp9ZTwKXNeO5wzbfKL7H3MYpCorM4oFBoQrdjnBgEoqG+RjhsvS1FKrDbKux+M1HhlnGWqcA=="
  "zod@$ZOD_VERSION sha512-g8W2D2kU6a8untc053fX1uVBKzM7yqAxW/3zwk83+6RyF2+SKOuV+c0wBDhUwzV1PaGapmZH+rmcUzPf+3CGwg=="
)

VIEWER_VENDOR=src/seeing/viewer/vendor
TEST_VENDOR=tests/browser/vendor
# Files in the vendor directories written by hand, so neither generated nor in SHA256SUMS.
HAND_WRITTEN=README.md

die() { echo "vendor_refresh: $*" >&2; exit 1; }

# Every file a vendor directory holds is in its SHA256SUMS (but the hand-written README), and
# every sum matches. Offline: sha256sum only.
check() {
  local dir f
  for dir in "$VIEWER_VENDOR" "$TEST_VENDOR"; do
    [ -f "$dir/SHA256SUMS" ] || die "$dir/SHA256SUMS is missing"
    (cd "$dir" && sha256sum --strict --quiet -c SHA256SUMS) || die "$dir: a file does not match SHA256SUMS"
    for f in "$dir"/*; do
      f=$(basename "$f")
      [ "$f" = SHA256SUMS ] || [ "$f" = "$HAND_WRITTEN" ] || grep -q "  $f\$" "$dir/SHA256SUMS" \
        || die "$dir/$f is not in $dir/SHA256SUMS"
    done
  done
  echo "vendor_refresh: vendored files match SHA256SUMS"
}

sha512_integrity() {
  node -e 'const c=require("crypto"),fs=require("fs");console.log("sha512-"+c.createHash("sha512").update(fs.readFileSync(process.argv[1])).digest("base64"))' "$1"
}

# Downloads the pinned tarballs and checks their integrity, then installs the locked tree
# (npm ci checks every tarball against package-lock.json) into $1, with no install scripts.
fetch_inputs() {
  local work=$1 entry spec want got file
  command -v node >/dev/null && command -v npm >/dev/null || die "node and npm are needed (not for --check)"
  mkdir -p "$work/packs" "$work/build"
  for entry in "${PINNED[@]}"; do
    spec=${entry% *}
    want=${entry#* }
    file=$(cd "$work/packs" && npm pack --silent "$spec" | tail -n 1)
    got=$(sha512_integrity "$work/packs/$file")
    [ "$got" = "$want" ] || die "INTEGRITY MISMATCH for $spec: pinned $want, registry tarball $got"
    echo "vendor_refresh: $spec integrity ok"
  done
  # The lock must name the same versions and integrity as the pins above.
  node - "$ROOT/scripts/vendor/package-lock.json" "${PINNED[@]}" <<'EOF'
const [lockPath, ...pins] = process.argv.slice(2);
const lock = JSON.parse(require("fs").readFileSync(lockPath, "utf8"));
for (const pin of pins) {
  const [spec, integrity] = pin.split(" ");
  const at = spec.lastIndexOf("@");
  const name = spec.slice(0, at), version = spec.slice(at + 1);
  const entry = lock.packages["node_modules/" + name];
  if (!entry || entry.version !== version || entry.integrity !== integrity) {
    console.error(`vendor_refresh: package-lock.json disagrees with the pin ${spec}: ${JSON.stringify(entry && { version: entry.version, integrity: entry.integrity })}`);
    process.exit(1);
  }
}
EOF
  cp scripts/vendor/package.json scripts/vendor/package-lock.json scripts/vendor/*-entry.js "$work/build/"
  (cd "$work/build" && npm ci --ignore-scripts --no-audit --no-fund --loglevel=error >/dev/null) \
    || die "npm ci failed (an integrity mismatch against package-lock.json fails here)"
  local installed
  installed=$(cd "$work/build" && node_modules/.bin/esbuild --version)
  [ "$installed" = "$ESBUILD_VERSION" ] || die "esbuild is $installed, pinned $ESBUILD_VERSION"
}

# Writes SHA256SUMS over every other file of directory $1 (but the hand-written README).
write_sums() {
  (cd "$1" && find . -maxdepth 1 -type f ! -name SHA256SUMS ! -name "$HAND_WRITTEN" -printf '%f\n' \
    | LC_ALL=C sort | xargs sha256sum > SHA256SUMS)
}

# Bundles from the tree fetch_inputs installed in $1 into the vendor directories under $2.
build() {
  local work=$1 out=$2 esbuild="$1/build/node_modules/.bin/esbuild"
  local common=(--bundle --minify --format=iife --target=es2020 --platform=browser --log-level=warning)
  local dir
  for dir in "$VIEWER_VENDOR" "$TEST_VENDOR"; do
    mkdir -p "$out/$dir"
    # Generated files only: a licence no longer needed must not linger.
    find "$out/$dir" -maxdepth 1 -type f ! -name "$HAND_WRITTEN" -delete
  done

  (cd "$work/build" && "$esbuild" three-entry.js "${common[@]}" --global-name=THREE --outfile="$out/$VIEWER_VENDOR/three.min.js")
  cp "$work/build/node_modules/three/LICENSE" "$out/$VIEWER_VENDOR/three.LICENSE"
  write_sums "$out/$VIEWER_VENDOR"

  (cd "$work/build" && "$esbuild" host-entry.js "${common[@]}" --global-name=McpHost \
    --metafile="$work/host-meta.json" --outfile="$out/$TEST_VENDOR/ext-apps-host.js")
  # The licence of every package with code in the bundle, read off esbuild's metafile.
  node - "$work/host-meta.json" "$work/build/node_modules" "$out/$TEST_VENDOR" <<'EOF'
const fs = require("fs"), path = require("path");
const [meta, modules, out] = process.argv.slice(2);
const m = JSON.parse(fs.readFileSync(meta, "utf8"));
const names = new Set();
for (const o of Object.values(m.outputs))
  for (const input of Object.keys(o.inputs)) {
    const hit = input.match(/node_modules\/((?:@[^/]+\/)?[^/]+)\//);
    if (hit) names.add(hit[1]);
  }
for (const name of [...names].sort()) {
  const dir = path.join(modules, name);
  const licence = fs.readdirSync(dir).find((f) => /^(LICEN[CS]E|COPYING)(\.(md|txt))?$/i.test(f));
  if (!licence) { console.error(`vendor_refresh: no licence file in ${name}`); process.exit(1); }
  fs.copyFileSync(path.join(dir, licence), path.join(out, name.replace(/^@/, "").replace("/", "-") + ".LICENSE"));
}
EOF
  write_sums "$out/$TEST_VENDOR"
}

mode=${1:-refresh}
case "$mode" in
  --check)
    check
    ;;
  refresh | --rebuild-check)
    work=$(mktemp -d)
    trap 'rm -rf "$work"' EXIT
    fetch_inputs "$work"
    if [ "$mode" = refresh ]; then
      build "$work" "$ROOT"
      check
      ls -l "$VIEWER_VENDOR" "$TEST_VENDOR"
    else
      build "$work" "$work/out"
      for dir in "$VIEWER_VENDOR" "$TEST_VENDOR"; do
        diff -r -x "$HAND_WRITTEN" "$work/out/$dir" "$dir" >/dev/null \
          || die "rebuilding $dir does not give the committed files: $(diff -rq -x "$HAND_WRITTEN" "$work/out/$dir" "$dir" | head -5)"
      done
      echo "vendor_refresh: a fresh build is byte-identical to the committed files"
    fi
    ;;
  *)
    die "usage: $0 [--check | --rebuild-check]"
    ;;
esac
