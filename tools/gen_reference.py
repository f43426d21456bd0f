#!/usr/bin/env python
"""Write docs/reference.md: the options of every registered capability (polypack._reference).

Run after adding or changing a capability's options dataclass:

    PYTHONPATH=src python tools/gen_reference.py

tests/test_declarations.py fails while the checked-in page differs from the code.
"""

from pathlib import Path

from polypack._reference import reference_markdown
from polypack._util import atomic_path

if __name__ == "__main__":
    out = Path(__file__).resolve().parent.parent / "docs" / "reference.md"
    with atomic_path(out) as tmp:
        Path(tmp).write_text(reference_markdown())
    print(f"wrote {out}")
