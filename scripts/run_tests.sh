#!/usr/bin/env bash
# Set up everything and run the whole test suite (what .ci/run calls).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
bash "$root/scripts/setup_venv.sh"
. "$root/scripts/env.sh"
cd "$root"
exec python -P -m pytest -p no:cacheprovider "$@" test
