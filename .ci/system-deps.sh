#!/usr/bin/env bash
# System libraries aion's Python packages need and pip cannot install: libusb-1.0, which open3d's
# wheel links against (`aion export` fails without it). Installed with the machine's package
# manager when it is missing (as root, or through sudo without a password prompt); otherwise
# the script says what to run and fails, so `make demo` never ends in an obscure ImportError.
set -euo pipefail

has_libusb() {
    if command -v ldconfig >/dev/null 2>&1 && ldconfig -p 2>/dev/null | grep -q 'libusb-1.0.so.0'; then
        return 0
    fi
    if [ -x /sbin/ldconfig ] && /sbin/ldconfig -p 2>/dev/null | grep -q 'libusb-1.0.so.0'; then
        return 0
    fi
    python3 -c 'import ctypes.util, sys; sys.exit(0 if ctypes.util.find_library("usb-1.0") else 1)' 2>/dev/null
}

if has_libusb; then
    exit 0
fi

SUDO=""
if [ "$(id -u)" != 0 ]; then
    if command -v sudo >/dev/null 2>&1 && sudo -n true 2>/dev/null; then
        SUDO="sudo -n"
    else
        SUDO="none"
    fi
fi

if [ "$SUDO" != none ]; then
    if command -v apt-get >/dev/null 2>&1; then
        echo "installing libusb-1.0 (open3d needs it): apt-get install libusb-1.0-0"
        $SUDO apt-get update -qq
        DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq libusb-1.0-0
    elif command -v dnf >/dev/null 2>&1; then
        echo "installing libusb-1.0 (open3d needs it): dnf install libusb1"
        $SUDO dnf install -y -q libusb1
    elif command -v apk >/dev/null 2>&1; then
        echo "installing libusb-1.0 (open3d needs it): apk add libusb"
        $SUDO apk add -q libusb
    fi
fi

if ! has_libusb; then
    echo "error: the system library libusb-1.0 is missing (open3d, used by aion export, links against it)" >&2
    echo "hint: install it, then rerun make: sudo apt-get install libusb-1.0-0 (Debian/Ubuntu)," \
        "sudo dnf install libusb1 (Fedora), brew install libusb (macOS)" >&2
    exit 1
fi
