"""The mark every PNG aion draws carries, and how a picture is told as aion's: a ``Software``
text chunk that says ``aion`` (matplotlib writes it before the pixels). Pictures are replaced
only when they carry it (``formats.outputs``' rule: aion replaces only what it wrote). Small
on purpose: the evaluation and report plots import it without the map-drawing modules."""

from __future__ import annotations

from pathlib import Path
from typing import Any

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"
PNG_SOFTWARE = "aion"
"""The ``Software`` text of every PNG aion draws."""


def save_marked_png(fig: Any, path: Any, **options: Any) -> None:
    """``fig.savefig(path, format="png", ...)`` with aion's mark (``options``: savefig's).
    A character the font lacks (a map or room named in Japanese: DejaVu Sans has no kana) is
    drawn as a box, without matplotlib's warning per character, which named a line of
    aion's source on the terminal. matplotlib 3.9 on says "missing from font(s) DejaVu Sans.",
    3.7 and 3.8 (which aion supports) "missing from current font.": both are left out."""
    import warnings

    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=r"Glyph \d+ .* missing from (current )?font")
        fig.savefig(path, format="png", metadata={"Software": PNG_SOFTWARE}, **options)


def is_aion_png(path: Path) -> bool:
    """Whether ``path`` is a PNG file aion drew (:data:`PNG_SOFTWARE`; reads 4 KiB)."""
    try:
        with open(path, "rb") as fh:
            head = fh.read(4096)
    except OSError:
        return False
    text = b"Software\x00" + PNG_SOFTWARE.encode()
    # the whole chunk's head: its length (the text's, exactly: "aionic" is someone else's)
    # and type, then the text
    chunk = len(text).to_bytes(4, "big") + b"tEXt" + text
    return head.startswith(PNG_MAGIC) and chunk in head
