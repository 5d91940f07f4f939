"""Where benchmarks put their tables: results/<name>.md (printed too)."""
from __future__ import annotations

from pathlib import Path


def write(name: str, lines) -> Path:
    """Write the Markdown ``lines`` to results/<name>.md and print them."""
    text = "\n".join(lines)
    out = Path("results") / f"{name}.md"
    out.parent.mkdir(exist_ok=True)
    out.write_text(text + "\n")
    print(text)
    return out
