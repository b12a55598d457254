#!/usr/bin/env bash
# The C ABI as a C program sees it:
#  1. builds libtranscut (.so and .a) with cargo,
#  2. installs it with scripts/install.sh into a scratch prefix (lib, include, transcut.pc),
#  3. compiles include/transcut.h as C99 and C++17 with -Wall -Wextra -Werror (its layout
#     checks compare every struct with the library's),
#  4. compiles each C test program (tests/c/marble_sphere.c: TransCut, the hierarchical
#     dipole and the polygrid against closed forms, edits, misuse; tests/c/radiosity_room.c: translucent
#     radiosity, a marble ball in an emissive diffuse room) against the shared and against the
#     static library (through pkg-config), runs the static build and runs the shared one under
#     valgrind memcheck with no suppression file (the static archive is the same code; step 5
#     checks its memory):
#     zero errors, no definitely or possibly lost bytes (the library joins its worker threads
#     before each call returns, so nothing of it is left running when the program exits;
#     "still reachable" is not counted: it is the C runtime's and the dynamic loader's own),
#     and nothing written to the program's stderr by the library (a panic included);
#  5. builds each again with gcc's AddressSanitizer and runs it with leak detection
#     (ASAN_OPTIONS=detect_leaks=1), against the static library: no leak, no error.
# Prints the path of the built shared library (reused by the Blender add-on tests).
set -euo pipefail
cd "$(dirname "$0")/../.."

bash scripts/install-test-deps.sh

# The profile of the C library: `test` (opt-level 2, debug assertions, output in target/debug).
# What cargo builds: by default the same selection as scripts/test.sh's
# `cargo test --workspace --all-targets`, so that cargo resolves the same features, every crate
# compiled for the tests is reused and only the C library itself is new. (`cargo build -p
# transcut-capi` alone resolves features without the other crates' dev-dependencies and would
# compile the core and wgpu a second time.) Standalone, e.g. after `cargo test -p
# transcut-capi`, use TRANSCUT_CAPI_BUILD="-p transcut-capi --all-targets".
profile=${TRANSCUT_PROFILE:-test}
if [ "$profile" = test ]; then
    build_args=${TRANSCUT_CAPI_BUILD:---workspace --all-targets}
else
    build_args=${TRANSCUT_CAPI_BUILD:--p transcut-capi}
fi
target_dir=${CARGO_TARGET_DIR:-target}
case "$profile" in
    dev | test) out_dir="$target_dir/debug" ;;
    *) out_dir="$target_dir/$profile" ;;
esac
# shellcheck disable=SC2086
cargo build $build_args --profile "$profile" --locked
echo "tests/c/run.sh: shared library: $(cd "$out_dir" && pwd)/libtranscut.so"

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
TRANSCUT_PROFILE=$profile TRANSCUT_NO_BUILD=1 bash scripts/install.sh "$work/prefix" >/dev/null
export PKG_CONFIG_PATH="$work/prefix/lib/pkgconfig"
cflags=$(pkg-config --cflags transcut)

# The header alone, as C99 and as C++17.
printf '#include "transcut.h"\nint main(void) { return tc_version() == TRANSCUT_VERSION ? 0 : 1; }\n' > "$work/header.c"
gcc -std=c99 -Wall -Wextra -Werror -pedantic $cflags -c "$work/header.c" -o "$work/header.o"
printf '#include "transcut.h"\n#include <cstdio>\n' > "$work/header.cpp"
g++ -std=c++17 -Wall -Wextra -Werror -pedantic $cflags -fsyntax-only "$work/header.cpp"
echo "tests/c/run.sh: include/transcut.h compiles as C99 and C++17 (-Wall -Wextra -Werror -pedantic)"

warn="-std=c99 -Wall -Wextra -Werror -O1 -g"
# The system libraries transcut.pc lists for static linking.
static_libs=$(pkg-config --static --libs-only-l transcut | sed 's/-ltranscut//')
programs="marble_sphere radiosity_room"
for program in $programs; do
    # shellcheck disable=SC2046
    gcc $warn $cflags "tests/c/$program.c" -o "$work/${program}_shared" $(pkg-config --libs transcut) -lm \
        -Wl,-rpath,"$work/prefix/lib"
    # The static archive.
    # shellcheck disable=SC2086
    gcc $warn $cflags "tests/c/$program.c" -o "$work/${program}_static" "$work/prefix/lib/libtranscut.a" $static_libs -lm
done

# Under valgrind: the CPU path (software Vulkan drivers are not what is being checked here),
# and no panic backtraces (symbolising one caches the library's debug info: ~90 MB "still
# reachable", and slow under valgrind). Valgrind's own report goes to a log file, so that the
# program's stderr holds only what the program (or the library) wrote: it must stay empty.
for program in $programs; do
    exe="${program}_static"
    echo "tests/c/run.sh: $exe"
    if ! env -u RUST_BACKTRACE TRANSCUT_BACKEND=cpu "$work/$exe" >"$work/$exe.stdout" 2>"$work/$exe.stderr"; then
        cat "$work/$exe.stdout" "$work/$exe.stderr"
        echo "tests/c/run.sh: $exe failed" >&2
        exit 1
    fi
    if [ -s "$work/$exe.stderr" ]; then
        cat "$work/$exe.stderr"
        echo "tests/c/run.sh: $exe wrote to stderr (the library must print nothing)" >&2
        exit 1
    fi
    for exe in "${program}_shared"; do
        echo "tests/c/run.sh: valgrind $exe"
        if ! env -u RUST_BACKTRACE TRANSCUT_BACKEND=cpu valgrind --tool=memcheck --error-exitcode=1 --leak-check=full \
            --errors-for-leak-kinds=definite,possible --show-leak-kinds=definite,possible --log-file="$work/$exe.valgrind" \
            "$work/$exe" 2>"$work/$exe.stderr"; then
            cat "$work/$exe.valgrind" "$work/$exe.stderr"
            echo "tests/c/run.sh: $exe failed under valgrind" >&2
            exit 1
        fi
        grep -E "ERROR SUMMARY|definitely lost|possibly lost" "$work/$exe.valgrind" || true
        if [ -s "$work/$exe.stderr" ]; then
            cat "$work/$exe.stderr"
            echo "tests/c/run.sh: $exe wrote to stderr (the library must print nothing)" >&2
            exit 1
        fi
    done
done
echo "tests/c/run.sh: C programs ($programs) passed (static) and under valgrind (shared), stderr empty"

# Under AddressSanitizer's leak checker: the same programs, built with -fsanitize=address.
for program in $programs; do
    exe="${program}_asan"
    # shellcheck disable=SC2086
    gcc $warn -fsanitize=address -fno-omit-frame-pointer $cflags "tests/c/$program.c" -o "$work/$exe" \
        "$work/prefix/lib/libtranscut.a" $static_libs -lm
    echo "tests/c/run.sh: AddressSanitizer + LeakSanitizer $exe"
    if ! env -u RUST_BACKTRACE TRANSCUT_BACKEND=cpu ASAN_OPTIONS=detect_leaks=1:abort_on_error=0 "$work/$exe" \
        >"$work/$exe.stdout" 2>"$work/$exe.stderr"; then
        cat "$work/$exe.stdout" "$work/$exe.stderr"
        echo "tests/c/run.sh: $exe failed (a leak or a memory error)" >&2
        exit 1
    fi
    if [ -s "$work/$exe.stderr" ]; then
        cat "$work/$exe.stderr"
        echo "tests/c/run.sh: $exe wrote to stderr" >&2
        exit 1
    fi
done
echo "tests/c/run.sh: C programs ($programs) passed under LeakSanitizer, stderr empty"
