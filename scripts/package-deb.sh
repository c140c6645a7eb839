#!/usr/bin/env bash
# Builds the Debian package softhom_<version>_<arch>.deb with CPack and checks it without installing it:
#
#   bash scripts/package-deb.sh [BUILD_DIR]        # default: build-deb; the .deb is left in BUILD_DIR
#
# The build is configured for the package: prefix /usr, the Python module in /usr/lib/python3/dist-packages
# (where Debian's python3 of any minor version looks), no tests or benchmarks. The checks: the package's
# control data (Depends from dpkg-shlibdeps plus cmake/Packaging.cmake's list) and file list, every
# dependency installed on this machine, the tree unpacked into a temporary root with `dpkg -x`, every
# shared library of the program and the module resolved by the dynamic loader, and the unpacked program
# and module run. Installing it: `apt install ./softhom_*.deb` (apt fetches the Depends).
set -euo pipefail
source_dir=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-build-deb}
launcher=()
command -v ccache > /dev/null && launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache)

mkdir -p "$build"
cmake -S "$source_dir" -B "$build" -DCMAKE_BUILD_TYPE=Release "${launcher[@]}" \
  -DCMAKE_INSTALL_PREFIX=/usr -DSOFTHOM_PYTHON_INSTALL_DIR=lib/python3/dist-packages \
  -DSOFTHOM_BUILD_TESTS=OFF -DSOFTHOM_BUILD_BENCH=OFF > "$build/configure.log"
cmake --build "$build" -j "$(nproc)"
(cd "$build" && rm -f softhom_*.deb && cpack -G DEB > cpack.log)
deb=$(ls "$build"/softhom_*.deb)
echo "== $deb ($(du -h "$deb" | cut -f1))"
dpkg-deb -I "$deb"
dpkg-deb -c "$deb" | awk '{print $6}' | grep -E '/bin/|dist-packages/softhom/|share/softhom/examples/[^/]*$' | awk 'NR <= 20'

# Every package the control file depends on (alternatives: the first) is known to dpkg here.
depends=$(dpkg-deb -f "$deb" Depends)
missing=0
while read -r dep; do
  name=${dep%% *}
  dpkg-query -W -f='${Status}' "$name" 2>/dev/null | grep -q "install ok installed" || { echo "not installed: $dep"; missing=1; }
done < <(tr ',' '\n' <<< "$depends" | sed 's/|.*//; s/^ *//; s/ *$//' | grep -v '^$')
((missing == 0)) && echo "== every Depends installed here: $(tr ',' '\n' <<< "$depends" | grep -c .) packages"

root=$(mktemp -d)
trap 'rm -rf "$root"' EXIT
dpkg -x "$deb" "$root"
module=$(ls "$root"/usr/lib/python3/dist-packages/softhom/_softhom*.so)
for binary in "$root/usr/bin/softhom" "$module"; do
  if ldd "$binary" | grep -q "not found"; then
    echo "unresolved libraries of $binary:"; ldd "$binary" | grep "not found"; exit 1
  fi
  echo "== ldd $(basename "$binary"): $(ldd "$binary" | wc -l) libraries, none missing"
done
"$root/usr/bin/softhom" --version
"$root/usr/bin/softhom" examples list | awk 'NR <= 3'
"$root/usr/bin/softhom" point "$root/usr/share/softhom/examples/scenes/point_uniaxial_ecoflex.toml" --out "$root/run" -q
echo "== softhom point from the unpacked examples: $(($(wc -l < "$root/run/response.csv") - 1)) rows"
PYTHONPATH="$root/usr/lib/python3/dist-packages" /usr/bin/python3 -c \
  "import softhom; print('python module', softhom.__version__, softhom.__file__)"
echo "== ok: $deb"
