"""Find a ZWO mount on this machine's serial ports: ``--device auto`` and ``--list-devices``.

A ZWO AM3/AM5/AM5N/AM7 on USB is a CDC-ACM device with VID 03c3, PID 4001. pyserial's port
listing reports USB IDs on Linux, macOS and Windows, so that is the first and main test. A port
whose IDs the OS does not show (a container without sysfs, a driver that hides them) but whose
name says it is a USB modem-class port is asked for the mount's model (``:GVP#``, a read-only
query) with a short timeout; so are ports named with ``--probe``. Ports that are identified as
some other USB device, and built-in UARTs (possibly a console or a GPS), are never opened: asking
them would disturb a device that is not ours.

Errors carry what to do about them, because they are read by someone at a telescope at night.
"""

from __future__ import annotations

import concurrent.futures
import errno
import os
import re
import sys
from dataclasses import dataclass, replace
from pathlib import Path

from .._exceptions import AlpacaZwoError

__all__ = [
    "ZWO_PID",
    "ZWO_VID",
    "Candidate",
    "DeviceError",
    "check_device",
    "find_mount",
    "format_candidates",
    "list_candidates",
]

ZWO_VID = 0x03C3
ZWO_PID = 0x4001
PROBE_TIMEOUT_S = 0.6  # a mount answers :GVP# in ~20 ms at 9600 baud; anything slower is not one
STABLE_NAMES = ("/dev/zwo-mount",)  # deploy/99-zwo-mount.rules
_MODEL_REPLY = re.compile(rb"^(AM\d{1,2}[A-Z]{0,2})#$")  # AM3, AM5, AM5N, AM7, and suffixes to come
_MODEM_NAME = re.compile(r"(ttyACM\d+|usbmodem|^COM\d+$)", re.IGNORECASE)

PERMISSION_ADVICE = (
    "add your user to the dialout group (sudo usermod -aG dialout $USER), then log out and in again "
    "(or reboot); or install the udev rule deploy/99-zwo-mount.rules from the source "
    "(sudo cp deploy/99-zwo-mount.rules /etc/udev/rules.d/ && sudo udevadm control --reload && sudo udevadm trigger)"
)
BUSY_ADVICE = (
    "another program has the port open: close the ZWO app's or ASIAIR's USB connection, or the other "
    "ASCOM/INDI driver, or let that program use the mount through this server instead"
)
NOT_FOUND_ADVICE = (
    "check that the mount is switched on and its USB cable is plugged in (it shows as USB 03c3:4001: "
    "/dev/ttyACM* on Linux, /dev/cu.usbmodem* on macOS, a COM port on Windows); over WiFi use "
    "--device socket://192.168.4.1:4030; `alpaca-zwo --list-devices` shows every port and what answered"
)


class DeviceError(AlpacaZwoError):
    """No usable mount port: the message says what was seen and what to do."""


@dataclass(frozen=True)
class Candidate:
    """One port as found: what the OS says it is, and what it answered if it was asked."""

    device: str
    what: str
    usb_ids: str | None = None
    zwo_usb: bool = False
    probe: bool = False  # whether asking it :GVP# is allowed
    answer: str = "not asked"
    model: str | None = None
    problem: str | None = None  # "permission", "busy", "missing" when opening failed that way

    @property
    def is_mount(self) -> bool:
        return self.model is not None


def _listed_ports() -> list[Candidate]:
    from serial.tools import list_ports

    found = []
    for info in list_ports.comports():
        ids = f"{info.vid:04x}:{info.pid:04x}" if info.vid is not None and info.pid is not None else None
        description = info.description if info.description and info.description != "n/a" else ""
        if info.vid == ZWO_VID and info.pid == ZWO_PID:
            found.append(Candidate(info.device, f"ZWO mount on USB ({description or 'CDC-ACM'})", ids, True, True))
        elif ids is not None:
            label = " ".join(x for x in (description, info.manufacturer or "") if x) or "USB serial device"
            found.append(Candidate(info.device, f"another USB device: {label} (not asked)", ids))
        elif _MODEM_NAME.search(info.device):
            found.append(Candidate(info.device, "USB modem-class port with no USB IDs shown", probe=True))
        else:
            found.append(Candidate(info.device, "built-in serial port (not asked: it may be a console or a GPS)"))
    return found


def list_candidates(extra: list[str] | tuple[str, ...] = (), timeout: float = PROBE_TIMEOUT_S) -> list[Candidate]:
    """Every port seen, with the probe-able ones asked for the mount's model (in parallel)."""
    candidates = _listed_ports()
    seen = {os.path.realpath(c.device) for c in candidates}
    for name in (*STABLE_NAMES, *extra):
        if name in extra or os.path.exists(name):
            real = os.path.realpath(name)
            if real in seen and name not in extra:
                continue
            seen.add(real)
            what = "named with --probe" if name in extra else "the udev rule's stable name"
            candidates.append(Candidate(name, what, probe=True))
    with concurrent.futures.ThreadPoolExecutor(max_workers=max(1, len(candidates))) as pool:
        return list(pool.map(lambda c: _probe(c, timeout) if c.probe else c, candidates))


def _classify_open_error(exc: Exception, device: str) -> tuple[str, str]:
    """(problem, human text) for a failed open, from its errno or, on Windows, its message."""
    code = getattr(exc, "errno", None)
    text = str(exc)
    if code == errno.ENOENT or "FileNotFoundError" in text or "cannot find the file" in text:
        return "missing", f"{device} does not exist"
    if code == errno.EBUSY or code == errno.EAGAIN or "exclusively lock" in text or (
        sys.platform == "win32" and ("Access is denied" in text or "PermissionError" in text)
    ):
        return "busy", f"{device} is busy: {BUSY_ADVICE}"
    if code == errno.EACCES or "Permission denied" in text:
        return "permission", f"permission denied on {device}: {PERMISSION_ADVICE}"
    return "error", f"cannot open {device}: {text}"


def _probe(candidate: Candidate, timeout: float) -> Candidate:
    """Ask one port ``:GVP#`` once; never more than ``timeout`` of waiting, never a second command."""
    import serial

    port = serial.Serial()
    port.port = candidate.device
    port.baudrate = 9600
    port.timeout = timeout
    port.write_timeout = timeout
    if not candidate.zwo_usb:  # do not pull DTR/RTS on a port that may be something else
        port.dtr = False
        port.rts = False
    if os.name == "posix":
        port.exclusive = True  # and do not read replies meant for another program
    try:
        port.open()
    except (OSError, serial.SerialException) as exc:
        problem, text = _classify_open_error(exc, candidate.device)
        return replace(candidate, answer=text, problem=problem)
    try:
        port.reset_input_buffer()
        port.write(b":GVP#")
        reply = port.read_until(b"#", 32)
    except (OSError, serial.SerialException) as exc:
        return replace(candidate, answer=f"failed while asking: {exc}")
    finally:
        port.close()
    match = _MODEL_REPLY.match(reply.strip())
    if match:
        model = match.group(1).decode()
        return replace(candidate, answer=f"answered :GVP# with {reply.decode()!r}: ZWO {model}", model=model)
    if not reply:
        return replace(candidate, answer=f"no answer to :GVP# within {timeout:g} s: not a ZWO mount")
    return replace(candidate, answer=f"answered :GVP# with {reply[:24]!r}: not a ZWO mount")


def _stable_name(device: str) -> str:
    """A name that survives re-plugging (the udev rule's or /dev/serial/by-id), else ``device``."""
    real = os.path.realpath(device)
    names = [Path(n) for n in STABLE_NAMES]
    by_id = Path("/dev/serial/by-id")
    if by_id.is_dir():
        names += sorted(by_id.iterdir())
    for name in names:
        if name.exists() and os.path.realpath(name) == real:
            return str(name)
    return device


def format_candidates(candidates: list[Candidate]) -> str:
    """The ``--list-devices`` table: one port per line, what it is, what answered."""
    if not candidates:
        return "no serial ports found"
    width = max(len(c.device) for c in candidates)
    lines = []
    for c in candidates:
        ids = f"USB {c.usb_ids}, " if c.usb_ids else ""
        asked = f"; {c.answer}" if c.probe else ""
        lines.append(f"{c.device:<{width}}  {ids}{c.what}{asked}")
    return "\n".join(lines)


def find_mount(extra: list[str] | tuple[str, ...] = (), timeout: float = PROBE_TIMEOUT_S) -> str:
    """The port of the one ZWO mount attached (its stable name where there is one), or DeviceError."""
    candidates = list_candidates(extra, timeout)
    mounts = [c for c in candidates if c.is_mount]
    if len(mounts) == 1:
        return _stable_name(mounts[0].device)
    if len(mounts) > 1:
        names = ", ".join(c.device for c in mounts)
        raise DeviceError(f"several ZWO mounts answered ({names}): choose one with --device PORT")
    zwo = [c for c in candidates if c.zwo_usb]
    for c in zwo:  # a mount is there by its USB IDs, but it could not be asked
        if c.problem in ("permission", "busy"):
            raise DeviceError(c.answer)
    if len(zwo) == 1 and zwo[0].problem is None:
        # Found by its USB IDs but silent (still booting?): use it; the link retries until it talks.
        return _stable_name(zwo[0].device)
    seen = "; ".join(f"{c.device} ({c.answer if c.probe else c.what})" for c in candidates) or "none"
    raise DeviceError(f"no ZWO mount found. Ports seen: {seen}. What to do: {NOT_FOUND_ADVICE}")


def check_device(device: str) -> str | None:
    """For an explicit local port: a warning (with what to do) if it is missing, or None.

    A permission problem is an error (the server could never open the port), so it raises
    DeviceError; a missing port is only a warning, because the mount may be switched on later
    and the link keeps retrying.
    """
    if "://" in device or os.name != "posix":
        return None  # URLs and Windows COM ports are checked by opening them, in the link
    if not os.path.exists(device):
        seen = ", ".join(c.device for c in _listed_ports()) or "none"
        return f"{device} does not exist (yet); ports seen: {seen}. {NOT_FOUND_ADVICE}; the server keeps trying"
    if not os.access(device, os.R_OK | os.W_OK):
        raise DeviceError(f"permission denied on {device}: {PERMISSION_ADVICE}")
    return None
