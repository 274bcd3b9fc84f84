"""Checks of input files before a subcommand reads them, so that a bad one is reported by name."""

from __future__ import annotations

import os
import stat
from pathlib import Path


def text_file(path) -> Path:
    """``path`` when it is a UTF-8 text file; a ``ValueError`` (or ``OSError``) naming it otherwise."""
    path = Path(path)
    data = path.read_bytes()
    try:
        data.decode("utf-8")
    except UnicodeDecodeError as exc:
        byte = data[exc.start]
        raise ValueError(f"{path}: not a text file (byte {byte:#04x} at offset {exc.start})") from None
    return path


def serial_device(port: str) -> str:
    """``port`` when it is a character device (a serial port, a pty); ``ValueError`` naming it otherwise."""
    try:
        mode = os.stat(port).st_mode
    except OSError as exc:
        raise ValueError(f"{port}: {exc.strerror}") from None
    if not stat.S_ISCHR(mode):
        raise ValueError(f"{port}: not a serial device")
    return port
