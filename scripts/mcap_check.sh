#!/usr/bin/env bash
# Every recorded run (replays/*.sqlite) exports to an MCAP file that Foxglove can open
# (`.ci/run`): runs scripts/mcap_check.py with the `mcap` reader and `jsonschema` (pinned, from
# PyPI, in a venv) against Foxglove's published JSON schemas (the npm package
# @foxglove/schemas, pinned, its tarball's sha256 checked).
#
#   scripts/mcap_check.sh
#   PHYSICS_MCP_BIN=target/debug/physics-mcp scripts/mcap_check.sh   # skip the release build
set -euo pipefail
cd "$(dirname "$0")/.."

MCAP_VERSION=1.6.0
JSONSCHEMA_VERSION=4.26.0
SCHEMAS_VERSION=2.1.0
SCHEMAS_SHA256=c6d2746e10bbb451a680307b6e5ec3b186de3263df2a41869a7757b3042fcbf0

bin="${PHYSICS_MCP_BIN:-}"
if [[ -z "$bin" ]]; then
  cargo build --release --locked --bin physics-mcp >&2
  bin="${CARGO_TARGET_DIR:-target}/release/physics-mcp"
fi

venv="${MCAP_CHECK_VENV:-${CARGO_TARGET_DIR:-target}/mcap-check-venv}"
if ! "$venv/bin/python" -c "import importlib.metadata as m; assert m.version('mcap') == '$MCAP_VERSION' and m.version('jsonschema') == '$JSONSCHEMA_VERSION'" 2>/dev/null; then
  python3 -m venv "$venv"
  "$venv/bin/pip" install --quiet --disable-pip-version-check "mcap==$MCAP_VERSION" "jsonschema==$JSONSCHEMA_VERSION"
fi

# The schemas' tarball, kept beside the venv once its hash is right.
tgz="$venv/foxglove-schemas-$SCHEMAS_VERSION.tgz"
if ! echo "$SCHEMAS_SHA256  $tgz" | sha256sum --check --status 2>/dev/null; then
  "$venv/bin/python" - "$tgz" "$SCHEMAS_VERSION" <<'PY'
import sys, urllib.request
out, version = sys.argv[1], sys.argv[2]
url = f"https://registry.npmjs.org/@foxglove/schemas/-/schemas-{version}.tgz"
with urllib.request.urlopen(url, timeout=60) as r, open(out, "wb") as f:
    f.write(r.read())
PY
  echo "$SCHEMAS_SHA256  $tgz" | sha256sum --check --status || { echo "mcap_check: $tgz is not the pinned @foxglove/schemas $SCHEMAS_VERSION" >&2; exit 1; }
fi

scratch=$(mktemp -d "${TMPDIR:-/tmp}/physics-mcp-mcap-check.XXXXXX")
trap 'rm -rf "$scratch"' EXIT
"$venv/bin/python" scripts/mcap_check.py "$bin" "$tgz" "$scratch"
