#!/bin/sh
# Remove the walkmon service installed by deploy/install.sh:
#   sudo deploy/uninstall.sh [--purge]
# Stops and disables the unit, removes it, the udev rule and /opt/walkmon. The configuration
# (/etc/walkmon), the session database (/var/lib/walkmon) and the 'walkmon' user are kept unless --purge.
set -eu

PURGE=0
for arg in "$@"; do
    case "$arg" in
        --purge) PURGE=1 ;;
        -h|--help) sed -n '2,5p' "$0"; exit 0 ;;
        *) echo "uninstall.sh: unknown option $arg" >&2; exit 2 ;;
    esac
done
if [ "$(id -u)" -ne 0 ]; then
    echo "uninstall.sh: run as root (sudo $0)" >&2
    exit 2
fi

systemctl disable --now walkmon.service 2>/dev/null || true
rm -f /etc/systemd/system/walkmon.service
systemctl daemon-reload 2>/dev/null || true
rm -f /etc/udev/rules.d/99-walkmon.rules
udevadm control --reload-rules 2>/dev/null || true
rm -rf /opt/walkmon
if [ "$PURGE" -eq 1 ]; then
    rm -rf /etc/walkmon /var/lib/walkmon
    if id walkmon >/dev/null 2>&1; then userdel walkmon; fi
    echo "walkmon removed, with its configuration, sessions and user"
else
    echo "walkmon removed; kept /etc/walkmon and /var/lib/walkmon (use --purge to delete them)"
fi
