#!/usr/bin/env bash
# Installs the Khronos glTF validator (the npm package gltf-validator, pinned) into the
# project-local, git-ignored .tools/ folder, for tests/blender/test_gltf_validity.py.
# Needs Node.js and npm: when they are missing they are installed from Debian's packages
# (apt-get, as root or through sudo). Idempotent: an existing install of the pinned version
# is kept.
#
# Usage: scripts/setup_validator.sh     then: node scripts/validate_gltf.js FILE.gltf
set -euo pipefail

cd "$(dirname "$0")/.."
TOOLS=.tools
VALIDATOR_VERSION=2.0.0-dev.3.10

if ! command -v node >/dev/null 2>&1 || ! command -v npm >/dev/null 2>&1; then
    echo "setup_validator.sh: node/npm missing: installing Debian's nodejs and npm" >&2
    SUDO=""
    if [[ $(id -u) -ne 0 ]]; then
        SUDO=sudo
    fi
    $SUDO apt-get update
    $SUDO env DEBIAN_FRONTEND=noninteractive apt-get install -y --no-install-recommends nodejs npm
fi

installed=$(node -e "try { console.log(require('./$TOOLS/node_modules/gltf-validator/package.json').version) } catch (e) {}")
if [[ "$installed" == "$VALIDATOR_VERSION" ]]; then
    echo "setup_validator.sh: $TOOLS has gltf-validator $VALIDATOR_VERSION"
    exit 0
fi

mkdir -p "$TOOLS"
npm install --prefix "$TOOLS" --no-audit --no-fund --save-exact "gltf-validator@$VALIDATOR_VERSION"
echo "setup_validator.sh: ready: node scripts/validate_gltf.js FILE.gltf"
