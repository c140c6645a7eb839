#!/usr/bin/env bash
# Installs the dependencies, builds and installs softhom (the `softhom` program, the libraries with their
# CMake package, the Python module) and runs the main job on its embedded default scenes. Results go to
# ./softhom-demo (or the directory given as $1).
#
# Install prefix: $SOFTHOM_PREFIX, else /usr/local as root (bin/ is on PATH and Debian's python3 finds
# the module there), else ~/.local. The script prints what to add to PATH / PYTHONPATH when needed.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
if [ -n "${SOFTHOM_PREFIX:-}" ]; then prefix="$SOFTHOM_PREFIX"
elif [ "$(id -u)" -eq 0 ]; then prefix=/usr/local
else prefix="$HOME/.local"; fi
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release
cmake --build build -j"$(nproc)" --target softhom softhom_python
cmake --install build --prefix "$prefix" >/dev/null
echo "softhom installed into $prefix"
"$prefix/bin/softhom" demo --out "${1:-softhom-demo}"
case ":$PATH:" in *":$prefix/bin:"*) ;; *) echo "add softhom to PATH:  export PATH=\"$prefix/bin:\$PATH\"" ;; esac
site="$prefix/$(sed -n 's/^SOFTHOM_PYTHON_INSTALL_DIR:STRING=//p' build/CMakeCache.txt)"
/usr/bin/python3 -c 'import softhom' 2>/dev/null || echo "for 'import softhom':  export PYTHONPATH=\"$site\""
