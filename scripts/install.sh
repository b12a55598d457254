#!/usr/bin/env bash
# Installs the C library: builds libtranscut (release profile unless TRANSCUT_PROFILE says
# otherwise) and copies
#   PREFIX/lib/libtranscut.so, PREFIX/lib/libtranscut.a, PREFIX/include/transcut.h,
#   PREFIX/lib/pkgconfig/transcut.pc
# Usage: scripts/install.sh PREFIX        (e.g. scripts/install.sh /usr/local, or $HOME/.local)
# Then:  cc app.c $(pkg-config --cflags --libs transcut)            (shared)
#        cc app.c $(pkg-config --cflags --libs --static transcut)   (static, with -static-libs)
# Set TRANSCUT_NO_BUILD=1 to install an already built library (CARGO_TARGET_DIR respected).
set -euo pipefail
cd "$(dirname "$0")/.."

if [ $# -ne 1 ]; then
    echo "usage: scripts/install.sh PREFIX" >&2
    exit 2
fi
mkdir -p "$1"
prefix=$(cd "$1" && pwd)
profile=${TRANSCUT_PROFILE:-release}
target_dir=${CARGO_TARGET_DIR:-target}
# Cargo puts the dev and test profiles in target/debug, every other profile in target/<name>.
case "$profile" in
    dev | test) out_dir="$target_dir/debug" ;;
    *) out_dir="$target_dir/$profile" ;;
esac

if [ -z "${TRANSCUT_NO_BUILD:-}" ]; then
    cargo build -p transcut-capi --profile "$profile" --locked
fi
for f in libtranscut.so libtranscut.a; do
    if [ ! -f "$out_dir/$f" ]; then
        echo "scripts/install.sh: $out_dir/$f is missing (build with: cargo build -p transcut-capi --profile $profile)" >&2
        exit 1
    fi
done

version=$(sed -n 's/^#define TRANSCUT_VERSION_STRING "\(.*\)"$/\1/p' include/transcut.h)
install -d "$prefix/lib/pkgconfig" "$prefix/include"
install -m 0755 "$out_dir/libtranscut.so" "$prefix/lib/libtranscut.so"
install -m 0644 "$out_dir/libtranscut.a" "$prefix/lib/libtranscut.a"
install -m 0644 include/transcut.h "$prefix/include/transcut.h"
# Libs.private: the system libraries the Rust standard library in libtranscut.a needs
# (rustc --print native-static-libs on Linux/glibc).
cat > "$prefix/lib/pkgconfig/transcut.pc" <<PC
prefix=$prefix
exec_prefix=\${prefix}
libdir=\${exec_prefix}/lib
includedir=\${prefix}/include

Name: transcut
Description: Subsurface scattering for translucent objects: per-vertex radiance (C API of libtranscut)
Version: $version
Libs: -L\${libdir} -ltranscut
Libs.private: -lgcc_s -lutil -lrt -lpthread -lm -ldl -lc
Cflags: -I\${includedir}
PC
echo "installed libtranscut $version into $prefix (lib, include, lib/pkgconfig/transcut.pc)"
