"""The public laser logs shipped with homebot (see README.md in this folder for credit)."""

from __future__ import annotations

from pathlib import Path

HERE = Path(__file__).resolve().parent

#: Bundled logs by name: the CARMEN log and its ground-truth relations.
BUNDLED = {
    "intel": (HERE / "intel" / "intel.clf.bz2", HERE / "intel" / "intel.relations"),
    "mit-csail": (HERE / "mit-csail" / "mit-csail.clf.bz2", HERE / "mit-csail" / "mit-csail.relations"),
}

CREDIT = ("Data: Freiburg SLAM benchmark / Radish, CC-BY (Intel Research Lab log "
          "recorded by Dirk Hähnel; MIT CSAIL log; relations by Kümmerle et al. 2009).")


def resolve_log(name_or_path) -> Path:
    """A log path: an existing file, or the name of a bundled log (``intel``, ``mit-csail``)."""
    path = Path(name_or_path)
    if path.exists():
        return path
    if str(name_or_path) in BUNDLED:
        return BUNDLED[str(name_or_path)][0]
    raise FileNotFoundError(f"no log file {name_or_path!r} (bundled logs: {', '.join(BUNDLED)})")


def resolve_relations(name_or_path) -> Path:
    """A relations path: an existing file, or the name of a bundled log."""
    path = Path(name_or_path)
    if path.exists():
        return path
    if str(name_or_path) in BUNDLED:
        return BUNDLED[str(name_or_path)][1]
    raise FileNotFoundError(f"no relations file {name_or_path!r} (bundled: {', '.join(BUNDLED)})")


def is_bundled(path) -> bool:
    return any(Path(path).resolve() == log for log, _ in BUNDLED.values())
