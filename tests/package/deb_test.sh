#!/usr/bin/env bash
# The Debian package, built, inspected, installed into a throwaway root and run there.
#
#   deb_test.sh BUILD_DIR SOURCE_DIR
#
# 1. Build: a copy of the source tree (debian/ writes into its tree) with
#    `AJAR_PREBUILT_DIR=BUILD_DIR dpkg-buildpackage -b`: debian/rules' test-only shortcut that
#    packages the Release tree just built (CMake component installs) instead of compiling again
#    (CI has 2 cores). Everything after the compile step is debhelper's normal sequence.
# 2. Contents and control data (dpkg-deb -c / -I / -e): the files of both packages, the conffile,
#    the maintainer scripts (unit enabled not started, ajar-card group created), the dependencies.
# 3. lintian: no error or warning except the justified overrides in debian/*.lintian-overrides.
# 4. Install into a throwaway root: an overlay of this machine's root filesystem (read-only lower
#    layer, a temporary upper layer) in a private mount namespace (unshare --mount), chroot'ed;
#    `apt-get install ./ajar_*.deb ./ajar-dev_*.deb` there (the dependencies are already installed
#    in the lower layer, so nothing is downloaded). In that root: the conffile is registered, the
#    group exists, the unit is enabled and passes `systemd-analyze verify` (installed paths, man
#    pages included) with an exposure <= 2.0, `man ajarctl` renders, `ajard --check-config
#    /etc/ajar/ajard.yaml` passes, the installed ajard runs the simulated drivers from the
#    installed example config (card simulator found in LIBDIR/ajar) and the installed ajarctl
#    gets its status and passes the conformance suite (installed golden vectors); then
#    `dpkg --purge ajar` removes the conffile. Where no overlay can be mounted (an unprivileged
#    container), the test says so and instead extracts the package (dpkg-deb -x) and runs the same
#    checks on the extracted tree: ajard and ajarctl find their files relative to themselves
#    (AJAR_DEB_TEST_EXTRACT=1 forces this path).
set -euo pipefail
build=$(realpath "$1") src=$(realpath "$2")
tmp=$(mktemp -d "${TMPDIR:-/tmp}/ajar-deb.XXXXXX")
cleanup() { rm -rf "$tmp"; }
trap cleanup EXIT
fail() { echo "FAIL: $*"; exit 1; }

# ---- 1. build -----------------------------------------------------------------------------------
mkdir "$tmp/src"
# The top-level entries are listed first and tarred by name: scripts/test starts the next stage's
# build (build-asan/, build-logs/) beside these tests, and a tar of "." fails ("file changed as we
# read it") when a top-level entry appears while it reads. node_modules (the browser tests') is not
# a source of the package.
mapfile -t entries < <(find "$src" -mindepth 1 -maxdepth 1 ! -name 'build*' ! -name .git \
  ! -name 'obj-*' ! -name node_modules -printf '%P\n')
tar -C "$src" -cf - "${entries[@]}" | tar -C "$tmp/src" -xf -
(cd "$tmp/src" && AJAR_PREBUILT_DIR=$build dpkg-buildpackage -b -us -uc >"$tmp/build.log" 2>&1) ||
  { tail -n 40 "$tmp/build.log"; fail "dpkg-buildpackage"; }
version=$(cd "$tmp/src" && dpkg-parsechangelog -S Version)
arch=$(dpkg --print-architecture)
deb=$tmp/ajar_${version}_${arch}.deb
dev=$tmp/ajar-dev_${version}_${arch}.deb
[[ -f $deb && -f $dev ]] || { ls "$tmp"; fail "packages not built"; }
echo "built $(basename "$deb") ($(stat -c %s "$deb") bytes), $(basename "$dev")"

# ---- 2. contents ----------------------------------------------------------------------------------
contents=$(dpkg-deb -c "$deb" | awk '{print $6}')
grep -Eq '^\./usr/lib/([^/]+/)?ajar/libajar_gts_sim\.so$' <<<"$contents" || fail "ajar lacks the card simulator"
for f in ./usr/sbin/ajard ./usr/bin/ajarctl ./usr/bin/ajar-armsim \
  ./etc/ajar/ajard.yaml ./lib/systemd/system/ajard.service ./lib/udev/rules.d/60-ajar.rules \
  ./usr/lib/sysusers.d/ajar.conf ./usr/share/ajar/examples/ajard.sim.yaml \
  ./usr/share/ajar/examples/systemd/ajard-site-devices.conf ./usr/share/ajar/vectors/ping.vec \
  ./usr/share/bash-completion/completions/ajarctl ./usr/share/man/man8/ajard.8.gz \
  ./usr/share/man/man1/ajarctl.1.gz ./usr/share/man/man1/ajar-armsim.1.gz \
  ./usr/share/man/man5/ajard.yaml.5.gz ./usr/share/doc/ajar/copyright \
  ./usr/share/doc/ajar/operations.md.gz; do
  grep -qx -- "$f" <<<"$contents" || fail "ajar lacks $f"
done
grep -q '^./usr/share/ajar/examples/scenarios/.*\.yaml$' <<<"$contents" || fail "ajar lacks scenarios"
if grep -Eq '\.(a|hpp|pc)$|/cmake/' <<<"$contents"; then fail "development files in ajar"; fi
dev_contents=$(dpkg-deb -c "$dev" | awk '{print $6}')
for f in ./usr/include/ajar/client/client.hpp ./usr/include/ajar/protocol/messages.hpp \
  ./usr/include/ajar/core/types.hpp ./usr/include/ajar/version.hpp; do
  grep -qx -- "$f" <<<"$dev_contents" || fail "ajar-dev lacks $f"
done
for pattern in '/libajar_client\.a$' '/libajar_protocol\.a$' '/libajar_core\.a$' \
  '/cmake/ajar/ajarConfig\.cmake$' '/cmake/ajar/ajarConfigVersion\.cmake$' '/pkgconfig/ajar\.pc$'; do
  grep -Eq -- "$pattern" <<<"$dev_contents" || fail "ajar-dev lacks $pattern"
done
if grep -Eq 'cli\.hpp|sbin|/etc/' <<<"$dev_contents"; then fail "ajarctl or daemon files in ajar-dev"; fi
dpkg-deb -e "$deb" "$tmp/control"
[[ $(cat "$tmp/control/conffiles") == /etc/ajar/ajard.yaml ]] || fail "conffiles: $(cat "$tmp/control/conffiles")"
grep -q "systemd-sysusers.*ajar.conf" "$tmp/control/postinst" || fail "postinst does not create the group"
grep -q "deb-systemd-helper enable 'ajard.service'" "$tmp/control/postinst" || fail "unit not enabled"
if grep -q "invoke-rc.d\|deb-systemd-invoke start" "$tmp/control/postinst"; then
  fail "postinst starts ajard (it must wait for the site's config)"
fi
depends=$(dpkg-deb -f "$deb" Depends)
for d in libserial libsystemd0 libyaml-cpp libspdlog; do
  grep -q "$d" <<<"$depends" || fail "Depends lacks $d: $depends"
done
dpkg-deb -I "$deb" | sed -n '/conffiles/p;/Depends/p'

# ---- 3. lintian -----------------------------------------------------------------------------------
# pkg-config-unavailable-for-cross-compilation: only this prebuilt test package has ajar.pc in
# /usr/lib/pkgconfig (the Release tree's libdir is lib); dpkg-buildpackage proper installs it in
# /usr/lib/<triplet>/pkgconfig.
if command -v lintian >/dev/null; then
  lintian_rc=0
  lintian --fail-on error,warning --suppress-tags pkg-config-unavailable-for-cross-compilation \
    "$deb" "$dev" >"$tmp/lintian.log" 2>&1 || lintian_rc=$?
  grep -v "running with root privileges" "$tmp/lintian.log" || true
  ((lintian_rc == 0)) || fail "lintian"
  echo "lintian: clean (overrides: debian/*.lintian-overrides)"
else
  fail "lintian not installed (scripts/install-deps installs it)"
fi

# ---- 4. install and run ---------------------------------------------------------------------------
# Runs in ROOT ("/" in the chroot, or the extracted tree): checks that need an installed system
# are skipped for the extracted tree.
cat >"$tmp/in-root.sh" <<'IN'
#!/bin/bash
set -euo pipefail
root=$1 mode=$2 work=$3
fail() { echo "FAIL ($mode): $*"; exit 1; }
ajard=$root/usr/sbin/ajard ajarctl=$root/usr/bin/ajarctl
if [[ $mode == installed ]]; then
  dpkg-query -W -f='${Conffiles}\n' ajar | grep -q '/etc/ajar/ajard.yaml' || fail "conffile not registered"
  getent group ajar-card >/dev/null || fail "group ajar-card not created"
  [[ -L /etc/systemd/system/multi-user.target.wants/ajard.service ]] || fail "unit not enabled"
  systemd-analyze verify /lib/systemd/system/ajard.service || fail "systemd-analyze verify"
  exposure=$(systemd-analyze security --offline=yes /lib/systemd/system/ajard.service 2>&1 |
             sed -n 's/.*Overall exposure level for ajard.service: \([0-9.]*\).*/\1/p')
  awk -v e="$exposure" 'BEGIN { exit !(e != "" && e <= 2.0) }' || fail "exposure '$exposure' > 2.0"
  echo "systemd-analyze verify: clean; exposure $exposure"
  MANPAGER=cat MANWIDTH=80 man ajarctl 2>/dev/null | grep -q "ajarctl - command-line client" || fail "man ajarctl"
  MANPAGER=cat man 5 ajard.yaml 2>/dev/null | grep -q "deadman_timeout_s" || fail "man 5 ajard.yaml"
  MANPAGER=cat man 8 ajard 2>/dev/null | grep -q "\-\-check-config" || fail "man 8 ajard"
  echo "man ajarctl, man 8 ajard, man 5 ajard.yaml: render"
fi
"$ajard" --check-config "$root/etc/ajar/ajard.yaml" >"$work/effective.yaml" || fail "ajard --check-config"
grep -q "kind: real" "$work/effective.yaml" || fail "the robot config should select the real drivers"
echo "ajard --check-config $root/etc/ajar/ajard.yaml: valid"
"$ajard" --config "$root/usr/share/ajar/examples/ajard.sim.yaml" --listen 127.0.0.1:0 \
  --port-file "$work/port" --state-dir "$work/state" >"$work/ajard.log" 2>&1 &
pid=$!
# A failed check below must not leave this ajard running (it outlives the test's mount namespace).
trap 'kill -KILL $pid 2>/dev/null || true' EXIT
for _ in $(seq 1 200); do [[ -s $work/port ]] && break; kill -0 $pid 2>/dev/null || break; sleep 0.05; done
[[ -s $work/port ]] || { cat "$work/ajard.log"; fail "ajard did not start on the simulated drivers"; }
port=$(cat "$work/port")
"$ajarctl" --connect "127.0.0.1:$port" status >"$work/status.txt" || fail "ajarctl status"
grep -q "card / arm: *active / active" "$work/status.txt" ||
  { cat "$work/status.txt"; fail "card simulator or arm simulator not active"; }
"$ajarctl" --connect "127.0.0.1:$port" conformance >"$work/conformance.txt" ||
  { grep -v ^PASS "$work/conformance.txt"; fail "conformance"; }
grep -q "vectors: found in $root/usr/share/ajar/vectors" "$work/conformance.txt" ||
  fail "ajarctl did not use the installed vectors"
echo "installed ajard on simulated drivers: $(tail -n 1 "$work/conformance.txt") (installed vectors)"
kill -TERM $pid
wait $pid || fail "ajard did not exit 0 on SIGTERM"
if [[ $mode == installed ]]; then
  dpkg --purge ajar-dev ajar >/dev/null || fail "purge"
  [[ ! -e /etc/ajar/ajard.yaml && ! -e /usr/sbin/ajard ]] || fail "purge left files"
  echo "dpkg --purge: conffile and binaries removed"
fi
IN
chmod +x "$tmp/in-root.sh"

overlay_root() {
  local o=$tmp/overlay
  mkdir -p "$o/upper" "$o/work" "$o/merged"
  unshare --mount --fork bash -euo pipefail -c '
    o=$1 tmp=$2
    mount --make-rprivate /
    mount -t overlay overlay -o "lowerdir=/,upperdir=$o/upper,workdir=$o/work" "$o/merged"
    mount --rbind /dev "$o/merged/dev"
    mount -t proc proc "$o/merged/proc"
    mount -t tmpfs tmpfs "$o/merged/tmp"
    mount -t tmpfs tmpfs "$o/merged/run"
    mkdir -p "$o/merged/mnt/ajar"
    mount --bind "$tmp" "$o/merged/mnt/ajar"
    exec chroot "$o/merged" /bin/bash -euo pipefail -c "
      cd /mnt/ajar
      export DEBIAN_FRONTEND=noninteractive
      apt-get install -y -q /mnt/ajar/$(basename "$3") /mnt/ajar/$(basename "$4") >/mnt/ajar/apt.log 2>&1 ||
        { tail -n 30 /mnt/ajar/apt.log; echo \"FAIL: apt-get install\"; exit 1; }
      echo \"installed with apt-get install ./$(basename "$3") ./$(basename "$4") into the overlay root\"
      mkdir -p /tmp/work
      /mnt/ajar/in-root.sh \"\" installed /tmp/work
    "' _ "$o" "$tmp" "$deb" "$dev"
}

if [[ "${AJAR_DEB_TEST_EXTRACT:-0}" != 1 ]] && unshare --mount --fork sh -c "mkdir -p '$tmp/probe/u' '$tmp/probe/w' '$tmp/probe/m' &&
    mount -t overlay overlay -o 'lowerdir=/,upperdir=$tmp/probe/u,workdir=$tmp/probe/w' '$tmp/probe/m'" \
    2>/dev/null; then
  overlay_root
else
  echo "NOTE: cannot mount an overlay root here (no CAP_SYS_ADMIN?): extracting with dpkg-deb -x" \
       "and running the extracted ajard/ajarctl instead"
  mkdir -p "$tmp/root" "$tmp/work"
  dpkg-deb -x "$deb" "$tmp/root"
  "$tmp/in-root.sh" "$tmp/root" extracted "$tmp/work"
  [[ -e "$tmp/root/lib/systemd/system/ajard.service" ]] &&
    systemd-analyze verify --man=no --root="$tmp/root" /lib/systemd/system/ajard.service ||
    echo "NOTE: systemd-analyze verify --root not conclusive here"
fi
echo "Debian package test passed"
