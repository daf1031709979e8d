"""Percentiles and per-label summaries, kept dependency-free so results can be re-rendered anywhere."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

__all__ = ["percentile", "slope_per_minute", "summarise"]


def percentile(values: Sequence[float], q: float) -> float | None:
    """Nearest-rank percentile (q in 0..100): a value that was really observed, never interpolated."""
    if not values:
        return None
    ordered = sorted(values)
    rank = max(1, math.ceil(q / 100.0 * len(ordered)))
    return ordered[min(rank, len(ordered)) - 1]


def summarise(entry: dict[str, Any], duration: float) -> dict[str, Any]:
    """Counts, rate and latency percentiles (ms) of one label's merged tallies."""
    latency = sorted(entry["latency_ms"])
    out: dict[str, Any] = {
        "clients": entry["clients"],
        "ok": entry["ok"],
        "errors": entry["errors"],
        "reconnects": entry["reconnects"],
        "rate_per_s": round(entry["ok"] / duration, 1) if duration > 0 else None,
        "error_samples": list(entry["error_samples"])[:5],
    }
    if latency:
        out.update({
            "p50_ms": round(percentile(latency, 50) or 0.0, 2),
            "p90_ms": round(percentile(latency, 90) or 0.0, 2),
            "p99_ms": round(percentile(latency, 99) or 0.0, 2),
            "p999_ms": round(percentile(latency, 99.9) or 0.0, 2),
            "max_ms": round(latency[-1], 2),
            "mean_ms": round(sum(latency) / len(latency), 3),
        })
    for name, values in entry.get("extra", {}).items():
        ordered = sorted(values)
        if ordered:
            out[f"{name}_p50"] = round(percentile(ordered, 50) or 0.0, 3)
            out[f"{name}_p99"] = round(percentile(ordered, 99) or 0.0, 3)
            out[f"{name}_max"] = round(ordered[-1], 3)
            out[f"{name}_n"] = len(ordered)
    return out


def slope_per_minute(points: Sequence[tuple[float, float]]) -> float | None:
    """Least-squares slope of (seconds, value) points, per minute."""
    if len(points) < 3:
        return None
    n = len(points)
    mean_t = sum(t for t, _ in points) / n
    mean_v = sum(v for _, v in points) / n
    var = sum((t - mean_t) ** 2 for t, _ in points)
    if var == 0:
        return None
    cov = sum((t - mean_t) * (v - mean_v) for t, v in points)
    return cov / var * 60.0
