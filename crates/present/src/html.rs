//! A self-contained HTML report: headings, paragraphs, tables and figures, the figures inline
//! as SVG elements, the figures' font (the embedded DejaVu Sans of the PNGs) inline as base64
//! data, no external resource of any kind (it opens from a file, offline). A table of contents
//! after the opening notice links every heading and every figure (each has a stable id, made
//! from its text).

use std::fmt::Write;

/// One piece of the report, in order.
#[derive(Debug, Clone, PartialEq)]
pub enum Block {
    /// A section heading.
    Heading(String),
    /// A paragraph of plain text (escaped).
    Paragraph(String),
    /// A warning paragraph, set apart (escaped).
    Notice(String),
    /// A table: caption, header cells, rows of cells (escaped).
    Table {
        /// Caption above the table.
        caption: String,
        /// Header cells.
        header: Vec<String>,
        /// Rows of cells.
        rows: Vec<Vec<String>>,
    },
    /// A bulleted list, one item a point.
    List(Vec<String>),
    /// A figure: an SVG document and its caption.
    Figure {
        /// The SVG document, inlined.
        svg: String,
        /// Caption below the figure.
        caption: String,
        /// The figure's file name without extension (`bode_stroke`, `identification/fit-1`):
        /// its id in the page.
        name: String,
    },
}

const STYLE: &str =
    "body{font-family:'DejaVu Sans',Arial,sans-serif;max-width:1800px;margin:2em auto;\
padding:0 2vw;color:#222;line-height:1.45}p,figcaption{max-width:60em}h1{font-size:1.6em}\
h2{font-size:1.25em;margin-top:2em;border-bottom:1px solid #ccc}table{border-collapse:collapse;\
margin:1em 0}caption{text-align:left;font-weight:bold;padding:.3em 0}td,th{border:1px solid #bbb;\
padding:.25em .6em;text-align:left;vertical-align:top}td.num{text-align:right;white-space:nowrap}\
.n{white-space:nowrap}th{background:#eee}figure{margin:1.5em 0;max-width:1400px}\
figure svg{display:block;width:100%;height:auto;border:1px solid #ddd}figcaption{font-size:.9em;color:#444}\
.notice{background:#fff4d6;border-left:4px solid #e0a000;padding:.6em 1em}\
nav.toc{font-size:.9em;margin:1em 0}nav.toc ul{margin:.2em 0;padding-left:1.4em}\
nav.toc>ul>li{margin-top:.3em}nav.toc ul ul{list-style:circle}\
details{margin:1em 0}summary{cursor:pointer;font-weight:bold}";

/// Marks on `<body>` how many figures laid out with a non-zero size (data-figures-loaded) out
/// of how many (data-figures-total), and flags any that did not; the page's height in pixels
/// with its long tables folded (data-page-height) and unfolded (data-page-height-unfolded)
/// and how many are (data-folded-tables); how
/// many number cells (data-number-cells, the folded tables opened to lay them out, then folded
/// again) laid out on more than one line (data-wrapped-numbers); and, once the
/// fonts are ready, how many faces of the embedded font loaded (data-embedded-font) and how
/// many of the figures' text elements (data-figure-texts) name it first (data-figure-texts-embedded):
/// all checked by the browser test.
const SCRIPT: &str = "window.addEventListener('load',function(){var b=document.body;\
var im=document.querySelectorAll('figure svg');\
var ok=0;im.forEach(function(i){if(i.getBoundingClientRect().height>0){ok++}\
else{i.insertAdjacentHTML('afterend','<p class=notice>This figure did not load.</p>')}});\
b.setAttribute('data-figures-loaded',ok);b.setAttribute('data-figures-total',im.length);\
var folded=document.querySelectorAll('details');\
b.setAttribute('data-page-height',document.documentElement.scrollHeight);\
b.setAttribute('data-folded-tables',folded.length);folded.forEach(function(d){d.open=true});\
b.setAttribute('data-page-height-unfolded',document.documentElement.scrollHeight);\
var wrapped=0,cells=document.querySelectorAll('td.num');cells.forEach(function(c){\
var r=document.createRange();r.selectNodeContents(c);var tops={};\
Array.prototype.forEach.call(r.getClientRects(),function(q){tops[Math.round(q.top)]=1});\
if(Object.keys(tops).length>1){wrapped++}});\
b.setAttribute('data-number-cells',cells.length);b.setAttribute('data-wrapped-numbers',wrapped);\
folded.forEach(function(d){d.open=false});\
document.fonts.ready.then(function(){var faces=0;document.fonts.forEach(function(f){\
if(f.family.replace(/[\"']/g,'')==='DejaVu Sans'&&f.status==='loaded'){faces++}});\
var texts=document.querySelectorAll('figure svg text'),named=0;texts.forEach(function(t){\
if(getComputedStyle(t).fontFamily.replace(/[\"']/g,'').indexOf('DejaVu Sans')===0){named++}});\
b.setAttribute('data-embedded-font',faces);b.setAttribute('data-figure-texts',texts.length);\
b.setAttribute('data-figure-texts-embedded',named)})});";

/// The page's style with the embedded font declared first, as a data URL.
fn style() -> String {
    format!(
        "@font-face{{font-family:'{}';src:url(data:font/ttf;base64,{}) format('truetype')}}{STYLE}",
        crate::plot::font::EMBEDDED_FAMILY,
        base64(crate::plot::font::DEJAVU_SANS)
    )
}

/// The page: `title` and the blocks, in order, with a table of contents after the first
/// notice (at the top when there is none).
pub fn html_page(title: &str, blocks: &[Block]) -> String {
    let mut s = format!(
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\
         <meta name=\"viewport\" content=\"width=device-width,initial-scale=1\">\
         <title>{t}</title><style>{}</style><script>{SCRIPT}</script></head>\n<body>\n<h1>{t}</h1>\n",
        style(),
        t = escape(title)
    );
    let ids = anchors(blocks);
    let toc_after = blocks.iter().position(|b| matches!(b, Block::Notice(_)));
    if toc_after.is_none() {
        s.push_str(&contents(blocks, &ids));
    }
    let mut in_section = false;
    for (k, (b, id)) in blocks.iter().zip(&ids).enumerate() {
        let id = id.as_deref().unwrap_or("");
        match b {
            Block::Heading(h) => {
                in_section = true;
                let _ = writeln!(s, "<h2 id=\"{id}\">{}</h2>", escape(h));
            }
            Block::Paragraph(p) => {
                let _ = writeln!(s, "<p>{}</p>", escape(p));
            }
            Block::Notice(p) => {
                let _ = writeln!(s, "<p class=\"notice\">{}</p>", escape(p));
            }
            Block::List(items) => {
                s.push_str("<ul>");
                for i in items {
                    let _ = write!(s, "<li>{}</li>", escape(i));
                }
                s.push_str("</ul>\n");
            }
            Block::Table {
                caption,
                header,
                rows,
            } => table(&mut s, caption, header, rows, in_section),
            Block::Figure { svg, caption, .. } => {
                let _ = writeln!(
                    s,
                    "<figure>{}<figcaption>{}</figcaption></figure>",
                    inline_svg(svg, caption, id),
                    escape(caption)
                );
            }
        }
        if toc_after == Some(k) {
            s.push_str(&contents(blocks, &ids));
        }
    }
    s.push_str("</body></html>\n");
    s
}

/// The id of every heading and figure of `blocks` (`None` for the other blocks): a heading's
/// text, or a figure's file name, as lower-case ASCII words joined by hyphens (at most eight
/// words), prefixed `sec-` or `fig-`, and suffixed `-2`, `-3`, … where it would repeat
/// an earlier one. The same blocks give the same ids.
fn anchors(blocks: &[Block]) -> Vec<Option<String>> {
    let mut seen: Vec<String> = Vec::new();
    blocks
        .iter()
        .map(|b| {
            let base = match b {
                Block::Heading(h) => format!("sec-{}", slug(h)),
                Block::Figure { name, .. } => format!("fig-{}", slug(name)),
                _ => return None,
            };
            let id = (1..)
                .map(|n| match n {
                    1 => base.clone(),
                    n => format!("{base}-{n}"),
                })
                .find(|id| !seen.contains(id))
                .unwrap_or(base);
            seen.push(id.clone());
            Some(id)
        })
        .collect()
}

/// `text` as at most eight lower-case ASCII words joined by hyphens ("x" when it has none).
fn slug(text: &str) -> String {
    let lower = text.to_ascii_lowercase();
    let words: Vec<&str> = lower
        .split(|c: char| !c.is_ascii_alphanumeric())
        .filter(|w| !w.is_empty())
        .take(8)
        .collect();
    if words.is_empty() {
        "x".to_string()
    } else {
        words.join("-")
    }
}

/// The table of contents' name for a figure: the first words of its caption (about 110
/// characters, cut at a word with "…"), without parenthesised remarks.
fn figure_label(caption: &str) -> String {
    const CHARS: usize = 110;
    let mut plain = String::new();
    let mut depth = 0usize;
    for c in caption.chars() {
        match c {
            '(' => depth += 1,
            ')' => depth = depth.saturating_sub(1),
            _ if depth == 0 => plain.push(c),
            _ => {}
        }
    }
    // punctuation that followed a remark joins the word before it
    let plain = [".", ",", ":", ";"]
        .iter()
        .fold(plain, |t, p| t.replace(&format!(" {p}"), p));
    let mut label = String::new();
    for w in plain.split_whitespace() {
        if !label.is_empty() && label.chars().count() + 1 + w.chars().count() > CHARS {
            return format!("{label} …");
        }
        if !label.is_empty() {
            label.push(' ');
        }
        label.push_str(w);
    }
    label
}

/// The table of contents: every heading of `blocks` linked by its id (`ids`, from
/// [`anchors`]), with the figures under it; figures before the first heading at the top.
fn contents(blocks: &[Block], ids: &[Option<String>]) -> String {
    let mut s =
        String::from("<nav class=\"toc\" aria-label=\"Contents\"><strong>Contents</strong><ul>");
    let mut in_section = false;
    let link = |id: &str, text: &str| format!("<a href=\"#{id}\">{}</a>", escape(text));
    for (b, id) in blocks.iter().zip(ids) {
        let id = id.as_deref().unwrap_or("");
        match b {
            Block::Heading(h) => {
                s.push_str(if in_section { "</ul></li>" } else { "" });
                let _ = write!(s, "<li>{}<ul>", link(id, h));
                in_section = true;
            }
            Block::Figure { caption, .. } => {
                let _ = write!(s, "<li>{}</li>", link(id, &figure_label(caption)));
            }
            _ => {}
        }
    }
    s.push_str(if in_section { "</ul></li>" } else { "" });
    s.push_str("</ul></nav>\n");
    s.replace("<ul></ul>", "")
}

/// The SVG document `svg` as an element of the page with the id `id` (none when empty),
/// labelled with `caption` for screen readers; the namespace, implied in HTML, dropped with
/// any XML declaration.
fn inline_svg(svg: &str, caption: &str, id: &str) -> String {
    let svg = svg.trim_start();
    let svg = match svg.strip_prefix("<?xml") {
        Some(rest) => rest
            .split_once("?>")
            .map_or(svg, |(_, doc)| doc.trim_start()),
        None => svg,
    };
    let svg = svg.replacen(" xmlns=\"http://www.w3.org/2000/svg\"", "", 1);
    let id = if id.is_empty() {
        String::new()
    } else {
        format!(" id=\"{id}\"")
    };
    match svg.strip_prefix("<svg") {
        Some(rest) => format!(
            "<svg{id} role=\"img\" aria-label=\"{}\"{rest}",
            escape(caption)
        ),
        None => svg,
    }
}

/// Rows beyond which a table in a section is folded behind a disclosure (`<details>`) headed
/// by its caption: the answers and their figures lead each section, the long tables open on a
/// click. The page's lead (what comes before its first section heading: reproduce's comparison
/// with the article) is never folded.
pub const LONG_TABLE_ROWS: usize = 12;

fn table(s: &mut String, caption: &str, header: &[String], rows: &[Vec<String>], fold: bool) {
    let long = fold && rows.len() > LONG_TABLE_ROWS;
    if long {
        let _ = write!(
            s,
            "<details><summary>{} ({} rows)</summary>",
            escape(caption),
            rows.len()
        );
    }
    let _ = write!(s, "<table><caption>{}</caption><tr>", escape(caption));
    for h in header {
        let _ = write!(s, "<th>{}</th>", escape(h));
    }
    s.push_str("</tr>\n");
    for row in rows {
        s.push_str("<tr>");
        for (k, c) in row.iter().enumerate() {
            let _ = write!(s, "{}", cell(c, k == 0));
        }
        s.push_str("</tr>\n");
    }
    s.push_str("</table>\n");
    if long {
        s.push_str("</details>\n");
    }
}

/// A table cell: a short one holding a number, past the first (naming) column, is kept on one
/// line and right-aligned (`td.num`); any other is prose, left-aligned and wrapped at its
/// spaces, but never inside a word that holds a digit (a number, a range, a value with its
/// unit).
fn cell(text: &str, first: bool) -> String {
    let numeric = !first && text.chars().any(|c| c.is_ascii_digit());
    if numeric && text.chars().count() <= NUMBER_CELL_CHARS {
        return format!("<td class=\"num\">{}</td>", escape(text));
    }
    let words: Vec<String> = text
        .split(' ')
        .map(|w| {
            if w.chars().any(|c| c.is_ascii_digit()) {
                format!("<span class=\"n\">{}</span>", escape(w))
            } else {
                escape(w)
            }
        })
        .collect();
    format!("<td>{}</td>", words.join(" "))
}

/// The longest cell (characters) shown whole on one line as a number.
const NUMBER_CELL_CHARS: usize = 32;

/// HTML-escape text, written with the symbols the terminal's ASCII spells out (`>=` as ≥,
/// `<=` as ≤, the word `beta` as β; `beta_bar` and other key names stay as they are).
fn escape(t: &str) -> String {
    typeset(t)
        .replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// `t` with ` >= `, ` <= ` and the word `beta` (alone or in `beta_e`) as symbols.
fn typeset(t: &str) -> String {
    let t = t.replace(" >= ", " ≥ ").replace(" <= ", " ≤ ");
    let mut out = String::with_capacity(t.len());
    let mut rest = t.as_str();
    while let Some(at) = rest.find("beta") {
        let (before, after) = rest.split_at(at);
        let word_start = !before.ends_with(|c: char| c.is_alphanumeric() || c == '_');
        let tail = &after[4..];
        let word_end = !tail.starts_with(|c: char| c.is_alphanumeric() || c == '_')
            || tail.starts_with("_e ")
            || tail.starts_with("_e(")
            || tail == "_e";
        out.push_str(before);
        out.push_str(if word_start && word_end { "β" } else { "beta" });
        rest = tail;
    }
    out.push_str(rest);
    out
}

/// Standard base64 (RFC 4648) with padding.
fn base64(bytes: &[u8]) -> String {
    const A: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::with_capacity(bytes.len().div_ceil(3) * 4);
    for chunk in bytes.chunks(3) {
        let b = [
            chunk[0],
            *chunk.get(1).unwrap_or(&0),
            *chunk.get(2).unwrap_or(&0),
        ];
        let n = (u32::from(b[0]) << 16) | (u32::from(b[1]) << 8) | u32::from(b[2]);
        for k in 0..4 {
            if k <= chunk.len() {
                out.push(A[((n >> (18 - 6 * k)) & 63) as usize] as char);
            } else {
                out.push('=');
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn prose_is_typeset_and_key_names_kept() {
        assert_eq!(
            typeset("PM >= 34 deg at beta 154.6 bar, beta_e 152 bar; key beta_bar, betamax"),
            "PM ≥ 34 deg at β 154.6 bar, β_e 152 bar; key beta_bar, betamax"
        );
    }

    #[test]
    fn base64_matches_rfc4648_vectors() {
        for (plain, coded) in [
            ("", ""),
            ("f", "Zg=="),
            ("fo", "Zm8="),
            ("foo", "Zm9v"),
            ("foob", "Zm9vYg=="),
            ("fooba", "Zm9vYmE="),
            ("foobar", "Zm9vYmFy"),
        ] {
            assert_eq!(base64(plain.as_bytes()), coded);
        }
    }

    #[test]
    fn page_escapes_text_and_inlines_figures() {
        let page = html_page(
            "a <b> & c",
            &[
                Block::Paragraph("x < y".into()),
                Block::Figure {
                    svg: "<svg/>".into(),
                    caption: "\"fig\"".into(),
                    name: "fig".into(),
                },
            ],
        );
        assert!(page.contains("<h1>a &lt;b&gt; &amp; c</h1>"));
        assert!(page.contains("<p>x &lt; y</p>"));
        assert!(page
            .contains("<figure><svg id=\"fig-fig\" role=\"img\" aria-label=\"&quot;fig&quot;\"/>"));
        assert!(page
            .contains("@font-face{font-family:'DejaVu Sans';src:url(data:font/ttf;base64,AAEAA"));
        assert!(page.contains("<figcaption>&quot;fig&quot;</figcaption>"));
        assert!(!page.contains("http://") && !page.contains("https://"));
    }

    /// The values of attribute `name` in `html`, in order.
    fn attr_values<'a>(html: &'a str, name: &str) -> Vec<&'a str> {
        let key = format!(" {name}=\"");
        html.split(&key)
            .skip(1)
            .filter_map(|v| v.split('"').next())
            .collect()
    }

    /// A caption of 122 characters, cut within 110.
    const LONG: &str = "Article Figure 14. Bode diagram: Figure 14, cumulative damping study, \
                        with a long caption that goes on and on past the cut";

    #[test]
    fn contents_link_every_heading_and_figure_after_the_notice() {
        let figure = |caption: &str, name: &str| Block::Figure {
            svg: "<svg/>".into(),
            caption: caption.into(),
            name: name.into(),
        };
        let blocks = [
            Block::Paragraph("before".into()),
            Block::Notice("EMULATED".into()),
            Block::Heading("1. Drive gain (the article §2.4.1)".into()),
            figure(
                "Article Figure 5 (with a remark). Drive 1 (Kp = 25): alone",
                "drive_step",
            ),
            Block::Heading("β".into()),
            figure(LONG, "identification/fit-1"),
            figure(LONG, "identification/fit-1"),
            Block::Heading("1. Drive gain (the article §2.4.1)".into()),
        ];
        let page = html_page("t", &blocks);
        let (nav_at, nav_end) = (page.find("<nav").unwrap(), page.find("</nav>").unwrap());
        assert!(
            page.find("class=\"notice\"").unwrap() < nav_at,
            "after the notice"
        );
        assert!(
            nav_at < page.find("<h2").unwrap(),
            "before the first heading"
        );
        let nav = &page[nav_at..nav_end];
        let links: Vec<&str> = attr_values(nav, "href");
        let ids = attr_values(&page[nav_end..], "id");
        assert_eq!(
            ids,
            [
                "sec-1-drive-gain-the-article-2-4-1",
                "fig-drive-step",
                "sec-x",
                "fig-identification-fit-1",
                "fig-identification-fit-1-2",
                "sec-1-drive-gain-the-article-2-4-1-2",
            ]
        );
        // every link points at an id of the page, in order, one a heading or a figure
        let targets: Vec<String> = ids.iter().map(|id| format!("#{id}")).collect();
        assert_eq!(links, targets);
        let mut unique = ids.clone();
        unique.sort_unstable();
        unique.dedup();
        assert_eq!(unique.len(), ids.len(), "unique ids");
        // figures named by their caption's first words, remarks in parentheses left out
        assert!(
            nav.contains(">Article Figure 5. Drive 1: alone</a>"),
            "{nav}"
        );
        assert!(nav.contains(">Article Figure 14. Bode diagram: Figure 14, cumulative damping study, with a long caption that goes on and on …</a>"), "{nav}");
        // the figures sit under their heading
        assert!(
            nav.contains("§2.4.1)</a><ul><li><a href=\"#fig-drive-step"),
            "{nav}"
        );
        // the same blocks give the same page; without a notice the contents come first
        assert_eq!(html_page("t", &blocks), page);
        let bare = html_page("t", &blocks[2..]);
        assert!(bare.find("<nav").unwrap() < bare.find("<h2").unwrap());
        assert!(html_page("t", &[Block::Paragraph("p".into())]).contains("<nav"));
    }
}
