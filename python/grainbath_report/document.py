"""Report structure (Section of text / tables / figures) and its Markdown and HTML writers.

Text blocks use a small Markdown subset that both writers understand: paragraphs separated by
blank lines, `code`, **bold**, and lines starting with "- " as bullet lists.
"""
import base64
import html
import math
import os
import re


def fmt(x, digits=6):
    """The one number format of the report (also used by the tests to find summary values)."""
    if x is None:
        return "n/a"
    if isinstance(x, bool):
        return "true" if x else "false"
    if isinstance(x, int):
        return str(x)
    if isinstance(x, float):
        if not math.isfinite(x):
            return str(x)
        return f"{x:.{digits}g}"
    return str(x)


def fmt_pm(mean, err, digits=6):
    if err is None:
        return fmt(mean, digits)
    return f"{fmt(mean, digits)} ± {fmt(err, 2)}"


class Table:
    def __init__(self, headers, rows, caption=None):
        self.headers = list(headers)
        self.rows = [[c if isinstance(c, str) else fmt(c) for c in r] for r in rows]
        self.caption = caption


class Figure:
    def __init__(self, path, caption, alt=None):
        self.path = path          # absolute path of the PNG (inside the report directory)
        self.caption = caption
        if alt is None:           # first sentence of the caption, kept short
            alt = re.split(r"(?<=[a-z0-9)])(?<!std)(?<!eqs)(?<!Fig)\. ", caption, maxsplit=1)[0].rstrip(".")
            alt = alt if len(alt) <= 120 else alt[:117].rsplit(" ", 1)[0] + "…"
        self.alt = alt


class Section:
    def __init__(self, title, anchor=None):
        self.title = title
        self.anchor = anchor or re.sub(r"[^a-z0-9]+", "-", title.lower()).strip("-")
        self.blocks = []          # ("text", str) | ("table", Table) | ("figure", Figure) | ("code", str)

    def text(self, s):
        self.blocks.append(("text", s.strip()))
        return self

    def table(self, headers, rows, caption=None):
        self.blocks.append(("table", Table(headers, rows, caption)))
        return self

    def figure(self, path, caption, alt=None):
        if path:
            self.blocks.append(("figure", Figure(path, caption, alt)))
        return self

    def code(self, s, summary=None):
        self.blocks.append(("code", (s, summary)))
        return self

    def figures(self):
        return [b[1] for b in self.blocks if b[0] == "figure"]


# ---- Markdown ---------------------------------------------------------------------------
def _md_cell(s):
    return s.replace("|", "\\|").replace("\n", " ")


def write_markdown(path, title, intro, sections):
    out = [f"# {title}", ""]
    if intro:
        out += [intro.strip(), ""]
    out += ["Contents:", ""]
    out += [f"- [{s.title}](#{s.anchor})" for s in sections]
    out.append("")
    for s in sections:
        out += [f'<a id="{s.anchor}"></a>', "", f"## {s.title}", ""]
        for kind, b in s.blocks:
            if kind == "text":
                out += [b, ""]
            elif kind == "table":
                if b.caption:
                    out += [f"*{b.caption}*", ""]
                out.append("| " + " | ".join(_md_cell(h) for h in b.headers) + " |")
                out.append("|" + "|".join("---" for _ in b.headers) + "|")
                for r in b.rows:
                    out.append("| " + " | ".join(_md_cell(c) for c in r) + " |")
                out.append("")
            elif kind == "figure":
                name = os.path.basename(b.path)
                out += [f"![{_md_cell(b.alt).replace('[', '(').replace(']', ')')}]({name})", "", f"*{b.caption}*", ""]
            elif kind == "code":
                text, summary = b
                if summary:
                    out += [f"<details><summary>{summary}</summary>", ""]
                out += ["```", text.rstrip(), "```", ""]
                if summary:
                    out += ["</details>", ""]
    with open(path, "w") as f:
        f.write("\n".join(out))


# ---- HTML -------------------------------------------------------------------------------
def _inline(s):
    s = html.escape(s, quote=False)
    s = re.sub(r"`([^`]+)`", r"<code>\1</code>", s)
    s = re.sub(r"\*\*([^*]+)\*\*", r"<strong>\1</strong>", s)
    s = re.sub(r"(?<![\w*])\*([^*\s][^*]*)\*(?![\w*])", r"<em>\1</em>", s)
    return s


def _html_text(block):
    parts = []
    for para in re.split(r"\n\s*\n", block):
        lines = para.splitlines()
        if lines and all(l.lstrip().startswith("- ") for l in lines):
            parts.append("<ul>" + "".join(f"<li>{_inline(l.lstrip()[2:])}</li>" for l in lines) + "</ul>")
        else:
            parts.append(f"<p>{_inline(' '.join(lines))}</p>")
    return "\n".join(parts)


_CSS = """
body{font-family:system-ui,-apple-system,"Segoe UI",Roboto,sans-serif;max-width:1000px;margin:2em auto;
     padding:0 1em;color:#222;line-height:1.45}
h1{border-bottom:2px solid #444;padding-bottom:.2em} h2{border-bottom:1px solid #bbb;margin-top:2em}
table{border-collapse:collapse;margin:.8em 0;font-size:.92em}
th,td{border:1px solid #ccc;padding:.25em .6em;text-align:left} th{background:#f0f0f0}
td:nth-child(n+2){font-variant-numeric:tabular-nums}
figure{margin:1em 0} figure img{max-width:100%;border:1px solid #ddd}
figcaption{font-size:.9em;color:#444;margin-top:.3em}
code{background:#f4f4f4;padding:0 .2em} pre{background:#f6f6f6;padding:.6em;overflow-x:auto;font-size:.85em}
nav ul{columns:2} .caption{font-style:italic;color:#555}
"""


def write_html(path, title, intro, sections):
    out = ["<!DOCTYPE html>", '<html lang="en"><head><meta charset="utf-8">',
           f"<title>{html.escape(title)}</title>", f"<style>{_CSS}</style></head><body>",
           f"<h1>{html.escape(title)}</h1>"]
    if intro:
        out.append(_html_text(intro))
    out.append("<nav><ul>" + "".join(f'<li><a href="#{s.anchor}">{html.escape(s.title)}</a></li>'
                                     for s in sections) + "</ul></nav>")
    for s in sections:
        out.append(f'<h2 id="{s.anchor}">{html.escape(s.title)}</h2>')
        for kind, b in s.blocks:
            if kind == "text":
                out.append(_html_text(b))
            elif kind == "table":
                if b.caption:
                    out.append(f'<p class="caption">{_inline(b.caption)}</p>')
                out.append("<table><tr>" + "".join(f"<th>{_inline(h)}</th>" for h in b.headers) + "</tr>")
                for r in b.rows:
                    out.append("<tr>" + "".join(f"<td>{_inline(c)}</td>" for c in r) + "</tr>")
                out.append("</table>")
            elif kind == "figure":
                with open(b.path, "rb") as f:
                    data = base64.b64encode(f.read()).decode("ascii")
                out.append(f'<figure><img alt="{html.escape(b.alt)}" '
                           f'src="data:image/png;base64,{data}"><figcaption>{_inline(b.caption)}'
                           f"</figcaption></figure>")
            elif kind == "code":
                text, summary = b
                pre = f"<pre>{html.escape(text.rstrip())}</pre>"
                out.append(f"<details><summary>{html.escape(summary)}</summary>{pre}</details>" if summary else pre)
    out.append("</body></html>")
    with open(path, "w") as f:
        f.write("\n".join(out))
