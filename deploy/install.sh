#!/usr/bin/env bash
# SPDX-License-Identifier: GPL-3.0-or-later
#
# Installs hdrstereo as a system service on a lab PC (Debian 12), as root:
# builds (deploy/build.sh), installs the binaries under /usr/local/bin, the
# operator's console under /usr/local/share/hdrstereo/web, the systemd unit,
# the udev rules, the config (kept if already there), creates the user
# `hdrstereo` (groups plugdev, dialout) and the data root /var/lib/hdrstereo.
# Idempotent: run it again after an update.
#
# Usage: sudo deploy/install.sh [--no-build] [--tls-from DIR]
#                               [--uninstall [--purge]]
#   --no-build   install what is in build/ without building
#   --tls-from DIR  install the daemon's TLS files from DIR, a folder of
#                deploy/make-certs.sh (server.pem, server.key, ca.pem, crl/),
#                into /etc/hdrstereo/tls, 0640 root:hdrstereo; then set
#                [tls] and listen (gRPC) or http-listen (HTTP: browsers,
#                curl) in the config (see its comments)
#   --uninstall  stop and remove the service, binaries, console, unit and udev
#                rules; keeps the config, user and data unless --purge
#   --purge      with --uninstall: also remove config, user and data root
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
prefix=/usr/local
unit=/etc/systemd/system/hdrstereod.service
config_dir=/etc/hdrstereo
data_root=/var/lib/hdrstereo
udev_dir=/etc/udev/rules.d
user=hdrstereo
binaries=(hdrstereod hdrstereo hdrstereo-proc hdrstereo-sim)
# Where the installed hdrstereod finds the console: <its folder>/../share.
web_root=$prefix/share/hdrstereo/web

build=1
uninstall=0
purge=0
tls_from=""
while [[ $# -gt 0 ]]; do
  case "$1" in
    --no-build) build=0 ;;
    --tls-from) tls_from=${2:-}; shift
      [[ -n "$tls_from" ]] || { echo "install.sh: --tls-from needs DIR" >&2; exit 2; } ;;
    --uninstall) uninstall=1 ;;
    --purge) purge=1 ;;
    -h|--help) sed -n '3,21p' "$0"; exit 0 ;;
    *) echo "install.sh: unknown argument $1" >&2; exit 2 ;;
  esac
  shift
done
if [[ -n "$tls_from" ]]; then
  for f in server.pem server.key ca.pem; do
    [[ -f "$tls_from/$f" ]] || {
      echo "install.sh: --tls-from $tls_from has no $f (deploy/make-certs.sh" \
           "makes it)" >&2; exit 2; }
  done
fi
if [[ $(id -u) -ne 0 ]]; then
  echo "install.sh: run as root (sudo)" >&2
  exit 1
fi
have_systemd() { [[ -d /run/systemd/system ]]; }

if [[ $uninstall == 1 ]]; then
  if have_systemd; then
    systemctl disable --now hdrstereod.service 2>/dev/null || true
  fi
  rm -f "$unit"
  if have_systemd; then systemctl daemon-reload; fi
  for b in "${binaries[@]}"; do rm -f "$prefix/bin/$b"; done
  rm -rf "$web_root"
  rmdir "$(dirname "$web_root")" 2>/dev/null || true
  rm -f "$udev_dir/60-hdrstereo-stage.rules" \
        "$udev_dir/60-hdrstereo-gphoto2.rules"
  udevadm control --reload 2>/dev/null || true
  if [[ $purge == 1 ]]; then
    rm -rf "$config_dir" "$data_root"
    if id "$user" >/dev/null 2>&1; then userdel "$user"; fi
    echo "hdrstereo removed, with its config, user and data"
  else
    echo "hdrstereo removed; kept $config_dir, $data_root and user $user" \
         "(--uninstall --purge removes them)"
  fi
  exit 0
fi

# 1. Build (as the invoking user when run through sudo, so build/ stays
#    theirs).
if [[ $build == 1 ]]; then
  if [[ -n "${SUDO_USER:-}" ]]; then
    sudo -u "$SUDO_USER" -H "$root/deploy/build.sh" "$root/build"
  else
    "$root/deploy/build.sh" "$root/build"
  fi
fi

# 2. Binaries.
install -d "$prefix/bin"
for b in "${binaries[@]}"; do
  path=$(find "$root/build" -type f -name "$b" -perm -u+x | head -n 1)
  if [[ -z "$path" ]]; then
    echo "install.sh: $b not found under build/ (build first)" >&2
    exit 1
  fi
  install -m 0755 "$path" "$prefix/bin/$b"
done

# 2b. The operator's console (the web_console target's build/share/hdrstereo/
#     web), replacing the one installed before.
if [[ -f "$root/build/share/hdrstereo/web/index.html" ]]; then
  rm -rf "$web_root"
  install -d -m 0755 "$web_root"
  install -m 0644 "$root"/build/share/hdrstereo/web/* "$web_root/"
else
  echo "install.sh: no console in build/share/hdrstereo/web (built with" \
       "-DHDRSTEREO_WEB=OFF?): the HTTP edge's / will say it is not installed"
fi

# 3. User and data root.
for group in plugdev dialout; do
  getent group "$group" >/dev/null || groupadd --system "$group"
done
if ! id "$user" >/dev/null 2>&1; then
  useradd --system --home-dir "$data_root" --no-create-home \
          --shell /usr/sbin/nologin --user-group "$user"
fi
usermod -a -G plugdev,dialout "$user"
install -d -m 0750 -o "$user" -g "$user" "$data_root"

# 4. Config: installed once; an existing (edited) config is kept and the
#    shipped one placed beside it for comparison.
install -d -m 0755 "$config_dir"
if [[ -f "$config_dir/hdrstereod.toml" ]]; then
  install -m 0644 "$root/deploy/config/hdrstereod.toml" \
          "$config_dir/hdrstereod.toml.dist"
else
  install -m 0644 "$root/deploy/config/hdrstereod.toml" "$config_dir/"
fi
# Refuse to go on with a config the daemon would refuse.
if ! "$prefix/bin/hdrstereod" --config "$config_dir/hdrstereod.toml" \
       --help >/dev/null; then
  echo "install.sh: $config_dir/hdrstereod.toml is refused by hdrstereod" >&2
  exit 1
fi

# 4b. TLS files: readable by the daemon's group, not by other users; the
#     CA's private key stays where it was made.
if [[ -n "$tls_from" ]]; then
  install -d -m 0750 -o root -g "$user" "$config_dir/tls" "$config_dir/tls/crl"
  for f in server.pem server.key ca.pem; do
    install -m 0640 -o root -g "$user" "$tls_from/$f" "$config_dir/tls/$f"
  done
  rm -f "$config_dir/tls/crl/"*.r0
  for crl in "$tls_from"/crl/*.r0; do
    [[ -e "$crl" ]] && install -m 0640 -o root -g "$user" "$crl" \
                         "$config_dir/tls/crl/"
  done
  echo "install.sh: TLS files in $config_dir/tls; set [tls] and listen (gRPC)" \
       "or http-listen (HTTP) in $config_dir/hdrstereod.toml, then" \
       "systemctl restart hdrstereod"
fi

# 5. udev rules: the stage symlink, and libgphoto2's camera rules when its
#    generator is installed.
# (The folders may be missing on a machine without udev or systemd yet.)
install -d -m 0755 "$udev_dir"
install -m 0644 "$root/deploy/udev/60-hdrstereo-stage.rules" "$udev_dir/"
generator=$(find /usr/lib -path '*libgphoto2/print-camera-list' -type f \
              2>/dev/null | head -n 1)
if [[ -n "$generator" ]]; then
  "$generator" udev-rules version 201 group plugdev mode 0660 \
    > "$udev_dir/60-hdrstereo-gphoto2.rules"
else
  echo "install.sh: libgphoto2's print-camera-list not found; relying on" \
       "Debian's /lib/udev/rules.d/60-libgphoto2-6.rules (see deploy/udev/README.md)"
fi
udevadm control --reload 2>/dev/null || true
udevadm trigger 2>/dev/null || true

# 6. The unit.
install -d -m 0755 "$(dirname "$unit")"
install -m 0644 "$root/deploy/systemd/hdrstereod.service" "$unit"
if have_systemd; then
  systemctl daemon-reload
  systemctl enable hdrstereod.service
  systemctl restart hdrstereod.service
  echo "hdrstereod installed and (re)started: systemctl status hdrstereod"
else
  echo "hdrstereod installed; systemd is not running here, so the service" \
       "was not started"
fi
