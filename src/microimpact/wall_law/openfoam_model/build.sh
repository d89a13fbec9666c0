#!/usr/bin/env bash
# build.sh LIBDIR -- build LIBDIR/libstochasticWallLaw.so, microimpact's
# stochastic wall law as an OpenFOAM patch interaction model (the sources are
# in stochasticWallLaw/ next to this script), against the OpenFOAM on the PATH.
#
#  * What is built comes from stochasticWallLaw/Make/files (the sources: one
#    registration file per cloud type) and Make/options (EXE_INC: include
#    folders; LIB_LIBS: libraries), as wmake reads them: a cloud is added by
#    a registration file listed in Make/files, and a library by a line of
#    Make/options, without a change to this script. The log names the clouds
#    registered.
#  * Where OpenFOAM has wmake and its headers (a source build, OpenCFD's or the
#    Foundation's packages with a sourced etc/bashrc): `wmake libso` with
#    FOAM_USER_LIBBIN=LIBDIR.
#  * Where it is a binary install without headers or wmake (Debian's and
#    Ubuntu's `openfoam` packages): the same release's sources are fetched with
#    apt from its Debian source package (`apt-get source --download-only
#    openfoam=<the installed version>`, through a private apt configuration
#    with deb-src lines made from the system's deb lines: no root needed, no
#    change to /etc/apt), the src/ tree of its .orig tarball is unpacked into
#    a cache, lnInclude folders are made as wmakeLnInclude makes them, and the
#    model is compiled with the release's wmake flags (linux64Gcc, DP, Int32,
#    Opt), MICROIMPACT_BUILD_JOBS sources at a time (default: the CPUs), and
#    linked against the installed libraries.
#
# The cache: $MICROIMPACT_OPENFOAM_SRC if set, else
# ${XDG_CACHE_HOME:-~/.cache}/microimpact/openfoam-<source version>; it is
# filled once (about 45 MB download, 85 MB unpacked) and reused.
# Every step is printed; a failure says what is missing. Exit codes: 0 built,
# 2 bad usage, 3 something missing in the environment, 1 a failed compile.
set -euo pipefail

say() { printf 'build.sh: %s\n' "$*"; }
missing() { printf 'build.sh: error: %s\n' "$*" >&2; exit 3; }

if [ "$#" -ne 1 ] || [ -z "$1" ] || [ "$1" = "-h" ] || [ "$1" = "--help" ]; then
    sed -n '2,30p' "$0" | sed 's/^# \{0,1\}//' >&2
    printf 'usage: bash build.sh LIBDIR\n' >&2
    exit 2
fi

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
model="$here/stochasticWallLaw"
[ -f "$model/Make/files" ] || missing "the model's sources are not in $model (Make/files missing); re-run microimpact wall-law"
[ -f "$model/swl.c" ] || missing "$model/swl.c is missing; re-run microimpact wall-law"
mkdir -p -- "$1" || { printf 'build.sh: error: cannot create LIBDIR %s\n' "$1" >&2; exit 2; }
libdir="$(cd -- "$1" && pwd)"
lib="$libdir/libstochasticWallLaw.so"
say "model sources: $model"
say "library to build: $lib"

# the sources of Make/files, and the clouds their registrations name
sources=()
while IFS= read -r f; do sources+=("$f"); done \
    < <(sed -n 's/^[[:space:]]*\([^[:space:]=]*\.[cC]\)[[:space:]]*$/\1/p' "$model/Make/files")
clouds=()
for f in "${sources[@]}"; do
    [ -f "$model/$f" ] || missing "$model/Make/files lists $f, which is not in $model"
    while IFS= read -r c; do clouds+=("$c"); done < <(sed -n \
        's/^[[:space:]]*makePatchInteractionModelType([[:space:]]*StochasticWallLaw[[:space:]]*,[[:space:]]*\([A-Za-z0-9_:]*\)[[:space:]]*).*/\1/p' \
        "$model/$f")
done
if [ "${#clouds[@]}" -gt 0 ]; then
    say "clouds registered (${#clouds[@]}): ${clouds[*]}"
else
    say "warning: no source in Make/files registers stochasticWallLaw for a cloud (makePatchInteractionModelType); the library will add no model"
fi

# the words of a Make/options variable (backslash-continued lines joined)
options_var() {
    sed -e ':a' -e '/\\$/{N;s/\\\n/ /;ba' -e '}' "$model/Make/options" \
        | sed -n "s/^[[:space:]]*$1[[:space:]]*=//p" | tr -s ' \t' '\n\n' | sed '/^$/d'
}

# --- 1. the OpenFOAM on the PATH ------------------------------------------------
solver=""
for app in icoUncoupledKinematicParcelFoam blockMesh foamList simpleFoam; do
    if command -v "$app" >/dev/null 2>&1; then solver="$(command -v "$app")"; break; fi
done
if [ -z "$solver" ] && ! command -v wmake >/dev/null 2>&1; then
    missing "no OpenFOAM on the PATH (neither a solver such as blockMesh nor wmake); install it (Debian/Ubuntu: apt-get install openfoam) or source its etc/bashrc"
fi

# --- 2a. wmake, where it exists ---------------------------------------------------
if command -v wmake >/dev/null 2>&1 && [ -n "${FOAM_SRC:-}" ] \
        && [ -d "$FOAM_SRC/lagrangian/intermediate/lnInclude" ]; then
    say "OpenFOAM ${WM_PROJECT_VERSION:-?} with wmake ($(command -v wmake)) and headers ($FOAM_SRC)"
    build="$(mktemp -d "${TMPDIR:-/tmp}/stochasticWallLaw.XXXXXX")"
    trap 'rm -rf -- "$build"' EXIT
    cp -R "$model/." "$build/"
    say "step: (cd $build && FOAM_USER_LIBBIN=$libdir wmake libso)"
    (cd "$build" && FOAM_USER_LIBBIN="$libdir" wmake libso) \
        || { printf 'build.sh: error: wmake libso failed (messages above)\n' >&2; exit 1; }
    [ -f "$lib" ] || { printf 'build.sh: error: wmake did not write %s\n' "$lib" >&2; exit 1; }
    say "built $lib (stochasticWallLaw for ${#clouds[@]} clouds: ${clouds[*]})"
    exit 0
fi

# --- 2b. a binary install: the release's headers from its source package --------
say "no wmake with OpenFOAM headers here: building with the release's own sources"
command -v g++ >/dev/null 2>&1 || missing "g++ is missing (Debian: apt-get install g++)"
command -v gcc >/dev/null 2>&1 || missing "gcc is missing (Debian: apt-get install gcc)"

foamlib=""
if [ -n "${FOAM_LIBBIN:-}" ] && [ -f "$FOAM_LIBBIN/libOpenFOAM.so" ]; then
    foamlib="$FOAM_LIBBIN"
elif [ -n "$solver" ]; then
    foamlib="$(ldd "$solver" 2>/dev/null | sed -n 's/.*libOpenFOAM\.so => \(.*\)\/libOpenFOAM\.so.*/\1/p' | head -n 1)"
fi
[ -n "$foamlib" ] && [ -f "$foamlib/liblagrangianIntermediate.so" ] \
    || missing "cannot find OpenFOAM's libraries (libOpenFOAM.so, liblagrangianIntermediate.so) from $solver; set FOAM_LIBBIN to their folder"
say "OpenFOAM libraries: $foamlib"

pkg=""
srcver="${MICROIMPACT_OPENFOAM_SOURCE_VERSION:-}"
if [ -z "$srcver" ] && command -v dpkg >/dev/null 2>&1; then
    for f in "$foamlib/libOpenFOAM.so" "$(readlink -f "$foamlib/libOpenFOAM.so")" \
             "/usr${foamlib#/usr}/libOpenFOAM.so" "$solver"; do
        pkg="$(dpkg -S "$f" 2>/dev/null | head -n 1 | cut -d: -f1 || true)"
        [ -n "$pkg" ] && break
    done
    if [ -n "$pkg" ]; then
        srcname="$(dpkg-query -W -f='${source:Package}' "$pkg")"
        srcver="$(dpkg-query -W -f='${source:Version}' "$pkg")"
    fi
fi
srcname="${srcname:-openfoam}"
[ -n "$srcver" ] || missing "$foamlib/libOpenFOAM.so does not belong to a Debian package, so its source package is unknown: use an OpenFOAM with wmake and headers, or set MICROIMPACT_OPENFOAM_SOURCE_VERSION to the Debian source version of this release (e.g. 1912.200626-1)"
say "OpenFOAM package: ${pkg:-?} from Debian source package $srcname $srcver"
api="$(printf '%s' "$srcver" | sed -n 's/^\([0-9]\{4\}\).*/\1/p')"
[ -n "$api" ] || missing "cannot read the OpenFOAM API (e.g. 1912) from the source version $srcver"

cache="${MICROIMPACT_OPENFOAM_SRC:-${XDG_CACHE_HOME:-${HOME:-/tmp}/.cache}/microimpact/openfoam-$srcver}"
mkdir -p -- "$(dirname -- "$cache")" || missing "cannot create the cache folder $(dirname -- "$cache")"
# one build at a time fills the cache (parallel test workers, two users' shells)
exec 9> "$cache.lock" || missing "cannot write the cache lock $cache.lock"
if command -v flock >/dev/null 2>&1; then
    flock 9
fi
if [ -f "$cache/.complete" ]; then
    say "OpenFOAM $api sources: cached in $cache"
else
    command -v apt-get >/dev/null 2>&1 || missing "apt-get is missing: cannot fetch the source package $srcname $srcver (set MICROIMPACT_OPENFOAM_SRC to an unpacked OpenFOAM source tree holding src/, and touch its .complete)"
    command -v tar >/dev/null 2>&1 || missing "tar is missing"
    work="$(mktemp -d "${TMPDIR:-/tmp}/openfoam-src.XXXXXX")"
    trap 'rm -rf -- "$work"' EXIT
    mkdir -p "$work/lists/partial" "$work/cache/archives/partial" "$work/parts"
    # deb-src lines for the system's deb lines (one-line and deb822 formats)
    : > "$work/sources.list"
    for f in /etc/apt/sources.list /etc/apt/sources.list.d/*.list; do
        [ -f "$f" ] && sed -n 's/^[[:space:]]*deb[[:space:]]/deb-src /p' "$f" >> "$work/sources.list"
    done
    for f in /etc/apt/sources.list.d/*.sources; do
        [ -f "$f" ] && sed 's/^Types:.*/Types: deb-src/' "$f" > "$work/parts/$(basename "$f")"
    done
    apt=(apt-get -q -o "Dir::Etc::SourceList=$work/sources.list"
         -o "Dir::Etc::SourceParts=$work/parts" -o "Dir::State::Lists=$work/lists"
         -o "Dir::Cache=$work/cache" -o "Debug::NoLocking=1")
    say "step: apt-get update with deb-src lines of the system's sources (private lists in $work)"
    "${apt[@]}" update > "$work/apt-update.log" 2>&1 \
        || { cat "$work/apt-update.log" >&2; missing "apt-get update of the deb-src indexes failed (network, or no Debian mirror configured)"; }
    say "step: apt-get source --download-only $srcname=$srcver"
    (cd "$work" && "${apt[@]}" source --download-only "$srcname=$srcver") > "$work/apt-source.log" 2>&1 \
        || { cat "$work/apt-source.log" >&2; missing "the source package $srcname $srcver cannot be downloaded with apt (is it still on the mirror? snapshot.debian.org keeps old versions)"; }
    orig="$(ls "$work"/"${srcname}"_*.orig.tar.* 2>/dev/null | head -n 1)"
    [ -n "$orig" ] || missing "apt-get source gave no .orig tarball for $srcname $srcver"
    say "step: unpack src/ and wmake/rules/ of $(basename "$orig") into $cache"
    rm -rf -- "$cache.part"
    mkdir -p -- "$cache.part"
    tar -xf "$orig" -C "$cache.part" --strip-components=1 --wildcards '*/src/*' '*/wmake/rules/*' \
        || missing "cannot unpack $orig (tar with bzip2/xz support needed)"
    [ -d "$cache.part/src/lagrangian/intermediate" ] || missing "$orig has no src/lagrangian/intermediate"
    rm -rf -- "$cache"
    mv -- "$cache.part" "$cache"
    touch "$cache/.complete"
    say "OpenFOAM $api sources cached in $cache"
fi
src="$cache/src"

# the include folders of Make/options' EXE_INC: -I$(LIB_SRC)/... (lnInclude
# folders made where missing), -I. and other folders relative to the model,
# plus OpenFOAM's and OSspecific's, which wmake adds itself; -D words pass on
incs=(-I"$model/lnInclude")
defs=()
dirs=(OpenFOAM/lnInclude OSspecific/POSIX/lnInclude)
while IFS= read -r w; do
    case "$w" in
        '-I$(LIB_SRC)/'* | '-I$(FOAM_SRC)/'*) dirs+=("${w#-I\$(*SRC)/}") ;;
        -I\$*) missing "Make/options' EXE_INC has $w: only \$(LIB_SRC)/... and folders relative to the model are known here (no wmake)" ;;
        -I/*) incs+=("$w") ;;
        -I*) incs+=(-I"$model/${w#-I}") ;;
        -D*) defs+=("$w") ;;
        *) say "warning: Make/options' EXE_INC word $w is not an include folder nor a -D definition: ignored" ;;
    esac
done < <(options_var EXE_INC)
for d in "${dirs[@]}"; do
    top="$src/${d%/lnInclude}"
    [ -d "$top" ] || missing "the OpenFOAM sources in $cache have no ${d%/lnInclude} (named in Make/options' EXE_INC)"
    if [ "${d##*/}" = lnInclude ] && [ ! -f "$top/lnInclude/.done" ]; then
        say "step: lnInclude of ${d%/lnInclude} (links to its .C/.H files, as wmakeLnInclude)"
        mkdir -p "$top/lnInclude"
        (cd "$top/lnInclude" && find .. \( -name lnInclude -o -name Make -o -name config -o -name noLink \) -prune \
            -o \( -name '*.[CHch]' -o -name '*.cc' -o -name '*.hh' -o -name '*.[ch]xx' -o -name '*.[ch]pp' -o -name '*.type' \) \
            -exec ln -sf {} . \;)
        touch "$top/lnInclude/.done"
    fi
    incs+=(-I"$src/$d")
done
exec 9>&-  # the cache is complete: release the lock

# the libraries of Make/options' LIB_LIBS (-lNAME, -L folders), then
# -lOpenFOAM and -ldl, which wmake adds to every library
libs=(-L"$foamlib")
while IFS= read -r w; do
    case "$w" in
        '-L$(FOAM_LIBBIN)' | '-L$(FOAM_LIBBIN)/'*) libs+=(-L"$foamlib${w#-L\$(FOAM_LIBBIN)}") ;;
        '-L$(FOAM_USER_LIBBIN)') libs+=(-L"$libdir") ;;
        -L\$*) missing "Make/options' LIB_LIBS has $w: only \$(FOAM_LIBBIN) and \$(FOAM_USER_LIBBIN) are known here (no wmake)" ;;
        -L*) libs+=("$w") ;;
        -l*)
            name="${w#-l}"
            if [ ! -f "$foamlib/lib$name.so" ] && [ "$(gcc -print-file-name="lib$name.so")" = "lib$name.so" ]; then
                missing "Make/options' LIB_LIBS names $w, but there is no lib$name.so in $foamlib nor on the compiler's library path (install the OpenFOAM package that has it)"
            fi
            libs+=("$w") ;;
        *) say "warning: Make/options' LIB_LIBS word $w is not -lNAME nor -LFOLDER: ignored" ;;
    esac
done < <(options_var LIB_LIBS)
libs+=(-lOpenFOAM -ldl)
say "libraries (Make/options' LIB_LIBS, then -lOpenFOAM -ldl): ${libs[*]}"

# wmake/rules of the release: linux64Gcc c++ + c++Opt + General/Gcc/c++, DP, Int32
cxxflags=(-std=c++11 -m64 -pthread "-DOPENFOAM=$api" -DWM_DP -DWM_LABEL_SIZE=32
          -Wall -Wextra -Wold-style-cast -Wnon-virtual-dtor -Wno-unused-parameter
          -Wno-invalid-offsetof -Wno-attributes -Wno-unknown-pragmas
          -O3 -DNoRepository -ftemplate-depth-100 -fPIC)
cflags=(-std=c99 -m64 -O3 -fPIC -ffp-contract=off)
say "compiler flags of OpenFOAM $api (wmake/rules/linux64Gcc, Opt, DP, Int32): ${cxxflags[*]} ${defs[*]}"
objdir="$(mktemp -d "${TMPDIR:-/tmp}/stochasticWallLaw-obj.XXXXXX")"
trap 'rm -rf -- "$objdir" "${work:-}"' EXIT

jobs="${MICROIMPACT_BUILD_JOBS:-$(nproc 2>/dev/null || echo 1)}"
case "$jobs" in ''|*[!0-9]*|0) printf 'build.sh: error: MICROIMPACT_BUILD_JOBS must be a positive integer; got %s\n' "$jobs" >&2; exit 2 ;; esac
compile() {  # compile Make/files' source $1 into $objdir; its messages in $objdir/$1.log
    local f="$1" o="$objdir/${1%.*}.o"
    case "$f" in
        *.c) gcc "${cflags[@]}" "${defs[@]}" -I"$model" -c "$model/$f" -o "$o" ;;
        *.C) g++ "${cxxflags[@]}" "${defs[@]}" "${incs[@]}" -c "$model/$f" -o "$o" ;;
    esac
}
say "step: compile ${#sources[@]} sources, $jobs at a time (a C++ registration: 10 s to a minute)"
objs=()
for f in "${sources[@]}"; do
    while [ "$(jobs -rp | wc -l)" -ge "$jobs" ]; do wait -n || true; done
    case "$f" in *.c) say "step: gcc $f" ;; *) say "step: g++ $f" ;; esac
    { compile "$f" > "$objdir/$f.log" 2>&1 && touch "$objdir/$f.ok"; } &
    objs+=("$objdir/${f%.*}.o")
done
wait
failed=()
for f in "${sources[@]}"; do
    cat "$objdir/$f.log" >&2
    [ -f "$objdir/$f.ok" ] || failed+=("$f")
done
[ "${#failed[@]}" -eq 0 ] || { printf 'build.sh: error: compiling %s failed (messages above)\n' "${failed[*]}" >&2; exit 1; }
say "step: link ${lib}"
g++ "${cxxflags[@]}" -shared -Xlinker --add-needed -Xlinker --no-as-needed \
    -o "$lib.tmp" "${objs[@]}" "${libs[@]}" \
    || { printf 'build.sh: error: linking %s failed\n' "$lib" >&2; exit 1; }
undefined="$(LD_LIBRARY_PATH="$foamlib:${LD_LIBRARY_PATH:-}" ldd -r "$lib.tmp" 2>&1 | grep -i 'undefined symbol' || true)"
if [ -n "$undefined" ]; then
    rm -f -- "$lib.tmp"
    printf '%s\n' "$undefined" | head -n 5 >&2
    printf 'build.sh: error: the library has undefined symbols (headers of another release?)\n' >&2
    exit 1
fi
mv -f -- "$lib.tmp" "$lib"
say "built $lib (stochasticWallLaw for ${#clouds[@]} clouds: ${clouds[*]})"
say "use it: libs (\"libstochasticWallLaw.so\"); in system/controlDict, with LD_LIBRARY_PATH=$libdir (or copy it to \$FOAM_USER_LIBBIN)"
