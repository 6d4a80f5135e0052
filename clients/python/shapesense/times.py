"""Times as the CLI and recordings write them: seconds since the epoch with a decimal fraction."""

from __future__ import annotations


def parse_time(text: str) -> int:
    """Nanoseconds of "1600000000.033333" (exact: no float rounding), or 0 for "latest", "now"
    or "" (the newest frame). ValueError for anything else."""
    text = text.strip()
    if text in ("", "latest", "now"):
        return 0
    whole, _, frac = text.partition(".")
    if not (whole or frac) or not (whole + frac).isdigit() or not (whole + frac).isascii():
        raise ValueError(f"'{text}' is not a time: give seconds since the epoch such as "
                         "1700000000.033333, or 'latest'")
    nanos = int((frac + "000000000")[:9])
    if len(frac) > 9 and frac[9] >= "5":
        nanos += 1
    return int(whole or "0") * 1_000_000_000 + nanos


def format_ns(ns: int) -> str:
    """Seconds with nine decimals, as parse_time reads them back exactly."""
    return f"{ns // 1_000_000_000}.{ns % 1_000_000_000:09d}"
