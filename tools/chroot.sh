# Shared by the harnesses that run a program inside a cached Debian root (tools/monado/run,
# tools/godot/run): sourced after they define SELF (the harness), log and die (exit 125: the
# harness failed).

now() { date +%s.%N; }
since() { awk -v a="$1" -v b="$(now)" 'BEGIN { printf "%.1f", b - a }'; }

# A package or requirement list: one entry per line, # comments, sorted and unique.
list_file() { sed -e 's/#.*//' -e 's/[[:space:]]//g' "$1" | grep -v '^$' | sort -u; }

# The machine's own Debian mirror is the one known to be reachable from here.
detect_mirror() {
    if [[ -n ${SAND_EDITOR_DEBIAN_MIRROR:-} ]]; then
        echo "$SAND_EDITOR_DEBIAN_MIRROR"
        return
    fi
    local uri
    uri=$(
        {
            cat /etc/apt/sources.list.d/*.sources 2>/dev/null |
                awk 'tolower($1) == "uris:" { for (i = 2; i <= NF; i++) print $i }'
            cat /etc/apt/sources.list /etc/apt/sources.list.d/*.list 2>/dev/null |
                sed -e 's/#.*//' -e 's/\[[^]]*\]//' | awk '$1 == "deb" { print $2 }'
        } | grep -E '^https?://' | grep -v -- '-security' | grep -E '/debian/?$' | head -n1
    ) || true
    echo "${uri:-http://deb.debian.org/debian}"
}

# Runs the harness again ($SELF "$@") in a private mount + pid namespace, and any further
# namespaces in $NAMESPACES ("--net --ipc"): whatever the step mounts or starts is gone when it
# ends, even if the harness is killed outright.
in_private_ns() {
    # shellcheck disable=SC2086
    setpriv --pdeathsig SIGKILL \
        unshare --mount --propagation private --pid --fork --mount-proc ${NAMESPACES:-} \
        --kill-child=SIGKILL bash "$SELF" "$@"
}

# Mounts needed to run apt/pip inside a root; called in a private mount namespace.
mount_basics() {
    local r=$1
    mount -t proc proc "$r/proc"
    mount --rbind /dev "$r/dev"
    mount --rbind /sys "$r/sys"
}

chroot_env() {
    local r=$1
    shift
    chroot "$r" /usr/bin/env -i PATH=/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin \
        HOME=/root LANG=C.UTF-8 DEBIAN_FRONTEND=noninteractive "$@"
}

# Debootstrap suite $2 from mirror $3 into root $1 and install packages $4…: no docs, no
# recommends, no services started. A mirror's frozen suite (sid) may carry an expired
# Valid-Until; apt is told not to mind. Call in a private mount namespace.
bootstrap_root() {
    local r=$1 suite=$2 mirror=$3
    shift 3
    log "debootstrap $suite from $mirror"
    debootstrap --variant=minbase --components=main "$suite" "$r" "$mirror" >"$r.debootstrap.log" 2>&1 || {
        tail -n 30 "$r.debootstrap.log" >&2
        die "debootstrap failed (log: $r.debootstrap.log)"
    }
    mkdir -p "$r/etc/dpkg/dpkg.cfg.d" "$r/etc/apt/apt.conf.d"
    # Docs, man pages and translations are a large share of the download's unpack time.
    cat >"$r/etc/dpkg/dpkg.cfg.d/01-sand-nodoc" <<'DPKG'
path-exclude=/usr/share/doc/*
path-include=/usr/share/doc/*/copyright
path-exclude=/usr/share/man/*
path-exclude=/usr/share/info/*
path-exclude=/usr/share/locale/*
DPKG
    printf '%s\n' 'APT::Install-Recommends "false";' 'Acquire::Check-Valid-Until "false";' \
        >"$r/etc/apt/apt.conf.d/01-sand"
    printf '#!/bin/sh\nexit 101\n' >"$r/usr/sbin/policy-rc.d"
    chmod 755 "$r/usr/sbin/policy-rc.d"
    cp -L /etc/resolv.conf "$r/etc/resolv.conf"
    mount_basics "$r"
    log "apt-get install $*"
    {
        chroot_env "$r" apt-get update &&
            chroot_env "$r" apt-get install -y "$@"
    } >"$r.apt.log" 2>&1 || {
        tail -n 30 "$r.apt.log" >&2
        die "apt-get failed (log: $r.apt.log)"
    }
    chroot_env "$r" apt-get clean
    rm -rf "$r"/var/lib/apt/lists/* "$r.debootstrap.log" "$r.apt.log"
}
