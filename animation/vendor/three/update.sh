#!/usr/bin/env bash
# Re-vendor three.js from the npm registry: ./update.sh 0.185.1
set -euo pipefail
version="${1:?usage: $0 VERSION}"
here="$(cd "$(dirname "$0")" && pwd)"
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
(cd "$tmp" && npm pack --silent "three@$version" >/dev/null && tar xzf "three-$version.tgz")
p="$tmp/package"
cp "$p/build/three.core.min.js" "$p/build/three.module.min.js" \
   "$p/examples/jsm/controls/OrbitControls.js" "$p/LICENSE" "$here/"
(cd "$here" && sha256sum three.core.min.js three.module.min.js OrbitControls.js LICENSE > SHA256SUMS)
echo "vendored three@$version; now update README.md here and run the tests"
