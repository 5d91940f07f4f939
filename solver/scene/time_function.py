"""The time-function keys that loads and prescribed motions share (kind,
amplitude, omega, duration, start, table): which of them a kind needs and
which it does not use.  Part of the scene schema."""
from __future__ import annotations

from solver.scene.schema import fail

NEEDS = {"sine": ("omega",), "half_sine": ("duration",), "rectangular": ("duration",),
         "tabulated": ("table",)}


def check(spec, path: str, noun: str):
    """Refuse the keys ``spec``'s kind lacks or does not use (``noun``: what the
    function drives, for the message: load, motion)."""
    if spec.kind == "tabulated" and spec.amplitude != 1.0:
        fail(f"{path}.amplitude", f"not used by a tabulated {noun} (its table holds the values)")
    if spec.kind in ("sine", "tabulated") and spec.start != 0.0:
        fail(f"{path}.start", f"not used by a {spec.kind} {noun} (it starts at t = 0)")
    need = NEEDS[spec.kind]
    for name in ("omega", "duration", "table"):
        given = getattr(spec, name) is not None
        if name in need and not given:
            fail(f"{path}.{name}", f"required for a {spec.kind} {noun}")
        if name not in need and given:
            fail(f"{path}.{name}", f"not used by a {spec.kind} {noun}")
    if spec.kind == "tabulated":
        rows = spec.table
        if len(rows) < 2 or any(len(r) != 2 for r in rows):
            fail(f"{path}.table", "needs at least two [t, value] rows")
        ts = [r[0] for r in rows]
        if any(b <= a for a, b in zip(ts, ts[1:])):
            fail(f"{path}.table", "times must increase strictly")
