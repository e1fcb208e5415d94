#!/usr/bin/env bash
# Installs the Debian packages kfx needs when they are missing (apt-get, when run as root);
# otherwise says which are missing and how to install them. Usage: install-deps.sh PKG...
set -euo pipefail
missing=()
for pkg in "$@"; do
  status=$(dpkg-query -W -f='${Status}' "$pkg" 2>/dev/null || true)
  [[ "$status" == "install ok installed" ]] || missing+=("$pkg")
done
if [[ ${#missing[@]} -eq 0 ]]; then
  exit 0
fi
if [[ $(id -u) -eq 0 ]]; then
  echo "kfx: installing missing Debian packages: ${missing[*]}" >&2
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq >&2
  apt-get install -y -qq --no-install-recommends "${missing[@]}" >&2
else
  echo "kfx: missing Debian packages: ${missing[*]}" >&2
  echo "kfx: install them with: sudo apt-get install ${missing[*]}" >&2
  exit 1
fi
