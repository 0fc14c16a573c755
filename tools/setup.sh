# shellcheck shell=bash
# Shared set-up for tools/run-editor and tools/run-tests (sourced, not run).
# Installs, only when missing, the Debian packages the project needs, and keeps a virtual
# environment in .venv with the project installed (editable) and the extras asked for.
# Works on a fresh Debian 12 as root, or as a user with sudo.

# Mesa's EGL and GL (headless rendering on llvmpipe), Xvfb, and the X libraries Qt's xcb plugin
# loads; debootstrap builds the OpenXR runtime's root for the VR tests, and the export tests
# render exported glTF files with three.js in headless Chromium.
SYSTEM_PACKAGES=(
    ca-certificates python3 python3-venv python3-pip
    libegl1 libegl-mesa0 libgl1 libgl1-mesa-dri libglx-mesa0 libopengl0 libgles2
    libglib2.0-0 libfontconfig1 libfreetype6 libdbus-1-3 libxkbcommon0 libxkbcommon-x11-0
    libxcb1 libxcb-cursor0 libxcb-icccm4 libxcb-image0 libxcb-keysyms1 libxcb-randr0
    libxcb-render-util0 libxcb-shape0 libxcb-shm0 libxcb-sync1 libxcb-xfixes0 libxcb-xinerama0
    libxcb-xkb1 libx11-xcb1 libxrender1 libxi6 libsm6 libice6
    xvfb xauth
)
TEST_SYSTEM_PACKAGES=(debootstrap util-linux chromium glslang-tools)

say() { printf 'sand-editor setup: %s\n' "$*" >&2; }

as_root() {
    if [[ $(id -u) -eq 0 ]]; then
        "$@"
    elif command -v sudo >/dev/null; then
        sudo "$@"
    else
        say "needs root (or sudo) to install: ${*: -1}…"
        return 1
    fi
}

ensure_system_packages() {
    local wanted=("${SYSTEM_PACKAGES[@]}") missing=()
    [[ ${1:-} == test ]] && wanted+=("${TEST_SYSTEM_PACKAGES[@]}")
    command -v dpkg-query >/dev/null || { say "not a Debian system: install the equivalents of ${wanted[*]} yourself"; return 0; }
    local pkg
    for pkg in "${wanted[@]}"; do
        dpkg-query -W -f='${Status}' "$pkg" 2>/dev/null | grep -q 'install ok installed' || missing+=("$pkg")
    done
    ((${#missing[@]} == 0)) && return 0
    say "installing Debian packages: ${missing[*]}"
    as_root env DEBIAN_FRONTEND=noninteractive apt-get update -qq
    as_root env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
}

# The interpreter for the venv: $PYTHON, else the first python3 on PATH that has venv.
find_python() {
    local candidate
    for candidate in "${PYTHON:-}" python3 /usr/bin/python3; do
        [[ -n $candidate ]] || continue
        if "$candidate" -c 'import sys, venv, ensurepip; sys.exit(sys.version_info < (3, 10))' 2>/dev/null; then
            echo "$candidate"
            return 0
        fi
    done
    say "no Python ≥ 3.10 with venv found (Debian: apt-get install python3 python3-venv)"
    return 1
}

# Creates or refreshes .venv; reinstalls only when pyproject.toml changed or extras are missing.
# The stamp records the pyproject.toml hash and the extras installed, so alternating between
# the editor and the tests does not reinstall.
ensure_venv() {
    local requested=$1 venv=.venv python hash installed="" extras
    hash=$(sha256sum pyproject.toml | cut -c1-16)
    if [[ -x $venv/bin/python && -f $venv/.sand-editor-stamp ]]; then
        read -r stamp_hash installed <"$venv/.sand-editor-stamp" || true
        if [[ $stamp_hash == "$hash" ]]; then
            local extra complete=1
            for extra in ${requested//,/ }; do
                [[ ",$installed," == *",$extra,"* ]] || complete=0
            done
            ((complete)) && return 0
        else
            installed=""
        fi
    fi
    extras=$(tr ',' '\n' <<<"$installed,$requested" | sed '/^$/d' | sort -u | paste -sd, -)
    python=$(find_python)
    if [[ ! -x $venv/bin/python ]]; then
        say "creating $venv with $($python --version)"
        "$python" -m venv "$venv"
    fi
    say "installing the project and its dependencies ($extras) into $venv"
    "$venv/bin/python" -m pip install -q --upgrade pip
    "$venv/bin/python" -m pip install -q -e ".[${extras}]"
    echo "$hash $extras" >"$venv/.sand-editor-stamp"
}

# Installs the Node packages of tools/js (three.js, the Khronos glTF validator) with npm ci into
# ${SAND_EDITOR_CACHE:-~/.cache/sand-editor}/js/<first 16 hex digits of the sha256 of
# tools/js/package-lock.json>, outside the repository, and exports that folder as SAND_EDITOR_JS
# (tests/export/js_tools.py computes the same path). A finished install is marked by a
# .sand-editor-complete file and is not repeated; a changed lock file gets a new folder.
ensure_js_packages() {
    local cache hash dir tmp
    cache=$(realpath -m -- "${SAND_EDITOR_CACHE:-$HOME/.cache/sand-editor}")
    hash=$(sha256sum tools/js/package-lock.json | cut -c1-16)
    dir=$cache/js/$hash
    if [[ ! -f $dir/.sand-editor-complete ]]; then
        if ! command -v npm >/dev/null; then
            # Debian 12's Node.js 18 and npm are enough for three.js and the validator.
            say "installing Debian packages: nodejs npm"
            as_root env DEBIAN_FRONTEND=noninteractive apt-get update -qq
            as_root env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends nodejs npm >/dev/null
        fi
        say "installing the Node packages of tools/js into $dir"
        mkdir -p "$cache/js"
        tmp=$(mktemp -d "$cache/js/.install-$hash.XXXXXX")
        cp tools/js/package.json tools/js/package-lock.json "$tmp/"
        if ! (cd "$tmp" && npm ci --no-audit --no-fund --silent); then
            rm -rf "$tmp"
            say "npm ci failed for tools/js"
            return 1
        fi
        touch "$tmp/.sand-editor-complete"
        rm -rf "$dir"
        mv -T "$tmp" "$dir" 2>/dev/null || rm -rf "$tmp"
    fi
    export SAND_EDITOR_JS=$dir
}
