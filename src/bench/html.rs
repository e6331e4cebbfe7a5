//! `report.html`: the report as one self-contained page an engineer opens in a browser.
//!
//! Rendered from `report.md` (one source for both), with every SVG figure inlined, every
//! table sortable by clicking a column's header (numbers by value, the rest as text), and
//! nothing fetched from a network: no external style, script or font.

use crate::verdict::Verdict;
use pulldown_cmark::{Options, Parser, html};

/// The page for `markdown`, whose images named in `figures` (file name, SVG text) are
/// inlined in place of links.
pub fn page(title: &str, markdown: &str, figures: &[(String, String)]) -> String {
    let mut body = String::new();
    html::push_html(&mut body, Parser::new_ext(markdown, Options::ENABLE_TABLES));
    for (name, svg) in figures {
        body = inline_image(&body, name, svg);
    }
    let body = fold_long_cells(&body);
    format!(
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>{}</title>\n<style>{STYLE}</style>\n</head>\n<body>\n{body}<script>{SORT}</script>\n</body>\n</html>\n",
        escape(title)
    )
}

/// `html` with each `<img src="name" …>` replaced by the figure itself.
fn inline_image(html: &str, name: &str, svg: &str) -> String {
    let key = format!("<img src=\"{name}\"");
    let mut out = String::with_capacity(html.len() + svg.len());
    let mut rest = html;
    while let Some(at) = rest.find(&key) {
        out.push_str(&rest[..at]);
        let after = &rest[at..];
        let end = after.find('>').map_or(after.len(), |e| e + 1);
        out.push_str("<figure>");
        out.push_str(svg);
        out.push_str("</figure>");
        rest = &after[end..];
    }
    out.push_str(rest);
    out
}

/// Cells whose text runs past this many characters are folded (a failure's reason is
/// several lines in a narrow column).
const FOLD_CHARS: usize = 80;

/// `html` with the long cells of each failed run's row folded into a `<details>`: its
/// summary is the cell up to its first bold part (a verdict) or its first words, the rest
/// opens on a click. A row is a failed run's when a cell shows a verdict other than
/// `running` in bold or italics; other long cells (definitions, spectra) stay open.
fn fold_long_cells(html: &str) -> String {
    let mut out = String::with_capacity(html.len());
    let mut rest = html;
    while let Some(at) = rest.find("<tr>") {
        let Some(end) = rest[at..].find("</tr>").map(|e| at + e) else {
            break;
        };
        out.push_str(&rest[..at]);
        let row = &rest[at..end];
        if failed(row) {
            out.push_str(&fold_row(row));
        } else {
            out.push_str(row);
        }
        rest = &rest[end..];
    }
    out.push_str(rest);
    out
}

/// Whether `row` shows a failing verdict, as the report marks one: `**lost-sync**` or
/// `*off-speed*`.
fn failed(row: &str) -> bool {
    Verdict::ALL
        .iter()
        .filter(|v| **v != Verdict::Running)
        .any(|v| {
            let v = v.as_str();
            row.contains(&format!("<strong>{v}</strong>")) || row.contains(&format!("<em>{v}</em>"))
        })
}

/// `row` with each of its long cells folded.
fn fold_row(row: &str) -> String {
    let mut out = String::with_capacity(row.len() + 64);
    let mut rest = row;
    while let Some(at) = rest.find("<td") {
        let Some(open) = rest[at..].find('>').map(|e| at + e + 1) else {
            break;
        };
        let Some(close) = rest[open..].find("</td>").map(|e| open + e) else {
            break;
        };
        out.push_str(&rest[..open]);
        out.push_str(&fold(&rest[open..close]));
        rest = &rest[close..];
    }
    out.push_str(rest);
    out
}

/// One cell's content, folded when long.
fn fold(cell: &str) -> String {
    if text_len(cell) <= FOLD_CHARS {
        return cell.to_string();
    }
    let (split, more) = match cell.find("</strong>") {
        Some(e) if e < FOLD_CHARS * 2 => (e + "</strong>".len(), ""),
        _ => (word_break(cell, FOLD_CHARS / 2), " …"),
    };
    let (head, tail) = cell.split_at(split);
    let tail = tail.trim_start_matches(':').trim_start();
    format!("<details><summary>{head}{more}</summary>{tail}</details>")
}

/// Characters of text in `html` (tags not counted).
fn text_len(html: &str) -> usize {
    let mut in_tag = false;
    html.chars()
        .filter(|&c| {
            match c {
                '<' => in_tag = true,
                '>' if in_tag => {
                    in_tag = false;
                    return false;
                }
                _ => {}
            }
            !in_tag
        })
        .count()
}

/// The byte offset of the last space outside a tag within the first `max` characters of
/// text (the cell's length if there is none).
fn word_break(html: &str, max: usize) -> usize {
    let (mut in_tag, mut seen, mut best) = (false, 0, None);
    for (i, c) in html.char_indices() {
        match c {
            '<' => in_tag = true,
            '>' if in_tag => in_tag = false,
            ' ' if !in_tag && seen <= max => best = Some(i),
            _ => {}
        }
        if !in_tag && c != '>' {
            seen += 1;
        }
    }
    best.unwrap_or(html.len())
}

fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

const STYLE: &str = "body{font-family:sans-serif;max-width:1000px;margin:2em auto;padding:0 1em;line-height:1.45;color:#222}\
table{border-collapse:collapse;margin:1em 0;font-size:0.9em}\
th,td{border:1px solid #ccc;padding:0.25em 0.6em}\
th{background:#f2f2f2;cursor:pointer;user-select:none}\
th.asc::after{content:' \\25B2'}th.desc::after{content:' \\25BC'}\
tr:nth-child(even) td{background:#fafafa}\
pre{background:#f6f6f6;padding:0.8em;overflow-x:auto;font-size:0.85em}\
code{background:#f3f3f3;padding:0 0.2em}\
figure{margin:1em 0;overflow-x:auto}figure svg{max-width:100%;height:auto}\
details summary{cursor:pointer}";

/// Click a header to sort its table by that column; click again to reverse. Cells that
/// read as numbers (a leading sign, digits, a decimal point, an exponent) sort by value
/// and come before text such as a verdict or "–".
const SORT: &str = r#"
document.querySelectorAll('table').forEach(function (table) {
  var heads = table.querySelectorAll('thead th');
  heads.forEach(function (th, col) {
    th.addEventListener('click', function () {
      var asc = !th.classList.contains('asc');
      heads.forEach(function (h) { h.classList.remove('asc', 'desc'); });
      th.classList.add(asc ? 'asc' : 'desc');
      var body = table.tBodies[0];
      var rows = Array.prototype.slice.call(body.rows);
      var key = function (r) {
        var t = r.cells[col] ? r.cells[col].textContent.trim() : '';
        var m = t.match(/^[+-]?\d+(\.\d+)?(e[+-]?\d+)?/i);
        return m ? [0, parseFloat(m[0]), t] : [1, 0, t];
      };
      rows.sort(function (a, b) {
        var x = key(a), y = key(b);
        var d = x[0] - y[0] || (x[0] === 0 ? x[1] - y[1] : x[2].localeCompare(y[2]));
        return asc ? d : -d;
      });
      rows.forEach(function (r) { body.appendChild(r); });
    });
  });
});
"#;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn figures_are_inlined_tables_rendered_and_nothing_is_fetched() {
        let md = "# R\n\n![speed](speed.svg)\n\n| a | b |\n|---|---:|\n| x | 2 |\n";
        let svg = "<svg xmlns=\"http://www.w3.org/2000/svg\"><path d=\"M0,0 L1,1\"/></svg>";
        let p = page("t <1>", md, &[("speed.svg".into(), svg.into())]);
        assert!(p.contains("<figure><svg") && !p.contains("<img"), "{p}");
        assert!(
            p.contains("<table>") && p.contains("<thead>") && p.contains("<th"),
            "{p}"
        );
        assert!(p.contains("<title>t &lt;1&gt;</title>"));
        // Self-contained: no reference to anything outside the page (the SVG namespace
        // is an identifier, not a fetch).
        for fetch in ["src=\"http", "href=\"http", "<link", "@import", "url("] {
            assert!(!p.contains(fetch), "{fetch}");
        }
    }

    #[test]
    fn a_failed_runs_long_cells_fold_and_other_cells_stay() {
        let reason = "in synchronism, true mean 512.5 rpm against the 492 rpm command (+4.1 %, tolerance ±2 %)";
        let md = format!(
            "| s | verdict | why |\n|---|---|---|\n| a | **off-speed**: {reason} | – |\n| b | *lost-sync* | {reason} |\n| c | running | {reason} |\n"
        );
        let p = page("t", &md, &[]);
        // Behind the verdict when the cell has one; else behind its first words.
        assert!(
            p.contains(&format!(
                "<td><details><summary><strong>off-speed</strong></summary>{reason}</details></td>"
            )),
            "{p}"
        );
        assert!(
            p.contains("<td><details><summary>in synchronism, true mean 512.5 rpm …</summary>against the 492"),
            "{p}"
        );
        // A running row's long cell, and short cells, stay as they are.
        assert!(p.contains(&format!("<td>{reason}</td>")), "{p}");
        assert!(p.contains("<td><em>lost-sync</em></td>"), "{p}");
        assert_eq!(p.matches("<details>").count(), 2);
    }

    /// The sorting script, run by Node.js on a minimal stand-in for the page's DOM: a
    /// click sorts numbers by value (not as text: 10.5 after 9), puts text such as a verdict or
    /// "–" after them in the locale's order (punctuation before letters), and a second
    /// click reverses.
    #[test]
    fn a_header_click_sorts_its_column() {
        let dom = r#"
function el(text) {
  var cls = {};
  return { textContent: text, handlers: [],
    classList: { add: function () { for (var c of arguments) cls[c] = 1; },
                 remove: function () { for (var c of arguments) delete cls[c]; },
                 contains: function (c) { return !!cls[c]; } },
    addEventListener: function (_, f) { this.handlers.push(f); },
    click: function () { this.handlers.forEach(function (f) { f(); }); } };
}
var cells = [['a', '9'], ['b', 'lost-sync'], ['c', '10.5'], ['d', '-2e1'], ['e', '–']];
var heads = [el('name'), el('rpm')];
var body = { rows: cells.map(function (c) { return { cells: c.map(el), id: c[0] }; }),
  appendChild: function (r) { this.rows.splice(this.rows.indexOf(r), 1); this.rows.push(r); } };
var table = { querySelectorAll: function () { return heads; }, tBodies: [body] };
var document = { querySelectorAll: function () { return [table]; } };
"#;
        let check = r#"
var order = function () { return body.rows.map(function (r) { return r.id; }).join(''); };
heads[1].click();
if (order() !== 'daceb') throw new Error('ascending: ' + order());
heads[1].click();
if (order() !== 'becad') throw new Error('descending: ' + order());
if (!heads[1].classList.contains('desc') || heads[0].classList.contains('asc')) throw new Error('marks');
heads[0].click();
if (order() !== 'abcde') throw new Error('text: ' + order());
"#;
        let out = std::process::Command::new("node")
            .arg("-e")
            .arg(format!("{dom}{SORT}{check}"))
            .output()
            .unwrap_or_else(|e| {
                panic!("node not found ({e}): install Node.js (apt-get install nodejs)")
            });
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
}
