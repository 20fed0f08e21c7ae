# Headless Chromium for the browser tests (`cargo test --test seeing -- --ignored …`): Debian's
# `chromium` package, installed with apt-get when missing (CI runs as root); scripts/ci_prepare.sh
# installs it ahead. Sourced.
if ! command -v chromium >/dev/null 2>&1; then
  DEBIAN_FRONTEND=noninteractive apt-get update -qq
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium >/dev/null
fi
