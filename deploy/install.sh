#!/bin/sh
# Install walkmon as a service on Raspberry Pi OS / Debian (run as root from a walkmon source checkout):
#   sudo deploy/install.sh [--with-depthai] [--no-enable]
# System packages, a virtual environment in /opt/walkmon/venv, the 'walkmon' user, /var/lib/walkmon,
# the udev rule, /etc/walkmon/walkmon.toml (kept if present), and the systemd unit (enabled and started).
set -eu

PREFIX=/opt/walkmon
CONF_DIR=/etc/walkmon
DATA_DIR=/var/lib/walkmon
SRC_DIR=$(cd "$(dirname "$0")/.." && pwd)
EXTRAS=""
ENABLE=1
for arg in "$@"; do
    case "$arg" in
        --with-depthai) EXTRAS="[depthai]" ;;
        --no-enable) ENABLE=0 ;;
        -h|--help) sed -n '2,6p' "$0"; exit 0 ;;
        *) echo "install.sh: unknown option $arg" >&2; exit 2 ;;
    esac
done
if [ "$(id -u)" -ne 0 ]; then
    echo "install.sh: run as root (sudo $0)" >&2
    exit 2
fi

echo "== system packages"
export DEBIAN_FRONTEND=noninteractive
apt-get update -q
# python3-venv for the venv; libgl/libglib for OpenCV wheels; alsa-utils/pulseaudio-utils for sound alerts;
# v4l-utils to inspect cameras; sqlite3 to inspect the session database.
apt-get install -y -q python3 python3-venv python3-pip libglib2.0-0 libgl1 alsa-utils v4l-utils sqlite3
apt-get install -y -q pulseaudio-utils || true

echo "== user and directories"
if ! id walkmon >/dev/null 2>&1; then
    useradd --system --home-dir "$DATA_DIR" --no-create-home --shell /usr/sbin/nologin \
        --groups video,dialout,audio walkmon
fi
# health data: the session database is readable by the walkmon user only (an older install made it 0750/0644)
install -d -o walkmon -g walkmon -m 0700 "$DATA_DIR"
chmod 0700 "$DATA_DIR"
find "$DATA_DIR" -maxdepth 1 -type f -name 'walkmon.sqlite*' -exec chmod 0600 {} +
install -d -m 0755 "$PREFIX" "$CONF_DIR"

echo "== virtual environment in $PREFIX/venv"
python3 -m venv "$PREFIX/venv"
"$PREFIX/venv/bin/pip" install --upgrade pip wheel
"$PREFIX/venv/bin/pip" install "$SRC_DIR$EXTRAS"

echo "== configuration"
# readable by root and the service only: it may hold the dashboard's token, apprise URLs with credentials and
# the wearer's name (an older install made it 0644)
if [ ! -e "$CONF_DIR/walkmon.toml" ]; then
    install -m 0640 -o root -g walkmon "$SRC_DIR/deploy/walkmon.toml" "$CONF_DIR/walkmon.toml"
else
    echo "keeping existing $CONF_DIR/walkmon.toml"
    chgrp walkmon "$CONF_DIR/walkmon.toml"
    chmod o-rwx,g-w "$CONF_DIR/walkmon.toml"
fi
"$PREFIX/venv/bin/walkmon" config --check "$CONF_DIR/walkmon.toml"  # as 'walkmon live' reads it: URLs, files

echo "== udev rule"
install -m 0644 "$SRC_DIR/deploy/99-walkmon.rules" /etc/udev/rules.d/99-walkmon.rules
udevadm control --reload-rules 2>/dev/null || true
udevadm trigger 2>/dev/null || true

echo "== systemd unit"
install -m 0644 "$SRC_DIR/systemd/walkmon.service" /etc/systemd/system/walkmon.service
# the unit allows no IP sockets: a dashboard ([serve] enabled) or apprise alerts need the network drop-in
if "$PREFIX/venv/bin/python" -c "import sys; from walkmon.live.config import read_config; \
c = read_config('$CONF_DIR/walkmon.toml'); sys.exit(0 if c.serve.enabled or c.sinks.apprise_urls else 1)"; then
    install -D -m 0644 "$SRC_DIR/systemd/walkmon-network.conf" /etc/systemd/system/walkmon.service.d/network.conf
    echo "dashboard or apprise alerts configured: installed the network drop-in (walkmon.service.d/network.conf)"
fi
systemctl daemon-reload
if [ "$ENABLE" -eq 1 ]; then
    systemctl enable --now walkmon.service
    echo "walkmon is running: journalctl -u walkmon -f ; sessions: sudo -u walkmon $PREFIX/venv/bin/walkmon sessions list --data-dir $DATA_DIR"
else
    echo "installed; start with: systemctl enable --now walkmon"
fi
