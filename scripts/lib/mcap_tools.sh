# What scripts/mcap_check.sh reads MCAP files with: the `mcap` reader and `jsonschema` (pinned,
# from PyPI, in a venv kept in target/) and Foxglove's published JSON schemas (the npm package
# @foxglove/schemas, pinned, its tarball's sha256 checked, kept beside the venv). Installed once;
# scripts/ci_prepare.sh fetches them ahead. Sourced after `cd` to the repository. Sets
# `mcap_venv` and `mcap_schemas_tgz`.
MCAP_VERSION=1.6.0
MCAP_JSONSCHEMA_VERSION=4.26.0
SCHEMAS_VERSION=2.1.0
SCHEMAS_SHA256=c6d2746e10bbb451a680307b6e5ec3b186de3263df2a41869a7757b3042fcbf0

mcap_venv="${MCAP_CHECK_VENV:-${CARGO_TARGET_DIR:-target}/mcap-check-venv}"
if ! "$mcap_venv/bin/python" -c "import importlib.metadata as m; assert m.version('mcap') == '$MCAP_VERSION' and m.version('jsonschema') == '$MCAP_JSONSCHEMA_VERSION'" 2>/dev/null; then
  python3 -m venv "$mcap_venv"
  "$mcap_venv/bin/pip" install --quiet --disable-pip-version-check "mcap==$MCAP_VERSION" "jsonschema==$MCAP_JSONSCHEMA_VERSION"
fi

mcap_schemas_tgz="$mcap_venv/foxglove-schemas-$SCHEMAS_VERSION.tgz"
if ! echo "$SCHEMAS_SHA256  $mcap_schemas_tgz" | sha256sum --check --status 2>/dev/null; then
  "$mcap_venv/bin/python" - "$mcap_schemas_tgz" "$SCHEMAS_VERSION" <<'PY'
import sys, urllib.request
out, version = sys.argv[1], sys.argv[2]
url = f"https://registry.npmjs.org/@foxglove/schemas/-/schemas-{version}.tgz"
with urllib.request.urlopen(url, timeout=60) as r, open(out, "wb") as f:
    f.write(r.read())
PY
  echo "$SCHEMAS_SHA256  $mcap_schemas_tgz" | sha256sum --check --status || { echo "mcap_tools: $mcap_schemas_tgz is not the pinned @foxglove/schemas $SCHEMAS_VERSION" >&2; exit 1; }
fi
