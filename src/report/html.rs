//! `report.html` (and a study's `study.html`): one self-contained page per run, made from
//! the same markdown as `report.md` so the two never disagree. Tables become real tables,
//! every figure the markdown links (`![caption](name.svg)`) is inlined as vector SVG with
//! links to its PNG and PDF, and a block after a `<!-- fold: TITLE -->` line is folded
//! into a `<details>` element (the diagnostics). No script, no external resource.

use std::fmt::Write;
use std::path::Path;

fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// Inline markdown: `code`, **bold**, [text](link); everything else escaped.
fn inline(s: &str) -> String {
    let mut out = String::new();
    let mut rest = s;
    while !rest.is_empty() {
        if let Some(r) = rest.strip_prefix('`') {
            if let Some(end) = r.find('`') {
                let _ = write!(out, "<code>{}</code>", escape(&r[..end]));
                rest = &r[end + 1..];
                continue;
            }
        }
        if let Some(r) = rest.strip_prefix("**") {
            if let Some(end) = r.find("**") {
                let _ = write!(out, "<strong>{}</strong>", inline(&r[..end]));
                rest = &r[end + 2..];
                continue;
            }
        }
        if let Some(r) = rest.strip_prefix('[') {
            if let Some(mid) = r.find("](") {
                if let Some(end) = r[mid + 2..].find(')') {
                    let href = &r[mid + 2..mid + 2 + end];
                    if !href.contains(' ') {
                        let _ = write!(out, "<a href=\"{}\">{}</a>", escape(href), inline(&r[..mid]));
                        rest = &r[mid + 2 + end + 1..];
                        continue;
                    }
                }
            }
        }
        let ch = rest.chars().next().expect("not empty");
        out += &escape(&ch.to_string());
        rest = &rest[ch.len_utf8()..];
    }
    out
}

fn cells(line: &str) -> Vec<&str> {
    let t = line.trim().trim_start_matches('|').trim_end_matches('|');
    t.split('|').map(str::trim).collect()
}

/// The SVG file `name` in `dir`, ready to sit inline: its element ids prefixed with
/// `prefix` (several figures share one page), or a note where it is missing.
fn inline_svg(dir: &Path, name: &str, prefix: &str) -> String {
    match std::fs::read_to_string(dir.join(name)) {
        Ok(svg) => {
            let start = svg.find("<svg").unwrap_or(0);
            svg[start..]
                .replace("id=\"", &format!("id=\"{prefix}"))
                .replace("url(#", &format!("url(#{prefix}"))
        }
        Err(e) => format!("<p class=\"missing\">figure {} not found: {e}</p>", escape(name)),
    }
}

/// Render the markdown `md` (as the report writes it) to a whole HTML page titled
/// `title`, with the figures it links read from `dir`.
pub fn page(title: &str, md: &str, dir: &Path) -> std::io::Result<String> {
    let mut body = String::new();
    let lines: Vec<&str> = md.lines().collect();
    let mut i = 0;
    let mut figures = 0usize;
    // The `<details>` wrapper of the next block, if a fold marker asked for one.
    let mut fold: Option<String> = None;
    let mut open_fold = false;
    while i < lines.len() {
        let line = lines[i];
        let trimmed = line.trim();
        if trimmed.is_empty() {
            if open_fold {
                body += "</details>\n";
                open_fold = false;
            }
            i += 1;
            continue;
        }
        if let Some(t) = trimmed.strip_prefix("<!-- fold:").and_then(|t| t.strip_suffix("-->")) {
            fold = Some(t.trim().to_string());
            i += 1;
            continue;
        }
        if let Some(t) = fold.take() {
            let _ = writeln!(body, "<details><summary>{}</summary>", inline(&t));
            open_fold = true;
        }
        if let Some(h) = trimmed.strip_prefix('#') {
            let level = 1 + h.chars().take_while(|&c| c == '#').count();
            let text = h.trim_start_matches('#').trim();
            let _ = writeln!(body, "<h{level}>{}</h{level}>", inline(text));
            i += 1;
        } else if trimmed.starts_with("```") {
            let mut code = String::new();
            i += 1;
            while i < lines.len() && !lines[i].trim_start().starts_with("```") {
                code += lines[i];
                code.push('\n');
                i += 1;
            }
            i += 1;
            let _ = writeln!(body, "<pre>{}</pre>", escape(&code));
        } else if let Some(img) = trimmed.strip_prefix("![") {
            let (alt, rest) = img.split_once("](").unwrap_or((img, ""));
            let src = rest.trim_end_matches(')');
            figures += 1;
            let svg = inline_svg(dir, src, &format!("fig{figures}-"));
            let stem = src.trim_end_matches(".svg");
            let _ = writeln!(
                body,
                "<figure>\n{svg}<figcaption>{} <span class=\"files\">(<a href=\"{s}\">SVG</a>, <a href=\"{stem}.png\">PNG</a>, \
                 <a href=\"{stem}.pdf\">PDF</a>)</span></figcaption>\n</figure>",
                inline(alt),
                s = escape(src),
                stem = escape(stem)
            );
            i += 1;
        } else if trimmed.starts_with('|') {
            let header = cells(trimmed);
            let align: Vec<&str> = if i + 1 < lines.len() && lines[i + 1].trim().starts_with("|-") {
                cells(lines[i + 1])
                    .iter()
                    .map(|c| if c.ends_with(':') { "right" } else { "left" })
                    .collect()
            } else {
                Vec::new()
            };
            body += "<table>\n<thead><tr>";
            for (k, h) in header.iter().enumerate() {
                let _ = write!(
                    body,
                    "<th style=\"text-align:{}\">{}</th>",
                    align.get(k).unwrap_or(&"left"),
                    inline(h)
                );
            }
            body += "</tr></thead>\n<tbody>\n";
            i += if align.is_empty() { 1 } else { 2 };
            while i < lines.len() && lines[i].trim().starts_with('|') {
                body += "<tr>";
                for (k, c) in cells(lines[i]).iter().enumerate() {
                    let _ = write!(
                        body,
                        "<td style=\"text-align:{}\">{}</td>",
                        align.get(k).unwrap_or(&"left"),
                        inline(c)
                    );
                }
                body += "</tr>\n";
                i += 1;
            }
            body += "</tbody></table>\n";
        } else if trimmed.starts_with("- ") {
            body += "<ul>\n";
            while i < lines.len() && lines[i].trim_start().starts_with("- ") {
                let _ = writeln!(body, "<li>{}</li>", inline(&lines[i].trim_start()[2..]));
                i += 1;
            }
            body += "</ul>\n";
        } else if trimmed.starts_with('>') {
            let mut text = String::new();
            while i < lines.len() && lines[i].trim_start().starts_with('>') {
                text += lines[i].trim_start().trim_start_matches('>').trim();
                text.push(' ');
                i += 1;
            }
            let _ = writeln!(body, "<blockquote>{}</blockquote>", inline(text.trim()));
        } else {
            let mut text = String::new();
            while i < lines.len() {
                let t = lines[i].trim();
                if t.is_empty() || t.starts_with(['#', '|', '>', '!']) || t.starts_with("- ") || t.starts_with("```") {
                    break;
                }
                text += t;
                text.push(' ');
                i += 1;
            }
            let _ = writeln!(body, "<p>{}</p>", inline(text.trim()));
        }
    }
    if open_fold {
        body += "</details>\n";
    }
    Ok(format!(
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n\
         <meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n<title>{}</title>\n<style>{STYLE}</style>\n\
         </head>\n<body>\n<main>\n{body}</main>\n</body>\n</html>\n",
        escape(title)
    ))
}

const STYLE: &str = "
body { font-family: 'DejaVu Sans', Verdana, Arial, Helvetica, sans-serif; color: #1a1a1a; margin: 0; background: #fafafa; }
main { max-width: 1240px; margin: 0 auto; padding: 1.5em 2em 4em; background: white; }
h1 { font-size: 1.6em; border-bottom: 2px solid #333; padding-bottom: .3em; }
h2 { font-size: 1.3em; margin-top: 2em; border-bottom: 1px solid #ccc; }
h3 { font-size: 1.1em; margin-top: 1.6em; }
table { border-collapse: collapse; margin: .8em 0; font-size: .9em; }
th, td { border: 1px solid #d0d0d0; padding: .25em .6em; }
thead th { background: #f0f0f0; }
tbody tr:nth-child(even) { background: #fafafa; }
code { font-family: 'DejaVu Sans Mono', Menlo, Consolas, monospace; font-size: .92em; background: #f3f3f3; padding: 0 .2em; }
pre { background: #f6f6f6; border: 1px solid #e0e0e0; padding: .7em; overflow-x: auto; font-size: .85em; }
figure { margin: 1.2em 0; }
figure svg { max-width: 100%; height: auto; display: block; }
figcaption { font-size: .9em; color: #444; margin-top: .3em; }
.files { color: #777; }
details { margin: .5em 0 1em; border-left: 3px solid #ddd; padding-left: .8em; }
summary { cursor: pointer; color: #333; }
blockquote { border-left: 4px solid #c33; margin: 1em 0; padding: .3em 1em; background: #fff5f5; }
.missing { color: #a00; }
";

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tables_figures_and_folds_render() {
        let dir = tempfile::tempdir().expect("tempdir");
        std::fs::write(
            dir.path().join("a.svg"),
            "<svg xmlns=\"http://www.w3.org/2000/svg\"><clipPath id=\"clip1\"/><g clip-path=\"url(#clip1)\"/></svg>",
        )
        .expect("write");
        let md = "# T\n\nSome **bold** `x<y`.\n\n| a | b |\n|---|---:|\n| 1 | 2 |\n\n![The caption](a.svg)\n\n\
                  <!-- fold: diagnostics -->\n- rank 3/3\n- time 1 s\n\n## Next\n";
        let html = page("t", md, dir.path()).expect("page");
        assert!(html.contains("<table>") && html.contains("<td style=\"text-align:right\">2</td>"));
        assert!(html.contains("<strong>bold</strong>") && html.contains("<code>x&lt;y</code>"));
        assert!(html.contains("id=\"fig1-clip1\"") && html.contains("url(#fig1-clip1)"));
        assert!(html.contains("<details><summary>diagnostics</summary>\n<ul>"));
        assert!(html.contains("</ul>\n</details>\n<h2>Next</h2>"));
    }
}
