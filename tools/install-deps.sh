#!/usr/bin/env bash
# Installs the Debian packages of the named groups of tools/deps/debian.txt when they are missing
# (apt-get, when run as root); otherwise says which are missing and how to install them. Then reports
# which packages of the other (unrequested) groups are installed, so that a log shows what a target
# did not need. Usage: install-deps.sh GROUP...   (e.g. build python test mpi)
set -euo pipefail
table="$(dirname "$0")/deps/debian.txt"
declare -A group_packages=()
groups_in_order=()
while read -r group packages; do
  [[ -z "$group" || "$group" == \#* ]] && continue
  group_packages[$group]=$packages
  groups_in_order+=("$group")
done < "$table"

installed() { [[ "$(dpkg-query -W -f='${Status}' "$1" 2>/dev/null || true)" == "install ok installed" ]]; }

wanted=()
for group in "$@"; do
  [[ -n "${group_packages[$group]+x}" ]] || { echo "install-deps.sh: no group '$group' in $table" >&2; exit 2; }
  read -ra pkgs <<< "${group_packages[$group]}"
  wanted+=("${pkgs[@]}")
done
missing=()
for pkg in "${wanted[@]}"; do
  installed "$pkg" || missing+=("$pkg")
done
if [[ ${#missing[@]} -gt 0 ]]; then
  if [[ $(id -u) -eq 0 ]]; then
    echo "kfx: installing missing Debian packages ($*): ${missing[*]}" >&2
    export DEBIAN_FRONTEND=noninteractive
    apt-get update -qq >&2
    apt-get install -y -qq --no-install-recommends "${missing[@]}" >&2
  else
    echo "kfx: missing Debian packages: ${missing[*]}" >&2
    echo "kfx: install them with: sudo apt-get install ${missing[*]}" >&2
    exit 1
  fi
fi
others=()
present=()
for group in "${groups_in_order[@]}"; do
  [[ " $* " == *" $group "* ]] && continue
  others+=("$group")
  read -ra pkgs <<< "${group_packages[$group]}"
  for pkg in "${pkgs[@]}"; do
    installed "$pkg" && present+=("$pkg")
  done
done
if [[ ${#others[@]} -gt 0 ]]; then
  echo "kfx: deps $*; not needed here (${others[*]}), installed anyway: ${present[*]:-none}" >&2
fi
