#!/usr/bin/env bash
# Install the Debian packages some tests need, when their programs are missing:
#   chromium    the headless-browser test
#   postgresql  the results-store tests start a private server of their own (test/fleet/)
# Safe to run again: with both programs present nothing is done. Not root: prints what is
# missing and exits 0 (those tests skip locally; under CI=true they fail and name this script).
set -euo pipefail

missing=()
command -v chromium >/dev/null 2>&1 || missing+=(chromium)
# the server's programs are not on PATH (Debian: /usr/lib/postgresql/<version>/bin)
compgen -G '/usr/lib/postgresql/*/bin/initdb' >/dev/null || missing+=(postgresql)
if [ "${#missing[@]}" -eq 0 ]; then
    exit 0
fi

if [ "$(id -u)" -ne 0 ]; then
    echo "system_packages: missing ${missing[*]}; install with: sudo apt-get install --no-install-recommends ${missing[*]}"
    exit 0
fi

export DEBIAN_FRONTEND=noninteractive
# The tests run their own server on 127.0.0.1; the package's cluster on port 5432 must not be
# started: policy-rc.d exiting 101 tells invoke-rc.d and deb-systemd-invoke not to start
# services. One already there (Docker images ship one) is left as it is.
policy=/usr/sbin/policy-rc.d
if [ ! -e "$policy" ]; then
    printf '#!/bin/sh\n# temporary: scripts/system_packages.sh\nexit 101\n' > "$policy"
    chmod 755 "$policy"
    trap 'rm -f "$policy"' EXIT
fi

echo "system_packages: installing ${missing[*]}"
# wait for the dpkg lock rather than fail when another apt-get is running
apt=(apt-get -q -o DPkg::Lock::Timeout=600)
"${apt[@]}" update
"${apt[@]}" install -y --no-install-recommends "${missing[@]}"

# Should a cluster have been started anyway (no policy-rc.d honoured), stop it.
if command -v pg_lsclusters >/dev/null 2>&1; then
    { pg_lsclusters -h 2>/dev/null || true; } | while read -r version name _port status _rest; do
        case "$status" in
            online*) pg_ctlcluster "$version" "$name" stop || service postgresql stop || true ;;
        esac
    done
fi

command -v chromium >/dev/null 2>&1 || { echo "system_packages: error: chromium still missing" >&2; exit 1; }
compgen -G '/usr/lib/postgresql/*/bin/initdb' >/dev/null \
    || { echo "system_packages: error: postgresql's initdb still missing" >&2; exit 1; }
echo "system_packages: installed ${missing[*]}"
