"""The printable report (``report/report.pdf``): the report's blocks on A4 pages (fpdf2), the
same content as the HTML page, for e-mail. Text in DejaVu Sans (matplotlib's own copy), so units
such as ° and ² print; figures as their PNGs, the key plan as its PNG rendering.
"""

from __future__ import annotations

import datetime
import io
from pathlib import Path

from .blocks import Block, Bullets, Figure, Gallery, Heading, Table, Text, Vector, Verdicts

#: printable width of an A4 page with 12 mm margins, mm
WIDTH = 186.0
#: table body font, pt; a table wider than this many columns prints smaller
TABLE_FONT = 7.0
WIDE_TABLE = 9
#: printable width of a landscape A4 page, mm
LANDSCAPE_WIDTH = 273.0
#: plate thumbnails per row
GALLERY_COLUMNS = 4


def _font_files() -> tuple[str, str]:
    from matplotlib import font_manager

    regular = font_manager.findfont("DejaVu Sans", fallback_to_default=False)
    bold = font_manager.findfont(
        font_manager.FontProperties(family="DejaVu Sans", weight="bold"),
        fallback_to_default=False,
    )
    return regular, bold


def render_pdf(blocks: list[Block], path: str | Path) -> Path:
    """Write ``blocks`` to ``path`` as a PDF."""
    from fpdf import FPDF

    pdf = FPDF(format="A4")
    pdf.set_margins(12, 12, 12)
    pdf.set_auto_page_break(True, margin=12)
    regular, bold = _font_files()
    pdf.add_font("DejaVu", "", regular)
    pdf.add_font("DejaVu", "B", bold)
    # the same run gives the same file: dated by the day, not the second
    today = datetime.date.today()
    pdf.set_creation_date(
        datetime.datetime(today.year, today.month, today.day, tzinfo=datetime.UTC)
    )
    pdf.set_creator("fabpanel")
    pdf.add_page()
    for block in blocks:
        _block(pdf, block)
    path = Path(path)
    pdf.output(str(path))
    return path


def _block(pdf, block: Block) -> None:
    if isinstance(block, Heading):
        size = {1: 16, 2: 13, 3: 11}.get(block.level, 10)
        if block.level == 2 and pdf.get_y() > 230:
            pdf.add_page()
        pdf.ln(2 if block.level > 1 else 0)
        pdf.set_font("DejaVu", "B", size)
        pdf.multi_cell(WIDTH, size * 0.5, block.text, new_x="LMARGIN", new_y="NEXT")
        pdf.ln(1)
    elif isinstance(block, Text):
        pdf.set_font("DejaVu", "", 9)
        pdf.multi_cell(WIDTH, 4.5, block.text, new_x="LMARGIN", new_y="NEXT")
        pdf.ln(1)
    elif isinstance(block, Bullets):
        _bullets(pdf, block.items)
    elif isinstance(block, Table):
        _table(pdf, block)
    elif isinstance(block, Verdicts):
        _verdicts(pdf, block)
    elif isinstance(block, Figure):
        _image(pdf, block.png, block.caption, WIDTH)
    elif isinstance(block, Vector):
        _image(pdf, block.pdf_png, block.caption, WIDTH)
    elif isinstance(block, Gallery):
        _gallery(pdf, block)


def _bullets(pdf, items) -> None:
    pdf.set_font("DejaVu", "", 8)
    for item in items:
        pdf.multi_cell(WIDTH, 3.8, f"•  {item}", new_x="LMARGIN", new_y="NEXT")
    pdf.ln(1)


def _table(pdf, block: Table) -> None:
    if block.caption:
        pdf.set_font("DejaVu", "B", 9)
        pdf.multi_cell(WIDTH, 4.5, block.caption, new_x="LMARGIN", new_y="NEXT")
    columns = len(block.header)
    width = WIDTH
    if columns > WIDE_TABLE:
        # a wide table on a landscape page of its own, so its numbers do not wrap mid-value
        pdf.add_page(orientation="L")
        width = LANDSCAPE_WIDTH
    size = TABLE_FONT if columns <= WIDE_TABLE else max(5.0, TABLE_FONT * 14 / columns)
    pdf.set_font("DejaVu", "", size)
    # column widths by the longest text in each (header words may wrap), at least 10 mm
    longest = [
        max([len(w) for w in block.header[c].split()] + [len(r[c]) for r in block.rows[:200]])
        for c in range(columns)
    ]
    weights = [min(max(n, 4), 60) for n in longest]
    widths = [width * w / sum(weights) for w in weights]
    line = size * 0.5
    _table_row(pdf, block.header, widths, line, heading=True)
    for row in block.rows:
        cells = [_cell_lines(pdf, text, w) for text, w in zip(row, widths)]
        if pdf.will_page_break(line * max(len(lines) for lines in cells)):
            # a row is never split across pages; the next page repeats the header
            pdf.add_page(orientation=pdf.cur_orientation)
            _table_row(pdf, block.header, widths, line, heading=True)
            pdf.set_font("DejaVu", "", size)
        _framed_cells(pdf, cells, widths, line)
    pdf.ln(2)
    if columns > WIDE_TABLE:
        pdf.add_page(orientation="P")


def _cell_lines(pdf, text: str, width: float) -> list[str]:
    """A cell's text in lines that fit its column, broken between words (inside a word only
    where the word alone is too wide), each measured once: fpdf2's own tables broke every
    cell character by character, re-measuring the line at each, 30 s for the 250-panel
    report's 47,000 cells."""
    room = width - 2 * pdf.c_margin
    if pdf.get_string_width(text) <= room:
        return [text]
    lines: list[str] = []
    current = ""
    for word in text.split():
        joined = f"{current} {word}" if current else word
        if pdf.get_string_width(joined) <= room:
            current = joined
            continue
        if current:
            lines.append(current)
        while pdf.get_string_width(word) > room and len(word) > 1:
            cut = max(1, next(i for i in range(len(word), 0, -1)
                              if pdf.get_string_width(word[:i]) <= room or i == 1))  # fmt: skip
            lines.append(word[:cut])
            word = word[cut:]
        current = word
    return [*lines, current] if current or not lines else lines


def _table_row(pdf, row, widths: list[float], line: float, heading: bool = False) -> None:
    """One table row at the current position (the heading bold on a grey fill)."""
    if heading:
        pdf.set_font(style="B")
        pdf.set_fill_color(240, 242, 245)
    _framed_cells(pdf, [_cell_lines(pdf, t, w) for t, w in zip(row, widths)], widths, line,
                  heading)  # fmt: skip
    if heading:
        pdf.set_font(style="")


def _framed_cells(
    pdf, cells: list[list[str]], widths: list[float], line: float, fill: bool = False
) -> None:
    """Cells of lines side by side at the current position, framed, as tall as the tallest;
    the position then at the row's foot."""
    height = line * max(len(lines) for lines in cells)
    x, y = pdf.l_margin, pdf.get_y()
    pdf.set_line_width(0.1)
    for lines, w in zip(cells, widths):
        pdf.rect(x, y, w, height, style="DF" if fill else "D")
        for index, text in enumerate(lines):
            pdf.set_xy(x, y + index * line)
            pdf.cell(w, line, text)
        x += w
    pdf.set_xy(pdf.l_margin, y + height)


def _verdicts(pdf, block: Verdicts) -> None:
    colours = {"pass": (26, 127, 55), "fail": (207, 34, 46)}
    for verdict in block.items:
        pdf.set_font("DejaVu", "B", 10)
        pdf.set_text_color(*colours.get(verdict.state, (90, 90, 90)))
        pdf.cell(38, 5, verdict.state.upper())
        pdf.set_text_color(0, 0, 0)
        pdf.cell(0, 5, verdict.name, new_x="LMARGIN", new_y="NEXT")
        pdf.set_font("DejaVu", "", 8)
        for line in verdict.lines:
            pdf.set_x(pdf.l_margin + 38)
            pdf.multi_cell(WIDTH - 38, 3.8, line, new_x="LMARGIN", new_y="NEXT")
        pdf.ln(1.5)
    if block.not_modelled:
        pdf.set_font("DejaVu", "B", 9)
        pdf.cell(0, 5, "What the structural check assumes and does not model",
                 new_x="LMARGIN", new_y="NEXT")  # fmt: skip
        _bullets(pdf, block.not_modelled)


def _image(pdf, png: bytes, caption: str, width: float) -> None:
    from PIL import Image

    with Image.open(io.BytesIO(png)) as image:
        height = width * image.height / image.width
    if height > 250:
        width, height = width * 250 / height, 250
    if pdf.get_y() + height + 8 > pdf.h - pdf.b_margin:
        pdf.add_page()
    pdf.image(io.BytesIO(png), w=width, h=height)
    pdf.set_font("DejaVu", "", 8)
    pdf.multi_cell(WIDTH, 4, caption, new_x="LMARGIN", new_y="NEXT")
    pdf.ln(2)


def _gallery(pdf, block: Gallery) -> None:
    from PIL import Image

    cell = WIDTH / GALLERY_COLUMNS
    for start in range(0, len(block.items), GALLERY_COLUMNS):
        row = block.items[start : start + GALLERY_COLUMNS]
        heights = []
        for thumb, _, _ in row:
            with Image.open(io.BytesIO(thumb)) as image:
                heights.append((cell - 3) * image.height / image.width)
        needed = max(heights) + 6
        if pdf.get_y() + needed > pdf.h - pdf.b_margin:
            pdf.add_page()
        top = pdf.get_y()
        for column, ((thumb, _, caption), height) in enumerate(zip(row, heights)):
            x = pdf.l_margin + column * cell
            pdf.image(io.BytesIO(thumb), x=x, y=top, w=cell - 3, h=height)
            pdf.set_xy(x, top + height + 0.5)
            pdf.set_font("DejaVu", "", 6.5)
            pdf.cell(cell - 3, 3, caption)
        pdf.set_xy(pdf.l_margin, top + needed)
