"""The HTML report (``report/index.html``): the report's blocks as one self-contained page.

Figures are embedded (PNG as data URIs, the key plan as inline SVG); plate thumbnails link to
the full images in ``cut/nests``. Wide tables scroll inside their own box instead of widening the
page; long ones (per panel, issues) sort by a clicked column and filter by a search box.
"""

from __future__ import annotations

import base64
import html

from .blocks import (
    Block,
    Bullets,
    Figure,
    Gallery,
    Heading,
    Table,
    Text,
    Vector,
    Verdicts,
)

STYLE = """
body{font-family:system-ui,-apple-system,'Segoe UI',sans-serif;max-width:1180px;margin:1.5em auto;
 padding:0 1em;color:#1f2328;line-height:1.4}
h1{font-size:1.6em;margin-bottom:.2em}h2{border-bottom:1px solid #d0d7de;padding-bottom:.2em;
 margin-top:1.8em}h3{margin-top:1.2em}
nav a{margin-right:.8em;font-size:.9em}
.scroll{overflow-x:auto;max-width:100%;margin:.5em 0}
table{border-collapse:collapse;font-size:13px}td,th{border:1px solid #d0d7de;padding:3px 7px;
 text-align:left;vertical-align:top}th{background:#f6f8fa;position:sticky;top:0}
td.num{text-align:right;font-variant-numeric:tabular-nums}
table.sortable th{cursor:pointer}table.sortable th:after{content:" \\2195";color:#8c959f}
.search{margin:.3em 0;padding:3px 6px;width:18em}
.cards{display:grid;grid-template-columns:repeat(auto-fill,minmax(270px,1fr));gap:10px}
.card{border:1px solid #d0d7de;border-left:6px solid #8c959f;border-radius:6px;padding:8px 12px}
.card.pass{border-left-color:#1a7f37}.card.fail{border-left-color:#cf222e}
.card h3{margin:0 0 .3em 0;font-size:1.05em}.state{float:right;font-weight:600}
.pass .state{color:#1a7f37}.fail .state{color:#cf222e}
.card p{margin:.15em 0;font-size:13px}
figure{margin:1em 0}figure img,figure svg{max-width:100%;height:auto}
figcaption{font-size:13px;color:#57606a}
.gallery{display:flex;flex-wrap:wrap;gap:10px}.gallery figure{margin:0;width:220px}
"""

SCRIPT = """
document.querySelectorAll('table.sortable').forEach(function(table){
  var heads = table.querySelectorAll('th');
  heads.forEach(function(th, col){
    th.addEventListener('click', function(){
      var body = table.tBodies[0], rows = Array.from(body.rows);
      var dir = th.dataset.dir === 'asc' ? -1 : 1; th.dataset.dir = dir > 0 ? 'asc' : 'desc';
      rows.sort(function(a, b){
        var x = a.cells[col].textContent, y = b.cells[col].textContent;
        var p = parseFloat(x), q = parseFloat(y);
        if (!isNaN(p) && !isNaN(q)) return dir * (p - q);
        return dir * x.localeCompare(y);
      });
      rows.forEach(function(r){ body.appendChild(r); });
    });
  });
});
document.querySelectorAll('input.search').forEach(function(box){
  var table = document.getElementById(box.dataset.table);
  box.addEventListener('input', function(){
    var term = box.value.toLowerCase();
    Array.from(table.tBodies[0].rows).forEach(function(r){
      r.style.display = r.textContent.toLowerCase().indexOf(term) >= 0 ? '' : 'none';
    });
  });
});
"""


def _numeric(text: str) -> bool:
    head = text.split(" ")[0].replace("−", "-")
    try:
        float(head)
    except ValueError:
        return False
    return True


def _table(block: Table, index: int) -> str:
    cls = ' class="sortable"' if block.sortable else ""
    table_id = f"t{index}"
    head = "".join(f"<th>{html.escape(h)}</th>" for h in block.header)
    body = "".join(
        "<tr>"
        + "".join(
            f'<td class="num">{html.escape(c)}</td>'
            if _numeric(c)
            else f"<td>{html.escape(c)}</td>"
            for c in row
        )
        + "</tr>"
        for row in block.rows
    )
    caption = f"<h4>{html.escape(block.caption)}</h4>" if block.caption else ""
    search = (
        f'<input class="search" type="search" placeholder="filter rows" data-table="{table_id}">'
        if block.sortable
        else ""
    )
    return (
        f'{caption}{search}<div class="scroll"><table id="{table_id}"{cls}><thead><tr>{head}'
        f"</tr></thead><tbody>{body}</tbody></table></div>"
    )


def _verdicts(block: Verdicts) -> str:
    cards = "".join(
        f'<div class="card {v.state.replace(" ", "-")}"><h3>{html.escape(v.name)}'
        f'<span class="state">{html.escape(v.state.upper())}</span></h3>'
        + "".join(f"<p>{html.escape(line)}</p>" for line in v.lines)
        + "</div>"
        for v in block.items
    )
    out = f'<div class="cards">{cards}</div>'
    if block.not_modelled:
        items = "".join(f"<li>{html.escape(a)}</li>" for a in block.not_modelled)
        out += (
            "<details><summary>What the structural check assumes and does not model "
            f"({len(block.not_modelled)})</summary><ul>{items}</ul></details>"
        )
    return out


def _png(data: bytes) -> str:
    return "data:image/png;base64," + base64.b64encode(data).decode()


def render(blocks: list[Block]) -> str:
    """The whole page."""
    title = next((b.text for b in blocks if isinstance(b, Heading) and b.level == 1), "report")
    nav = "".join(
        f'<a href="#{b.anchor}">{html.escape(b.text)}</a>'
        for b in blocks
        if isinstance(b, Heading) and b.anchor
    )
    parts = []
    for index, block in enumerate(blocks):
        if isinstance(block, Heading):
            anchor = f' id="{block.anchor}"' if block.anchor else ""
            parts.append(f"<h{block.level}{anchor}>{html.escape(block.text)}</h{block.level}>")
            if block.level == 1:
                parts.append(f"<nav>{nav}</nav>")
        elif isinstance(block, Text):
            parts.append(f"<p>{html.escape(block.text)}</p>")
        elif isinstance(block, Bullets):
            parts.append(
                "<ul>" + "".join(f"<li>{html.escape(i)}</li>" for i in block.items) + "</ul>"
            )
        elif isinstance(block, Table):
            parts.append(_table(block, index))
        elif isinstance(block, Verdicts):
            parts.append(_verdicts(block))
        elif isinstance(block, Figure):
            caption = html.escape(block.caption)
            parts.append(
                f'<figure><img alt="{caption}" src="{_png(block.png)}">'
                f"<figcaption>{caption}</figcaption></figure>"
            )
        elif isinstance(block, Vector):
            svg = block.svg[block.svg.find("<svg") :]
            parts.append(
                f"<figure>{svg}<figcaption>{html.escape(block.caption)}</figcaption></figure>"
            )
        elif isinstance(block, Gallery):
            items = "".join(
                f'<figure><a href="{html.escape(link)}"><img alt="{html.escape(caption)}" '
                f'src="{_png(thumb)}"></a><figcaption>{html.escape(caption)}</figcaption></figure>'
                for thumb, link, caption in block.items
            )
            parts.append(f'<div class="gallery">{items}</div>')
    return (
        "<!doctype html><html lang='en'><head><meta charset='utf-8'>"
        "<meta name='viewport' content='width=device-width, initial-scale=1'>"
        f"<title>{html.escape(title)}</title><style>{STYLE}</style></head><body>"
        f"{''.join(parts)}<script>{SCRIPT}</script></body></html>"
    )
