#!/usr/bin/env bash
# One-time set-up on a fresh Debian machine with the Rust toolchain:
# system packages (CalculiX for the Rotor 37 checks) and a Python virtual
# environment with pyarrow/pandas (to check the Parquet outputs).
set -euo pipefail
cd "$(dirname "$0")/.."
SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO="sudo"
if ! command -v ccx >/dev/null 2>&1; then
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq calculix-ccx python3-venv >/dev/null
fi
if [ ! -x venv/bin/python ]; then
  python3 -m venv venv
fi
venv/bin/pip install -q pyarrow pandas
