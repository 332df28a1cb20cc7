"""Reports as structured documents: sections of text, lists, tables and figures,
rendered to Markdown and to self-contained HTML by one renderer.

Producers (the validation case kinds, the query study) build `Section`s; nobody
writes Markdown or HTML by hand and nothing parses Markdown back. Everything is
escaped in HTML; figures are PNG bytes, embedded as base64 in HTML and linked by
file name in Markdown (the writer of the document puts the file there).
It sits below the studies and the validation so that both render the same way.
"""

from __future__ import annotations

import base64
import dataclasses
import html


@dataclasses.dataclass(frozen=True)
class Text:
    """A paragraph."""

    text: str


@dataclasses.dataclass(frozen=True)
class Link:
    """A link: `href` relative to the document (a replay, a file)."""

    text: str
    href: str


@dataclasses.dataclass(frozen=True)
class Bullets:
    """A list; an item is a str or a Link."""

    items: tuple


@dataclasses.dataclass(frozen=True)
class Table:
    """headers (k,) and rows of k cells, already formatted as text."""

    headers: tuple
    rows: tuple


@dataclasses.dataclass(frozen=True)
class Figure:
    """A PNG image; `file` is its name next to the Markdown document."""

    file: str
    alt: str
    png: bytes


@dataclasses.dataclass(frozen=True)
class Verdict:
    """The headline of a report: passed or failed, and a sentence."""

    passed: bool
    text: str


@dataclasses.dataclass
class Section:
    """A titled part of a report. `order` places it (lower first); `brief` = also in the
    short Markdown summary (False: only in the full documents)."""

    title: str | None
    blocks: list
    order: int = 50
    level: int = 2
    brief: bool = True


def table(headers, rows) -> Table:
    """A Table from any iterables (cells converted with str)."""
    return Table(tuple(str(h) for h in headers), tuple(tuple(str(c) for c in row) for row in rows))


def png(fig, dpi: int = 110) -> bytes:
    """A matplotlib figure as PNG bytes (the figure is closed)."""
    import io

    import matplotlib.pyplot as plt

    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=dpi, bbox_inches="tight")
    plt.close(fig)
    return buffer.getvalue()


def pyplot():
    """matplotlib.pyplot on the Agg backend (no display needed)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def figures(sections) -> list[Figure]:
    """Every Figure in the sections, in order."""
    return [b for s in sections for b in s.blocks if isinstance(b, Figure)]


def _ordered(sections, brief_only: bool):
    return [s for s in sorted(sections, key=lambda s: s.order) if s.brief or not brief_only]


# ----------------------------------------------------------------------------- Markdown


def _md_cell(value: str) -> str:
    return value.replace("|", "\\|").replace("\n", " ")


def _md_block(block) -> str:
    if isinstance(block, Text):
        return block.text
    if isinstance(block, Verdict):
        return f"**{'PASS' if block.passed else 'FAIL'}**: {block.text}"
    if isinstance(block, Bullets):
        return "\n".join(f"- {item.text}: {item.href}" if isinstance(item, Link) else f"- {item}" for item in block.items)
    if isinstance(block, Table):
        lines = ["| " + " | ".join(_md_cell(h) for h in block.headers) + " |", "|" + "---|" * len(block.headers)]
        lines += ["| " + " | ".join(_md_cell(c) for c in row) + " |" for row in block.rows]
        return "\n".join(lines)
    if isinstance(block, Figure):
        return f"![{block.alt}]({block.file})"
    raise TypeError(f"not a document block: {type(block).__name__}")


def to_markdown(title: str, sections, *, brief: bool = False) -> str:
    """The document as Markdown; brief=True leaves out the sections marked brief=False."""
    parts = [f"# {title}"]
    for s in _ordered(sections, brief):
        if s.title:
            parts.append("#" * s.level + " " + s.title)
        parts += [_md_block(b) for b in s.blocks]
    return "\n\n".join(parts) + "\n"


# ----------------------------------------------------------------------------- HTML

STYLE = ("body{font-family:sans-serif;max-width:70em;margin:2em auto;color:#222}table{border-collapse:collapse;"
         "margin:1em 0;font-size:90%}td,th{border:1px solid #ccc;padding:3px 7px;text-align:right}"
         "th{background:#f0f0f0}.verdict{font-size:140%;font-weight:bold}.pass{color:#17803d}.fail{color:#b3261e}"
         "img{max-width:100%}.env{color:#777;font-size:85%}pre{background:#f7f7f7;padding:1em;overflow:auto}"
         ".toc{font-size:85%;line-height:1.6;color:#555}")


def _html_block(block) -> str:
    e = html.escape
    if isinstance(block, Text):
        return f"<p>{e(block.text)}</p>"
    if isinstance(block, Verdict):
        word = "PASS" if block.passed else "FAIL"
        return f"<p class='verdict {word.lower()}'>{word}: {e(block.text)}</p>"
    if isinstance(block, Bullets):
        items = "".join(f"<li><a href='{e(i.href)}'>{e(i.text)}</a></li>" if isinstance(i, Link) else f"<li>{e(i)}</li>"
                        for i in block.items)
        return f"<ul>{items}</ul>"
    if isinstance(block, Table):
        head = "".join(f"<th>{e(h)}</th>" for h in block.headers)
        body = "".join("<tr>" + "".join(f"<td>{e(c)}</td>" for c in row) + "</tr>" for row in block.rows)
        return f"<table><tr>{head}</tr>{body}</table>"
    if isinstance(block, Figure):
        return f"<img src='data:image/png;base64,{base64.b64encode(block.png).decode()}' alt='{e(block.alt)}'>"
    raise TypeError(f"not a document block: {type(block).__name__}")


def anchor(title: str, taken: set) -> str:
    """A unique HTML id for a section title ('Closed loop: the ...' -> 'closed-loop-the-...')."""
    base = "".join(c if c.isalnum() else "-" for c in title.lower()).strip("-")
    base = "-".join(part for part in base.split("-") if part) or "section"
    name, n = base, 1
    while name in taken:
        n += 1
        name = f"{base}-{n}"
    taken.add(name)
    return name


def to_html(title: str, sections) -> str:
    """The whole document as one self-contained HTML page (figures embedded), with a table
    of contents (one line of links to the level-2 sections) under the title when there are
    three or more of them."""
    taken: set = set()
    body, contents = [], []
    for s in _ordered(sections, False):
        if s.title:
            level = min(6, s.level)
            name = anchor(s.title, taken)
            body.append(f"<h{level} id='{name}'>{html.escape(s.title)}</h{level}>")
            if level == 2:
                contents.append(f"<a href='#{name}'>{html.escape(s.title)}</a>")
        body += [_html_block(b) for b in s.blocks]
    parts = [f"<h1>{html.escape(title)}</h1>"]
    if len(contents) >= 3:
        parts.append("<nav class='toc'>Contents: " + " &middot; ".join(contents) + "</nav>")
    parts += body
    return (f"<!DOCTYPE html><html><head><meta charset='utf-8'><title>{html.escape(title)}</title>"
            f"<style>{STYLE}</style></head><body>{''.join(parts)}</body></html>\n")


def markdown_html(text: str) -> str:
    """A small Markdown subset (#-headings, pipe tables, lists, paragraphs) as HTML;
    everything escaped, images left out. For Markdown written by hand or by older tools:
    the reports never go through it (they render their sections directly)."""
    out, pipe_lines, paragraph = [], [], []

    def flush():
        if pipe_lines:
            rows = [[c.strip() for c in line.strip().strip("|").split("|")] for line in pipe_lines
                    if not set(line.replace("|", "").strip()) <= set("-: ")]
            out.append(_html_block(table(rows[0], rows[1:])))
            pipe_lines.clear()
        if paragraph:
            out.append(f"<p>{html.escape(' '.join(paragraph))}</p>")
            paragraph.clear()

    for line in text.splitlines():
        stripped = line.strip()
        if stripped.startswith("|"):
            if paragraph:
                flush()
            pipe_lines.append(stripped)
            continue
        if pipe_lines or not stripped or stripped.startswith(("#", "- ", "![")):
            flush()
        if not stripped or stripped.startswith("!["):
            continue
        if stripped.startswith("#"):
            level = min(6, len(stripped) - len(stripped.lstrip("#")) + 2)
            out.append(f"<h{level}>{html.escape(stripped.lstrip('#').strip())}</h{level}>")
        elif stripped.startswith("- "):
            out.append(f"<ul><li>{html.escape(stripped[2:])}</li></ul>")
        else:
            paragraph.append(stripped)
    flush()
    return "".join(out)
