"""Generate docs/closures.md: every closure and equilibrium law with its options, defaults and units.

Run: python docs/make_reference.py   (the same as ``python -m granflow.rheology.docs docs/closures.md``;
tests/unit/test_closures_page.py checks the committed page is current). The text is
:func:`granflow.rheology.docs.closures_markdown`.
"""
from __future__ import annotations

from pathlib import Path

from granflow.rheology.docs import closures_markdown

OUT = Path(__file__).with_name("closures.md")
render = closures_markdown  # the name tests/integration/test_docs.py reads


if __name__ == "__main__":
    OUT.write_text(render())
    print(f"wrote {OUT}")
